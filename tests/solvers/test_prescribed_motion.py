"""Prescribed motion (no degree of freedom left) and inverse dynamics.

The mechanism: a slider-crank in the vertical plane, crank (uniform rod, pivoted at
the origin), connecting rod and slider on the x axis, in redundant coordinates
``theta1, x2, y2, theta2, x3``. A rheonomic driver ``theta1 = omega t`` removes the
last degree of freedom; its multiplier is the motor torque.

Reference: the minimal model, one closed-form kinematic chain in ``t`` (slider at
``r cos + sqrt(l^2 - r^2 sin^2)``), and the power balance ``tau omega = d(T + V)/dt``
differentiated by SymPy: independent of dalembert's derivation.
"""

from __future__ import annotations

import numpy as np
import pytest
import sympy as sp

from dalembert import ConstraintError, Holonomic, System, coordinates
from dalembert import t as time

R, L, M1, M2, M3, G, OMEGA = 0.3, 1.0, 2.0, 3.0, 1.5, 9.81, 4.0


def crank(driven: bool = True) -> System:
    th1, x2, y2, th2, x3 = coordinates("theta1 x2 y2 theta2 x3")
    d = {q: q.diff() for q in (th1, x2, y2, th2, x3)}
    kinetic = (M1 * R**2 / 6 * d[th1]**2 + M2 / 2 * (d[x2]**2 + d[y2]**2)
               + M2 * L**2 / 24 * d[th2]**2 + M3 / 2 * d[x3]**2)
    potential = M1 * G * R / 2 * sp.sin(th1) + M2 * G * y2
    joints = [Holonomic(x2 - L / 2 * sp.cos(th2) - R * sp.cos(th1), name="pin_x"),
              Holonomic(y2 - L / 2 * sp.sin(th2) - R * sp.sin(th1), name="pin_y"),
              Holonomic(x2 + L / 2 * sp.cos(th2) - x3, name="slider_x"),
              Holonomic(y2 + L / 2 * sp.sin(th2), name="slider_y")]
    if driven:
        joints.append(Holonomic(th1 - OMEGA * time, name="motor"))
    return System([th1, x2, y2, th2, x3], kinetic=kinetic, potential=potential,
                  constraints=joints, name="driven crank")


def closed_form():
    """Positions and the motor torque as functions of t, from the minimal model."""
    t = sp.Symbol("t")
    th = OMEGA * t
    xb = R * sp.cos(th) + sp.sqrt(L**2 - R**2 * sp.sin(th)**2)
    ax, ay = R * sp.cos(th), R * sp.sin(th)
    x2, y2 = (ax + xb) / 2, ay / 2
    th2 = sp.atan2(-ay, xb - ax)
    T = (M1 * R**2 / 6 * OMEGA**2 + M2 / 2 * (x2.diff(t)**2 + y2.diff(t)**2)
         + M2 * L**2 / 24 * th2.diff(t)**2 + M3 / 2 * xb.diff(t)**2)
    V = M1 * G * R / 2 * sp.sin(th) + M2 * G * y2
    tau = (T + V).diff(t) / OMEGA
    q = [th, x2, y2, th2, xb]
    return sp.lambdify(t, q), sp.lambdify(t, tau), sp.lambdify(t, [e.diff(t) for e in q])


@pytest.fixture(scope="module")
def run():
    positions, _, velocities = closed_form()
    q0, qd0 = (np.array(f(0.0), dtype=float) for f in (positions, velocities))
    times = np.linspace(0.0, 2.0, 81)
    return crank().simulate((0.0, 2.0), q0, qd0, t_eval=times)


def test_a_driven_mechanism_without_freedom_runs(run):
    assert run.status == "finished"
    report = crank().consistent_initial_state(run.q[0], run.qd[0])
    assert report.degrees_of_freedom == 0 and not report.changed
    positions, _, _ = closed_form()
    expected = np.array([positions(t) for t in run.t], dtype=float)
    expected[:, 3] = np.unwrap(expected[:, 3])
    assert np.abs(run.q - expected).max() < 1e-9


def test_the_motor_multiplier_is_the_driving_torque(run):
    _, tau, _ = closed_form()
    torque = run.multiplier("motor")  # A row (1, 0, ...): the generalized force on theta1
    assert np.abs(torque - np.array([tau(t) for t in run.t])).max() < 1e-9
    assert np.ptp(torque) > 1.0  # the torque varies: the check is not vacuous


def test_inverse_dynamics_of_the_free_crank_needs_the_same_power(run):
    """Without the motor the crank has one degree of freedom; the applied generalized
    force that makes it follow the driven motion delivers the motor's power."""
    free = crank(driven=False)
    for k in (0, 17, 40, 63):
        need = free.inverse_dynamics(run.t[k], run.q[k], run.qd[k], run.qdd[k])
        power = need.applied @ run.qd[k]
        assert power == pytest.approx(run.multiplier("motor")[k] * OMEGA, rel=1e-9, abs=1e-9)
        np.testing.assert_allclose(need.required, need.constraint_forces + need.applied)
    with pytest.raises(ValueError, match="the accelerations violate constraint '"):
        free.inverse_dynamics(0.0, run.q[0], run.qd[0], np.ones(5))


def test_accelerations_at_a_state_are_the_trajectory_ones(run):
    system = crank()
    for k in (5, 50):
        qdd, lam = system.accelerations(run.t[k], run.q[k], run.qd[k])
        assert np.abs(qdd - run.qdd[k]).max() < 1e-9
        assert np.abs(lam - run.multipliers[k]).max() < 1e-9


def test_a_locked_mechanism_is_still_refused():
    """Without a driver, constraints leaving no freedom lock the mechanism: refused."""
    th1 = coordinates("theta1")[0]
    locked = crank(driven=False)
    system = System(locked.model.coords.q, kinetic=locked.model.kinetic,
                    constraints=[*(Holonomic(e, name=n) for e, n in
                                   zip(locked.model.constraints.exprs,
                                       locked.constraint_names)),
                                 Holonomic(th1 - 0.2, name="brake")])
    positions, _, _ = closed_form()
    with pytest.raises(ConstraintError, match="no degree of freedom"):
        system.simulate((0.0, 1.0), np.array(positions(0.05 / OMEGA), dtype=float))
