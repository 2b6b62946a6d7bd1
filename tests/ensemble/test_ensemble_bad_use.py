"""Ensembles misused or hit by their surroundings: each case gets a message naming the
problem, and no computed case is lost."""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from ensemble_models import pendulum, released

from dalembert import EnsembleError, EnsembleWarning
from dalembert.ensemble import grid

T_EVAL = np.linspace(0.0, 1.0, 11)


@pytest.fixture(scope="module")
def pend():
    return pendulum()


def run(system, cases, **options):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", EnsembleWarning)
        return system.simulate_many((0.0, 1.0), cases, initial_state=released, t_eval=T_EVAL,
                                    scheduler="serial", progress=False, **options)


# -- retry -------------------------------------------------------------------------------------
@pytest.mark.parametrize(("cases", "got"), [
    ([{"l": 2.0}], "{'l': 2.0}"),
    (["0"], "'0'"),
    ([1.5], "1.5"),
    ([True], "True"),
])
def test_retry_with_what_is_not_case_numbers_says_so(pend, cases, got):
    first = run(pend, grid(l=[1.0, 2.0]))
    with pytest.raises(EnsembleError) as info:
        first.retry(cases=cases)
    message = str(info.value)
    assert message.startswith(f"retry takes case numbers (cases=[0, 3]), got {got}")
    assert "run simulate_many again with a new case table" in message


def test_retry_takes_numpy_case_numbers(pend):
    first = run(pend, grid(l=[1.0, 2.0]))
    again = first.retry(cases=np.array([1]))
    assert again.summary["status"].eq("finished").all()
