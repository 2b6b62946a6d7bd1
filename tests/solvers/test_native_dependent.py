"""The C loop with dependent constraint rows, against the Python loop.

The mechanism: a hexagonal ring of six rods joined by revolute joints (3D rigid
bodies), hung from the ground by one of its vertices and swinging in its plane.
A planar loop closed with 3D hinges has dependent rows: the hinges' axes and the
out-of-plane positions are constrained once too often around the loop, 3 rows in
all (``n - rank = 42 - 38 = 4`` degrees of freedom: ``3 * 6 - 2 * 7`` for the
planar six-bar on its pivot). The references: the Python loop (verified
elsewhere; it solves the same kept rows and reports minimum-norm multipliers) and
the constraints' residuals.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from dalembert import SingularSystemError
from dalembert.multibody import ring as ring_of_rods
from dalembert.multibody import ring_state
from dalembert.solvers.native import NativeSolver, native_solver
from dalembert.solvers.native.structure import schur_structure
from dalembert.solvers.projection import StepProjector

LENGTH, MASS, RADIUS = 0.5, 1.0, 0.02
T_END = 1.5  # the motion is chaotic: rounding differences grow ~10x per 0.4 s


def hexagon(joint: str = "revolute"):
    """``(multibody, q0, qd0)``: the ring, regular, tilted and turning about the pivot."""
    mb = ring_of_rods(6, LENGTH, MASS, RADIUS, joint=joint)
    return (mb, *ring_state(mb, 6, LENGTH))


def simulate(mb, q0, qd0, backend: str):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the dependent rows are reported by a warning
        return mb.simulate((0.0, T_END), q0, qd0, t_eval=np.linspace(0.0, T_END, 31),
                           backend=backend)


@pytest.fixture(scope="module")
def ring():
    return hexagon()


@pytest.fixture(scope="module")
def runs(ring):
    return {backend: simulate(*ring, backend) for backend in ("c", "python")}


def consistent(ring):
    """The numeric model, the initial state as arrays and the kept rows."""
    mb, q0, qd0 = ring
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        report = mb.system.consistent_initial_state(q0, qd0)
    return mb.system.numeric(), report.q, report.qd, report.rank.kept


def relative(x, reference):
    return np.abs(x - reference).max() / max(1.0, np.abs(reference).max())


def test_the_ring_has_three_dependent_rows(ring):
    mb, q0, qd0 = ring
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        report = mb.system.consistent_initial_state(q0, qd0)
    assert len(report.dependent_constraints) == 3
    assert report.degrees_of_freedom == 4


def test_it_runs_in_c(ring):
    mb, q0, qd0 = ring
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        plan = mb.system.plan((0.0, T_END), q0, qd0, backend="c")  # raises if C does not apply
    assert plan.loop == "c" and plan.stretches


def test_same_trajectory_as_the_python_loop(runs):
    fast, slow = runs["c"], runs["python"]
    assert fast.stats["n_steps"] == slow.stats["n_steps"]
    assert np.abs(fast.q - slow.q).max() < 1e-10
    assert np.abs(fast.qd - slow.qd).max() < 1e-10
    assert relative(fast.qdd, slow.qdd) < 1e-10
    assert relative(fast.multipliers, slow.multipliers) < 1e-10
    assert relative(fast.constraint_forces, slow.constraint_forces) < 1e-10


def test_constraints_hold_to_rounding(runs):
    traj = runs["c"]
    assert traj.position_residual.max() < 1e-13
    assert traj.velocity_residual.max() < 1e-12


def test_reported_multipliers_are_the_minimum_norm_ones(ring, runs):
    """Among all multipliers giving the same force, the reported ones have no part in
    the null space of ``A^T`` (the dependent combinations of rows)."""
    mb, _, _ = ring
    num, traj = mb.system.numeric(), runs["c"]
    for k in (0, len(traj.t) // 2, -1):
        A, _ = num.velocity_constraint(traj.t[k], traj.q[k])
        _, s, vt = np.linalg.svd(A.T)
        null = vt[np.sum(s > 1e-10 * s[0]):]  # rows spanning the null space of A^T
        assert len(null) == 3
        lam = traj.multipliers[k]
        assert np.abs(null @ lam).max() < 1e-10 * np.abs(lam).max()
        assert relative(A.T @ lam, traj.constraint_forces[k]) < 1e-12


def test_dropped_rows_stay_out_of_the_solve(ring):
    num, _, _, kept = consistent(ring)
    dropped = np.setdiff1d(np.arange(num.m), kept)
    s = schur_structure(num.pattern, kept)
    assert not np.isin(dropped, s.band_row).any()
    assert s.n_dropped_pairs > 0 and np.isin(s.pair_row[s.n_pairs:], dropped).all()
    assert not np.isin(s.pair_row[:s.n_pairs], dropped).any()


def test_projection_matches_python(ring):
    num, q0, qd0, kept = consistent(ring)
    native = NativeSolver(num, kept=kept)
    python = StepProjector(num, kept)
    rng = np.random.default_rng(1)
    for _ in range(3):
        y = np.concatenate([q0, qd0]) + 1e-7 * rng.standard_normal(2 * num.n)
        ours, ref = native.project(0.0, y), python(0.0, y)
        assert np.abs(ours - ref).max() < 1e-12
        assert np.abs(num.position_constraint(0.0, ours[:num.n])).max() < 1e-14


def test_a_change_of_rank_is_refused(ring):
    """Off the constraints the ring's rows are independent: the kept rows' solve would
    no longer be the motion, and C says so instead of returning it."""
    num, q0, qd0, kept = consistent(ring)
    solver = native_solver(num, np.concatenate([q0, qd0]), kept=kept)
    q = q0 + 0.05 * np.random.default_rng(0).standard_normal(num.n)
    with pytest.raises(SingularSystemError, match="rank of the constraints changed"):
        solver.solve(0.0, q, qd0)
