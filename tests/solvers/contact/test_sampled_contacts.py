"""Inputs held by a digital controller (``sample_time``) with contacts, in both modes.

References: a ball bouncing on a frictionless floor (``e = 0.8``) while a sampled PD
force acts along it: the two motions are independent, so the horizontal one at the
instants follows the exact discretization of a double integrator under a zero-order
hold, ``x+ = x + v dt + u dt^2 / 2``, ``v+ = v + u dt``, and the bounces keep their
closed-form times (``t_1 = sqrt(2 h / g)``, each flight ``e`` times the one before);
and a block resting on the floor lifted by a sampled force of twice its weight from
the instant it is sampled: the contact opens at that instant (not at the next switch)
and the block rises as ``g (t - t_s)^2 / 2``.

In the time-stepping mode the same recurrence holds for a block resting on the floor
(and, on a rough floor under a ramp sampled above the friction, with ``u - mu g`` for
``u``), and the lift the same flight: the steps fall on the instants, so the force is
constant over each step, and a Moreau-Jean step is exact for a constant force (its
position update is the trapezoid of a velocity linear in time). Its first-order error
is in where within a step a contact closes; here every contact opens at a step's
start, so these hold to rounding (1e-12 over 2000 steps), with steps that divide the
sample time and steps that do not (then each interval is cut into equal steps a
little shorter, which fall on the instants).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
import sympy as sp

from dalembert import IntegrationWarning, System, Unilateral, coordinates

G, E, H0, DT = 9.81, 0.8, 1.0, 0.05
KP, KD = 4.0, 1.0

x, y = coordinates("x y")
u, w = sp.symbols("u w")


def ball() -> System:
    return System([x, y], kinetic=(x.diff() ** 2 + y.diff() ** 2) / 2, potential=G * y,
                  generalized_forces={x: u, y: w}, inputs=[u, w],
                  constraints=[Unilateral(y, name="floor", restitution=E)])


def pd(t, q, qd):
    return [-KP * q[0] - KD * qd[0], 0.0]


def test_a_sampled_force_along_a_bouncing_ball_follows_the_zero_order_hold():
    instants = np.arange(0, 41) * DT  # to t = 2
    traj = ball().simulate((0.0, 2.0), {x: 1.0, y: H0}, inputs=pd, sample_time=DT,
                           t_eval=instants)
    assert traj.status == "finished"
    xs, vs, us = [1.0], [0.0], []
    for _ in instants[:-1]:
        uk = -KP * xs[-1] - KD * vs[-1]
        us.append(uk)
        xs.append(xs[-1] + vs[-1] * DT + uk * DT**2 / 2)
        vs.append(vs[-1] + uk * DT)
    np.testing.assert_allclose(traj["x"], xs, rtol=0, atol=1e-12)
    np.testing.assert_allclose(traj["x_dot"], vs, rtol=0, atol=1e-12)
    # the inputs shown at each instant are the sample taken there
    np.testing.assert_allclose(traj.inputs[:-1, 0], us, rtol=0, atol=1e-12)
    assert traj.inputs[-1, 0] == pytest.approx(-KP * xs[-1] - KD * vs[-1], abs=1e-12)
    # the bounces, untouched by the horizontal control
    t1 = math.sqrt(2 * H0 / G)
    expected = [t1]
    while len(expected) < 3:  # the fourth is after t = 2
        expected.append(expected[-1] + 2 * E ** len(expected) * t1)
    np.testing.assert_allclose(traj.contacts.impact_times, expected, rtol=0, atol=1e-10)


def test_a_sampled_force_lifting_a_resting_block_opens_the_contact_at_its_instant():
    def lift(t, q, qd):
        return [0.0, 2 * G if t >= 0.3 - 1e-12 else 0.0]

    traj = ball().simulate((0.0, 0.5), {x: 0.0, y: 0.0}, inputs=lift, sample_time=0.1,
                           t_eval=np.linspace(0.0, 0.5, 11))
    assert traj.status == "finished"
    switches = traj.contacts.switches
    assert [s.closed for s in switches] == [(0,), ()]
    assert switches[1].t == pytest.approx(0.3, abs=1e-14)
    after = traj.t >= 0.3
    np.testing.assert_allclose(traj["y"][after], G / 2 * (traj.t[after] - 0.3) ** 2,
                               rtol=0, atol=1e-12)
    np.testing.assert_allclose(traj["y"][~after], 0.0, atol=1e-15)
    # resting, the floor carries the weight; lifted, nothing
    np.testing.assert_allclose(traj.multiplier("floor")[~after], G, rtol=1e-12)
    np.testing.assert_allclose(traj.multiplier("floor")[after], 0.0, atol=1e-12)


def _zero_order_hold(count: int, force, x0: float = 1.0):
    """The positions, velocities and samples of a unit mass at the instants ``k DT``
    under ``force(x, v)`` sampled there and held (the exact recurrence)."""
    xs, vs, us = [x0], [0.0], []
    for _ in range(count):
        uk = force(xs[-1], vs[-1])
        us.append(uk)
        xs.append(xs[-1] + vs[-1] * DT + uk * DT**2 / 2)
        vs.append(vs[-1] + uk * DT)
    return np.array(xs), np.array(vs), np.array(us)


@pytest.mark.parametrize("step", [1e-3, 3e-3])  # 50 steps an interval; 17 cut short
def test_time_stepping_a_sampled_force_along_a_resting_block_follows_the_hold(step):
    instants = np.arange(0, 41) * DT  # to t = 2
    traj = ball().simulate((0.0, 2.0), {x: 1.0, y: 0.0}, inputs=pd, sample_time=DT,
                           t_eval=instants, contact_mode="time-stepping", contact_step=step)
    assert traj.status == "finished", traj.message
    assert traj.stats["n_steps"] == 40 * math.ceil(DT / step - 1e-9)
    xs, vs, us = _zero_order_hold(40, lambda xk, vk: -KP * xk - KD * vk)
    np.testing.assert_allclose(traj["x"], xs, rtol=0, atol=1e-12)
    np.testing.assert_allclose(traj["x_dot"], vs, rtol=0, atol=1e-12)
    # the inputs shown at each instant are the sample taken there, tf's too
    np.testing.assert_allclose(traj.inputs[:-1, 0], us, rtol=0, atol=1e-12)
    assert traj.inputs[-1, 0] == pytest.approx(-KP * xs[-1] - KD * vs[-1], abs=1e-12)
    np.testing.assert_allclose(traj["y"], 0.0, atol=1e-15)  # resting on the floor
    np.testing.assert_allclose(traj.multiplier("floor")[1:], G, rtol=1e-12)


def test_time_stepping_a_sampled_ramp_drags_a_block_on_a_rough_floor():
    """A ramp ``u = 2 mu g + c t_k`` sampled at ``t_k``: always above the friction
    ``mu g``, the block slides forward from the start, decelerated by ``mu g``."""
    mu, c = 0.3, 5.0
    rough = System([x, y], kinetic=(x.diff() ** 2 + y.diff() ** 2) / 2, potential=G * y,
                   generalized_forces={x: u, y: w}, inputs=[u, w],
                   constraints=[Unilateral(y, name="floor", friction=mu,
                                           tangents=[x.diff()])])
    instants = np.arange(0, 21) * DT

    def ramp(t, q, qd):
        return [2 * mu * G + c * t, 0.0]

    traj = rough.simulate((0.0, 1.0), {x: 0.0, y: 0.0}, inputs=ramp, sample_time=DT,
                          t_eval=instants, contact_mode="time-stepping")
    assert traj.status == "finished", traj.message
    t_k = iter(instants)
    xs, vs, _ = _zero_order_hold(20, lambda xk, vk: mu * G + c * next(t_k), 0.0)
    np.testing.assert_allclose(traj["x"], xs, rtol=0, atol=1e-12)
    np.testing.assert_allclose(traj["x_dot"], vs, rtol=0, atol=1e-12)
    # the friction force, -mu g against the sliding
    np.testing.assert_allclose(traj.multiplier("floor_friction_1")[1:], -mu * G, rtol=1e-12)


@pytest.mark.parametrize("step", [1e-3, 3e-3])
def test_time_stepping_a_sampled_lift_opens_the_contact_at_its_instant(step):
    def lift(t, q, qd):
        return [0.0, 2 * G if t >= 0.3 - 1e-12 else 0.0]

    traj = ball().simulate((0.0, 0.5), {x: 0.0, y: 0.0}, inputs=lift, sample_time=0.1,
                           t_eval=np.linspace(0.0, 0.5, 11), contact_mode="time-stepping",
                           contact_step=step)
    assert traj.status == "finished", traj.message
    np.testing.assert_array_equal(traj.t, np.linspace(0.0, 0.5, 11))  # the times asked
    # the contact opens in the first step after the instant (recorded at its end)
    opened = traj.contacts.switches[-1]
    assert opened.closed == () and 0.3 < opened.t <= 0.3 + step + 1e-12
    after = traj.t >= 0.3
    np.testing.assert_allclose(traj["y"][after], G / 2 * (traj.t[after] - 0.3) ** 2,
                               rtol=0, atol=1e-12)
    np.testing.assert_allclose(traj["y"][~after], 0.0, atol=1e-15)
    # the force over the step ending at each point: the weight up to 0.3, then none
    resting = traj.t <= 0.3 + 1e-12
    np.testing.assert_allclose(traj.multiplier("floor")[1:][resting[1:]], G, rtol=1e-12)
    np.testing.assert_allclose(traj.multiplier("floor")[~resting], 0.0, atol=1e-12)
    # the inputs shown at 0.3 are the sample taken there
    np.testing.assert_allclose(traj.inputs[:, 1], np.where(after, 2 * G, 0.0))


def test_time_stepping_a_sampled_input_that_fails_ends_the_run_with_what_it_computed():
    def failing(t, q, qd):
        if t > 0.25:
            raise RuntimeError("sensor lost")
        return [0.0, 0.0]

    with pytest.warns(IntegrationWarning, match="sensor lost"):
        traj = ball().simulate((0.0, 1.0), {x: 0.0, y: H0}, inputs=failing, sample_time=0.1,
                               t_eval=np.linspace(0.0, 1.0, 11), contact_mode="time-stepping")
    assert traj.status == "failed"
    assert "sensor lost" in traj.message
    np.testing.assert_allclose(traj.t, [0.0, 0.1, 0.2])
    # a free fall: the steps' trapezoids are exact for it
    np.testing.assert_allclose(traj["y"], H0 - G / 2 * traj.t**2, atol=1e-12)


def test_a_sampled_input_that_fails_ends_the_run_with_what_it_computed():
    def failing(t, q, qd):
        if t > 0.25:
            raise RuntimeError("sensor lost")
        return [0.0, 0.0]

    with pytest.warns(Warning):
        traj = ball().simulate((0.0, 1.0), {x: 0.0, y: H0}, inputs=failing, sample_time=0.1,
                               t_eval=np.linspace(0.0, 1.0, 11))
    assert traj.status == "failed"
    assert "sensor lost" in traj.message
    np.testing.assert_allclose(traj.t, [0.0, 0.1, 0.2])
    np.testing.assert_allclose(traj["y"], H0 - G / 2 * traj.t**2, atol=1e-12)
