"""Sampled inputs: a zero-order hold, one integration per sample interval.

With ``simulate(inputs=..., sample_time=dt)`` the inputs are computed at the sample
instants ``t0, t0 + dt, ...`` from the state there and held until the next one, as a
digital controller acts. The right-hand side is then smooth inside each interval and
jumps at the instants, so the integration restarts there: each interval is one
ordinary run (its own plan, with the inputs constant), and steps land on every
instant. The pieces are joined into one result: the outputs asked for (or every
step), the events, the statistics summed and, with ``dense_output``, one solution
that dispatches to the piece holding each time. At an instant the recorded point is
the new interval's (the new input value applies from there on).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np

from ..codegen.compiled import NumericModel
from ..inputs import InputSignal
from .integrate import IntegrationResult

#: ``plan(a, b, y, t_eval)``: the plan of one interval, from the state ``y`` at ``a``.
SegmentPlan = Callable[[float, float, np.ndarray, np.ndarray | None], object]


@dataclass
class SampledRun:
    """A sampled run's pieces joined: the raw result, the outputs at its points and the
    inputs applied there."""

    result: IntegrationResult
    derived: dict[str, np.ndarray]
    inputs: np.ndarray
    pieces: list[IntegrationResult] = field(default_factory=list)


def sample_instants(t_span: tuple[float, float], sample_time: float) -> np.ndarray:
    """``t0, t0 + dt, ...`` and ``tf`` (a last, shorter interval if ``dt`` does not divide
    the span; instants closer than a millionth of ``dt`` to ``tf`` merge with it).

    >>> sample_instants((0.0, 1.0), 0.25).tolist(), len(sample_instants((0.0, 1.0), 0.3))
    ([0.0, 0.25, 0.5, 0.75, 1.0], 5)
    """
    t0, tf = t_span
    direction = math.copysign(1.0, tf - t0)
    count = math.floor(abs(tf - t0) / sample_time * (1 + 1e-12))
    inner = t0 + direction * sample_time * np.arange(count + 1)
    inner = inner[np.abs(tf - inner) > 1e-6 * sample_time]
    return np.append(inner, tf)


def run_sampled(signal: InputSignal, num: NumericModel, t_span: tuple[float, float],
                y0: np.ndarray, t_eval: np.ndarray | None, plan: SegmentPlan) -> SampledRun:
    """Integrate interval by interval (see module docstring).

    Parameters
    ----------
    signal
        The inputs, with their ``sample_time``.
    num
        The numeric model whose inputs are set for each interval.
    t_span, y0, t_eval
        The run's span, its consistent initial state and its output times.
    plan
        Makes the plan of one interval (a :class:`~.plan.SimulationPlan`).
    """
    assert signal.sample_time is not None
    instants = sample_instants(t_span, signal.sample_time)
    direction = math.copysign(1.0, t_span[1] - t_span[0])
    n = num.n
    y = np.asarray(y0, dtype=float)
    pieces: list[IntegrationResult] = []
    times, states, applied = [], [], []
    derived: dict[str, list[np.ndarray]] = {}
    for k in range(len(instants) - 1):
        a, b, last = instants[k], instants[k + 1], k == len(instants) - 2
        u = signal(a, y[:n], y[n:])
        num.set_inputs(u)
        asked = _asked(t_eval, a, b, last, direction)
        segment_plan = plan(a, b, y, None if t_eval is None else np.append(asked, b))
        result = segment_plan.run()  # type: ignore[attr-defined]
        pieces.append(result)
        keep = _kept(result.t, t_eval, asked, b, last)
        if len(keep):
            out = segment_plan.outputs(result.t[keep], result.y[keep])  # type: ignore[attr-defined]
            for name, values in out.items():
                derived.setdefault(name, []).append(values)
            times.append(result.t[keep])
            states.append(result.y[keep])
            applied.append(np.tile(u, (len(keep), 1)))
        if not result.success or result.status == "event" or not len(result.t):
            break
        y = result.y[-1]
    joined = _join(pieces, times, states, num, t_span[0])
    return SampledRun(
        joined, {name: np.concatenate(values) for name, values in derived.items()},
        np.concatenate(applied) if applied else np.zeros((0, len(signal.names))), pieces)


def _asked(t_eval: np.ndarray | None, a: float, b: float, last: bool,
           direction: float) -> np.ndarray:
    """The output times asked for in ``[a, b)`` (``[a, b]`` for the last interval)."""
    if t_eval is None:
        return np.zeros(0)
    s = direction * np.asarray(t_eval)
    inside = (s >= direction * a) & ((s <= direction * b) if last else (s < direction * b))
    return np.asarray(t_eval)[inside]


def _kept(t: np.ndarray, t_eval: np.ndarray | None, asked: np.ndarray, b: float,
          last: bool) -> np.ndarray:
    """The rows of an interval's result to keep: those asked for (the end ``b``, added to
    know the state there, only if asked), or every step but the end of an inner
    interval (the next one records that instant)."""
    if t_eval is not None:
        return np.flatnonzero(np.isin(t, asked))
    if last:
        return np.arange(len(t))
    return np.flatnonzero(t != b)


def _join(pieces: Sequence[IntegrationResult], times: list[np.ndarray],
          states: list[np.ndarray], num: NumericModel, t0: float) -> IntegrationResult:
    last = pieces[-1]
    stats: dict[str, int] = {}
    for piece in pieces:
        for key, value in piece.stats.items():
            if isinstance(value, (int, float)):
                stats[key] = stats.get(key, 0) + value
    stats["n_samples"] = len(pieces)
    events = len(last.t_events)
    sols = [p.sol for p in pieces if p.sol is not None]
    return IntegrationResult(
        t=np.concatenate(times) if times else np.zeros(0),
        y=np.concatenate(states) if states else np.zeros((0, 2 * num.n)),
        status=last.status, message=last.message, stats=stats,
        t_events=[np.concatenate([p.t_events[k] for p in pieces]) for k in range(events)],
        y_events=[np.concatenate([np.reshape(p.y_events[k], (-1, 2 * num.n))
                                  for p in pieces]) for k in range(events)],
        sol=_Piecewise([p.t[0] if len(p.t) else t0 for p in pieces], sols)
        if len(sols) == len(pieces) else None,
        error=last.error)


class _Piecewise:
    """``sol(t)`` of joined pieces: each time answered by the piece whose interval holds it."""

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
