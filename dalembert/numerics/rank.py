"""Rank of a constraint Jacobian: which rows depend on the rows before them.

One test with one threshold, used by dynamics (dependent constraints at the
initial state), statics (equilibrium, linearization) and the multibody
diagnostics: a singular value at or below ``RANK_RTOL`` times the largest (or
times the largest entry, if that is larger than one) counts as zero.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from ..errors import ConstraintError
from .conditioning import gram_well_conditioned
from .singular import NEAR

#: Singular values below this fraction of the largest count as zero.
RANK_RTOL = 1e-10


def min_norm_multipliers(A: np.ndarray, force: np.ndarray) -> np.ndarray:
    """The minimum-norm ``lambda`` with ``A^T lambda = force`` (``force = M qdd - f``).

    >>> min_norm_multipliers(np.array([[1.0, 0.0], [1.0, 0.0]]), np.array([2.0, 0.0]))
    array([1., 1.])
    """
    return np.linalg.lstsq(A.T, force, rcond=RANK_RTOL)[0]


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
    #: Singular values counted as nonzero, but below ``singular.NEAR`` of the largest:
    #: the count is ambiguous (a state near a singular configuration).
    near: int = 0
    #: The rank at nearby states along the motion, if higher than here: the rows depend
    #: on each other at this configuration only (a singular one), else ``None``.
    rank_nearby: int | None = None

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
            return head + ", all independent)" + self._ambiguity()
        text = (head + f", {len(self.dependent)} dependent on those listed before: "
                f"{', '.join(self.dependent_names)}).")
        if self.rank_nearby is None:
            return (text + " The motion is unique; the multipliers are not (the "
                    "minimum-norm ones are reported)" + self._ambiguity())
        return (text + f" They depend at this configuration only: a singular one (at "
                f"nearby states along the motion the rank is {self.rank_nearby}, "
                f"{self.n - self.rank_nearby} degree(s) of freedom), where the motion may "
                "branch and is not unique; the multipliers are the minimum-norm ones"
                + self._ambiguity())

    def _ambiguity(self) -> str:
        if not self.near:
            return ""
        return (f". The count is ambiguous: {self.near} more singular value(s) of A are "
                f"nonzero but below {NEAR:g} of the largest (near a singular "
                f"configuration); with a looser tolerance there would be "
                f"{self.degrees_of_freedom + self.near} degree(s) of freedom")


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


#: From this many rows (fewer than the columns), the rank test screens ``A A^T``'s
#: condition first (:mod:`.conditioning`) and takes the SVD only if that fails.
SCREEN_FROM = 60


def sparse_constraint_rank(rows: np.ndarray, cols: np.ndarray, values: np.ndarray,
                           shape: tuple[int, int], names: Sequence[str]) -> ConstraintRank:
    """:func:`constraint_rank` of ``A`` given by its values on a pattern: a
    well-conditioned ``A A^T`` proves full row rank without the SVD.

    Parameters
    ----------
    rows, cols, values
        The entries of ``A``.
    shape
        ``(m, n)``.
    names
        One name per row.

    Examples
    --------
    >>> r = sparse_constraint_rank(np.array([0, 1]), np.array([0, 0]), np.ones(2), (2, 3), "ab")
    >>> r.rank, r.dependent_names
    (1, ['b'])
    """
    m, n = shape
    if SCREEN_FROM < m < n and gram_well_conditioned(rows, cols, values, shape):
        return ConstraintRank(n, m, (), tuple(names))  # independent: no SVD needed
    A = np.zeros(shape)
    np.add.at(A, (rows, cols), values)
    return constraint_rank(A, names)
