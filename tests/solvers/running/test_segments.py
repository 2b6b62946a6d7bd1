"""The segment driver's contract (solvers/running/segments.py) on small exact cases.

References: closed forms (a ball falling and bouncing, its impacts at known instants; a
ramp), the schedule's own instants and the states each segment was given.
"""

from __future__ import annotations

from typing import ClassVar

import numpy as np
import pytest
from scipy.integrate import RK45

from dalembert.solvers.running.integrate import integrate
from dalembert.solvers.running.segments import Schedule, SegmentState, run_segments

G, E, H = 9.81, 0.5, 1.0  # gravity, restitution, drop height
FIRST = np.sqrt(2 * H / G)  # the first impact; each bounce after lasts E times the one before
IMPACTS = FIRST + 2 * FIRST * np.cumsum([0.0, E, E**2])[:3]  # the first three impacts


def ball(t: float) -> np.ndarray:
    """Height and velocity of the ball dropped from rest at ``H`` (closed form)."""
    if t < IMPACTS[0]:
        return np.array([H - G * t**2 / 2, -G * t])
    k = int(np.searchsorted(IMPACTS, t, "right")) - 1
    up = E ** (k + 1) * G * FIRST  # the speed right after impact k
    s = t - IMPACTS[k]
    return np.array([up * s - G * s**2 / 2, up - G * s])


class Falling:
    """A segment of free fall, ``y = [height, velocity]``; it records what it was given."""

    made: ClassVar[list[tuple[float, float, SegmentState]]] = []

    def __init__(self, a, b, start, t_eval, progress, events=(), dense_output=False):
        Falling.made.append((a, b, start))
        self.run = lambda: integrate(lambda t, y: np.array([y[1], -G]), (a, b), start.y,
                                     method=RK45, t_eval=t_eval, events=events,
                                     dense_output=dense_output, rtol=1e-12, atol=1e-12,
                                     max_step=0.01)  # RK45 is exact here: steps would span bounces


def bounce(t: float, state: SegmentState) -> SegmentState:
    """The impact: the velocity reversed and scaled by the restitution."""
    return SegmentState(np.array([0.0, -E * state.y[1]]), state.inputs, state.active)


def no_outputs(segment, t, y):
    return {"height": y[:, 0]}


def bouncing(t_eval=None, **segment):
    Falling.made = []
    make = (lambda *args: Falling(*args, **segment)) if segment else Falling
    return run_segments(make, no_outputs, Schedule(IMPACTS, bounce, 1e-12), (0.0, 2.0),
                        np.array([H, 0.0]), t_eval)


def test_a_state_jump_at_each_instant_against_the_bouncing_ball():
    times = np.concatenate([np.linspace(0.0, 2.0, 41), IMPACTS])
    times.sort()
    joined = bouncing(times)
    np.testing.assert_array_equal(joined.result.t, times)  # each time once
    exact = np.array([ball(t) for t in times])
    assert np.abs(joined.result.y - exact).max() < 1e-10
    at = np.isin(times, IMPACTS)  # the post-reset value at each impact: moving up
    assert np.all(joined.result.y[at, 1] > 0)
    np.testing.assert_array_equal(joined.derived["height"], joined.result.y[:, 0])
    assert joined.result.stats["n_segments"] == 4
    # each segment started from the state the reset made, at its instant
    for (a, _, start), t in zip(Falling.made[1:], IMPACTS):
        assert a == t and np.abs(start.y - ball(t)).max() < 1e-10


def test_every_step_recorded_once_and_dense_output_piecewise():
    joined = bouncing(dense_output=True)
    t = joined.result.t
    assert np.all(np.diff(t) > 0) and t[0] == 0.0 and t[-1] == 2.0
    assert np.count_nonzero(np.isin(t, IMPACTS)) == 3
    probe = np.linspace(0.0, 2.0, 97)
    assert np.abs(joined.result.sol(probe).T - [ball(s) for s in probe]).max() < 1e-10
    assert joined.result.sol(IMPACTS[1])[1] > 0  # an instant: the segment starting there


def test_events_are_joined_and_a_terminal_one_ends_the_whole_run():
    apex = lambda t, y: y[1]  # noqa: E731  (the top of each bounce)
    joined = bouncing(np.linspace(0.0, 2.0, 41), events=[apex])
    tops = IMPACTS + E ** np.arange(1, 4) * FIRST  # each bounce's top, one per segment
    np.testing.assert_allclose(joined.result.t_events[0], tops, atol=1e-10)
    assert joined.result.y_events[0].shape == (3, 2)
    assert np.abs(joined.result.y_events[0][:, 0] - [ball(t)[0] for t in tops]).max() < 1e-10

    half = lambda t, y: y[0] - H / 2  # noqa: E731  (falling through half the height)
    top = lambda t, y: y[0] - 0.2  # noqa: E731  (rising through 0.2 on the first bounce)
    top.terminal, top.direction = True, 1
    joined = bouncing(np.linspace(0.0, 2.0, 41), events=[half, top])
    assert joined.result.status == "event"
    np.testing.assert_allclose(joined.result.t_events[0], [np.sqrt(H / G)], atol=1e-10)
    up = E * G * FIRST  # the speed after the first impact
    rise = IMPACTS[0] + (up - np.sqrt(up**2 - 2 * G * 0.2)) / G
    np.testing.assert_allclose(joined.result.t_events[1], [rise], atol=1e-10)
    assert joined.result.stats["n_segments"] == 2 and joined.result.t[-1] < rise


def test_the_active_rows_and_held_inputs_reach_each_segment():
    """The reset's other parts pass through: the held inputs (recorded at each point)
    and the active rows (a segment is given the rows the reset before chose)."""
    def close(t, state):
        return SegmentState(state.y, np.array([t]), (0,) if t >= 0.5 else None)

    Falling.made = []
    joined = run_segments(Falling, no_outputs, Schedule(np.array([0.0, 0.5]), close, 0.0),
                          (0.0, 1.0), np.array([H, 0.0]), np.array([0.0, 0.25, 0.5, 1.0]))
    assert [start.active for _, _, start in Falling.made] == [None, (0,)]
    np.testing.assert_array_equal(joined.inputs[:, 0], [0.0, 0.0, 0.5, 0.5])
    exact = np.array([[H - G * t**2 / 2, -G * t] for t in joined.result.t])
    assert np.abs(joined.result.y - exact).max() < 1e-12


@pytest.mark.parametrize("t_eval", [np.array([2.0, 1.0, 0.5, 0.0]), None])
def test_counting_down(t_eval):
    """From t = 2 back to 0 across instants at 1.5, 1 and 0.5 (no jump): the parabola."""
    Falling.made = []
    joined = run_segments(Falling, no_outputs,
                          Schedule(np.array([1.5, 1.0, 0.5]), lambda t, s: s, 1e-12),
                          (2.0, 0.0), np.array([0.0, 0.0]), t_eval)
    if t_eval is not None:
        np.testing.assert_array_equal(joined.result.t, t_eval)
    t = joined.result.t
    assert np.all(np.diff(t) < 0) and t[-1] == 0.0
    exact = np.stack([-G * (t - 2.0) ** 2 / 2, -G * (t - 2.0)], axis=1)
    assert np.abs(joined.result.y - exact).max() < 1e-11
    assert [a for a, _, _ in Falling.made] == [2.0, 1.5, 1.0, 0.5]
