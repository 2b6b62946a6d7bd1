"""The truncated KKT solve (band form, bordered, proximal iterations) against the dense
one: the KKT system of the rows' combinations that are kept, from an SVD."""

from __future__ import annotations

import numpy as np
import pytest

from dalembert.codegen.compiled import SparsePattern
from dalembert.solvers.kkt.truncated import TruncatedKKT


def nearly_dependent_system(n: int, m: int, k: int, gap: float, seed: int):
    """A banded mass matrix (SPD), ``m`` constraint rows of which ``k`` combinations
    have singular values ``gap`` (relative), the others of order one."""
    rng = np.random.default_rng(seed)
    B = np.zeros((n, n))
    for i in range(n):
        for j in range(max(0, i - 2), min(n, i + 3)):
            B[i, j] = rng.standard_normal()
    M = B @ B.T + n * np.eye(n)
    A = np.zeros((m, n))
    for i in range(m):
        for j in range(max(0, 2 * i - 3), min(n, 2 * i + 4)):
            A[i, j] = rng.standard_normal()
    u, s, vt = np.linalg.svd(A, full_matrices=False)
    s[-k:] = gap * s[0] * np.arange(1, k + 1)  # k combinations nearly dependent
    A = (u * s) @ vt
    A[np.abs(A) < 1e-14] = 0.0  # keep the (banded) pattern
    M_rows, M_cols = np.nonzero(M)
    A_rows, A_cols = np.nonzero(np.abs(A) > 0)
    pattern = SparsePattern(n, m, M_rows, M_cols, A_rows, A_cols)
    return pattern, M, A, rng.standard_normal(n), rng.standard_normal(m)


def dense_truncated(M, A, f, c, below):
    """The reference: rows scaled to unit length, the combinations with singular values
    under ``below`` of the largest left out (SVD), the KKT system of the others."""
    scale = 1.0 / np.linalg.norm(A, axis=1)
    An = A * scale[:, None]
    u, s, _ = np.linalg.svd(An, full_matrices=False)
    keep = s >= below * s[0]
    U, V = u[:, keep], u[:, ~keep]
    Ak = U.T @ An
    mk = Ak.shape[0]
    K = np.block([[M, Ak.T], [Ak, np.zeros((mk, mk))]])
    x = np.linalg.solve(K, np.concatenate([f, U.T @ (c * scale)]))
    return x[:M.shape[0]], -U @ x[M.shape[0]:], scale, V, s[0] ** 2


@pytest.mark.parametrize("gap", [1e-6, 1e-9, 0.0])
@pytest.mark.parametrize("seed", range(2))
def test_the_band_solve_is_the_dense_truncated_solve(gap, seed):
    pattern, M, A, f, c = nearly_dependent_system(30, 14, 3, gap, seed)
    x_ref, lam_ref, scale, V, largest = dense_truncated(M, A, f, c, 1e-5)
    assert V.shape[1] == 3
    solver = TruncatedKKT(pattern, np.arange(14))
    Mv = M[pattern.M_rows, pattern.M_cols]
    Av = A[pattern.A_rows, pattern.A_cols]
    x, lam = solver.factor(Mv, Av, scale, V, largest)(f, c * scale)
    np.testing.assert_allclose(x, x_ref, rtol=0, atol=1e-11 * np.abs(x_ref).max())
    np.testing.assert_allclose(lam, lam_ref, rtol=0, atol=1e-10 * np.abs(lam_ref).max())
    # what it means: the multipliers have no part in the left-out combinations, and
    # every other combination of the scaled rows is met
    assert np.abs(V.T @ lam).max() < 1e-10 * np.abs(lam).max()
    residual = (A * scale[:, None]) @ x - c * scale
    assert np.abs(residual - V @ (V.T @ residual)).max() < 1e-10 * np.abs(c * scale).max()


def test_with_nothing_left_out_it_is_the_kkt_solve():
    pattern, M, A, f, c = nearly_dependent_system(20, 8, 1, 1e-1, 5)
    solver = TruncatedKKT(pattern, np.arange(8))
    scale = np.ones(8)
    x, lam = solver.factor(M[pattern.M_rows, pattern.M_cols], A[pattern.A_rows, pattern.A_cols],
                           scale, np.zeros((8, 0)), 1.0)(f, c)
    K = np.block([[M, A.T], [A, np.zeros((8, 8))]])
    ref = np.linalg.solve(K, np.concatenate([f, c]))
    np.testing.assert_allclose(x, ref[:20], atol=1e-11 * np.abs(ref[:20]).max())
    np.testing.assert_allclose(lam, -ref[20:], atol=1e-10 * np.abs(ref[20:]).max())


def test_unit_mass_gives_the_minimum_norm_step():
    """With ``M = I`` the solve of ``A dq = -psi`` is the minimum-norm step (a projection's
    Newton step): ``dq = -A^+ psi`` over the kept combinations."""
    pattern, _, A, _, psi = nearly_dependent_system(20, 8, 1, 1e-1, 9)
    solver = TruncatedKKT(pattern, np.arange(8), unit_mass=True)
    dq, _ = solver.factor(None, A[pattern.A_rows, pattern.A_cols], np.ones(8),
                          np.zeros((8, 0)), 1.0)(np.zeros(20), -psi)
    np.testing.assert_allclose(dq, -np.linalg.pinv(A) @ psi, atol=1e-12)
