"""Dependent constraints in the KKT solve: unique accelerations, minimum-norm multipliers."""

from __future__ import annotations

import numpy as np
import pytest
import sympy as sp

from dalembert import Holonomic, System, coordinates
from dalembert.numerics.rank import constraint_rank
from dalembert.solvers.kkt.dense import kkt_accelerations, solve_kkt

M = np.diag([1.0, 2.0, 3.0])
F = np.array([1.0, -2.0, 0.5])
C = np.array([0.3, 0.6, -0.1])  # row 1 is twice row 0, consistently
A = np.array([[1.0, 1.0, 0.0], [2.0, 2.0, 0.0], [0.0, 0.0, 1.0]])


def test_duplicated_row_gives_the_reduced_accelerations_and_minimum_norm_multipliers():
    qdd, lam = solve_kkt(M, F, A, C, kept=np.array([0, 2]))
    # By hand, rows 0 and 2 only: qdd_z = -0.1; x'' + y'' = 0.3 with x'' = 1 + mu,
    # y'' = -1 + mu / 2  ->  1.5 mu = 0.3, mu = 0.2, x'' = 1.2, y'' = -0.9.
    np.testing.assert_allclose(qdd, [1.2, -0.9, -0.1], atol=1e-14)
    # mu = l0 + 2 l1 with the least |(l0, l1)|: (l0, l1) = mu (1, 2) / 5.
    np.testing.assert_allclose(lam[:2], [0.04, 0.08], atol=1e-14)
    assert lam[2] == pytest.approx(3 * -0.1 - 0.5, abs=1e-14)
    np.testing.assert_allclose(kkt_accelerations(M, F, A, C, np.array([0, 2])), qdd, atol=0)


def test_a_dropped_row_that_became_independent_falls_back_to_the_full_solve():
    A2 = A.copy()
    A2[1] = [0.0, 1.0, 0.0]  # the rank grew since it was measured
    qdd, lam = solve_kkt(M, F, A2, C, kept=np.array([0, 2]))
    qdd_full, lam_full = solve_kkt(M, F, A2, C)
    np.testing.assert_allclose(qdd, qdd_full, atol=1e-13)
    np.testing.assert_allclose(lam, lam_full, atol=1e-13)
    np.testing.assert_allclose(A2 @ qdd, C, atol=1e-13)


def test_constraint_rank():
    rank = constraint_rank(A, ["a", "b", "c"])
    assert (rank.rank, rank.dependent_names, rank.degrees_of_freedom) == (2, ["b"], 1)
    assert rank.kept.tolist() == [0, 2]
    full = constraint_rank(A[[0, 2]], ["a", "c"])
    assert full.kept is None and full.degrees_of_freedom == 1 and "all independent" in str(full)


def test_projection_with_a_constraint_given_twice():
    x, y = coordinates("x y")
    circle = x**2 + y**2 - 1
    system = System([x, y], kinetic=(x.diff() ** 2 + y.diff() ** 2) / 2,
                    constraints=[Holonomic(circle, name="c1"), Holonomic(circle, name="c2")])
    report = system.consistent_initial_state([1.2, 0.9], [1.0, 1.0])
    # The nearest point of the circle is along the ray; the radial velocity is removed.
    np.testing.assert_allclose(report.q, [0.8, 0.6], atol=1e-15)
    np.testing.assert_allclose(report.qd, [-0.12, 0.16], atol=1e-15)
    assert report.dependent_constraints == ["c2"] and report.degrees_of_freedom == 1


def test_proportional_rows_proceed_with_a_warning():
    x, y = coordinates("x y")
    system = System([x, y], kinetic=(x.diff() ** 2 + y.diff() ** 2) / 2,
                    potential=sp.Integer(0),
                    constraints=[Holonomic(x - y, name="h"), Holonomic(2 * x - 2 * y, name="h2")])
    with pytest.warns(UserWarning, match=r"dependent on those listed before: h2"):
        traj = system.simulate((0, 1), q0=[0.5, 0.5], qd0=[1.0, 1.0],
                               t_eval=np.linspace(0, 1, 11))
    np.testing.assert_allclose(traj["x"], 0.5 + traj.t, atol=1e-13)  # free flight along x = y
