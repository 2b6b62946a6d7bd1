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
space of ``A^T``. :func:`constraint_rank` finds the dependent rows once (at the
initial state); :func:`solve_kkt` given the independent rows ``kept`` solves the
reduced, nonsingular KKT system for ``qdd`` and returns the minimum-norm
``lambda`` of ``A^T lambda = M qdd - f``. Without ``kept`` it is one dense solve.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import scipy.linalg

from ..errors import ConstraintError, SingularSystemError

#: Singular values below this fraction of the largest count as zero.
RANK_RTOL = 1e-10
#: What to do with dependent constraints (the ``redundant_constraints`` option).
REDUNDANT_MODES = ("minimum-norm", "error")
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


def min_norm_multipliers(A: np.ndarray, force: np.ndarray) -> np.ndarray:
    """The minimum-norm ``lambda`` with ``A^T lambda = force`` (``force = M qdd - f``).

    >>> min_norm_multipliers(np.array([[1.0, 0.0], [1.0, 0.0]]), np.array([2.0, 0.0]))
    array([1., 1.])
    """
    return np.linalg.lstsq(A.T, force, rcond=RANK_RTOL)[0]


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


def dependent_rows(A: np.ndarray, rtol: float = RANK_RTOL) -> list[int]:
    """Rows of ``A`` that are linear combinations of the rows before them.

    >>> dependent_rows(np.array([[1.0, 0.0], [2.0, 0.0], [0.0, 1.0]]))
    [1]
    >>> dependent_rows(np.array([[1.0, 0.0], [0.0, 1.0], [1.0, -1.0]]))
    [2]
    """
    scale = max(np.abs(A).max(initial=0.0), 1.0)
    kept: list[np.ndarray] = []
    dependent = []
    for i, row in enumerate(A):
        trial = np.array([*kept, row])
        s = np.linalg.svd(trial, compute_uv=False)
        # More rows than columns: the last singular value is that of a square part.
        if len(s) < len(trial) or s[-1] <= rtol * max(s[0], scale):
            dependent.append(i)
        else:
            kept.append(row)
    return dependent


def check_constraint_rank(A: np.ndarray, labels: Sequence[str], when: str) -> None:
    """Raise if constraints are dependent at a state, naming each dependent one."""
    dependent = dependent_rows(A)
    if dependent:
        raise dependent_error([labels[i] for i in dependent], when)


def dependent_error(labels: Sequence[str], when: str) -> ConstraintError:
    """The error naming dependent constraints (``redundant_constraints="error"``)."""
    return ConstraintError(
        f"dependent (redundant) constraints {when}: {'; '.join(labels)} "
        f"{'is a combination' if len(labels) == 1 else 'are combinations'} of the "
        f"constraints listed before; remove {'it' if len(labels) == 1 else 'them'}, or pass "
        "redundant_constraints='minimum-norm' to proceed with non-unique multipliers"
    )


@dataclass(frozen=True)
class ConstraintRank:
    """The rank of ``A`` at one state and the rows that depend on earlier ones.

    ``kept`` is ``None`` when the rows are independent (the fast path of
    :func:`solve_kkt`), else the indices of the independent rows.
    """

    n: int
    rank: int
    dependent: tuple[int, ...]
    names: tuple[str, ...]

    @property
    def degrees_of_freedom(self) -> int:
        """``n - rank(A)``: the true (velocity-level) degrees of freedom."""
        return self.n - self.rank

    @property
    def kept(self) -> np.ndarray | None:
        if not self.dependent:
            return None
        return np.setdiff1d(np.arange(len(self.names)), self.dependent)

    @property
    def dependent_names(self) -> list[str]:
        return [self.names[i] for i in self.dependent]

    def __str__(self) -> str:
        m = len(self.names)
        head = (f"{self.degrees_of_freedom} degree(s) of freedom: n - rank(A) = {self.n} - "
                f"{self.rank} ({m} constraints")
        if not self.dependent:
            return head + ", all independent)"
        return (head + f", {len(self.dependent)} dependent on those listed before: "
                f"{', '.join(self.dependent_names)}). The motion is unique; the multipliers "
                "are not (the minimum-norm ones are reported)")


def constraint_rank(A: np.ndarray, names: Sequence[str], n: int | None = None) -> ConstraintRank:
    """Rank of the constraint matrix and its dependent rows (one SVD when independent).

    >>> r = constraint_rank(np.array([[1.0, 0, 0], [2.0, 0, 0], [0, 1.0, 0]]), "abc")
    >>> r.rank, r.dependent_names, r.degrees_of_freedom
    (2, ['b'], 1)
    """
    n = A.shape[1] if n is None else n
    m = A.shape[0]
    if m == 0:
        return ConstraintRank(n, 0, (), tuple(names))
    s = np.linalg.svd(A, compute_uv=False)
    scale = max(np.abs(A).max(), 1.0)
    if len(s) == m and s[-1] > RANK_RTOL * max(s[0], scale):
        return ConstraintRank(n, m, (), tuple(names))
    dependent = tuple(dependent_rows(A))
    return ConstraintRank(n, m - len(dependent), dependent, tuple(names))


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
