"""One KKT factorization, many right-hand sides, any set of active constraint rows.

The KKT system of constrained dynamics (sign convention ``M x = f + A^T lambda``)

    [ M  A^T ] [  x      ]   [ f ]
    [ A   0  ] [ -lambda ] = [ c ]

is factored once for the values of ``M`` and ``A`` on the model's pattern
(:class:`~dalembert.codegen.compiled.SparsePattern`, values ``[M values, A values]``)
and a set of *active* rows, then solved for one or many right-hand sides. An
inactive row is left out: its ``c`` is ignored and its multiplier is 0. Changing the
active rows is only a numeric refactorization: every backend factors the same
structure, with an inactive row's entries of ``A`` set to zero and a 1 on its place
of the (2,2) block, which decouples it (that place is in the pattern whatever the
rows, so no order, band or index map is made again).

Backends (:class:`Backend`, one chosen per pattern by :func:`choose_backend`):

- ``BAND``: LAPACK's band LU with partial pivoting (``gbtrf``/``gbtrs``) in a
  bandwidth-reducing order (:mod:`dalembert.numerics.band`): linear in the
  mechanism for chains and trees numbered along them.
- ``DENSE``: one LAPACK solve (``gesv``) of the dense matrix, for small systems whose
  band is wide.
- ``SPLU``: SuperLU with a fill-reducing order, for large patterns with a wide band.
- ``SCHUR``: the C runtime's block Cholesky of ``M`` and band ``LDL^T`` of the Schur
  complement ``A M^-1 A^T`` (:mod:`dalembert.solvers.native.factorization`), when the
  runtime is available and the pattern suits it.

>>> pattern = SparsePattern(2, 1, np.array([0, 1]), np.array([0, 1]),
...                         np.array([0, 0]), np.array([0, 1]))
>>> kkt = kkt_factorization(pattern)
>>> kkt.backend
<Backend.BAND: 'band'>
>>> kkt.factor(np.array([1.0, 1.0, 1.0, 1.0]))   # M = I, A = [1, 1]
>>> x, lam = kkt.solve(np.array([0.0, -2.0, 0.0]))
>>> x, lam
(array([ 1., -1.]), array([1.]))
"""

from __future__ import annotations

import enum
import warnings
from abc import ABC, abstractmethod
from collections.abc import Callable

import numpy as np
import scipy.sparse as sps
import scipy.sparse.linalg as spla
from scipy.linalg import lapack

from ...codegen.compiled import SparsePattern
from ...errors import SingularSystemError
from ...numerics.band import band_order
from ..pattern_cache import PatternCache, read_only
from .dense import _dense_solve, kkt_matrix

#: Largest KKT size ``n + m`` solved dense when the banded path does not apply.
DENSE_MAX = 60
#: Largest band ``kl + ku + 1`` (after reverse Cuthill-McKee) solved with LAPACK's band LU.
BAND_MAX = 40
#: SuperLU options: a symmetric fill-reducing order for the symmetric KKT pattern, and
#: threshold pivoting relaxed so that the order is mostly kept (zero (2,2) block).
PERMC = "MMD_AT_PLUS_A"
DIAG_PIVOT_THRESH = 0.1
SINGULAR_MESSAGE = (
    "the KKT matrix [[M, A^T], [A, 0]] became singular: the accelerations are not "
    "determined (a singular configuration of the constraints, or a coordinate without "
    "inertia)")


class Backend(enum.Enum):
    """The solver behind a :class:`KKTFactorization`."""

    DENSE = "dense"
    BAND = "band"
    SPLU = "splu"
    SCHUR = "schur"


def active_rows(active: np.ndarray | None, m: int) -> np.ndarray:
    """The boolean mask of the active rows from a mask, an index set or ``None`` (all).

    Parameters
    ----------
    active
        A boolean array of length ``m``, or the indices of the active rows, or ``None``.
    m
        The number of constraint rows.

    Examples
    --------
    >>> active_rows(np.array([2, 0]), 3)
    array([ True, False,  True])
    >>> active_rows(None, 2)
    array([ True,  True])
    """
    if active is None:
        return np.ones(m, dtype=bool)
    rows = np.asarray(active)
    if rows.dtype == bool:
        if rows.shape != (m,):
            raise ValueError(f"the mask of active constraint rows has shape {rows.shape}; "
                             f"give one entry per row ({m})")
        return rows.copy()
    if rows.size and (rows.ndim != 1 or not np.issubdtype(rows.dtype, np.integer)
                      or rows.min() < 0 or rows.max() >= m):
        raise ValueError(f"the active constraint rows must be indices between 0 and {m - 1} "
                         f"(or a boolean mask of length {m}), got {active!r}")
    mask = np.zeros(m, dtype=bool)
    mask[rows.astype(np.intp)] = True
    return mask


class KKTFactorization(ABC):
    """A KKT factorization for one pattern: :meth:`factor`, then :meth:`solve`.

    Made by :func:`kkt_factorization`; what depends on the pattern alone (orders,
    index maps) is made once per pattern and shared, the factors belong to the object
    (one object per thread).

    Parameters
    ----------
    pattern
        The sparsity pattern of ``M`` and ``A``.
    """

    backend: Backend

    def __init__(self, pattern: SparsePattern) -> None:
        self.pattern = pattern
        self.n, self.m = pattern.n, pattern.m
        self.n_values = len(pattern.M_rows) + len(pattern.A_rows)
        self.active: np.ndarray | None = None  # the rows of the last factorization
        self._all_active = True
        self._every_row = _EVERY_ROW.get(pattern)

    def factor(self, values: np.ndarray, active: np.ndarray | None = None) -> None:
        """Factor the KKT matrix of ``values`` with the rows ``active`` (default all).

        Parameters
        ----------
        values
            ``[M values, A values]`` in the pattern's order.
        active
            The active constraint rows: a boolean mask of length ``m`` or their
            indices (see :func:`active_rows`).

        Raises
        ------
        SingularSystemError
            If the matrix is singular (the dense backend finds out at :meth:`solve`).
        """
        values = np.asarray(values, dtype=float)
        if values.shape != (self.n_values,):
            raise ValueError(f"the KKT values have shape {values.shape}; give the "
                             f"{self.n_values} values of M and A in the pattern's order")
        mask = self._every_row if active is None else active_rows(active, self.m)
        self.active = None
        self._all_active = active is None or bool(mask.all())
        self._factor(values, mask)
        self.active = mask

    def solve(self, rhs: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``(x, lambda)`` for the right-hand sides ``[f; c]`` (the last factorization's).

        Parameters
        ----------
        rhs
            ``n + m`` values, or an ``(n + m, k)`` matrix of ``k`` right-hand sides: ``f``
            by coordinate on top, ``c`` by constraint row below (the inactive rows'
            entries are ignored).

        Returns
        -------
        x, lambda
            ``(n,)`` and ``(m,)`` (or ``(n, k)`` and ``(m, k)``): ``M x = f + A^T lambda``,
            ``A x = c`` on the active rows, ``lambda = 0`` on the others.
        """
        z = self.solve_stacked(rhs)
        x, lam = z[:self.n], -z[self.n:]
        if self.active is not None and not self._all_active:
            lam[~self.active] = 0.0
        return x, lam

    def solve_stacked(self, rhs: np.ndarray) -> np.ndarray:
        """The KKT matrix's own unknowns ``[x; -lambda]`` stacked, for the right-hand sides
        ``[f; c]`` (as :meth:`solve`)."""
        if self.active is None:
            raise RuntimeError("solve() needs a successful factor() first")
        rhs = np.asarray(rhs, dtype=float)
        if rhs.shape[:1] != (self.n + self.m,) or rhs.ndim > 2:
            raise ValueError(f"the right-hand side has shape {rhs.shape}; give n + m = "
                             f"{self.n + self.m} rows (one column per right-hand side)")
        if self._all_active:
            return self._stacked(rhs)
        inactive = ~self.active
        rhs = rhs.copy()  # the caller's right-hand side left as it is
        rhs[self.n:][inactive] = 0.0
        z = self._stacked(rhs)
        z[self.n:][inactive] = 0.0
        return z

    @abstractmethod
    def _factor(self, values: np.ndarray, active: np.ndarray) -> None: ...

    @abstractmethod
    def _stacked(self, rhs: np.ndarray) -> np.ndarray: ...


class _Entries:
    """The entries of ``K = [[M, A^T], [A, D]]`` (``D`` diagonal: 1 on an inactive row,
    else 0) and where each value comes from in ``[M values, A values, D]`` (read-only
    arrays: one per pattern, shared by every run)."""

    def __init__(self, pattern: SparsePattern) -> None:
        n, m = pattern.n, pattern.m
        n_m, n_a = len(pattern.M_rows), len(pattern.A_rows)
        diagonal = n + np.arange(m)
        #: the entries of M, A^T and A (the order is made from these), then D's
        self.rows = np.concatenate([pattern.M_rows, pattern.A_cols, n + pattern.A_rows,
                                    diagonal]).astype(np.intp)
        self.cols = np.concatenate([pattern.M_cols, n + pattern.A_rows, pattern.A_cols,
                                    diagonal]).astype(np.intp)
        self.src = np.concatenate([np.arange(n_m), n_m + np.arange(n_a),
                                   n_m + np.arange(n_a), n_m + n_a + np.arange(m)])
        for array in (self.rows, self.cols, self.src):
            read_only(array)
        self.n_ordered = n_m + 2 * n_a
        self.size = n + m
        self._a_rows = pattern.A_rows
        self._n_m = n_m

    def values(self, values: np.ndarray, active: np.ndarray) -> np.ndarray:
        """``[M values, A values, D]`` with an inactive row's ``A`` values zero."""
        if active.all():
            return np.concatenate([values, np.zeros(len(active))])
        out = np.concatenate([values, (~active).astype(float)])
        out[self._n_m:self._n_m + len(self._a_rows)] *= active[self._a_rows]
        return out


#: Each pattern's mask of every row active (read-only).
_EVERY_ROW: PatternCache[np.ndarray] = PatternCache(
    lambda p, _: read_only(np.ones(p.m, dtype=bool)), "every constraint row active")
#: Each pattern's KKT entries and where their values come from.
_ENTRIES: PatternCache[_Entries] = PatternCache(lambda p, _: _Entries(p), "KKT entries")


def _entries(pattern: SparsePattern) -> _Entries:
    return _ENTRIES.get(pattern)


def restricted_pattern(pattern: SparsePattern, rows: np.ndarray
                       ) -> tuple[SparsePattern, np.ndarray]:
    """The pattern of ``M`` and the rows ``rows`` of ``A`` (renumbered ``0..len(rows)-1``
    in that order) and which of ``A``'s values it takes; made once per set of rows.

    Parameters
    ----------
    pattern
        The sparsity pattern of ``M`` and ``A``.
    rows
        The constraint rows kept.

    Examples
    --------
    >>> pattern = SparsePattern(2, 2, np.array([0, 1]), np.array([0, 1]),
    ...                         np.array([0, 1, 1]), np.array([0, 0, 1]))
    >>> kept, taken = restricted_pattern(pattern, np.array([1]))
    >>> kept.m, kept.A_rows.tolist(), kept.A_cols.tolist(), taken.tolist()
    (1, [0, 0], [0, 1], [1, 2])
    """
    return _RESTRICTED.get(pattern, np.asarray(rows, dtype=np.intp))


def _restrict(pattern: SparsePattern, rows: np.ndarray | None
              ) -> tuple[SparsePattern, np.ndarray]:
    assert rows is not None
    position = np.full(pattern.m, -1)
    position[rows] = np.arange(len(rows))
    taken = read_only(np.flatnonzero(position[pattern.A_rows] >= 0))
    return SparsePattern(pattern.n, len(rows), pattern.M_rows, pattern.M_cols,
                         position[pattern.A_rows[taken]], pattern.A_cols[taken]), taken


#: The pattern of ``M`` and some rows of ``A``, and which of ``A``'s values it takes
#: (by pattern and rows kept).
_RESTRICTED: PatternCache[tuple[SparsePattern, np.ndarray]] = PatternCache(
    _restrict, "restricted patterns")


class DenseFactorization(KKTFactorization):
    """The dense KKT matrix, solved by LAPACK's ``gesv`` at each :meth:`solve` (one LU
    for all its right-hand sides: the systems are at most :data:`DENSE_MAX` big)."""

    backend = Backend.DENSE

    def _factor(self, values: np.ndarray, active: np.ndarray) -> None:
        p, n_m = self.pattern, len(self.pattern.M_rows)
        Av = values[n_m:]
        if not active.all():
            Av = Av * active[p.A_rows]
        self._K = kkt_matrix(p.dense_M(values[:n_m]), p.dense_A(Av))
        self._K[self.n:, self.n:][np.diag_indices(self.m)] = ~active

    def _stacked(self, rhs: np.ndarray) -> np.ndarray:
        return _dense_solve(self._K, rhs)


class BandFactorization(KKTFactorization):
    """LAPACK's band LU of the KKT matrix (:class:`BandLU`)."""

    backend = Backend.BAND

    def __init__(self, pattern: SparsePattern) -> None:
        super().__init__(pattern)
        self._entries = _entries(pattern)
        self.band = band_lu(pattern)

    def _factor(self, values: np.ndarray, active: np.ndarray) -> None:
        if self._all_active:  # the (2,2) block's zeros need no scatter
            self._apply = self.band.factor(values, ordered_only=True)
        else:
            self._apply = self.band.factor(self._entries.values(values, active))

    def _stacked(self, rhs: np.ndarray) -> np.ndarray:
        return self._apply(rhs)


def band_lu(pattern: SparsePattern) -> BandLU:
    """The :class:`BandLU` of a pattern's KKT matrix (its order made from ``M`` and ``A``
    alone; made once per pattern)."""
    return _BAND_LU.get(pattern)


def _make_band_lu(pattern: SparsePattern, _: object) -> BandLU:
    e = _entries(pattern)
    return BandLU(e.rows, e.cols, e.src, e.size, ordered=e.n_ordered)


#: Each pattern's band order and storage map of the KKT matrix.
_BAND_LU: PatternCache[BandLU] = PatternCache(_make_band_lu, "KKT band LU structures")


def band_condition(pattern: SparsePattern, values: np.ndarray) -> float:
    """Estimated 1-norm condition number of the KKT matrix of ``values`` (every row
    active) from its band LU (:meth:`BandLU.condition`; the next band factorization of
    the same values reuses that LU).

    >>> pattern = SparsePattern(2, 1, np.array([0, 1]), np.array([0, 1]),
    ...                         np.array([0, 0]), np.array([0, 1]))
    >>> bool(band_condition(pattern, np.ones(4)) < 10)
    True
    """
    return band_lu(pattern).condition(np.asarray(values, dtype=float), ordered_only=True)


class SpluFactorization(KKTFactorization):
    """SuperLU's sparse LU of the KKT matrix (fill-reducing order :data:`PERMC`)."""

    backend = Backend.SPLU

    def __init__(self, pattern: SparsePattern) -> None:
        super().__init__(pattern)
        self._entries = _entries(pattern)
        # Two structures: with the (2,2) diagonal for inactive rows, and without it when
        # every row is active (SuperLU's order and pivots then see the KKT pattern alone)
        self._maps = _CSC_MAPS.get(pattern)

    def matrix(self, values: np.ndarray, active: np.ndarray | None = None) -> sps.csc_matrix:
        """The KKT matrix of ``values`` (``[M values, A values]``) and rows ``active``."""
        mask = active_rows(active, self.m)
        src, indices, indptr = self._maps[0 if mask.all() else 1]
        full = self._entries.values(values, mask)
        return sps.csc_matrix((full[src], indices, indptr), shape=(self._entries.size,) * 2)

    def _factor(self, values: np.ndarray, active: np.ndarray) -> None:
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("error", spla.MatrixRankWarning)
                self._lu = spla.splu(self.matrix(values, active), permc_spec=PERMC,
                                     diag_pivot_thresh=DIAG_PIVOT_THRESH)
        except (RuntimeError, spla.MatrixRankWarning) as exc:
            raise SingularSystemError(SINGULAR_MESSAGE) from exc

    def _stacked(self, rhs: np.ndarray) -> np.ndarray:
        return self._lu.solve(rhs)


CscMaps = tuple[tuple[np.ndarray, np.ndarray, np.ndarray], ...]


def _csc_maps(pattern: SparsePattern, _: object) -> CscMaps:
    """``(source of each value, indices, indptr)`` of the CSC KKT matrix: without the
    (2,2) diagonal, then with it."""
    e = _entries(pattern)
    return tuple((read_only(e.src[:k][order]), read_only(indices), read_only(indptr))
                 for k in (e.n_ordered, len(e.rows))
                 for order, indices, indptr in [csc_map(e.rows[:k], e.cols[:k], e.size)])


#: Each pattern's CSC maps of the KKT matrix (:class:`SpluFactorization`).
_CSC_MAPS: PatternCache[CscMaps] = PatternCache(_csc_maps, "KKT CSC maps")


_PYTHON: dict[Backend, Callable[[SparsePattern], KKTFactorization]] = {
    Backend.DENSE: DenseFactorization, Backend.BAND: BandFactorization,
    Backend.SPLU: SpluFactorization}


def choose_backend(pattern: SparsePattern, native: bool = False) -> Backend:
    """The backend for a pattern (decided once per pattern).

    ``BAND`` when the KKT matrix's band is at most :data:`BAND_MAX` wide, else
    ``DENSE`` up to :data:`DENSE_MAX` unknowns, else ``SPLU``. With ``native``,
    ``SCHUR`` first, when the C runtime is available and the pattern suits it.

    Parameters
    ----------
    pattern
        The sparsity pattern of ``M`` and ``A``.
    native
        Whether the C block/Schur solver may be chosen.

    Examples
    --------
    >>> pattern = SparsePattern(2, 1, np.array([0, 1]), np.array([0, 1]),
    ...                         np.array([0, 0]), np.array([0, 1]))
    >>> choose_backend(pattern)
    <Backend.BAND: 'band'>
    """
    if native and _SCHUR_APPLIES.get(pattern):
        return Backend.SCHUR
    if band_lu(pattern).width <= BAND_MAX:
        return Backend.BAND
    return Backend.DENSE if pattern.n + pattern.m <= DENSE_MAX else Backend.SPLU


def _schur_applies(pattern: SparsePattern, _: object) -> bool:
    from ..native.factorization import schur_applies  # the C layer builds on this one
    return schur_applies(pattern)


#: Whether the C block/Schur solver suits each pattern.
_SCHUR_APPLIES: PatternCache[bool] = PatternCache(_schur_applies, "Schur backend applies")


def kkt_factorization(pattern: SparsePattern, backend: Backend | None = None
                      ) -> KKTFactorization:
    """A new :class:`KKTFactorization` for ``pattern`` (structural work shared per pattern).

    Parameters
    ----------
    pattern
        The sparsity pattern of ``M`` and ``A``.
    backend
        The solver; default :func:`choose_backend`'s for the pattern (Python backends).

    Examples
    --------
    Two right-hand sides, and the row made inactive: its multiplier is 0 and ``x``
    the unconstrained ``M^-1 f``.

    >>> pattern = SparsePattern(2, 1, np.array([0, 1]), np.array([0, 1]),
    ...                         np.array([0, 0]), np.array([0, 1]))
    >>> kkt = kkt_factorization(pattern, Backend.DENSE)
    >>> rhs = np.array([[0.0, 1.0], [-2.0, 1.0], [0.0, 0.0]])
    >>> kkt.factor(np.ones(4), active=np.array([False]))
    >>> x, lam = kkt.solve(rhs)
    >>> x, lam
    (array([[ 0.,  1.],
           [-2.,  1.]]), array([[0., 0.]]))
    """
    if backend is None:
        backend = choose_backend(pattern)
    if backend is Backend.SCHUR:
        from ..native.factorization import SchurFactorization
        return SchurFactorization(pattern)
    return _PYTHON[backend](pattern)


class BandLU:
    """Band LU (LAPACK ``gbtrf``/``gbtrs``) of a matrix in a bandwidth-reducing order.

    For a chain or a tree numbered along it the band stays a few bodies wide, so a
    factorization costs ``O(size * band^2)``: linear in the mechanism, and with far
    less overhead than SuperLU. The order and the scatter of the values straight into
    LAPACK's column-major band storage are computed once, so a factorization is one
    gather, one scatter and one LAPACK call.

    Parameters
    ----------
    rows, cols
        The matrix's entries (a symmetric pattern).
    src
        Where each entry's value is in the values :meth:`factor` is given.
    size
        The matrix's order.
    ordered
        The order is made from the first ``ordered`` entries (default all); the
        others must lie on the diagonal (they then change neither the band nor it).
    """

    def __init__(self, rows: np.ndarray, cols: np.ndarray, src: np.ndarray,
                 size: int, ordered: int | None = None) -> None:
        self.perm, self.kl, self.ku, self.flat = band_layout(rows, cols, size, ordered)
        self.size, self.src, self.cols = size, src, cols
        #: the scatter of all entries, and of the ordered ones alone (the others zero)
        self._scatter = {False: (self.flat, src, cols),
                         True: (self.flat[:ordered], src[:ordered], cols[:ordered])}
        self.width = self.kl + self.ku + 1
        self.ldab = 2 * self.kl + self.ku + 1
        #: the factorization :meth:`condition` made and the values it is of, for the
        #: next :meth:`factor` (the initial state's checks estimate the condition of the
        #: matrix its impact solve then factors); one tuple, replaced whole, so threads
        #: sharing the solver read a consistent pair. Loops that only factor never
        #: make it, and pay no comparison of values.
        self._conditioned: tuple[bytes, bool, tuple[np.ndarray, np.ndarray, int]] | None = None

    def _lu(self, values: np.ndarray, ordered_only: bool
            ) -> tuple[np.ndarray, np.ndarray, int]:
        flat, src, _ = self._scatter[ordered_only]
        ab = np.zeros(self.ldab * self.size)
        ab[flat] = values[src]
        return lapack.dgbtrf(ab.reshape(self.size, self.ldab).T, self.kl, self.ku,
                             overwrite_ab=1)

    def condition(self, values: np.ndarray, ordered_only: bool = False) -> float:
        """Estimated 1-norm condition number (LAPACK ``gbcon`` on the band LU), ``inf``
        if the matrix is singular (``ordered_only``: as :meth:`factor`)."""
        lu, piv, info = self._lu(values, ordered_only)
        self._conditioned = (values.tobytes(), ordered_only, (lu, piv, info))
        if info != 0:
            return np.inf
        _, src, cols = self._scatter[ordered_only]
        norm = np.bincount(cols, weights=np.abs(values[src]), minlength=self.size)
        rcond, info = lapack.dgbcon(self.kl, self.ku, lu, piv, norm.max())
        return 1.0 / rcond if info == 0 and rcond > 0.0 else np.inf

    def factor(self, values: np.ndarray, ordered_only: bool = False):
        """A function ``rhs -> K^-1 rhs`` (``rhs`` a vector or a matrix of columns);
        ``values`` indexed by the ``src`` given (``ordered_only``: the ordered entries'
        values alone, the others zero)."""
        kl, ku, perm = self.kl, self.ku, self.perm
        conditioned, self._conditioned = self._conditioned, None
        if conditioned is not None and conditioned[1] == ordered_only \
                and conditioned[0] == values.tobytes():
            lu, piv, info = conditioned[2]
        else:
            lu, piv, info = self._lu(values, ordered_only)
        if info != 0:
            raise SingularSystemError(SINGULAR_MESSAGE)

        def solve(rhs: np.ndarray) -> np.ndarray:
            x = lapack.dgbtrs(lu, kl, ku, rhs[perm], piv, overwrite_b=1)[0]
            out = np.empty_like(x)
            out[perm] = x
            return out

        return solve


def band_layout(rows: np.ndarray, cols: np.ndarray, size: int, ordered: int | None = None):
    """``(perm, kl, ku, flat)`` for the entries ``(rows, cols)`` of a symmetric pattern:
    a bandwidth-reducing order (:func:`~dalembert.numerics.band.band_order`, of the
    first ``ordered`` entries; SciPy's below ``DENSE_MAX`` unknowns, where the band
    hardly costs and another order would change the rounding of every result), the
    band, and each entry's index in the flat column-major storage of LAPACK's
    ``gbtrf`` (entry ``(i, j)`` of the permuted matrix at row ``kl + ku + i - j``,
    column ``j``)."""
    perm = band_order(rows[:ordered], cols[:ordered], size, peripheral_from=DENSE_MAX + 1)
    inverse = np.empty(size, dtype=np.intp)
    inverse[perm] = np.arange(size)
    i, j = inverse[rows], inverse[cols]
    kl = int(max(0, (i - j).max(initial=0)))
    ku = int(max(0, (j - i).max(initial=0)))
    flat = (kl + ku + i - j) + j * (2 * kl + ku + 1)
    return perm, kl, ku, flat


def csc_map(rows: np.ndarray, cols: np.ndarray, size: int):
    """CSC ``(order, indices, indptr)`` of the entries ``(rows, cols)``: the CSC data
    array is ``values[order]`` for values listed in the same order as the entries."""
    tag = np.arange(1, len(rows) + 1, dtype=float)
    K = sps.coo_matrix((tag, (rows, cols)), shape=(size, size)).tocsc()
    K.sort_indices()
    return K.data.astype(np.intp) - 1, K.indices, K.indptr
