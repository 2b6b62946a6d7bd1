"""The summary table as the client builds it: one row per case, filled in as the cases
finish, the same table whatever order they finish in."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from dalembert.ensemble.faults import CaseOutcome, error_outcome, not_run_outcome
from dalembert.ensemble.results import SummaryRows


def records() -> list[CaseOutcome]:
    """Cases 2, 5, 7 and 9: one that raised, one finished, one never reached, one that
    failed before its first output time (no final values); numbers as workers give them."""
    finals = {"final_x": 5.0, "final_y": -5.0}
    return [error_outcome(2, ValueError("m = -1 is negative"), 0.01, "host:2", 1.7e9),
            CaseOutcome(5, "finished", "reached the end", 0.5, "host:1",
                        numbers={"t_end": 1.0, "energy_error": 5e-9, **finals},
                        started=1.7e9 + 5),
            not_run_outcome(7),
            CaseOutcome(9, "failed", "step size too small", 0.9, "host:1",
                        numbers={"t_end": np.nan, "energy_error": np.nan}, started=1.7e9 + 9)]


def table(order: list[int]) -> pd.DataFrame:
    rows = SummaryRows([2, 5, 7, 9])
    found = records()
    for k in order:
        rows.add(found[k])
    assert rows.missing() == []
    return rows.table(pd.DataFrame({"m": [-1.0, 1.0, 1.1, 1.2]}))


def test_rows_hold_each_case_record():
    summary = table([0, 1, 2, 3])
    assert summary.columns.tolist() == [
        "m", "status", "message", "t_end", "energy_error", "final_x", "final_y", "seconds",
        "started", "worker", "warnings"]
    assert summary["status"].tolist() == ["error", "finished", "not-run", "failed"]
    assert summary["message"][0] == "ValueError: m = -1 is negative"
    np.testing.assert_array_equal(summary["final_x"], [np.nan, 5.0, np.nan, np.nan])
    np.testing.assert_allclose(summary["seconds"], [0.01, 0.5, 0.0, 0.9])
    assert summary["started"][1] == pd.Timestamp(1.7e9 + 5, unit="s", tz="UTC")
    assert summary["started"].isna().tolist() == [False, False, True, False]
    assert summary["worker"].tolist() == ["host:2", "host:1", "", "host:1"]


@pytest.mark.parametrize("order", [[3, 2, 1, 0], [2, 3, 0, 1], [1, 3, 0, 2]])
def test_the_table_does_not_depend_on_the_order_cases_finish_in(order):
    pd.testing.assert_frame_equal(table(order), table([0, 1, 2, 3]))


def test_a_record_that_comes_again_replaces_the_first():
    rows = SummaryRows([0, 1])
    rows.add(CaseOutcome(0, "finished", numbers={"t_end": 1.0, "final_x": 2.0}))
    rows.add(CaseOutcome(0, "lost", "the worker died"))
    assert rows.missing() == [1]
    rows.add(CaseOutcome(1, "finished", numbers={"t_end": 1.0}))
    summary = rows.table(pd.DataFrame({"m": [1.0, 2.0]}))
    assert summary["status"].tolist() == ["lost", "finished"]
    np.testing.assert_array_equal(summary["final_x"], [np.nan, np.nan])
    np.testing.assert_array_equal(summary["t_end"], [np.nan, 1.0])


def test_rows_are_the_cases_in_increasing_order():
    with pytest.raises(ValueError, match="increasing order"):
        SummaryRows([3, 1])
