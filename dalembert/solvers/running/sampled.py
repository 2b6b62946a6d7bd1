"""Sampled inputs: a zero-order hold, as a schedule of resets.

With ``simulate(inputs=..., sample_time=dt)`` the inputs are computed at the sample
instants ``t0 + k * dt`` (each computed, not accumulated) from the state there and
held until the next one, as a digital controller acts. The right-hand side is smooth
between instants and jumps at them: :func:`sampled_schedule` makes the
:class:`~.segments.Schedule` whose reset at each instant takes a new sample (the state
does not jump), and the segment driver (:mod:`~dalembert.solvers.running.segments`) runs one
integration per interval. An output time within rounding of an instant (a ``t_eval``
from ``np.linspace`` or ``np.arange``, or ``k / 10`` against ``k * 0.1``) shows the
new sample, the value applied from that instant on; so does ``tf`` if it is an
instant (the sample a controller would take there).
"""

from __future__ import annotations

import math

import numpy as np

from ...inputs import InputSignal
from ...numerics.state_layout import StateLayout
from .segments import Schedule, SegmentState

#: Output times within this many rounding units of the span's largest time (of ``dt``
#: if larger) of a sample instant are the instant's.
ROUNDING = 8


def sample_instants(t_span: tuple[float, float], sample_time: float) -> np.ndarray:
    """``t0 + k * dt`` for ``k = 0, 1, ...`` up to ``tf``; an instant closer than a
    millionth of ``dt`` to ``tf`` is ``tf`` itself.

    Parameters
    ----------
    t_span
        ``(t0, tf)`` (``tf < t0`` counts down).
    sample_time
        ``dt > 0``.

    Examples
    --------
    >>> sample_instants((0.0, 1.0), 0.25).tolist(), sample_instants((0.0, 1.0), 0.3).tolist()
    ([0.0, 0.25, 0.5, 0.75, 1.0], [0.0, 0.3, 0.6, 0.8999999999999999])
    """
    t0, tf = t_span
    direction = math.copysign(1.0, tf - t0)
    count = math.floor(abs(tf - t0) / sample_time * (1 + 1e-12))
    instants = t0 + direction * sample_time * np.arange(count + 2)
    near_end = np.abs(tf - instants) <= 1e-6 * sample_time
    instants[near_end] = tf
    keep = direction * (instants - tf) <= 0
    return instants[keep]


def sampled_schedule(signal: InputSignal, t_span: tuple[float, float], n: int) -> Schedule:
    """The resets of a zero-order hold: at each sample instant, the inputs from the
    state there.

    Parameters
    ----------
    signal
        The inputs, with their ``sample_time``.
    t_span
        The run's span.
    n
        The number of coordinates (the state is ``[q, qd]``).

    Examples
    --------
    >>> from dalembert.inputs import input_signal
    >>> signal = input_signal(lambda t, q, qd: -q[0], ["u"], 0.5, (0.0, 1.0))
    >>> schedule = sampled_schedule(signal, (0.0, 1.0), 1)
    >>> schedule.instants.tolist()
    [0.0, 0.5, 1.0]
    >>> schedule.reset(0.5, SegmentState(np.array([2.0, 0.0]))).inputs.tolist()
    [-2.0]
    """
    assert signal.sample_time is not None
    t0, tf = t_span
    layout = StateLayout(n)

    def sample(t: float, state: SegmentState) -> SegmentState:
        return SegmentState(state.y, signal(t, *layout.split(state.y)), state.active)

    scale = max(abs(t0), abs(tf), signal.sample_time)
    return Schedule(sample_instants(t_span, signal.sample_time), sample,
                    ROUNDING * np.finfo(float).eps * scale)
