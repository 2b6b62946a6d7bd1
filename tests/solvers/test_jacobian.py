"""The exact Jacobian of the constrained first-order system (``solvers/jacobian.py``).

References: central differences of the right-hand side ``F`` (the KKT solve itself,
``first_order_rhs``, a path that uses no Jacobian) at states of a run, on a quaternion
body (the heavy top), a 16-link chain assembled part by part, a rolling disk (Pfaffian
rows) and a pendulum whose rod is given twice (dependent rows: the kept one solved
for); a closed form on the pendulum; and Radau runs with it against a tight DOP853
reference, needing fewer evaluations than with forward differences.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest
import sympy as sp

from dalembert import Holonomic, System, coordinates
from dalembert.examples import heavy_top, rolling_disk
from dalembert.multibody import chain
from dalembert.solvers.dynamics import first_order_rhs
from dalembert.solvers.jacobian import first_order_jacobian
from dalembert.solvers.running import run_data
from dalembert.solvers.running.integrate import finite_difference_jacobian


def central_differences(rhs, t: float, y: np.ndarray) -> np.ndarray:
    J = np.empty((y.size, y.size))
    for j in range(y.size):
        h = 1e-6 * max(1.0, abs(y[j]))
        step = np.zeros(y.size)
        step[j] = h
        J[:, j] = (rhs(t, y + step) - rhs(t, y - step)) / (2 * h)
    return J


def assert_exact(system: System, traj, kept=None) -> None:
    num = system.numeric()
    jac, rhs = first_order_jacobian(num, kept), first_order_rhs(num, 0.0, kept)
    for k in (0, len(traj.t) // 2, -1):
        y = np.concatenate([traj.q[k], traj.qd[k]])
        exact, differences = jac(traj.t[k], y), central_differences(rhs, traj.t[k], y)
        scale = max(1.0, np.abs(differences).max())
        assert np.abs(exact - differences).max() <= 1e-6 * scale


def test_the_heavy_top_quaternion():
    system = heavy_top.build()
    traj = system.simulate((0, 0.5), **heavy_top.INITIAL, t_eval=[0.0, 0.25, 0.5])
    assert_exact(system, traj)


def test_a_16_link_chain_assembled_part_by_part():
    mb = chain(16, 1.0, 1.0, 0.05)
    omega = np.array([0.4, 0.7, 0.0])  # hanging straight, turning as one rigid body
    positions = {f"link{k + 1}": (0.0, 0.0, -(k + 0.5)) for k in range(16)}
    q0, qd0 = mb.initial_state(
        positions=positions,
        velocities={name: np.cross(omega, x) for name, x in positions.items()},
        angular_velocities=dict.fromkeys(positions, omega))
    traj = mb.simulate((0, 0.2), q0, qd0, t_eval=[0.0, 0.1, 0.2])
    assert_exact(mb.system, traj)


def test_a_rolling_disk_with_pfaffian_rows():
    system = rolling_disk.build()
    traj = system.simulate((0, 0.5), **rolling_disk.INITIAL, t_eval=[0.0, 0.25, 0.5])
    assert_exact(system, traj)


def test_dependent_rows_are_solved_on_the_kept_ones():
    x, y = coordinates("x y")
    rod = x**2 + y**2 - 1
    system = System([x, y], kinetic=(x.diff() ** 2 + y.diff() ** 2) / 2, potential=9.81 * y,
                    constraints=[Holonomic(rod, name="rod"), Holonomic(2 * rod, name="again")])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        plan = system.plan((0, 0.5), {x: np.sin(1.0), y: -np.cos(1.0)}, t_eval=[0, 0.5])
        traj = system.run(plan)
    assert plan.kept is not None and len(plan.kept) == 1
    assert_exact(system, traj, plan.kept)


def test_the_pendulum_in_closed_form():
    """The rod's pendulum (l = 1) solved by hand: ``q . qdd = -|qd|^2`` gives
    ``qdd = -g e_y + q (g y - |qd|^2) / |q|^2``. At ``|q| = 1``, ``q`` at the angle
    ``theta`` from the bottom and ``qd = w t`` (``t`` the tangent): along ``t``,
    ``t . dqdd/dq . t = g y - w^2 = -g cos(theta) - w^2`` and
    ``q . dqdd/dqd . t = -2 w``."""
    x, y = coordinates("x y")
    system = System([x, y], kinetic=(x.diff() ** 2 + y.diff() ** 2) / 2, potential=9.81 * y,
                    constraints=[Holonomic(x**2 + y**2 - 1, name="rod")])
    theta, w = 0.7, 1.3
    radial = np.array([np.sin(theta), -np.cos(theta)])
    tangent = np.array([np.cos(theta), np.sin(theta)])
    J = first_order_jacobian(system.numeric())(0.0, np.concatenate([radial, w * tangent]))
    d_qdd_d_q, d_qdd_d_qd = J[2:, :2], J[2:, 2:]
    assert tangent @ d_qdd_d_q @ tangent == pytest.approx(-9.81 * np.cos(theta) - w**2,
                                                         rel=1e-13)
    assert radial @ d_qdd_d_qd @ tangent == pytest.approx(-2 * w, rel=1e-13)
    np.testing.assert_allclose(J[:2], np.hstack([np.zeros((2, 2)), np.eye(2)]), atol=0)


def stiff_double_pendulum(k: float = 1e6) -> tuple[System, dict]:
    """A rod pendulum with a second mass on a stiff, damped spring (5% of critical)."""
    x, y, x2, y2 = coordinates("x y x2 y2")
    d = sp.sqrt((x2 - x) ** 2 + (y2 - y) ** 2)
    c = 0.1 * np.sqrt(k)
    relative = {x: x2.diff() - x.diff(), y: y2.diff() - y.diff()}
    system = System(
        [x, y, x2, y2],
        kinetic=(x.diff() ** 2 + y.diff() ** 2 + x2.diff() ** 2 + y2.diff() ** 2) / 2,
        potential=9.81 * (y + y2) + k / 2 * (d - 1) ** 2,
        generalized_forces={x: c * relative[x], y: c * relative[y],
                            x2: -c * relative[x], y2: -c * relative[y]},
        constraints=[Holonomic(x**2 + y**2 - 1, name="rod")])
    q0 = {x: np.sin(1.0), y: -np.cos(1.0), x2: np.sin(1.0) + 1.0, y2: -np.cos(1.0)}
    return system, q0


@pytest.mark.parametrize("backend", ["c", "python"])
def test_radau_with_the_exact_jacobian(backend, monkeypatch):
    """Radau on a stiff spring (k = 1e6) meets a tight DOP853 reference as with forward
    differences, in fewer evaluations of the right-hand side (none for the Jacobian).
    The forward differences are the Python loop's (the C stepper's Jacobian is always
    the exact one)."""
    system, q0 = stiff_double_pendulum()
    reference = system.simulate((0, 1), q0, rtol=1e-12, atol=1e-14, t_eval=[1.0])
    exact = system.simulate((0, 1), q0, method="Radau", rtol=1e-8, atol=1e-10,
                            t_eval=[1.0], backend=backend)
    monkeypatch.setattr(run_data, "first_order_jacobian",
                        lambda num, kept: finite_difference_jacobian(
                            first_order_rhs(num, 0.0, kept)))
    differences = system.simulate((0, 1), q0, method="Radau", rtol=1e-8, atol=1e-10,
                                  t_eval=[1.0], backend="python")
    for traj in (exact, differences):
        assert traj.status == "finished"
        assert np.abs(traj.q[-1] - reference.q[-1]).max() < 1e-9
    assert exact.stats["njev"] > 0
    # forward differences cost 2n + 1 = 9 evaluations a Jacobian
    assert exact.stats["nfev"] < differences.stats["nfev"] - 5 * exact.stats["njev"]
