"""Minimum-norm least-squares steps, dense for small systems and sparse for large ones.

Newton and Gauss-Newton iterations on constraints take the minimum-norm solution of
``J x = r``: ``J`` may be singular (dependent constraints; a direction without
stiffness, such as a link spinning about its own axis) and the minimum-norm step
does not wander along such directions. Small systems use LAPACK's least squares,
with singular values below ``rcond`` times the largest cut. A mechanism's ``J`` is
sparse and its dense solve costs ``O(size^3)``; from :data:`SPARSE_FROM` unknowns or
equations the step is ``x`` of the regularized augmented system

    [[I, J^T], [J, -mu^2 I]] [x; y] = [0; r],     x = J^T (J J^T + mu^2 I)^-1 r,

solved with a sparse LU. It tends to the minimum-norm solution as ``mu -> 0``
without squaring ``J``'s condition number: directions whose singular values are
far above ``mu`` are solved exactly, those far below are left alone, as the cut does.
``mu`` is :data:`REGULARIZATION` times ``J``'s largest entry.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sps
import scipy.sparse.linalg as spla

from .rank import RANK_RTOL

#: From this many unknowns (or equations) the sparse regularized solve is used.
SPARSE_FROM = 200
#: ``mu`` of the sparse solve, relative to the largest entry of ``J``.
REGULARIZATION = 1e-9


def min_norm_solve(matrix: np.ndarray, rhs: np.ndarray,
                   rcond: float | None = RANK_RTOL) -> np.ndarray:
    """The minimum-norm least-squares solution ``x`` of ``matrix x = rhs``.

    Parameters
    ----------
    matrix
        ``J`` (dense), any shape.
    rhs
        ``r``, one value per row of ``J``.
    rcond
        Singular values below ``rcond`` times the largest are treated as zero in the
        dense solve (``None``: LAPACK's default, ``eps * max(shape)``).

    Examples
    --------
    >>> min_norm_solve(np.array([[2.0, 0.0], [0.0, 0.0]]), np.array([1.0, 5.0]))
    array([0.5, 0. ])
    >>> J = np.eye(300)[:250] * 2.0  # 250 equations, 300 unknowns: the sparse route
    >>> x = min_norm_solve(J, np.ones(250))
    >>> float(x[:250].min()), float(np.abs(x[250:]).max())
    (0.5, 0.0)
    """
    rows, cols = matrix.shape
    if max(rows, cols) < SPARSE_FROM:
        return np.asarray(np.linalg.lstsq(matrix, rhs, rcond=rcond)[0], dtype=np.float64)
    J = sps.csr_matrix(matrix)
    mu2 = (REGULARIZATION * float(np.abs(matrix).max(initial=1.0))) ** 2
    K = sps.bmat([[sps.identity(cols), J.T], [J, -mu2 * sps.identity(rows)]], format="csc")
    x = spla.splu(K).solve(np.concatenate([np.zeros(cols), np.asarray(rhs, dtype=float)]))
    return np.asarray(x[:cols], dtype=np.float64)
