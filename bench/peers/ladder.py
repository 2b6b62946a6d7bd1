"""Find a tool's coarsest setting that meets the accuracy target, by bisection.

A setting is one positive number, larger = coarser (an rtol, a time step). The
ladder (``settings``, coarse to fine) only brackets the answer: it is climbed until
a setting meets the target, the rung before it (which missed) closing the bracket;
if the ladder's first rung already meets it, settings coarser by the ladder's first
ratio are tried until one misses (at most ``COARSER`` of them). The bracket
``(miss, meet)`` is then bisected on a log scale (the geometric mean tried) until
``miss / meet <= RATIO`` (5%), and the coarsest setting found meeting the target is
kept: every tool is timed within 5% of its cheapest setting, whatever its ladder's
spacing.

Accuracy need not be monotonic in the setting (the chains are chaotic: a coarser
setting can land on a smaller final energy error by chance). The bisection does
not look for that: it keeps the meeting end of its last bracket, which has a
setting that missed within 5% coarser; a coarser setting that meets the target
again beyond a miss is neither sought nor excluded. Every attempt is recorded
(``attempts``, in the order tried, each with ``meets``), so the JSON shows where
accuracy was not monotonic.

The kept setting is timed again by the caller (the suite interleaves the tools'
timing rounds): the attempts' times are the bisection's, each one run.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Sequence
from typing import NamedTuple

from .common import meets

#: The bisection stops when the bracket's ends are within this ratio (5%).
RATIO = 1.05
#: Settings coarser than the ladder's first rung tried when that rung meets the target.
COARSER = 6
#: Fields a repeat of a deterministic tool reproduces exactly.
SAME_IN_REPEATS = ("energy_error", "residual", "evaluations")
#: What each attempt keeps in the record's ``attempts``.
KEPT = ("setting", "simulate_s", "cpu_s", "energy_error", "residual", "evaluations",
        "finished", "error")


class Prepared(NamedTuple):
    """A tool's model built for one workload and ``n``: what to record about it
    (``info``), ``attempt(setting) -> record`` (one run, each from a fresh state),
    the ladder that brackets the setting (coarse to fine) and which records are good
    enough (``accept``)."""

    info: dict
    attempt: Callable[[float], dict]
    settings: Sequence[float]
    accept: Callable[[dict], bool]
    #: What is kept when no setting meets ``accept``: the ladder's first (coarsest)
    #: record that passes ``fallback`` (Exudyn: the residual target alone).
    fallback: Callable[[dict], bool] | None = None


def value(record: dict, key: str) -> float:
    """The number a record's ``setting`` dict was made from (``key``: rtol, step...)."""
    return float(record["setting"][key])


def bisect(prepared: Prepared, budget: float | None = None) -> dict:
    """The coarsest setting meeting ``prepared.accept`` within ``RATIO``, its record.

    If no setting meets it, the first one tried that passes ``prepared.fallback`` is
    kept (when given). Returns the kept setting's record with ``met_target`` (energy and residual
    targets), ``accepted`` (``accept``), ``bracket`` (the last miss and meet),
    ``setting_value`` and ``attempts`` (every run, in order). If nothing meets the
    target, the last setting tried is returned (``accepted`` False). Stops early
    when ``budget`` seconds are spent (``bisection`` says so).
    """
    attempt, accept = prepared.attempt, prepared.accept
    start = time.perf_counter()
    tried: list[dict] = []
    records: list[dict] = []

    def run(setting: float) -> tuple[dict, bool]:
        try:
            record = attempt(setting)
        except Exception as exc:  # a diverged or refused run: a miss, recorded
            record = {"setting": setting, "energy_error": math.nan, "finished": False,
                      "error": f"{type(exc).__name__}: {exc}"[:300]}
        ok = bool(accept(record)) if "error" not in record else False
        records.append(record)
        tried.append({**{k: record[k] for k in KEPT if k in record},
                      "setting_value": setting, "meets": ok})
        return record, ok

    def spent() -> bool:
        return budget is not None and time.perf_counter() - start > budget

    settings = list(prepared.settings)
    miss: float | None = None
    meet: tuple[float, dict] | None = None
    last: dict = {}
    for k, setting in enumerate(settings):
        last, ok = run(setting)
        if ok:
            meet = (setting, last)
            miss = settings[k - 1] if k else None
            break
        if spent():
            break
    note = "bisected to within 5%"
    if meet is not None and miss is None:  # the first rung meets it: look coarser
        factor = settings[0] / settings[1]
        setting = settings[0]
        for _ in range(COARSER):
            setting *= factor
            record, ok = run(setting)
            if not ok:
                miss = setting
                break
            meet = (setting, record)
        else:
            note = f"the coarsest setting tried ({COARSER} beyond the ladder) met the target"
    if meet is not None and miss is not None:
        while miss / meet[0] > RATIO and not spent():
            mid = math.sqrt(miss * meet[0])
            record, ok = run(mid)
            if ok:
                meet = (mid, record)
            else:
                miss = mid
        if miss / meet[0] > RATIO:
            note = "budget spent before the bracket closed to 5%"
    fallback = prepared.fallback
    kept = [(t, r) for t, r in zip(tried, records)
            if fallback is not None and "error" not in r and fallback(r)]
    if meet is None and kept:
        record, chosen = kept[0][1], kept[0][0]["setting_value"]
        note = ("no setting met the target: the ladder's first setting meeting the "
                "fallback (residual) target kept")
    elif meet is None:
        record, chosen, note = last, tried[-1]["setting_value"], "no setting met the target"
    else:
        chosen, record = meet
    record = dict(record)
    record["met_target"] = "error" not in record and meets(record)
    record["accepted"] = meet is not None or bool(kept)
    record["setting_value"] = chosen
    record["bracket"] = {"miss": miss, "meet": chosen if meet is not None else None}
    record["bisection"] = note
    record["attempts"] = tried
    return record


def timed(prepared: Prepared, record: dict) -> dict:
    """One more run of the kept setting: its wall and CPU seconds, and the fields of
    ``SAME_IN_REPEATS`` that differ from the kept record's (a tool that is not
    deterministic)."""
    again = prepared.attempt(record["setting_value"])
    differs = [k for k in SAME_IN_REPEATS
               if k in record and not _same(again.get(k), record[k])]
    return {"simulate_s": again["simulate_s"], "cpu_s": again["cpu_s"], "differs": differs}


def _same(a: object, b: object) -> bool:
    """Equal, counting two NaNs (a failed run's error) as equal."""
    return a == b or (isinstance(a, float) and isinstance(b, float) and a != a and b != b)

