"""Initialization of large models: sparse projections and the sparse KKT screen.

Past ``DENSE_MAX`` constraints the initial projection uses the sparse KKT solver
(Newton with the minimum-norm step); the reference is the dense least-squares
projection, the same least-change problem solved by another route.
"""

from __future__ import annotations

import numpy as np
import pytest
import sympy as sp

from dalembert import Holonomic, SingularSystemError, System, coordinates
from dalembert.multibody import chain
from dalembert.numerics.conditioning import _dense_spd_condition
from dalembert.solvers import initialization
from dalembert.solvers.kkt.dense import kkt_matrix
from dalembert.solvers.kkt.sparse import kkt_condition, kkt_solver
from dalembert.solvers.projection import project_positions, project_velocities


def test_sparse_initial_projection_matches_the_dense_one():
    mb = chain(20, 1.0, 1.0, 0.05)  # 80 constraints: the sparse route
    system = mb.system
    q0, qd0 = mb.initial_state(positions={f"link{k + 1}": (0.0, 0.0, -k - 0.5)
                                          for k in range(20)},
                               angular_velocities={"link3": (0.3, 0.0, 0.1)})
    rng = np.random.default_rng(2)
    names = system.coordinate_names
    q = np.array([q0[k] for k in names]) + 1e-3 * rng.normal(size=len(names))
    qd = np.array([qd0[k] for k in names]) + 1e-3 * rng.normal(size=len(names))
    report = system.consistent_initial_state(q, qd, velocity_projection="least-change")
    num = system.numeric()
    q_ref = project_positions(num, 0.0, q)
    qd_ref = project_velocities(num, 0.0, q_ref, qd)
    assert np.abs(report.q - q_ref).max() < 1e-11
    assert np.abs(report.qd - qd_ref).max() < 1e-11
    assert np.abs(num.position_constraint(0.0, report.q)).max() < 1e-13


def singular_system(size: int):
    """``x0`` has no inertia and no constraint: the KKT matrix is singular."""
    q = coordinates(" ".join(f"x{i}" for i in range(size)))
    m = sp.Symbol("m")
    T = sum(m / 2 * x.diff() ** 2 for x in q[1:])
    rods = [Holonomic(q[i] - q[i + 1] - 1, name=f"link{i}") for i in range(1, size - 1)]
    return System(q, kinetic=T, constraints=rods, parameters={m: 1.0})


def test_singular_kkt_found_by_the_sparse_screen_and_named_by_the_dense_check(monkeypatch):
    system = singular_system(40)  # 40 + 38 unknowns: past the dense solver's size
    q0 = {f"x{i}": -float(i) for i in range(40)}
    with pytest.raises(SingularSystemError, match="x0"):
        system.consistent_initial_state(q0)
    monkeypatch.setattr(initialization, "DENSE_CHECK_MAX", 10)  # as for a huge model
    with pytest.raises(SingularSystemError, match="condition number estimate"):
        system.consistent_initial_state(q0)


def _band_kkt(joint: str):
    """A 12-link chain's numeric model and its KKT values ``(M, f, A, c)`` at rest, a
    model large enough for the band solver."""
    mb = chain(12, 1.0, 1.0, 0.05, joint=joint, planar=joint == "revolute")
    num = mb.system.numeric()
    q0, qd0 = mb.initial_state()
    names = mb.system.coordinate_names
    q, qd = np.array([q0[k] for k in names]), np.array([qd0[k] for k in names])
    assert kkt_solver(num.pattern).method == "band"
    return num, num.kkt_sparse(0.0, q, qd)


@pytest.mark.parametrize("joint", ["spherical", "revolute"])
def test_condition_screens_agree_with_the_exact_condition_numbers(joint):
    """The band KKT screen (LAPACK gbcon) and the dense rank screen (pocon) estimate
    the 1-norm condition numbers NumPy computes exactly from the dense matrices."""
    num, (Mv, _, Av, _) = _band_kkt(joint)
    solver = kkt_solver(num.pattern)
    K = kkt_matrix(num.pattern.dense_M(Mv), num.pattern.dense_A(Av))
    exact = np.linalg.cond(K, 1)
    assert abs(kkt_condition(solver, Mv, Av) / exact - 1) < 1e-6
    A = num.pattern.dense_A(Av)
    gram = np.linalg.cond(A @ A.T, 1)
    assert abs(_dense_spd_condition(A @ A.T) / gram - 1) < 1e-6
    assert kkt_condition(solver, Mv, 0 * Av) == np.inf  # no constraints: M alone singular


def test_kkt_solvers_are_made_once_per_pattern():
    num = chain(3, 1.0, 1.0, 0.05).system.numeric()
    assert kkt_solver(num.pattern) is kkt_solver(num.pattern)
    kept = np.arange(num.m - 1)
    assert kkt_solver(num.pattern, kept) is kkt_solver(num.pattern, kept.copy())
    assert kkt_solver(num.pattern, kept).mk == num.m - 1


def test_band_solves_alternating_between_matrices_solve_each_one():
    """A condition estimate hands its factorization to the next solve (the initial
    checks and the impact solve factor the same matrix): solves that alternate between
    two matrices, each after the other's or its own condition estimate, as threads
    sharing a model may, each solve their own, against the dense solve."""
    num, (Mv, f, Av, c) = _band_kkt("spherical")
    solver = kkt_solver(num.pattern)
    heavier = (2.0 * Mv, f, Av, c)
    for values, estimated in [((Mv, f, Av, c), heavier), (heavier, heavier),
                              ((Mv, f, Av, c), (Mv, f, Av, c)), (heavier, (Mv, f, Av, c))]:
        kkt_condition(solver, estimated[0], estimated[2])
        M, A = num.pattern.dense_M(values[0]), num.pattern.dense_A(values[2])
        qdd, _ = solver.solve(*values)
        expected = np.linalg.solve(kkt_matrix(M, A), np.concatenate([values[1], values[3]]))
        assert np.allclose(qdd, expected[:num.n], rtol=1e-10, atol=1e-12)
