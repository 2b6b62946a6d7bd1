"""Steps that keep shrinking toward a time the run would never reach (a prescribed
motion that diverges at a finite time): the run stops within seconds naming it.

Reference: the driver's own closed form for the returned motion (the crank angle is
prescribed). Runs whose steps collapse and recover (tests/solvers/singular/test_singular.py)
must not be stopped, and are not.
"""

from __future__ import annotations

import numpy as np
import pytest

from dalembert import IntegrationWarning, System
from dalembert import t as time_symbol
from dalembert.examples import slider_crank
from dalembert.multibody import Driver, Multibody

T_STAR = 0.25  # the prescribed crank angle diverges there


def diverging_press() -> tuple[System, dict, dict]:
    """The slider-crank with its crank driven at THETA_0 + 0.01 / (t - 0.25)."""
    mb = slider_crank.build_multibody()
    angle = slider_crank.THETA_0 + 0.01 / (time_symbol - T_STAR)
    motor = Driver("motor", mb.joint("J1"), angle)
    system = Multibody(mb.bodies, [*mb.joints, motor], gravity=mb.gravity).system
    start = slider_crank.initial_state(slider_crank.THETA_0 - 0.01 / T_STAR,
                                       -0.01 / T_STAR**2)
    return system, start["q0"], start["qd0"]


@pytest.mark.parametrize("backend", ["c", "python"])
def test_a_driver_diverging_at_a_finite_time_stops_the_run_naming_it(backend):
    system, q0, qd0 = diverging_press()
    with pytest.warns(IntegrationWarning, match="grows without bound") as caught:
        traj = system.simulate((0, 0.5), q0, qd0, backend=backend)
    message = str(caught[-1].message)
    assert "the prescribed rate of motor_1" in message and "steps keep shrinking" in message
    assert traj.status == "failed" and 0.2499 < traj.t[-1] < T_STAR
    assert traj.stats["n_steps"] < 50_000  # it crept through millions before
    # what is returned is right: the crank follows its prescribed angle
    prescribed = slider_crank.THETA_0 + 0.01 / (traj.t - T_STAR)
    wrapped = np.angle(np.exp(1j * (traj["crank_theta"] - prescribed)))
    assert np.abs(wrapped).max() < 1e-6


@pytest.mark.parametrize("backend", ["c", "python"])
def test_a_force_that_is_not_smooth_where_the_motion_stops_stops_the_run_there(backend):
    """A block pushed by 2 N against a hand-written dry friction ``-5 sign(x')``,
    launched at 3 m/s: it decelerates at 3 m/s^2 and stops at t = 1 (x = 1.5), where
    the force flips at every step: the steps stall there instead of crawling for
    days (the run used to hang)."""
    import sympy as sp

    from dalembert import coordinates

    (x,) = coordinates("x")
    block = System([x], kinetic=x.diff() ** 2 / 2, potential=-2.0 * x,
                   generalized_forces={x: -5.0 * sp.sign(x.diff())})
    with pytest.warns(IntegrationWarning, match="the steps have stalled") as caught:
        traj = block.simulate((0, 10.0), {"x": 0.0}, {"x": 3.0}, backend=backend)
    assert "force that is not smooth" in str(caught[-1].message)
    assert traj.status == "failed" and abs(traj.t[-1] - 1.0) < 1e-6
    moving = traj.t <= 1.0
    assert np.abs(traj["x"][moving] - (3 * traj.t - 1.5 * traj.t**2)[moving]).max() < 1e-12
