"""Executing a plan: one run's data, its segments and their outputs.

:func:`execute` starts one run of a :class:`~.plan.SimulationPlan` (its own data,
:func:`~.run_data.start_run`) and runs it segment by segment
(:func:`~.segments.run_segments`): one segment, or one per sample interval with
sampled inputs (:mod:`~.sampled`), each holding its inputs in the run's data. What it
returns is what the layers above turn into a trajectory: the joined states, outputs
and held inputs, and the warning naming the singular configurations passed.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, replace
from functools import partial
from typing import TYPE_CHECKING, TypeVar

import numpy as np

from ...errors import InputError
from .run_data import RunData, RunSegment
from .sampled import sampled_schedule
from .segments import Schedule, SegmentedRun, SegmentState, run_segments
from .watchdog import Watchdog

T = TypeVar("T")

if TYPE_CHECKING:
    from .plan import SimulationPlan


@dataclass(frozen=True)
class Executed:
    """A plan's run: the joined segments and what it passed.

    Attributes
    ----------
    run
        The states at the recorded times, their outputs, the held inputs, the
        statistics (``n_samples`` too with sampled inputs).
    passages
        The warning naming the singular configurations the run passed (empty if none).
    """

    run: SegmentedRun
    passages: str


def execute(plan: SimulationPlan, dynamics: bool = True) -> Executed:
    """Run ``plan`` once, in its own data.

    Parameters
    ----------
    plan
        The plan (:func:`~.plan.plan_simulation`).
    dynamics
        ``False``: the outputs' ``qdd``, multipliers and constraint forces may be left
        uncomputed (NaN), for a caller that keeps none of them.

    Examples
    --------
    >>> from dalembert.examples import load
    >>> system = load("pendulum").build()
    >>> plan = system.plan((0.0, 1.0), {"x": 1.0, "y": 0.0}, t_eval=[0.5, 1.0])
    >>> done = execute(plan)
    >>> done.run.result.t.tolist(), sorted(done.run.derived)[:2], done.passages
    ([0.5, 1.0], ['constraint_forces', 'energies'], '')
    """
    options = plan.options
    signal = options.inputs
    sampled = signal is not None and signal.sample_time is not None
    schedule = Schedule.none()
    if sampled:
        assert signal is not None
        schedule = sampled_schedule(signal, options.t_span, len(plan.initial.q))
    data = plan.start()
    if data.watchdog is not None:  # the time limit also in the samples between segments
        schedule = replace(schedule, reset=_armed(data.watchdog, schedule.reset))
    # (not in the outputs: they are not the integration the limit is for, and on threads
    # they may wait for their turn behind another run)
    joined = run_segments(partial(_segment, data), partial(_outputs, dynamics=dynamics),
                          schedule, options.t_span, plan.y0, options.output.t_eval,
                          options.output.progress)
    if sampled:
        joined.result.stats["n_samples"] = joined.result.stats["n_segments"]
    return Executed(joined, data.passages())


def _segment(data: RunData, a: float, b: float, start: SegmentState,
             t_eval: np.ndarray | None, progress: bool) -> RunSegment:
    """The segment ``[a, b]`` of a run from ``start`` (consistent: projected after every
    step), with the inputs held at ``start.inputs`` (set in the run's data now: the
    driver runs the segment and takes its outputs before it makes the next)."""
    if start.active is not None:
        raise NotImplementedError("a reset of the active constraint rows is not "
                                  "supported by System's runs yet")
    if start.inputs is not None:
        data.hold_inputs(start.inputs)
    return data.segment((a, b), start.y, t_eval, progress)


def _armed(watchdog: Watchdog, function: Callable[..., T]) -> Callable[..., T]:
    """``function`` run with the run's watchdog armed: a sampled input that never
    returns is stopped as one inside a segment is."""
    def armed(*args: object) -> T:
        with watchdog.armed():
            return function(*args)

    return armed


def _outputs(segment: RunSegment, times: np.ndarray, states: np.ndarray,
             dynamics: bool = True) -> dict[str, np.ndarray]:
    """The derived arrays at points of a segment. A run that failed because its inputs
    could not be computed has points where they still cannot: those rows are NaN."""
    try:
        return segment.outputs(times, states, dynamics=dynamics)
    except InputError:
        rows: list[dict[str, np.ndarray] | None] = []
        for t, y in zip(times, states):
            try:
                rows.append(segment.outputs(np.array([t]), y[None], dynamics=dynamics))
            except InputError:
                rows.append(None)
        template = next((r for r in rows if r is not None), None)
        if template is None:
            empty = segment.outputs(np.zeros(0), np.zeros((0, states.shape[1])),
                                    dynamics=dynamics)
            return {name: np.full((len(rows), *v.shape[1:]), np.nan)
                    for name, v in empty.items()}
        return {name: np.concatenate([r[name] if r is not None else _missing(template[name])
                                      for r in rows])
                for name in template}


def _missing(like: np.ndarray) -> np.ndarray:
    """A row where an output could not be computed: NaN (False for a mark)."""
    return np.zeros_like(like) if like.dtype == bool else np.full_like(like, np.nan)
