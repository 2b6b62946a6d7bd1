"""Tighten a tool's tolerance or step until the accuracy target is met."""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence

from .common import meets


def climb(attempt: Callable[[object], dict], settings: Sequence[object],
          budget: float | None = None, accept: Callable[[dict], bool] = meets) -> dict:
    """Run ``attempt(setting)`` for each setting in turn until one meets the target.

    ``accept`` says which records are good enough (default: energy and residual
    targets both met). Returns the first accepted record (or the last one tried, with
    ``met_target`` False) and the list of every attempt under ``"attempts"``.
    Stops early when ``budget`` seconds are spent.
    """
    start = time.perf_counter()
    tried = []
    record: dict = {}
    for setting in settings:
        record = attempt(setting)
        tried.append({k: record[k] for k in ("setting", "simulate_s", "energy_error",
                                             "residual", "evaluations") if k in record})
        if accept(record):
            break
        if budget is not None and time.perf_counter() - start > budget:
            break
    record["met_target"] = meets(record)
    record["accepted"] = accept(record)
    record["attempts"] = tried
    return record
