"""Cheap condition estimates: a screen before a dense SVD.

A mechanism's constraint Jacobian ``A`` is sparse and, almost always, of full row
rank. Its rank test (:mod:`.rank`) takes an SVD, ``O(m^2 n)``; the screen here
factors ``A A^T`` (Cholesky, or a sparse LU for many rows) and estimates its
condition number, ``cond(A)^2``, in time linear for chains and trees, so the SVD
runs only when the rows may be dependent.
"""

from __future__ import annotations

import warnings

import numpy as np
import scipy.sparse as sps
import scipy.sparse.linalg as spla
from scipy.linalg import lapack

#: Up to this many constraint rows the screen factors ``A A^T`` dense (LAPACK).
GRAM_DENSE_MAX = 200


def gram_well_conditioned(rows: np.ndarray, cols: np.ndarray, Av: np.ndarray, shape: tuple,
                          limit: float = 1e10) -> bool:
    """``True`` when ``A`` (values on a pattern) surely has full row rank, with
    ``s_max / s_min < limit``: a screen before the SVD of
    :func:`~dalembert.numerics.rank.constraint_rank`, from a Cholesky (dense) or LU
    (sparse) factorization of ``A A^T``, whose condition number is that ratio squared.

    >>> gram_well_conditioned(np.array([0, 1]), np.array([0, 1]), np.ones(2), (2, 3))
    True
    >>> gram_well_conditioned(np.array([0, 1]), np.array([0, 0]), np.ones(2), (2, 3))
    False
    """
    if shape[0] <= GRAM_DENSE_MAX:
        A = np.zeros(shape)
        np.add.at(A, (rows, cols), Av)
        cond = spd_condition(A @ A.T)
    else:
        A = sps.csr_matrix((Av, (rows, cols)), shape=shape)
        cond = _sparse_condition((A @ A.T).tocsc())
    # cond(G) = cond(A)^2 and the 2-norm condition is at most m times the 1-norm one;
    # the estimate is reliable only well below 1/eps, hence the cap at 1e13.
    return bool(cond < min(limit**2 / max(shape[0], 1), 1e13))


def spd_condition(G: np.ndarray) -> float:
    """Estimated 1-norm condition number of a symmetric positive semidefinite ``G``
    (LAPACK ``potrf`` and ``pocon``), ``inf`` when its Cholesky factorization fails.

    >>> f"{spd_condition(np.diag([1.0, 1e-6])):.0e}"
    '1e+06'
    """
    factor, info = lapack.dpotrf(G, lower=1)
    if info != 0:
        return np.inf
    rcond, info = lapack.dpocon(factor, np.abs(G).sum(axis=0).max(), uplo="L")
    return 1.0 / rcond if info == 0 and rcond > 0.0 else np.inf


def _sparse_condition(G: sps.csc_matrix) -> float:
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("error", spla.MatrixRankWarning)
            solve = spla.splu(G, permc_spec="MMD_AT_PLUS_A").solve
    except (RuntimeError, spla.MatrixRankWarning):
        return np.inf
    with np.errstate(all="ignore"):
        return condition_1norm(G, solve)


def condition_1norm(K: sps.spmatrix, solve) -> float:
    size = K.shape[0]
    inverse = spla.LinearOperator((size, size), matvec=solve, rmatvec=solve, dtype=float)
    with np.errstate(all="ignore"):
        value = abs(K).sum(axis=0).max() * spla.onenormest(inverse)
    return float(value) if np.isfinite(value) else np.inf


_dense_spd_condition = spd_condition  # the former private name
