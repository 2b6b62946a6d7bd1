"""The Gram matrix of a sparse constraint Jacobian's rows, scaled to unit length, in band form.

Near a singular configuration the rows of ``A`` become nearly dependent. Their Gram
matrix ``G = D A A^T D`` (``D`` scales every row to unit length, so that the units of
a constraint do not matter) is symmetric positive semidefinite, its eigenvalues are
the squared singular values of the scaled rows, and its eigenvectors of small
eigenvalue are the near dependencies: the combinations of rows that lose rank. For
a chain or a tree ``G`` is banded in a bandwidth-reducing order of the rows
(:mod:`.band`), so everything here costs time linear in the mechanism (a band
Cholesky factorization) or ``O(rows^2 band)`` (LAPACK's band eigensolvers), where a
dense SVD costs ``O(rows^2 coordinates)``:

- :meth:`UnitGram.pivot_ratio`, the smallest pivot of its Cholesky factorization
  (the squared sine of the angle of a row to the rows before it): a cheap screen,
  small whenever the rows are nearly dependent in the band order;
- :meth:`UnitGram.eigenvalues`, all of them;
- :meth:`UnitGram.near_null`, the eigenvectors of the smallest ones.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.linalg import eig_banded, eigvals_banded, lapack

from .band import band_order


@dataclass(frozen=True)
class GramValues:
    """The values of a :class:`UnitGram` at one state."""

    #: LAPACK's lower band storage of ``G`` in the band order, ``(kd + 1, rows)``.
    band: np.ndarray
    #: ``1 / |row|``, by row (0 for a row of zeros, whose Gram row is zero).
    scale: np.ndarray


class UnitGram:
    """``G = D A A^T D`` for the rows ``rows`` of a sparse ``A`` (values on the pattern
    ``(A_rows, A_cols)``), ``D`` the inverse row norms, in band storage.

    Parameters
    ----------
    A_rows, A_cols
        Row and column of each value of ``A``.
    m
        Rows of ``A``.
    rows
        The rows taken (default: all), in this order: row ``k`` of ``G`` is ``rows[k]``.

    Examples
    --------
    Two rows at an angle of 1e-4 rad: the smallest eigenvalue is about ``1e-8 / 2``,
    its eigenvector the difference of the rows.

    >>> A_rows, A_cols = np.array([0, 1, 1]), np.array([0, 0, 1])
    >>> gram = UnitGram(A_rows, A_cols, 2)
    >>> values = gram.values(np.array([1.0, 1.0, 1e-4]))
    >>> [f"{w:.2e}" for w in gram.eigenvalues(values)]
    ['5.00e-09', '2.00e+00']
    >>> v = gram.near_null(values, 1)
    >>> bool(np.allclose(np.abs(v[:, 0]), np.sqrt(0.5)))
    True
    """

    def __init__(self, A_rows: np.ndarray, A_cols: np.ndarray, m: int,
                 rows: np.ndarray | None = None) -> None:
        rows = np.arange(m) if rows is None else np.asarray(rows, dtype=np.intp)
        self.size = len(rows)
        place = np.full(m, -1)
        place[rows] = np.arange(self.size)
        self._entries = np.flatnonzero(place[A_rows] >= 0)  # the values of these rows
        row = place[A_rows[self._entries]]
        col = np.asarray(A_cols)[self._entries]
        self._row = row
        # pairs of values in one column: each a term A_ik A_jk of G_ij (i >= j after ordering)
        by_col = np.argsort(col, kind="stable")
        first, second = [], []
        bounds = np.flatnonzero(np.diff(col[by_col])) + 1
        for group in np.split(by_col, bounds):
            i, j = np.triu_indices(len(group))
            first.append(group[i])
            second.append(group[j])
        e1 = np.concatenate(first) if first else np.zeros(0, dtype=np.intp)
        e2 = np.concatenate(second) if second else np.zeros(0, dtype=np.intp)
        r1, r2 = row[e1], row[e2]
        self.perm = band_order(np.concatenate([r1, r2]), np.concatenate([r2, r1]), self.size) \
            if self.size else np.zeros(0, dtype=np.intp)
        inverse = np.empty(self.size, dtype=np.intp)
        inverse[self.perm] = np.arange(self.size)
        i, j = inverse[r1], inverse[r2]
        low, high = np.maximum(i, j), np.minimum(i, j)
        self.kd = int((low - high).max(initial=0))
        # entry (low, high) of the ordered G at ab[low - high, high] (LAPACK lower storage)
        self._target = (low - high) * self.size + high
        self._e1, self._e2 = e1, e2

    def scale(self, Av: np.ndarray) -> np.ndarray:
        """``1 / |row|`` for the values ``Av`` of ``A`` (0 for a row of zeros)."""
        a = np.asarray(Av, dtype=float)[self._entries]
        norm2 = np.bincount(self._row, weights=a * a, minlength=self.size)
        return np.divide(1.0, np.sqrt(norm2), out=np.zeros(self.size), where=norm2 > 0)

    def values(self, Av: np.ndarray) -> GramValues:
        """``G`` for the values ``Av`` of ``A`` (all of them, in pattern order)."""
        scale = self.scale(Av)
        a = np.asarray(Av, dtype=float)[self._entries] * scale[self._row]
        band = np.bincount(self._target, weights=a[self._e1] * a[self._e2],
                           minlength=(self.kd + 1) * self.size)
        return GramValues(band.reshape(self.kd + 1, self.size), scale)

    def pivot_ratio(self, values: GramValues) -> float:
        """The smallest pivot of ``G``'s Cholesky factorization in the band order (its
        diagonal is 1): the squared sine of the smallest angle between a row and the
        span of the rows before it; 0 if the factorization fails (dependent rows, or a
        row of zeros)."""
        if self.size == 0:
            return 1.0
        factor, info = lapack.dpbtrf(values.band, lower=1)
        return float((factor[0] ** 2).min()) if info == 0 else 0.0

    def eigenvalues(self, values: GramValues) -> np.ndarray:
        """Every eigenvalue of ``G``, ascending: the squared singular values of the rows
        scaled to unit length."""
        if self.size == 0:
            return np.zeros(0)
        return np.maximum(eigvals_banded(values.band, lower=True), 0.0)

    def near_null(self, values: GramValues, k: int) -> np.ndarray:
        """The eigenvectors of ``G``'s ``k`` smallest eigenvalues (columns, by row of
        ``G``, orthonormal)."""
        if k == 0:
            return np.zeros((self.size, 0))
        _, vectors = eig_banded(values.band, lower=True, select="i", select_range=(0, k - 1))
        V = np.empty_like(vectors)
        V[self.perm] = vectors
        return V
