"""KKT solves (singular M, nonsingular KKT) and consistent initialization."""

from __future__ import annotations

import warnings

import numpy as np
import pytest
import sympy as sp

from dalembert import Holonomic, InitialConditionsAdjusted, System, coordinates, t
from dalembert.numerics.rank import dependent_rows
from dalembert.solvers.kkt.dense import check_kkt, solve_kkt


def test_singular_mass_nonsingular_kkt():
    M = np.diag([1.0, 0.0])
    A = np.array([[0.0, 1.0]])  # fixes the massless direction
    qdd, lam = solve_kkt(M, np.array([2.0, 5.0]), A, np.array([0.3]))
    # row 1: qdd_x = 2; constraint: qdd_y = 0.3; row 2: 0 = 5 + lambda.
    np.testing.assert_allclose(qdd, [2.0, 0.3], atol=1e-15)
    np.testing.assert_allclose(lam, [-5.0], atol=1e-15)
    check_kkt(M, A, ("x", "y"), "here")  # does not raise


def test_massless_coordinate_driven_by_a_constraint():
    # T has no y_dot; y = sin t is imposed; V = k x y couples them. Hand solution:
    # x'' = -k sin(t)/m, so x = (k/m)(sin t - t); the multiplier holds y: lambda = k x.
    x, y = coordinates("x y")
    m, k = 2.0, 3.0
    system = System([x, y], kinetic=m / 2 * x.diff() ** 2, potential=k * x * y,
                    constraints=[Holonomic(y - sp.sin(t), name="drive")])
    s = np.linspace(0, 2, 21)
    traj = system.simulate((0, 2), q0=[0.0, 0.0], qd0=[0.0, 1.0], t_eval=s)
    exact = k / m * (np.sin(s) - s)
    assert np.abs(traj["x"] - exact).max() < 1e-10
    assert np.abs(traj["y"] - np.sin(s)).max() < 1e-13
    assert np.abs(traj.multiplier("drive") - k * exact).max() < 1e-9


def test_dependent_rows():
    A = np.array([[1.0, -1.0, 0.0], [0.0, 0.0, 1.0], [2.0, -2.0, 0.0]])
    assert dependent_rows(A) == [2]
    assert dependent_rows(np.eye(2)) == []


def test_positions_by_least_change(pendulum):
    report = pendulum.consistent_initial_state({"x": 1.2, "y": 0.9})
    # The nearest point of the unit circle is along the ray: (0.8, 0.6).
    np.testing.assert_allclose(report.q, [0.8, 0.6], atol=1e-15)
    assert report.changed_positions() == ["x", "y"] and report.changed


@pytest.mark.parametrize("start", [(0.1, -0.2), (0.01, -0.02), (1e-3, 0.0), (0.0, -0.5)])
def test_positions_by_least_change_from_far_inside(pendulum, start):
    # A full Newton step from inside the circle overshoots it (or gains less than
    # half): the projection still ends on the ray through the start.
    report = pendulum.consistent_initial_state(dict(zip(("x", "y"), start)))
    np.testing.assert_allclose(report.q, np.array(start) / np.hypot(*start), rtol=0,
                               atol=1e-14)


def test_the_sparse_full_newton_counts_any_gain_far_from_the_constraints(pendulum, monkeypatch):
    from dalembert.solvers import projection

    monkeypatch.setattr(projection, "project_positions", None)  # no dense fallback
    q = projection.StepProjector(pendulum.numeric()).positions(0.0, np.array([0.0, -0.5]),
                                                                refactor=True)
    np.testing.assert_allclose(q, [0.0, -1.0], rtol=0, atol=1e-14)


def test_velocities_by_projection(pendulum):
    report = pendulum.consistent_initial_state([0.8, 0.6], [1.0, 1.0])
    # Remove the radial part: qd - (qd . n) n with n = (0.8, 0.6).
    np.testing.assert_allclose(report.qd, [-0.12, 0.16], atol=1e-15)
    assert report.changed_positions() == [] and report.changed_velocities() == ["x", "y"]
    text = str(report)
    assert "x_dot: 1 -> -0.12" in text and "y_dot: 1 -> 0.16" in text
    assert "  x:" not in text


def test_fixed_coordinates_are_respected(pendulum):
    report = pendulum.consistent_initial_state({"x": 0.6, "y": -0.5}, {"x": 1.0},
                                               fixed=["x"])
    assert report.q[0] == 0.6 and abs(report.q[1] + 0.8) < 1e-15
    assert report.qd[0] == 1.0 and abs(report.qd[1] - 0.75) < 1e-14  # 0.6*1 + (-0.8)*yd = 0
    assert report.changed_positions() == ["y"] and "y: -0.5 -> -0.8" in str(report)


def test_simulate_warns_with_the_report(pendulum):
    with pytest.warns(InitialConditionsAdjusted, match=r"x: 1\.2 -> 0\.8"):
        traj = pendulum.simulate((0, 0.1), q0=[1.2, 0.9])
    assert traj.q[0] == pytest.approx([0.8, 0.6], abs=1e-15)
    assert "x: 1.2 -> 0.8" in traj.initialization


def test_no_warning_when_consistent(pendulum):
    with warnings.catch_warnings():
        warnings.simplefilter("error", InitialConditionsAdjusted)
        traj = pendulum.simulate((0, 0.1), q0=[0.6, -0.8], qd0=[0.8, 0.6])
    assert "nothing changed" in traj.initialization


def test_rheonomic_initialization_uses_t0():
    x, y = coordinates("x y")
    system = System([x, y], kinetic=(x.diff() ** 2 + y.diff() ** 2) / 2,
                    constraints=[Holonomic(x - sp.sin(t), name="drive")])
    report = system.consistent_initial_state([0.0, 0.0], [0.0, 0.0], t0=1.0)
    assert abs(report.q[0] - np.sin(1.0)) < 1e-15 and abs(report.qd[0] - np.cos(1.0)) < 1e-15
    assert report.q[1] == 0.0 and report.qd[1] == 0.0
