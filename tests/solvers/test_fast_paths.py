"""The fast (sparse/band, compiled) paths against the simple dense reference path.

The reference is the dense KKT solve of :func:`dalembert.solvers.kkt.dense.solve_kkt` on
dense blocks and the dense least-squares projection; the fast paths must give the
same ``qdd`` and ``lambda`` to 1e-12 (relative) at random states, whatever
solver method (dense, band, SuperLU) is forced.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest
import scipy.sparse as sps
from scipy.linalg import null_space

from dalembert.examples import cartesian_pendulum, coin, four_bar, spherical_chain
from dalembert.solvers.dynamics import first_order_rhs
from dalembert.solvers.kkt.dense import kkt_matrix, solve_kkt
from dalembert.solvers.kkt.sparse import KKTSolver
from dalembert.solvers.projection import StepProjector, project_positions, project_velocities

EXAMPLES = {"pendulum": cartesian_pendulum, "four_bar": four_bar, "chain4": spherical_chain,
            "coin": coin}


@pytest.fixture(scope="module", params=list(EXAMPLES))
def case(request):
    module = EXAMPLES[request.param]
    system = module.build()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        report = system.consistent_initial_state(module.INITIAL["q0"], module.INITIAL.get("qd0"))
    kept = report.rank.kept if report.rank is not None else None
    return request.param, system.numeric(), report, kept


def random_states(num, report, count=5, seed=0):
    """Consistent states near the initial one: perturbed, then projected (dense path)."""
    rng = np.random.default_rng(seed)
    for _ in range(count):
        q = project_positions(num, 0.0, report.q + 1e-2 * rng.normal(size=num.n))
        qd = project_velocities(num, 0.0, q, report.qd + rng.normal(size=num.n))
        yield float(rng.uniform(0, 2)), q, qd


def relative(a, b):
    return np.abs(a - b).max() / max(1.0, np.abs(b).max())


@pytest.mark.parametrize("method", ["dense", "band", "splu"])
def test_kkt_solver_matches_dense_reference(case, method):
    name, num, report, kept = case
    solver = KKTSolver(num.pattern, kept)
    solver.method = method
    for t, q, qd in random_states(num, report):
        M, f, A, c = num.kkt_blocks(t, q, qd)
        qdd_ref, lam_ref = solve_kkt(M, f, A, c, kept)
        qdd, lam = solver.solve(*num.kkt_sparse(t, q, qd))
        assert relative(qdd, qdd_ref) < 1e-12, name
        assert relative(lam, lam_ref) < 1e-12, name
        assert relative(solver.accelerations(*num.kkt_sparse(t, q, qd)), qdd_ref) < 1e-12


def test_rhs_matches_dense_reference(case):
    name, num, report, kept = case
    rhs = first_order_rhs(num, kept=kept)
    for t, q, qd in random_states(num, report, count=3, seed=1):
        qdd_ref = solve_kkt(*num.kkt_blocks(t, q, qd), kept)[0]
        out = rhs(t, np.concatenate([q, qd]))
        assert np.array_equal(out[: num.n], qd)
        assert relative(out[num.n:], qdd_ref) < 1e-12, name


def test_step_projector_matches_dense_projection(case):
    """The nearest consistent state, residuals at rounding level.

    The reference is the optimality of a nearest point: the change of ``q`` is normal
    to the constraint manifold at the result (in the row space of ``J``), that of
    ``qd`` normal to ``A qd + b = 0``; for independent rows also the dense projection.
    With dependent rows the dense projection is no reference: off the manifold the
    rows are independent again (singular values of the size of the perturbation), so
    its least-squares steps wander along the near-null directions (their change is far
    from normal to the manifold) and end farther away than the kept rows' steps, which
    the fast path takes as the C loop does.
    """
    name, num, report, kept = case
    project = StepProjector(num, kept)
    rng = np.random.default_rng(2)
    hol = list(num.holonomic_rows)
    for t, q, qd in random_states(num, report, count=3, seed=3):
        y = np.concatenate([q + 1e-8 * rng.normal(size=num.n), qd + 1e-8 * rng.normal(size=num.n)])
        fast = project(t, y)
        qf, qdf = fast[: num.n], fast[num.n:]
        A, b = num.velocity_constraint(t, qf)
        for rows, change in ((hol, qf - y[: num.n]), (slice(None), qdf - y[num.n:])):
            basis = null_space(A[rows]) if len(A[rows]) else np.eye(num.n)
            assert np.linalg.norm(basis.T @ change) < 1e-6 * np.linalg.norm(change), name
        q_ref = project_positions(num, t, y[: num.n])
        ref = np.concatenate([q_ref, project_velocities(num, t, q_ref, y[num.n:])])
        if kept is None:
            assert relative(fast, ref) < 1e-12, name
        else:
            distance = np.linalg.norm(qf - y[: num.n])
            assert distance <= np.linalg.norm(q_ref - y[: num.n]), name
        if num.holonomic_rows:
            assert np.abs(num.position_constraint(t, qf)).max() < 1e-13
        assert np.abs(A @ qdf + b).max() < 1e-12


def test_band_path_is_chosen_for_a_chain_and_stays_narrow():
    """Linear cost needs a band independent of the chain's length. Past ``DENSE_MAX``
    unknowns the order is the narrower one (SciPy's reverse Cuthill-McKee alone gives
    a 27-wide band here); below, SciPy's order is kept."""
    from scipy.sparse.csgraph import reverse_cuthill_mckee

    from dalembert.multibody import chain
    from dalembert.solvers.kkt.sparse import DENSE_MAX, _bandwidth

    widths = []
    for n in (4, 8):
        num = chain(n, 1.0, 1.0, 0.05).system.numeric()
        solver = KKTSolver(num.pattern)
        assert solver.method == "band"
        rows, cols = solver._rows, solver._cols
        graph = sps.csr_matrix((np.ones(len(rows)), (rows, cols)), shape=(solver.size,) * 2)
        scipy_width = _bandwidth(rows, cols, reverse_cuthill_mckee(graph, symmetric_mode=True))
        assert solver._band.kl <= scipy_width
        if solver.size <= DENSE_MAX:
            assert solver._band.kl == scipy_width
        widths.append(solver._band.width)
    assert widths == [27, 23]


def test_peripheral_order_finds_the_band_of_a_shuffled_path():
    """A path numbered at random has bandwidth 1 in the order from one of its ends."""
    from dalembert.solvers.kkt.sparse import band_layout

    size = 100
    label = np.random.default_rng(4).permutation(size)
    a, b = label[:-1], label[1:]
    rows, cols = np.concatenate([a, b, label]), np.concatenate([b, a, label])
    perm, kl, ku, _ = band_layout(rows, cols, size)
    assert sorted(perm) == list(range(size))
    assert kl == ku == 1


def test_band_factor_solves_several_right_hand_sides(case):
    """The norm estimate of the initialization passes blocks of vectors."""
    name, num, report, kept = case
    solver = KKTSolver(num.pattern, kept)
    solver.method = "band"
    Mv, _, Av, _ = num.kkt_sparse(0.0, report.q, report.qd)
    solve = solver.factor(Mv, Av)
    rhs = np.random.default_rng(5).normal(size=(solver.size, 3))
    together = solve(rhs)
    for k in range(3):
        assert np.allclose(together[:, k], solve(rhs[:, k].copy()), rtol=1e-13, atol=0), name
    M, _, A, _ = num.kkt_blocks(0.0, report.q, report.qd)
    K = kkt_matrix(M, A if kept is None else A[kept])
    assert relative(K @ together, rhs) < 1e-10, name


def test_singular_kkt_matrix_raises_on_every_path():
    from dalembert.codegen.compiled import SparsePattern
    from dalembert.errors import SingularSystemError

    # Two coordinates, no inertia in y, and no constraint on y.
    pattern = SparsePattern(2, 1, np.array([0]), np.array([0]), np.array([0]), np.array([0]))
    for method in ("dense", "band", "splu"):
        solver = KKTSolver(pattern)
        solver.method = method
        with pytest.raises(SingularSystemError, match="singular"):
            solver.solve(np.array([1.0]), np.zeros(2), np.array([1.0]), np.zeros(1))
