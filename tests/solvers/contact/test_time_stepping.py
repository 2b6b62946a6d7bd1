"""The time-stepping contact mode (``solvers/contact/time_stepping.py``).

References: the bouncing ball's closed form (impact times and apex heights, against
which the scheme is first order: its errors halve with the step); a chain of rods
dropped onto a table (no penetration, the rods' lengths held, the energy never
rising, the chain at rest on the table at the end); the LCP on small matrices solved
by hand.
"""

from __future__ import annotations

import numpy as np
import pytest

from dalembert import Holonomic, System, Unilateral, coordinates
from dalembert.solvers.contact.impulses import solve_lcp

g, e, h0 = 9.81, 0.8, 1.0
(Y,) = coordinates("y")
BALL = System([Y], kinetic=Y.diff() ** 2 / 2, potential=g * Y,
              constraints=[Unilateral(Y, name="floor", restitution=e)])


def test_lcp_by_hand():
    W = np.array([[2.0, 1.0], [1.0, 2.0]])
    # both pushing: W P = -q
    assert np.allclose(solve_lcp(W, np.array([-3.0, -3.0])), [1.0, 1.0], atol=1e-15)
    # the second opens: P2 = 0, w2 = P1 + 1 >= 0
    assert np.allclose(solve_lcp(W, np.array([-3.0, 1.0])), [1.5, 0.0], atol=1e-15)
    assert np.array_equal(solve_lcp(W, np.array([1.0, 1.0])), [0.0, 0.0])  # none


def test_bouncing_ball_is_first_order_in_the_step():
    """The impact lands in the step that closes the gap, so the speed it reverses is
    off by at most ``g h`` and the apex after it by ``2 g h / v1`` relative at most."""
    t1 = np.sqrt(2 * h0 / g)
    impacts = t1 + 2 * t1 * np.cumsum(np.r_[0.0, e ** np.arange(1, 4)])
    for h in (2e-3, 7e-4):
        traj = BALL.simulate((0.0, 1.2), {"y": h0}, contact_mode="time-stepping",
                             contact_step=h)
        assert traj.success and traj.q.min() >= 0.0  # projected: never below the floor
        first = traj.contacts.impact_times[0]
        assert impacts[0] <= first <= impacts[0] + 2 * h  # the step that closes it
        apex = traj.q[(traj.t > impacts[0]) & (traj.t < impacts[1]), 0].max()
        assert abs(apex / (e**2 * h0) - 1) <= 2 * g * h / (g * t1)


@pytest.mark.parametrize("h", [2e-3, 1e-3])
def test_a_bouncing_ball_comes_to_rest_where_its_bounces_accumulate(h):
    """The bounces accumulate at ``t_inf = t_1 (1 + e) / (1 - e)`` (a Zeno
    accumulation). The ball then rests on the floor: there, height and speed 0, the
    multiplier the weight, no impact after. Each impact lands within two steps of its
    time (the test above), so rest comes within ``2 h`` per impact of ``t_inf``; the
    energy the impacts took is the drop's, ``m g h0``, to first order in ``h``.
    Without the step's rest rule (a slow impact plastic) the ball hops by ``g h`` for
    ever, an impact every few steps."""
    t1 = np.sqrt(2 * h0 / g)
    t_inf = t1 * (1 + e) / (1 - e)
    traj = BALL.simulate((0.0, t_inf + 0.5), {"y": h0}, contact_mode="time-stepping",
                         contact_step=h)
    assert traj.success, traj.message
    moving = np.flatnonzero((traj.q[:, 0] != 0.0) | (traj.qd[:, 0] != 0.0))
    rest = traj.t[moving[-1] + 1]
    impacts = traj.contacts.impact_times
    assert impacts[-1] == rest  # the last impact puts it to rest
    assert abs(rest - t_inf) <= 2 * h * len(impacts)
    assert np.abs(traj.multiplier("floor")[traj.t > rest] - g).max() < 1e-12
    lost = sum(i.energy_lost for i in traj.contacts.impacts)
    assert abs(lost - g * h0) < 0.01 * g * h0


def test_chain_dropped_on_a_table_comes_to_rest_on_it():
    count, link = 6, 0.2
    xs = coordinates(" ".join(f"x{k}" for k in range(count)))
    ys = coordinates(" ".join(f"y{k}" for k in range(count)))
    rods = [Holonomic((xs[k + 1] - xs[k]) ** 2 + (ys[k + 1] - ys[k]) ** 2 - link**2,
                      name=f"rod{k}") for k in range(count - 1)]
    table = [Unilateral(y, name=f"table{k}") for k, y in enumerate(ys)]
    chain = System([*xs, *ys], kinetic=sum(c.diff() ** 2 for c in (*xs, *ys)) / 2,
                   potential=g * sum(ys), constraints=rods + table)
    angle = 0.3  # tilted: one end lands first, the others follow
    q0 = {f"x{k}": k * link * np.cos(angle) for k in range(count)}
    q0.update({f"y{k}": 0.3 + k * link * np.sin(angle) for k in range(count)})
    traj = chain.simulate((0.0, 1.5), q0, contact_mode="time-stepping", contact_step=2e-3)
    assert traj.success, traj.message
    heights = traj.q[:, count:]
    assert heights.min() >= -1e-12  # nothing below the table
    assert traj.position_residual.max() < 1e-10  # the rods' lengths
    energy = traj.energy
    # plastic: the energy falls, but for the potential energy a landing step's position
    # projection adds (lifting what went below the table within the step: at most
    # m g v h per mass, v about 3.3 m/s here)
    assert np.diff(energy).max() <= count * g * 3.5 * 2e-3
    assert energy[-1] < 0.3 * energy[0]
    assert np.abs(heights[-1]).max() < 1e-9  # flat on the table
    assert len(traj.contacts.impacts) >= 2  # landed in a cascade, not all at once
    closed = traj.contacts.closed_at(traj.t[-1:])[0]
    assert closed.all()
    # on the table each mass's weight is carried by its table contact (the mean force)
    assert np.abs(traj.multipliers[-1, count - 1:] - g).max() < 1e-6


def test_time_stepping_refuses_a_step_without_its_mode():
    with pytest.raises(ValueError, match=r"contact_step=0\.01 is the time-stepping"):
        BALL.simulate((0.0, 1.0), {"y": h0}, contact_step=0.01)


def test_a_long_chain_lying_on_the_table_stays_at_rest():
    """17 masses on 16 rods landing while sliding sideways (frictionless), steps of
    0.01: once flat they stay on the table, with no vertical motion. A contact that
    pushes is held at 0 by the position projection; left free, the projection of the
    flat chain's rods lifted masses by ~1e-8, above the touch tolerance, and each then
    fell a step and was caught the next (a hop of g h = 0.098 m/s every 0.1-0.2 s)."""
    count, link, angle = 17, 0.15, 0.35
    xs = coordinates(" ".join(f"x{k}" for k in range(count)))
    ys = coordinates(" ".join(f"y{k}" for k in range(count)))
    rods = [Holonomic((xs[k + 1] - xs[k]) ** 2 + (ys[k + 1] - ys[k]) ** 2 - link**2,
                      name=f"rod{k}") for k in range(count - 1)]
    table = [Unilateral(y, name=f"table{k}") for k, y in enumerate(ys)]
    chain = System([*xs, *ys], kinetic=sum(c.diff() ** 2 for c in (*xs, *ys)) / 20,
                   potential=0.1 * g * sum(ys), constraints=rods + table)
    q0 = {f"x{k}": k * link * np.cos(angle) for k in range(count)}
    q0.update({f"y{k}": 0.25 + k * link * np.sin(angle) for k in range(count)})
    traj = chain.simulate((0.0, 2.0), q0, {f"x{k}": 0.4 for k in range(count)},
                          contact_mode="time-stepping", contact_step=0.01)
    assert traj.success, traj.message
    flat = traj.t >= 1.5
    assert np.abs(traj.q[flat, count:]).max() < 1e-12
    assert np.abs(traj.qd[flat, count:]).max() < 1e-12
    # sliding on at the sideways speed: horizontal momentum is kept (no friction)
    assert np.abs(traj.qd[flat, :count].sum(axis=1) - count * 0.4).max() < 1e-12



def test_time_stepping_stops_at_its_time_limit_keeping_the_steps_done():
    """A run far too long for its ``timeout`` stops with status ``"timeout"`` and a
    warning, returning the points computed: before the first impact they follow the
    free fall's closed form (the step is exact for a constant force)."""
    from dalembert.errors import IntegrationWarning

    # a million steps (minutes of work), whose grid of step ends is still small to make
    # (a span of 1e4 s took the whole limit to lay out its 1e8 steps)
    with pytest.warns(IntegrationWarning, match="time limit"):
        traj = BALL.simulate((0.0, 100.0), {"y": h0}, contact_mode="time-stepping",
                             contact_step=1e-4, timeout=1.0)
    assert traj.status == "timeout"
    assert "time limit (timeout=)" in traj.message
    assert 0.0 < traj.t[-1] < 100.0 and len(traj.t) >= 2
    falling = traj.t < np.sqrt(2 * h0 / g) - 1e-3
    assert np.allclose(traj["y"][falling], h0 - g * traj.t[falling] ** 2 / 2,
                       atol=1e-12, rtol=0)
