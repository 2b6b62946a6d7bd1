"""The band Gram matrix of a sparse Jacobian's unit rows against dense linear algebra."""

from __future__ import annotations

import numpy as np
import pytest

from dalembert.numerics.gram import UnitGram


def chain_jacobian(m: int, n: int, seed: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A random sparse ``A`` shaped like a chain's: row ``i`` touches a few coordinates
    around ``n i / m``, in a scrambled numbering (the band order must find the band)."""
    rng = np.random.default_rng(seed)
    rows, cols = [], []
    for i in range(m):
        centre = int(i * n / m)
        for j in range(max(0, centre - 2), min(n, centre + 3)):
            rows.append(i)
            cols.append(j)
    scramble = rng.permutation(n)
    return np.array(rows), scramble[np.array(cols)], rng.standard_normal(len(rows)) * 3.0


def dense_unit_gram(rows, cols, values, m, n, subset=None):
    A = np.zeros((m, n))
    np.add.at(A, (rows, cols), values)
    if subset is not None:
        A = A[subset]
    norms = np.linalg.norm(A, axis=1)
    An = A / np.where(norms > 0, norms, 1.0)[:, None]
    return An @ An.T


@pytest.mark.parametrize("seed", range(3))
def test_eigenvalues_and_near_null_vectors_match_dense(seed):
    m, n = 40, 45
    rows, cols, values = chain_jacobian(m, n, seed)
    gram = UnitGram(rows, cols, m)
    assert gram.kd < 12  # the band order found the chain's band
    got = gram.values(values)
    G = dense_unit_gram(rows, cols, values, m, n)
    w = np.linalg.eigvalsh(G)
    np.testing.assert_allclose(gram.eigenvalues(got), w, atol=1e-12 * w[-1])
    V = gram.near_null(got, 3)
    np.testing.assert_allclose(V.T @ V, np.eye(3), atol=1e-12)
    np.testing.assert_allclose(np.diag(V.T @ G @ V), w[:3], atol=1e-12 * w[-1])


def test_a_subset_of_rows_and_a_near_dependency():
    """Rows 0..9 of which row 7 is nearly row 2 scaled: the smallest eigenvalue is the
    squared angle over two, its vector the difference of the two unit rows."""
    m, n = 12, 15
    rows, cols, values = chain_jacobian(m, n, 7)
    A = np.zeros((m, n))
    np.add.at(A, (rows, cols), values)
    A[7] = 5.0 * A[2] + 1e-6 * np.linalg.norm(A[2]) * np.eye(n)[0]
    rows, cols = np.nonzero(A)
    values = A[rows, cols]
    subset = np.arange(10)
    gram = UnitGram(rows, cols, m, subset)
    got = gram.values(values)
    G = dense_unit_gram(rows, cols, values, m, n, subset)
    w = np.linalg.eigvalsh(G)
    assert w[0] < 1e-11
    np.testing.assert_allclose(gram.eigenvalues(got), w, atol=1e-12)
    v = gram.near_null(got, 1)[:, 0]
    assert abs(abs(v[2]) - np.sqrt(0.5)) < 1e-5 and abs(abs(v[7]) - np.sqrt(0.5)) < 1e-5
    # the screen: the pivot of the later of the two rows is the squared sine of its
    # angle to the rows before it (about 1e-12 here), the smallest
    assert gram.pivot_ratio(got) < 1e-10


def test_the_pivot_ratio_is_the_smallest_cholesky_pivot_in_the_band_order():
    m, n = 30, 35
    rows, cols, values = chain_jacobian(m, n, 11)
    gram = UnitGram(rows, cols, m)
    G = dense_unit_gram(rows, cols, values, m, n)
    P = G[np.ix_(gram.perm, gram.perm)]
    L = np.linalg.cholesky(P)
    assert gram.pivot_ratio(gram.values(values)) == pytest.approx((np.diag(L) ** 2).min(),
                                                                   rel=1e-10)


def test_a_row_of_zeros_is_a_rank_drop():
    """A constraint whose gradient vanished (a rod of length zero): its Gram row is zero,
    the screen says 0 and the smallest eigenvalue is 0."""
    rows, cols = np.array([0, 0, 1, 1]), np.array([0, 1, 1, 2])
    gram = UnitGram(rows, cols, 2)
    got = gram.values(np.array([1.0, 2.0, 0.0, 0.0]))
    assert got.scale[1] == 0.0
    assert gram.pivot_ratio(got) == 0.0
    assert gram.eigenvalues(got)[0] == 0.0
