"""Runs made of smooth segments joined by resets.

A run is cut at the instants of a :class:`Schedule`. Between two instants the
equations are smooth and one ordinary integration (a *segment*) runs; at an instant a
*reset* may jump what the next segment starts from, a :class:`SegmentState`:

- ``y``, the state ``[q, qd]`` (an impact; unchanged for a held input);
- ``inputs``, the input values held over the next segment (a zero-order hold:
  :mod:`~dalembert.solvers.running.sampled`); ``None``, the run's own inputs;
- ``active``, the constraint rows the next segment enforces (a contact that opens or
  closes); ``None``, the run's own rows.

The contract, in the spirit of SciPy's ``solve_ivp`` and diffrax: the schedule is a
value (its instants and its reset map ``reset(t, state) -> state``, which returns a
new state and changes nothing else); the state goes in and out of every reset and of
every segment explicitly. :func:`run_segments` guarantees

- the instants are the schedule's, exactly; a reset at the start applies to the
  initial state, one at the end to the final state;
- each segment is made (``make(a, b, start, t_eval, progress)``) just before it runs,
  and the outputs at its points are computed before the next one is made (a segment
  may hold its inputs in the model it shares with the others);
- every output time is recorded once, with the post-reset value at an instant: an
  output time within ``schedule.tolerance`` of an instant is the instant's (so a
  ``t_eval`` from ``np.linspace`` or ``np.arange`` meets instants computed as
  ``t0 + k * dt``), and is recorded with the time it was asked at; without output
  times, every step is, an instant once;
- a terminal event, a failure or an interruption in a segment ends the whole run
  (its status and message are the run's), as does a reset that fails (an
  :class:`~dalembert.errors.InputError`) or passes the run's time limit (a
  :class:`~dalembert.errors.TimeLimitExceeded`): the points before are kept; the
  events' times and states are concatenated, the statistics summed (``n_segments``
  counts the segments run), one progress bar covers the span, and with dense output
  ``sol`` answers each time from the segment holding it (at an instant, the segment
  that starts there).

Each segment locates its own events: one whose function changes sign exactly at an
instant is found by the segment that ends there, not again by the next, and an event's
``terminal`` count (``terminal=k``) counts within a segment.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Protocol

import numpy as np

from ...errors import InputError, TimeLimitExceeded
from .integrate import IntegrationResult, progress_bar


@dataclass(frozen=True)
class SegmentState:
    """What a segment starts from (see :mod:`~dalembert.solvers.running.segments`).

    Attributes
    ----------
    y
        The state ``[q, qd]``.
    inputs
        The input values held over the segment, or ``None`` (the run's own inputs).
    active
        The constraint rows the segment enforces (indices in the model's order), or
        ``None`` (the run's own rows).
    """

    y: np.ndarray
    inputs: np.ndarray | None = None
    active: tuple[int, ...] | None = None


#: ``reset(t, state) -> state``: what the segment starting at instant ``t`` starts from.
Reset = Callable[[float, SegmentState], SegmentState]


def _no_reset(t: float, state: SegmentState) -> SegmentState:
    return state


@dataclass(frozen=True)
class Schedule:
    """The instants at which a run resets, and the reset map.

    Attributes
    ----------
    instants
        Strictly monotone in the run's direction, inside ``t_span`` (its ends
        included).
    reset
        ``reset(t, state) -> state`` at each instant.
    tolerance
        An output time this close to an instant is the instant's (recorded with the
        post-reset value).

    Examples
    --------
    >>> Schedule.none().instants.size
    0
    """

    instants: np.ndarray
    reset: Reset = _no_reset
    tolerance: float = 0.0

    @classmethod
    def none(cls) -> Schedule:
        """No reset: the run is one segment."""
        return cls(np.zeros(0))


class Segment(Protocol):
    """One smooth segment, as :func:`run_segments` uses it (a run's
    :class:`~dalembert.solvers.running.run_data.RunSegment` is one)."""

    def run(self) -> IntegrationResult:
        ...


#: ``make(a, b, start, t_eval, progress)``: the segment from ``start`` at ``a`` to ``b``.
MakeSegment = Callable[[float, float, SegmentState, np.ndarray | None, bool], Segment]
#: ``outputs(segment, t, y)``: the derived arrays at a segment's points.
SegmentOutputs = Callable[[Segment, np.ndarray, np.ndarray], dict[str, np.ndarray]]


@dataclass
class SegmentedRun:
    """A run's segments joined (see :func:`run_segments`).

    Attributes
    ----------
    result
        The states at the recorded times, the events, the statistics, ``sol``.
    derived
        The outputs at the recorded times.
    inputs
        The input values held at the recorded times, or ``None`` if some segment
        holds none (the run's own inputs apply).
    segments
        Each segment's own result.
    """

    result: IntegrationResult
    derived: dict[str, np.ndarray]
    inputs: np.ndarray | None
    segments: list[IntegrationResult] = field(default_factory=list)


def run_segments(make: MakeSegment, outputs: SegmentOutputs, schedule: Schedule,
                 t_span: tuple[float, float], y0: np.ndarray,
                 t_eval: np.ndarray | None = None, progress: bool = False) -> SegmentedRun:
    """Run ``t_span`` segment by segment (see :mod:`~dalembert.solvers.running.segments`).

    Parameters
    ----------
    make
        ``make(a, b, start, t_eval, progress)``: the segment from ``start`` (a
        :class:`SegmentState`) at ``a`` to ``b``, recording ``t_eval`` (inside
        ``[a, b]``; ``None``: every step).
    outputs
        ``outputs(segment, t, y)``: the derived arrays at points of a segment.
    schedule
        The instants and the reset map.
    t_span, y0, t_eval
        The run's span, initial state and output times (``None``: every step).
    progress
        Show one progress bar for the whole span.

    Returns
    -------
    SegmentedRun

    Examples
    --------
    ``y' = u`` with ``u`` held at ``1 - y`` sampled every 0.5 (the state halves its
    distance to 1 at each sample):

    >>> from scipy.integrate import RK45
    >>> from dalembert.solvers.running.integrate import integrate
    >>> class Held:
    ...     def __init__(self, a, b, start, t_eval, progress):
    ...         u = start.inputs[0]
    ...         self.run = lambda: integrate(lambda t, y: np.array([u]), (a, b), start.y,
    ...                                      method=RK45, t_eval=t_eval)
    >>> def sample(t, state):
    ...     return SegmentState(state.y, inputs=1.0 - state.y)
    >>> schedule = Schedule(np.array([0.0, 0.5, 1.0]), sample, 1e-12)
    >>> joined = run_segments(Held, lambda s, t, y: {}, schedule, (0.0, 1.0), np.zeros(1),
    ...                       t_eval=np.linspace(0.0, 1.0, 3))
    >>> np.round(joined.result.y[:, 0], 12).tolist(), np.round(joined.inputs[:, 0], 12).tolist()
    ([0.0, 0.5, 0.75], [1.0, 0.5, 0.25])
    """
    t0, tf = float(t_span[0]), float(t_span[1])
    direction = math.copysign(1.0, tf - t0)
    instants = np.asarray(schedule.instants, dtype=float)
    tol = schedule.tolerance
    at_start = bool(instants.size) and abs(instants[0] - t0) <= tol
    at_end = bool(instants.size) and abs(instants[-1] - tf) <= tol
    inner = instants[int(at_start):instants.size - int(at_end)]
    edges = np.concatenate([[t0], inner, [tf]])
    count = len(edges) - 1
    times = None if t_eval is None else np.asarray(t_eval, dtype=float)
    # which segment records each output time: the one starting within tol before it
    # (an output time within tol of tf is the end's, after a reset there)
    owner = None if times is None else \
        np.searchsorted(direction * (edges[1:] - direction * tol), direction * times, "right")
    state = SegmentState(np.asarray(y0, dtype=float))
    if at_start:
        state = schedule.reset(t0, state)
    record = _Record()
    bar = progress_bar(t0, tf) if progress and count > 1 else None
    last: IntegrationResult | None = None
    try:
        for k in range(count):
            a, b, final = float(edges[k]), float(edges[k + 1]), k == count - 1
            asked = None if times is None or owner is None else times[owner == k]
            if final and times is not None and owner is not None:
                asked = times[owner >= k]
            run_at = None if asked is None else _inside(asked, a, b, direction)
            if run_at is not None and not final:
                run_at = np.append(run_at[run_at != b], b)  # the next segment's start
            segment = make(a, b, state, run_at, progress and count == 1)
            last = segment.run()
            record.segments.append(last)
            ended = not last.success or last.status == "event" or not len(last.t)
            if count == 1 and not at_end:  # the whole run: every point as recorded
                keep, shown = np.arange(len(last.t)), last.t
            elif asked is None:  # every step; an inner segment's end is the next one's start
                keep = np.arange(len(last.t)) if final or ended else \
                    np.flatnonzero(last.t != b)
                shown = last.t[keep]
            else:
                keep = np.flatnonzero(np.isin(last.t, _inside(asked, a, b, direction)))
                shown = asked[:len(keep)]
            if final and at_end and not ended and len(keep) and last.t[keep[-1]] == b:
                # the reset at the end: the last point recorded after it
                record.add(segment, shown[:-1], last.y[keep[:-1]], state, outputs)
                state = schedule.reset(tf, SegmentState(last.y[keep[-1]], state.inputs,
                                                        state.active))
                record.add(make(tf, tf, state, None, False), shown[-1:],
                           state.y[None, :], state, outputs)
            else:
                record.add(segment, shown, last.y[keep], state, outputs)
            if bar is not None:
                bar.update(abs(_reached(last, a, b, ended) - a))
            if record.interrupted:
                record.mark_stopped(last)
                break
            if ended:
                break
            state = SegmentState(last.y[-1], state.inputs, state.active)
            if not final:
                try:
                    state = schedule.reset(b, state)
                except TimeLimitExceeded:  # a sampled input that never returned
                    last.status, last.message = "timeout", (
                        f"stopped at t={b:.6g}: the run's time limit (timeout=) passed while "
                        "the inputs were sampled there (a function of yours had not "
                        "returned)")
                    break
                except InputError as exc:  # a sampled input that failed: the run so far
                    last.status, last.message = "failed", f"integration stopped at " \
                        f"t={b:.6g}: {exc}"
                    last.error = exc
                    break
    finally:
        if bar is not None:
            bar.close()
    assert last is not None
    return record.joined(len(y0), t0)


def _reached(result: IntegrationResult, a: float, b: float, ended: bool) -> float:
    """How far a segment ran (for the progress bar): to its end, to the terminal event,
    or to its last point."""
    if not ended:
        return b
    if result.status == "event":
        last = [te[-1] for te in result.t_events if len(te)]
        if last:
            return float(max(last, key=lambda t: abs(t - a)))
    return float(result.t[-1]) if len(result.t) else a


def _inside(asked: np.ndarray, a: float, b: float, direction: float) -> np.ndarray:
    """Output times assigned to ``[a, b]``, those within rounding of an end moved onto it."""
    lo, hi = (a, b) if direction > 0 else (b, a)
    return np.clip(asked, lo, hi)


class _Record:
    """The points, outputs and held inputs recorded so far, segment by segment."""

    def __init__(self) -> None:
        self.segments: list[IntegrationResult] = []
        self.t: list[np.ndarray] = []
        self.y: list[np.ndarray] = []
        self.derived: list[dict[str, np.ndarray]] = []
        self.inputs: list[np.ndarray | None] = []
        self.made: tuple[Segment, SegmentOutputs]
        #: ``"interrupted"`` (a Ctrl-C) or ``"timeout"`` (the run's time limit) came while
        #: outputs were computed: their arrays from there are NaN; else ``None``.
        self.interrupted: str | None = None

    def mark_stopped(self, last: IntegrationResult) -> None:
        """Give the last segment's result the status and message of a stop while the
        outputs were computed (:attr:`interrupted`)."""
        assert self.interrupted is not None
        last.status = self.interrupted
        cause = "interrupted by the user" if self.interrupted == "interrupted" \
            else "stopped by the run's time limit (timeout=)"
        last.message = (f"{cause} at t={last.t[-1]:.6g}, while the outputs were "
                        "computed: the states are kept, the accelerations, multipliers "
                        "and energies from there are NaN")

    def add(self, segment: Segment, t: np.ndarray, y: np.ndarray, state: SegmentState,
            outputs: SegmentOutputs) -> None:
        self.made = (segment, outputs)
        if not len(t):
            return
        self.t.append(np.asarray(t, dtype=float))
        self.y.append(y)
        self.derived.append(self._outputs(segment, np.asarray(t, dtype=float), y, outputs))
        self.inputs.append(None if state.inputs is None else
                           np.tile(np.asarray(state.inputs, dtype=float), (len(t), 1)))

    def _outputs(self, segment: Segment, t: np.ndarray, y: np.ndarray,
                 outputs: SegmentOutputs) -> dict[str, np.ndarray]:
        """The derived arrays at the points; after a Ctrl-C (during them or before) NaN
        of the same shapes, the states kept: a long run is not lost for its outputs."""
        if not self.interrupted:
            try:
                return outputs(segment, t, y)
            except KeyboardInterrupt:
                self.interrupted = "interrupted"
            except TimeLimitExceeded:
                self.interrupted = "timeout"
        empty = outputs(segment, np.zeros(0), np.zeros((0, y.shape[1])))
        return {name: np.full((len(t), *v.shape[1:]), np.nan) for name, v in empty.items()}

    def joined(self, size: int, t0: float) -> SegmentedRun:
        pieces = self.segments
        last = pieces[-1]
        stats: dict[str, int] = {}
        for piece in pieces:
            for key, value in piece.stats.items():
                if isinstance(value, (int, float)):
                    stats[key] = stats.get(key, 0) + value
        stats["n_segments"] = len(pieces)
        events = len(last.t_events)
        sols = [p.sol for p in pieces if p.sol is not None]
        result = IntegrationResult(
            t=np.concatenate(self.t) if self.t else np.zeros(0),
            y=np.concatenate(self.y) if self.y else np.zeros((0, size)),
            status=last.status, message=last.message, stats=stats,
            t_events=[np.concatenate([p.t_events[k] for p in pieces]) for k in range(events)],
            y_events=[np.concatenate([np.reshape(p.y_events[k], (-1, size)) for p in pieces])
                      for k in range(events)],
            sol=(sols[0] if len(sols) == 1 else
                 Piecewise([p.t[0] if len(p.t) else t0 for p in pieces], sols))
            if len(sols) == len(pieces) else None,
            error=last.error)
        if not self.derived:  # no point: the outputs' arrays, empty
            segment, outputs = self.made
            self.derived.append(outputs(segment, np.zeros(0), np.zeros((0, size))))
        derived = {name: np.concatenate([d[name] for d in self.derived])
                   for name in self.derived[0]}
        held = None if not self.inputs or any(v is None for v in self.inputs) else \
            np.concatenate([v for v in self.inputs if v is not None])
        return SegmentedRun(result, derived, held, pieces)


class Piecewise:
    """``sol(t)`` of joined segments: each time answered by the segment whose interval
    holds it (at an instant, the one starting there).

    Parameters
    ----------
    starts
        The segments' start times, monotone.
    sols
        Their dense outputs.

    Examples
    --------
    >>> sol = Piecewise([0.0, 1.0], [lambda t: np.array([t]), lambda t: np.array([-t])])
    >>> sol(0.5).tolist(), sol(1.0).tolist(), sol(np.array([0.5, 2.0])).tolist()
    ([0.5], [-1.0], [[0.5, -2.0]])
    """

    def __init__(self, starts: Sequence[float], sols: Sequence[Callable]) -> None:
        self.starts, self.sols = np.asarray(starts, dtype=float), list(sols)
        self.ascending = len(starts) < 2 or starts[-1] >= starts[0]

    def __call__(self, t: float | np.ndarray) -> np.ndarray:
        times = np.atleast_1d(np.asarray(t, dtype=float))
        key = self.starts if self.ascending else -self.starts
        where = np.searchsorted(key, times if self.ascending else -times, "right") - 1
        where = np.clip(where, 0, len(self.sols) - 1)
        out = np.stack([self.sols[k](s) for k, s in zip(where, times)], axis=-1)
        return out[:, 0] if np.ndim(t) == 0 else out
