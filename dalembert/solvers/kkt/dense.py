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

from ...errors import SingularSystemError
from ...numerics.rank import RANK_RTOL, min_norm_multipliers

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


#: Condition numbers above this are singular to working precision (no digit is left);
#: between ``1 / RANK_RTOL`` and this the KKT matrix is ill-conditioned, not singular.
SINGULAR_COND = 1e14
#: Below this ratio of smallest to largest inertia (on the motions the constraints
#: allow) the ill-conditioning is blamed on the inertia (a thin rod's axial spin).
INERTIA_SPREAD = 1e-8


def check_kkt(M: np.ndarray, A: np.ndarray, coordinate_names: Sequence[str], when: str) -> None:
    """Raise :class:`SingularSystemError` naming the coordinates of a singular KKT matrix.

    A matrix singular to working precision gets "no inertia in a direction the
    constraints leave free"; one that is only ill-conditioned (a condition number
    between ``1 / RANK_RTOL`` and :data:`SINGULAR_COND`) gets its cause: a direction
    with almost no inertia (a thin rod's spin about its axis) or nearly dependent
    constraints, and what to do about it.

    >>> check_kkt(np.diag([1.0, 1e-12]), np.zeros((0, 2)), ("x", "y"), "here")
    ... # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    dalembert.errors.SingularSystemError: the KKT matrix ... is ill-conditioned here ...
    """
    K = kkt_matrix(M, A)
    if not np.all(np.isfinite(K)):
        raise SingularSystemError(f"the mass or constraint matrix is not finite {when}")
    s = np.linalg.svd(K, compute_uv=False)  # 2-3x cheaper; the vectors only if singular
    if s[-1] > RANK_RTOL * s[0]:
        return
    _, s, vt = np.linalg.svd(K)
    null = vt[-1, : len(coordinate_names)]
    involved = [n for n, v in zip(coordinate_names, null) if abs(v) > 0.1 * np.abs(null).max()]
    motion = ", ".join(involved) or "the system"
    cond = s[0] / max(s[-1], 1e-300)
    if cond >= SINGULAR_COND:
        raise SingularSystemError(
            f"the KKT matrix [[M, A^T], [A, 0]] is singular {when} (condition number "
            f"{cond:.1e}): the motion of {motion} is not determined. The mass matrix has no "
            "inertia in a direction the constraints leave free; check the kinetic energy or "
            "add the missing constraint."
        )
    raise SingularSystemError(
        f"the KKT matrix [[M, A^T], [A, 0]] is ill-conditioned {when} (condition number "
        f"{cond:.1e}, above the {1 / RANK_RTOL:.0e} the solver trusts): the motion of "
        f"{motion} would be determined to only about {max(0, 16 - np.log10(cond)):.0f} "
        f"digits. {_ill_conditioning_cause(M, A)}"
    )


def _ill_conditioning_cause(M: np.ndarray, A: np.ndarray) -> str:
    """Why the KKT matrix is nearly singular: the inertia or the constraints."""
    Z = scipy.linalg.null_space(A) if A.shape[0] else np.eye(M.shape[0])
    inertia = np.linalg.eigvalsh(Z.T @ M @ Z) if Z.shape[1] else np.ones(1)
    spread = inertia[0] / inertia[-1] if inertia[-1] > 0 else 0.0
    if spread < INERTIA_SPREAD:
        return (
            f"The inertia on the motions the constraints allow spans a ratio of {spread:.1e} "
            "(smallest to largest): a direction with almost no inertia, such as the spin of "
            "a thin rod or disk about its own axis, or a very light body among heavy ones. "
            f"Give that direction more inertia (a ratio above {INERTIA_SPREAD:.0e}: for a "
            "thin rod a larger radius, which hardly changes its swinging), model the rod "
            "without that rotation (two particles and a Distance joint), or rescale the units"
        )
    sv = np.linalg.svd(A, compute_uv=False) if A.shape[0] else np.ones(1)
    return (
        f"The constraints are nearly dependent (the smallest singular value of A is "
        f"{sv[-1] / sv[0]:.1e} of the largest): a configuration near a singular one (a "
        "linkage almost straight or flat), or constraints of very different scales. Start "
        "away from it, or rescale the constraints to similar sizes"
    )
