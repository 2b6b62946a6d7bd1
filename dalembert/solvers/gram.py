"""The Gram matrix ``A A^T`` factored as the C loop factors it: conditioning and rows off.

Both simulation loops judge how near a singular configuration a state is from the
Cholesky factorization of the Gram matrix of the kept constraint rows (see
:mod:`dalembert.numerics.singular`). The C loop factors it in ``kkt.c``
(``factor_schur`` with ``M = I``): the rows inside one block of ``M`` (a quaternion's
unit norm) are eliminated first, inside their block, then the other rows' Gram matrix
is factored in band form, in the band order of :func:`~.native.structure.gram_structure`.
:class:`GramFactor` is the same computation in NumPy and LAPACK, for the Python loop:
the same order, the same pivots (to rounding), so the same decisions, whether or not
the C loop applies to the model.

A row's *pivot ratio* is its pivot against ``|a_r|^2`` (the squared sine of its angle
to the rows before it, internal ones included); a row's *norm ratio* is ``|a_r|^2``
against its value at the initial state. The conditioning of a state is the smallest of
both over the rows.
With ``truncate``, a row whose pivot ratio falls below ``TRUNCATE**2`` is turned *off*:
left out of the factorization as if it were not there, as the C loop's
``band_cholesky`` does.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.linalg import lapack

from ..codegen.compiled import SparsePattern
from ..numerics.singular import TRUNCATE
from .native.structure import gram_structure

#: A pivot ratio at or below this is singular (kkt.c's test).
SINGULAR_PIVOT = 1e-14


@dataclass(frozen=True)
class Conditioning:
    """The conditioning of one state (see the module docstring).

    Attributes
    ----------
    ratio
        The smallest pivot or norm ratio over the rows (``inf`` without rows).
    row
        Its row (``-1`` without rows).
    off
        Which rows are off (only with ``truncate``), one flag per constraint row.
    diagonal
        Each row's ``|a_r|^2`` (0 for rows not factored): the reference of its pivot
        ratio, and at the initial state the reference of its norm ratio.
    """

    ratio: float
    row: int
    off: np.ndarray
    diagonal: np.ndarray


class GramFactor:
    """``factor(Av, active=None, truncate=False, norm0=None)``: the :class:`Conditioning`
    of ``A`` (values on ``pattern``) over the kept rows (all rows if ``kept`` is ``None``).

    Parameters
    ----------
    pattern
        The sparsity pattern of ``M`` and ``A``.
    kept
        The independent rows when some are dependent (the dependent ones are never
        factored).

    Examples
    --------
    Two rows at an angle of 1e-6 radians: the second's pivot ratio is ``1e-12``, off
    once truncated (below ``1e-10``):

    >>> pattern = SparsePattern(2, 2, np.arange(2), np.arange(2), np.array([0, 1, 1]),
    ...                         np.array([0, 0, 1]))
    >>> found = GramFactor(pattern)(np.array([1.0, 1.0, 1e-6]), truncate=True)
    >>> f"{found.ratio:.1e}", found.row, found.off.tolist()
    ('1.0e-12', 1, [False, True])
    """

    def __init__(self, pattern: SparsePattern, kept: np.ndarray | None = None) -> None:
        s = gram_structure(pattern, kept)
        self.m, self.kd, self.m_band = pattern.m, s.kd, len(s.band_row)
        self.band_row = s.band_row
        self._a_at, self._size = s.A_at, int(s.pair_vec[-1])
        solved = np.ones(pattern.m, dtype=bool)
        solved[s.dropped_rows] = False
        self._a_kept = np.flatnonzero(solved[pattern.A_rows])  # the kept rows' entries
        self._a_rows = pattern.A_rows[self._a_kept]
        sizes = np.diff(s.block_start)
        self._eliminations = _eliminations(s, sizes)
        self._products = _products(s, sizes)
        w, m_band = self.kd + 1, self.m_band
        # the C layout S[i * w + (i - j)] to LAPACK's lower band ab[i - j, j]
        d, i = np.meshgrid(np.arange(w), np.arange(m_band), indexing="ij")
        valid = i >= d
        self._ab_at = (d * m_band + (i - d))[valid]
        self._c_at = (i * w + d)[valid]

    def __call__(self, Av: np.ndarray, active: np.ndarray | None = None,
                 truncate: bool = False, norm0: np.ndarray | None = None) -> Conditioning:
        z = np.zeros(self._size)
        z[self._a_at] = Av
        notes = _Notes(self.m, norm0, np.bincount(self._a_rows, weights=Av[self._a_kept] ** 2,
                                                  minlength=self.m))
        on = np.ones(self.m, dtype=bool) if active is None else np.asarray(active, dtype=bool)
        if not _eliminate(self._eliminations, z, on, notes):
            return notes.result(np.zeros(self.m, dtype=bool))
        S = np.zeros(self.m_band * (self.kd + 1))
        for vec_i, vec_j, nb, target, row_i, row_j in self._products:
            both = on[row_i] & on[row_j]
            if not both.any():
                continue
            values = (z[vec_i[:, None] + np.arange(nb)] * z[vec_j[:, None] + np.arange(nb)]
                      ).sum(axis=1)
            np.add.at(S, target[both], values[both])
        w = self.kd + 1
        band_on = on[self.band_row]
        S[np.flatnonzero(~band_on) * w] = 1.0  # factor_band: a unit diagonal
        off = self._band_cholesky(S, band_on, truncate, notes)
        rows_off = np.zeros(self.m, dtype=bool)
        rows_off[self.band_row[off]] = True
        return notes.result(rows_off)

    def _band_cholesky(self, S: np.ndarray, band_on: np.ndarray, truncate: bool,
                       notes: _Notes) -> np.ndarray:
        """kkt.c's band_cholesky: the pivots noted, the rows below the threshold off."""
        m_band, w = self.m_band, self.kd + 1
        if m_band == 0:
            return np.zeros(0, dtype=bool)
        ab = np.zeros(w * m_band)
        ab[self._ab_at] = S[self._c_at]
        ab = ab.reshape(w, m_band)
        scale = np.abs(ab[0]).copy()
        off = np.zeros(m_band, dtype=bool)
        pivot = np.full(m_band, np.nan)
        while True:
            work = ab.copy()
            _decouple(work, np.flatnonzero(off))
            factor, info = lapack.dpbtrf(work, lower=1)
            if info > 0:  # not positive definite at place info - 1: its pivot is <= 0
                j = info - 1
                pivot[j] = 0.0
                if truncate:
                    off[j] = True
                    continue
                if j:  # the pivots before it, as kkt.c notes them before it stops
                    pivot[:j] = lapack.dpbtrf(work[:, :j], lower=1)[0][0] ** 2
                _note_band(notes, self.band_row, pivot, band_on & ~off, upto=j)
                notes.singular = True
                return off
            pivot = np.where(off, pivot, factor[0] ** 2)
            reference = notes.diagonal[self.band_row]
            below = np.flatnonzero(band_on & ~off & ~(pivot > TRUNCATE**2 * reference))
            if truncate and len(below):
                off[below[0]] = True
                continue
            break
        _note_band(notes, self.band_row, pivot, band_on, upto=m_band - 1)
        bad = band_on & ~off & ~(pivot > SINGULAR_PIVOT * scale)
        notes.singular = bool(bad.any())
        return off


class _Notes:
    """note_conditioning of kkt.c: the smallest ratio and its row. ``diagonal`` holds
    each row's ``|a_r|^2``, the reference of its pivot ratio."""

    def __init__(self, m: int, norm0: np.ndarray | None, diagonal: np.ndarray) -> None:
        self.ratio, self.row, self.norm0 = np.inf, -1, norm0
        self.diagonal = diagonal
        self.singular = False

    def note(self, rows: np.ndarray, pivots: np.ndarray) -> None:
        if len(rows) == 0:
            return
        diagonals = self.diagonal[rows]
        with np.errstate(divide="ignore", invalid="ignore"):
            ratio = np.where(diagonals > 0.0, pivots / diagonals, 0.0)
            if self.norm0 is not None:
                reference = self.norm0[rows]
                norm = np.where(reference > 0.0, diagonals / reference, np.inf)
                ratio = np.minimum(ratio, norm)
        k = int(np.argmin(np.where(np.isnan(ratio), -np.inf, ratio)))
        if not ratio[k] >= self.ratio:
            self.ratio, self.row = float(ratio[k]), int(rows[k])

    def result(self, off: np.ndarray) -> Conditioning:
        return Conditioning(self.ratio, self.row, off, self.diagonal)


def _note_band(notes: _Notes, band_row: np.ndarray, pivot: np.ndarray, noted: np.ndarray,
               upto: int) -> None:
    places = np.flatnonzero(noted[: upto + 1])
    notes.note(band_row[places], pivot[places])


def _decouple(ab: np.ndarray, places: np.ndarray) -> None:
    """Rows and columns ``places`` of a lower band matrix replaced by the identity's."""
    w = ab.shape[0]
    for j in places:
        ab[1:, j] = 0.0  # column j below the diagonal
        for d in range(1, min(w, j + 1)):
            ab[d, j - d] = 0.0  # row j left of the diagonal
        ab[0, j] = 1.0


def _eliminations(s, sizes: np.ndarray) -> list[tuple]:
    """Per block with internal rows (in the order of kkt.c's elim_blocks): its size, its
    pairs' vectors and rows, and how many of them are internal (the pivots first)."""
    out = []
    for b in s.elim_blocks:
        p0, pe, p1 = s.block_pairs[b], s.block_external[b], s.block_pairs[b + 1]
        out.append((int(sizes[b]), s.pair_vec[p0:p1], s.pair_row[p0:p1], int(pe - p0)))
    return out


def _eliminate(eliminations: list[tuple], z: np.ndarray, on: np.ndarray,
               notes: _Notes) -> bool:
    """kkt.c's eliminate_internal over every block (Gaussian pivots on the internal
    rows, later pairs losing their part along each); ``False`` if a pivot is singular."""
    for nb, vecs, rows, n_internal in eliminations:
        zb = [z[v:v + nb] for v in vecs]  # views: the elimination writes into z
        several = n_internal > 1
        first = {i: float(zb[i] @ zb[i]) for i in range(n_internal) if on[rows[i]]}
        for i in range(n_internal):
            if not on[rows[i]]:
                continue
            s = float(zb[i] @ zb[i])
            reference = first[i] if several else s
            notes.note(rows[i:i + 1], np.array([s]))
            if not s > SINGULAR_PIVOT * reference:
                notes.singular = True
                return False
            for p in range(i + 1, len(vecs)):
                if on[rows[p]]:
                    zb[p] -= (zb[i] @ zb[p]) / s * zb[i]
    return True


def _products(s, sizes: np.ndarray) -> list[tuple]:
    """The gram products ``z_i . z_j`` (``j <= i``) of every block's external pairs, as
    kkt.c's gram_block walks them, grouped by block size: vectors, size, band place,
    rows."""
    vec_i, vec_j, nbs, targets, rows_i, rows_j = [], [], [], [], [], []
    for b in range(len(sizes)):
        first, last = s.block_external[b], s.block_pairs[b + 1]
        count = last - first
        if count <= 0:
            continue
        i, j = np.tril_indices(count)
        vec_i.append(s.pair_vec[first + i])
        vec_j.append(s.pair_vec[first + j])
        rows_i.append(s.pair_row[first + i])
        rows_j.append(s.pair_row[first + j])
        nbs.append(np.full(len(i), sizes[b]))
        targets.append(s.gram_target[s.gram_start[b]:s.gram_start[b + 1]])
    if not vec_i:
        return []
    arrays = [np.concatenate(a) for a in (vec_i, vec_j, nbs, targets, rows_i, rows_j)]
    out = []
    for nb in np.unique(arrays[2]):
        pick = arrays[2] == nb
        vi, vj, _, target, ri, rj = (a[pick] for a in arrays)
        out.append((vi, vj, int(nb), target, ri, rj))
    return out
