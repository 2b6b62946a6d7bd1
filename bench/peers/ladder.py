"""Tighten a tool's tolerance or step until the accuracy target is met.

The kept setting's run is timed again when it is short: single timings under about
a second move by up to 2x on a shared machine, so it is repeated to ``REPEATS`` runs
in all and the fastest is reported (as ``timeit`` takes the minimum of its repeats),
for every tool alike. Each ``attempt`` builds its own state, so a repeat is the same
run: only its time is taken, the first run's accuracy and counts are kept.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence

from .common import meets

#: Runs of the kept setting in all when its first run is shorter than ``SHORT_S``.
REPEATS = 5
SHORT_S = 1.0
#: Fields a repeat of a deterministic tool reproduces exactly.
SAME_IN_REPEATS = ("energy_error", "residual", "evaluations")


def climb(attempt: Callable[[object], dict], settings: Sequence[object],
          budget: float | None = None, accept: Callable[[dict], bool] = meets) -> dict:
    """Run ``attempt(setting)`` for each setting in turn until one meets the target.

    ``accept`` says which records are good enough (default: energy and residual
    targets both met). Returns the first accepted record (or the last one tried, with
    ``met_target`` False) and the list of every attempt under ``"attempts"``.
    Stops early when ``budget`` seconds are spent. The returned setting is timed
    ``REPEATS`` times if its run took under ``SHORT_S``: ``simulate_s`` is the
    fastest, ``simulate_runs`` every run's seconds (see :func:`repeat`).
    """
    start = time.perf_counter()
    tried = []
    record: dict = {}
    setting = None
    for setting in settings:
        record = attempt(setting)
        tried.append({k: record[k] for k in ("setting", "simulate_s", "energy_error",
                                             "residual", "evaluations") if k in record})
        if accept(record):
            break
        if budget is not None and time.perf_counter() - start > budget:
            break
    if tried:
        repeat(attempt, setting, record)
        tried[-1].update(simulate_s=record["simulate_s"], simulate_runs=record["simulate_runs"])
    record["met_target"] = meets(record)
    record["accepted"] = accept(record)
    record["attempts"] = tried
    return record


def repeat(attempt: Callable[[object], dict], setting: object, record: dict) -> None:
    """Time ``setting`` again if ``record`` (its first run) was short; update ``record``.

    Sets ``simulate_runs`` (seconds of every run, the first one first) and
    ``simulate_s`` (their minimum). A repeat whose accuracy or counts differ from
    the first run's is named in ``repeat_differs`` (a tool that is not deterministic).
    """
    runs = [record["simulate_s"]]
    differs: set[str] = set()
    if runs[0] < SHORT_S:
        for _ in range(REPEATS - 1):
            again = attempt(setting)
            runs.append(again["simulate_s"])
            differs.update(k for k in SAME_IN_REPEATS
                           if k in record and not _same(again.get(k), record[k]))
    record["simulate_runs"] = runs
    record["simulate_s"] = min(runs)
    if differs:
        record["repeat_differs"] = sorted(differs)


def _same(a: object, b: object) -> bool:
    """Equal, counting two NaNs (a failed run's error) as equal."""
    return a == b or (isinstance(a, float) and isinstance(b, float) and a != a and b != b)
