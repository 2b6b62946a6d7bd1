"""The KKT system of constrained dynamics and its diagnosis.

    [ M  A^T ] [ qdd    ]   [ f ]
    [ A   0  ] [-lambda ] = [ c ]

With the sign convention ``M qdd = f + A^T lambda`` the symmetric matrix above
multiplies ``[qdd; -lambda]``; :func:`solve_kkt` returns ``lambda`` itself.
The KKT matrix is nonsingular whenever ``A`` has full row rank and ``M`` is
positive definite on the null space of ``A``, even if ``M`` itself is singular
(a quaternion's 4x4 inertia block has rank 3; the unit-norm constraint restores
it). So the block system is solved as a whole, never through ``M^-1``.

Dependent (redundant) constraints, e.g. a planar loop closed with 3D hinges, make
``A`` rank deficient and the KKT matrix singular. ``qdd`` is still unique (``M``
positive definite on the null space of ``A``), ``lambda`` only up to the null
space of ``A^T``. :func:`~dalembert.numerics.rank.constraint_rank` finds the
dependent rows once (at the initial state); :func:`solve_kkt` given the
independent rows ``kept`` solves the reduced, nonsingular KKT system for ``qdd``
and returns the minimum-norm ``lambda`` of ``A^T lambda = M qdd - f``. Without
``kept`` it is one dense solve.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import scipy.linalg

from ..errors import SingularSystemError
from ..numerics.rank import RANK_RTOL, min_norm_multipliers

#: A dropped (dependent) row may miss ``A qdd = c`` by this much (relative) before the
#: reduced solve is distrusted and the full least-squares KKT system is solved instead.
DROPPED_ROW_RTOL = 1e-6


def kkt_matrix(M: np.ndarray, A: np.ndarray) -> np.ndarray:
    n, m = M.shape[0], A.shape[0]
    K = np.zeros((n + m, n + m))
    K[:n, :n] = M
    K[:n, n:] = A.T
    K[n:, :n] = A
    return K


def solve_kkt(
    M: np.ndarray,
    f: np.ndarray,
    A: np.ndarray,
    c: np.ndarray,
    kept: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Accelerations and multipliers from one KKT solve.

    ``kept`` (independent rows of ``A``, see :func:`constraint_rank`) selects the
    path for dependent constraints: ``lambda`` is then the minimum-norm solution of
    ``A^T lambda = M qdd - f``, one of infinitely many.

    >>> M = np.eye(2); A = np.array([[1.0, 1.0]])
    >>> qdd, lam = solve_kkt(M, np.array([0.0, -2.0]), A, np.array([0.0]))
    >>> qdd, lam
    (array([ 1., -1.]), array([1.]))

    The same row given twice: same ``qdd``, the multiplier split evenly (minimum norm).

    >>> qdd, lam = solve_kkt(M, np.array([0.0, -2.0]), np.vstack([A, A]), np.zeros(2),
    ...                      kept=np.array([0]))
    >>> qdd, lam
    (array([ 1., -1.]), array([0.5, 0.5]))
    """
    if kept is None:
        x = _dense_solve(kkt_matrix(M, A), np.concatenate([f, c]))
        n = M.shape[0]
        return x[:n], -x[n:]
    qdd, force, lam = _redundant_solve(M, f, A, c, kept)
    return qdd, min_norm_multipliers(A, force) if lam is None else lam


def kkt_accelerations(
    M: np.ndarray, f: np.ndarray, A: np.ndarray, c: np.ndarray, kept: np.ndarray | None = None
) -> np.ndarray:
    """``qdd`` alone: with dependent constraints this skips the multipliers' extra solve.

    >>> A = np.array([[1.0, 1.0], [2.0, 2.0]])
    >>> kkt_accelerations(np.eye(2), np.array([0.0, -2.0]), A, np.zeros(2), np.array([0]))
    array([ 1., -1.])
    """
    if kept is None:
        return solve_kkt(M, f, A, c)[0]
    return _redundant_solve(M, f, A, c, kept)[0]


def _dense_solve(K: np.ndarray, rhs: np.ndarray) -> np.ndarray:
    try:
        return np.linalg.solve(K, rhs)
    except np.linalg.LinAlgError as exc:
        raise SingularSystemError(
            "the KKT matrix [[M, A^T], [A, 0]] became singular: the accelerations are not "
            "determined (a singular configuration of the constraints, or a coordinate "
            "without inertia)"
        ) from exc


def _redundant_solve(M, f, A, c, kept):
    """``(qdd, A^T lambda, None)`` from the reduced KKT system of the ``kept`` rows or,
    if the dropped rows no longer follow from the kept ones (the rank changed since
    it was measured), ``(qdd, A^T lambda, lambda)`` from the minimum-norm
    least-squares solve of the full one."""
    n = M.shape[0]
    Ak = A[kept]
    x = _dense_solve(kkt_matrix(M, Ak), np.concatenate([f, c[kept]]))
    qdd = x[:n]
    dropped = np.ones(A.shape[0], dtype=bool)
    dropped[kept] = False
    miss = np.abs(A[dropped] @ qdd - c[dropped])
    scale = 1.0 + np.abs(c).max(initial=0.0) + np.abs(A).max() * np.abs(qdd).max(initial=0.0)
    if miss.max(initial=0.0) <= DROPPED_ROW_RTOL * scale:
        return qdd, Ak.T @ -x[n:], None
    qdd, lam = _least_squares_kkt(M, f, A, c)
    return qdd, A.T @ lam, lam


def _least_squares_kkt(M, f, A, c) -> tuple[np.ndarray, np.ndarray]:
    """Minimum-norm solution of the full (singular) KKT system; SVD-based ('gelsd')."""
    n = M.shape[0]
    K = kkt_matrix(M, A)
    x = scipy.linalg.lstsq(K, np.concatenate([f, c]), cond=RANK_RTOL,
                           lapack_driver="gelsd")[0]
    return x[:n], -x[n:]


def check_kkt(M: np.ndarray, A: np.ndarray, coordinate_names: Sequence[str], when: str) -> None:
    """Raise :class:`SingularSystemError` naming the coordinates of a singular KKT matrix."""
    K = kkt_matrix(M, A)
    if not np.all(np.isfinite(K)):
        raise SingularSystemError(f"the mass or constraint matrix is not finite {when}")
    s = np.linalg.svd(K, compute_uv=False)  # 2-3x cheaper; the vectors only if singular
    if s[-1] > RANK_RTOL * s[0]:
        return
    _, s, vt = np.linalg.svd(K)
    null = vt[-1, : len(coordinate_names)]
    involved = [n for n, v in zip(coordinate_names, null) if abs(v) > 0.1 * np.abs(null).max()]
    raise SingularSystemError(
        f"the KKT matrix [[M, A^T], [A, 0]] is singular {when} (condition number "
        f"{s[0] / max(s[-1], 1e-300):.1e}): the motion of {', '.join(involved) or 'the system'} "
        "is not determined. The mass matrix has no inertia in a direction the constraints "
        "leave free; check the kinetic energy or add the missing constraint."
    )
