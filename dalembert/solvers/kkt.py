"""The KKT system of constrained dynamics and its diagnosis.

    [ M  A^T ] [ qdd    ]   [ f ]
    [ A   0  ] [-lambda ] = [ c ]

With the sign convention ``M qdd = f + A^T lambda`` the symmetric matrix above
multiplies ``[qdd; -lambda]``; :func:`solve_kkt` returns ``lambda`` itself.
The KKT matrix is nonsingular whenever ``A`` has full row rank and ``M`` is
positive definite on the null space of ``A``, even if ``M`` itself is singular
(a quaternion's 4x4 inertia block has rank 3; the unit-norm constraint restores
it). So the block system is solved as a whole, never through ``M^-1``.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from ..errors import ConstraintError, SingularSystemError

#: Singular values below this fraction of the largest count as zero.
RANK_RTOL = 1e-10


def kkt_matrix(M: np.ndarray, A: np.ndarray) -> np.ndarray:
    n, m = M.shape[0], A.shape[0]
    K = np.zeros((n + m, n + m))
    K[:n, :n] = M
    K[:n, n:] = A.T
    K[n:, :n] = A
    return K


def solve_kkt(
    M: np.ndarray, f: np.ndarray, A: np.ndarray, c: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Accelerations and multipliers from one KKT solve.

    >>> M = np.eye(2); A = np.array([[1.0, 1.0]])
    >>> qdd, lam = solve_kkt(M, np.array([0.0, -2.0]), A, np.array([0.0]))
    >>> qdd, lam
    (array([ 1., -1.]), array([1.]))
    """
    n = M.shape[0]
    try:
        x = np.linalg.solve(kkt_matrix(M, A), np.concatenate([f, c]))
    except np.linalg.LinAlgError as exc:
        raise SingularSystemError(
            "the KKT matrix [[M, A^T], [A, 0]] became singular: the accelerations are not "
            "determined (a singular configuration of the constraints, or a coordinate "
            "without inertia)"
        ) from exc
    return x[:n], -x[n:]


def dependent_rows(A: np.ndarray, rtol: float = RANK_RTOL) -> list[int]:
    """Rows of ``A`` that are linear combinations of the rows before them.

    >>> dependent_rows(np.array([[1.0, 0.0], [2.0, 0.0], [0.0, 1.0]]))
    [1]
    """
    scale = max(np.abs(A).max(initial=0.0), 1.0)
    kept: list[np.ndarray] = []
    dependent = []
    for i, row in enumerate(A):
        trial = np.array([*kept, row])
        s = np.linalg.svd(trial, compute_uv=False)
        if s[-1] <= rtol * max(s[0], scale):
            dependent.append(i)
        else:
            kept.append(row)
    return dependent


def check_constraint_rank(A: np.ndarray, labels: Sequence[str], when: str) -> None:
    """Raise if constraints are dependent at a state, naming each dependent one."""
    dependent = dependent_rows(A)
    if dependent:
        names = "; ".join(labels[i] for i in dependent)
        raise ConstraintError(
            f"dependent (redundant) constraints {when}: {names} "
            "is a combination of the constraints listed before it; remove it"
        )


def check_kkt(M: np.ndarray, A: np.ndarray, coordinate_names: Sequence[str], when: str) -> None:
    """Raise :class:`SingularSystemError` naming the coordinates of a singular KKT matrix."""
    K = kkt_matrix(M, A)
    if not np.all(np.isfinite(K)):
        raise SingularSystemError(f"the mass or constraint matrix is not finite {when}")
    _, s, vt = np.linalg.svd(K)
    if s[-1] > RANK_RTOL * s[0]:
        return
    null = vt[-1, : len(coordinate_names)]
    involved = [n for n, v in zip(coordinate_names, null) if abs(v) > 0.1 * np.abs(null).max()]
    raise SingularSystemError(
        f"the KKT matrix [[M, A^T], [A, 0]] is singular {when} (condition number "
        f"{s[0] / max(s[-1], 1e-300):.1e}): the motion of {', '.join(involved) or 'the system'} "
        "is not determined. The mass matrix has no inertia in a direction the constraints "
        "leave free; check the kinetic energy or add the missing constraint."
    )
