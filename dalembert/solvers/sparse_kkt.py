"""KKT solves in time linear in the size of the mechanism, from the fixed sparsity pattern.

The generated code returns the values of ``M`` and ``A`` on a fixed pattern
(:class:`~dalembert.codegen.compiled.SparsePattern`). :class:`KKTSolver` maps them
straight into the arrays of ``K = [[M, A^T], [A, 0]]`` (the maps are computed
once) and picks, once per pattern, one of three factorizations:

- ``band`` (when the band is at most ``BAND_MAX`` wide): a bandwidth-reducing
  order (:mod:`dalembert.numerics.band`), then LAPACK's band LU
  with partial pivoting (``gbtrf``/``gbtrs``), the values scattered straight into
  its storage. For a chain the band is ~2 links wide whatever the length
  (``kl = ku = 11`` for spherical quaternion links), so a solve costs ``O(n)``.
- ``dense`` (small systems whose band is wide): one LAPACK solve.
- ``splu``: SuperLU with a fill-reducing order (``MMD_AT_PLUS_A``), for large
  patterns with a wide band (a branching tree); it has a fixed overhead, so it
  is kept for what the band cannot serve.

A dense LU is ``O(n^3)`` and, past ~100 unknowns, multithreaded BLAS adds more
than it saves on small cores: the band path is what keeps a chain linear.

Products with ``A`` and ``A^T`` go through :func:`numpy.bincount` on the pattern:
``O(nnz)`` with no sparse-matrix object built.
"""

from __future__ import annotations

import warnings

import numpy as np
import scipy.sparse as sps
import scipy.sparse.linalg as spla
from scipy.linalg import lapack

from ..codegen.compiled import SparsePattern
from ..errors import SingularSystemError
from ..numerics.band import band_order
from ..numerics.band import bandwidth as _bandwidth  # noqa: F401 (tests measure with it)
from ..numerics.conditioning import condition_1norm
from ..numerics.rank import min_norm_multipliers
from .kkt import DROPPED_ROW_RTOL, _dense_solve, _least_squares_kkt, kkt_matrix

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


def matvec(pattern_rows: np.ndarray, pattern_cols: np.ndarray, values: np.ndarray,
           x: np.ndarray, size: int) -> np.ndarray:
    """``A @ x`` for ``A`` given by its values on a pattern, ``O(nnz)``.

    >>> matvec(np.array([0, 1]), np.array([1, 1]), np.array([2.0, 3.0]), np.array([5.0, 7.0]), 2)
    array([14., 21.])
    """
    return np.bincount(pattern_rows, weights=values * x[pattern_cols], minlength=size)


class KKTSolver:
    """Solves ``M qdd = f + A^T lambda``, ``A qdd = c`` from pattern values.

    ``kept`` (independent rows, see :func:`~dalembert.numerics.rank.constraint_rank`)
    solves the reduced system of those rows, as :func:`~dalembert.solvers.kkt.solve_kkt`
    does; ``dense`` forces (``True``) or forbids (``False``) the dense path.

    >>> pattern = SparsePattern(2, 1, np.array([0, 1]), np.array([0, 1]),
    ...                         np.array([0, 0]), np.array([0, 1]))
    >>> KKTSolver(pattern).solve(np.ones(2), np.array([0.0, -2.0]), np.ones(2), np.zeros(1))
    (array([ 1., -1.]), array([1.]))
    """

    def __init__(self, pattern: SparsePattern, kept: np.ndarray | None = None,
                 dense: bool | None = None) -> None:
        self.pattern = pattern
        self.kept = None if kept is None else np.asarray(kept, dtype=np.intp)
        n = pattern.n
        rows = np.arange(pattern.m) if self.kept is None else self.kept
        self.mk = len(rows)
        # Entries of A in the kept rows, renumbered 0..mk-1.
        position = np.full(pattern.m, -1)
        position[rows] = np.arange(self.mk)
        self._a_sel = np.flatnonzero(position[pattern.A_rows] >= 0)
        a_rows = position[pattern.A_rows[self._a_sel]]
        a_cols = pattern.A_cols[self._a_sel]
        self.size = n + self.mk
        # Every entry of K: row, column, and where its value is in ``[M values, A values]``.
        n_m = len(pattern.M_rows)
        self._rows = np.concatenate([pattern.M_rows, a_cols, n + a_rows]).astype(np.intp)
        self._cols = np.concatenate([pattern.M_cols, n + a_rows, a_cols]).astype(np.intp)
        self._src = np.concatenate([np.arange(n_m), n_m + self._a_sel, n_m + self._a_sel])
        self._data_order, self._indices, self._indptr = _csc_map(self._rows, self._cols,
                                                                 self.size)
        self._csc_src = self._src[self._data_order]
        self._band = BandLU(self._rows, self._cols, self._src, self.size)
        if dense is not None:
            self.method = "dense" if dense else "splu"
        elif self._band.width <= BAND_MAX:
            self.method = "band"
        else:
            self.method = "dense" if self.size <= DENSE_MAX else "splu"

    @property
    def dense(self) -> bool:
        return self.method == "dense"

    def solve(self, Mv: np.ndarray, f: np.ndarray, Av: np.ndarray,
              c: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``(qdd, lambda)``; with ``kept``, ``lambda`` is the minimum-norm one."""
        qdd, lam, force = self._solve(Mv, f, Av, c)
        if lam is None:
            lam = min_norm_multipliers(self.pattern.dense_A(Av), force)
        return qdd, lam

    def accelerations(self, Mv: np.ndarray, f: np.ndarray, Av: np.ndarray,
                      c: np.ndarray) -> np.ndarray:
        """``qdd`` alone (no multipliers computed with dependent constraints)."""
        return self._solve(Mv, f, Av, c, multipliers=False)[0]

    def factor(self, Mv: np.ndarray, Av: np.ndarray):
        """A function ``rhs -> K^-1 rhs`` for the KKT matrix of these values."""
        if self.method == "dense":
            K = kkt_matrix(self.pattern.dense_M(Mv), self._dense_kept_A(Av))
            return lambda rhs: _dense_solve(K, rhs)
        values = np.concatenate([Mv, Av])
        if self.method == "band":
            return self._band.factor(values)
        K = sps.csc_matrix((values[self._csc_src], self._indices, self._indptr),
                           shape=(self.size, self.size))
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("error", spla.MatrixRankWarning)
                lu = spla.splu(K, permc_spec=PERMC, diag_pivot_thresh=DIAG_PIVOT_THRESH)
        except (RuntimeError, spla.MatrixRankWarning) as exc:
            raise SingularSystemError(SINGULAR_MESSAGE) from exc
        return lu.solve

    def _dense_kept_A(self, Av: np.ndarray) -> np.ndarray:
        A = self.pattern.dense_A(Av)
        return A if self.kept is None else A[self.kept]

    def _solve(self, Mv, f, Av, c, multipliers: bool = True):
        """``(qdd, lambda or None, A^T lambda)``; see :func:`.kkt._redundant_solve`.
        Without ``multipliers`` the full-rank path leaves ``lambda`` out (``None``)."""
        n, p = self.pattern.n, self.pattern
        rhs = np.concatenate([f, c if self.kept is None else c[self.kept]])
        x = self.factor(Mv, Av)(rhs)
        qdd = x[:n]
        if self.kept is None:
            return qdd, -x[n:] if multipliers else None, None
        mu = -x[n:]
        miss = np.abs(matvec(p.A_rows, p.A_cols, Av, qdd, p.m) - c)
        miss[self.kept] = 0.0
        scale = 1.0 + np.abs(c).max(initial=0.0) \
            + np.abs(Av).max(initial=0.0) * np.abs(qdd).max(initial=0.0)
        if miss.max(initial=0.0) <= DROPPED_ROW_RTOL * scale:
            lam_k = np.zeros(p.m)
            lam_k[self.kept] = mu
            return qdd, None, matvec(p.A_cols, p.A_rows, Av, lam_k, n)
        # The rank changed since it was measured: the full least-squares solve (dense, rare).
        qdd, lam = _least_squares_kkt(p.dense_M(Mv), f, p.dense_A(Av), c)
        return qdd, lam, None


def kkt_solver(pattern: SparsePattern, kept: np.ndarray | None = None) -> KKTSolver:
    """``KKTSolver(pattern, kept)``, made once per pattern and set of kept rows (a
    solver holds index maps only, so one serves every simulation of a model).

    >>> pattern = SparsePattern(2, 1, np.array([0, 1]), np.array([0, 1]),
    ...                         np.array([0, 0]), np.array([0, 1]))
    >>> kkt_solver(pattern) is kkt_solver(pattern)
    True
    """
    rows = None if kept is None else np.asarray(kept, dtype=np.intp)
    key = ("kkt_solver", None if rows is None else rows.tobytes())
    return pattern.remember(key, lambda: KKTSolver(pattern, rows))


class BandLU:
    """Band LU (LAPACK ``gbtrf``/``gbtrs``) of the KKT matrix in a bandwidth-reducing order.

    For a chain or a tree numbered along it the band stays a few bodies wide, so a
    factorization costs ``O(size * band^2)``: linear in the mechanism, and with far
    less overhead than SuperLU. The order and the scatter of the values straight into
    LAPACK's column-major band storage are computed once, so a factorization is one
    gather, one scatter and one LAPACK call.
    """

    def __init__(self, rows: np.ndarray, cols: np.ndarray, src: np.ndarray,
                 size: int) -> None:
        self.perm, self.kl, self.ku, self.flat = band_layout(rows, cols, size)
        self.size, self.src, self.cols = size, src, cols
        self.width = self.kl + self.ku + 1
        self.ldab = 2 * self.kl + self.ku + 1
        #: the factorization :meth:`condition` made and the values it is of, for the
        #: next :meth:`factor` (the initial state's checks estimate the condition of the
        #: matrix its impact solve then factors); one tuple, replaced whole, so threads
        #: sharing the solver read a consistent pair. Loops that only factor never
        #: make it, and pay no comparison of values.
        self._conditioned: tuple[bytes, tuple[np.ndarray, np.ndarray, int]] | None = None

    def _lu(self, values: np.ndarray) -> tuple[np.ndarray, np.ndarray, int]:
        ab = np.zeros(self.ldab * self.size)
        ab[self.flat] = values[self.src]
        return lapack.dgbtrf(ab.reshape(self.size, self.ldab).T, self.kl, self.ku,
                             overwrite_ab=1)

    def condition(self, values: np.ndarray) -> float:
        """Estimated 1-norm condition number (LAPACK ``gbcon`` on the band LU), ``inf``
        if the matrix is singular."""
        lu, piv, info = self._lu(values)
        self._conditioned = (values.tobytes(), (lu, piv, info))
        if info != 0:
            return np.inf
        norm = np.bincount(self.cols, weights=np.abs(values[self.src]), minlength=self.size)
        rcond, info = lapack.dgbcon(self.kl, self.ku, lu, piv, norm.max())
        return 1.0 / rcond if info == 0 and rcond > 0.0 else np.inf

    def factor(self, values: np.ndarray):
        """A function ``rhs -> K^-1 rhs``; ``values`` indexed by the ``src`` given."""
        kl, ku, perm = self.kl, self.ku, self.perm
        conditioned, self._conditioned = self._conditioned, None
        if conditioned is not None and conditioned[0] == values.tobytes():
            lu, piv, info = conditioned[1]
        else:
            lu, piv, info = self._lu(values)
        if info != 0:
            raise SingularSystemError(SINGULAR_MESSAGE)

        def solve(rhs: np.ndarray) -> np.ndarray:
            x = lapack.dgbtrs(lu, kl, ku, rhs[perm], piv, overwrite_b=1)[0]
            out = np.empty_like(x)
            out[perm] = x
            return out

        return solve


def band_layout(rows: np.ndarray, cols: np.ndarray, size: int):
    """``(perm, kl, ku, flat)`` for the entries ``(rows, cols)`` of a symmetric pattern:
    a bandwidth-reducing order (:func:`~dalembert.numerics.band.band_order`; SciPy's
    below ``DENSE_MAX`` unknowns, where the band hardly costs and another order
    would change the rounding of every result), the band, and each entry's index
    in the flat column-major storage of LAPACK's ``gbtrf`` (entry ``(i, j)`` of the
    permuted matrix at row ``kl + ku + i - j``, column ``j``)."""
    perm = band_order(rows, cols, size, peripheral_from=DENSE_MAX + 1)
    inverse = np.empty(size, dtype=np.intp)
    inverse[perm] = np.arange(size)
    i, j = inverse[rows], inverse[cols]
    kl = int(max(0, (i - j).max(initial=0)))
    ku = int(max(0, (j - i).max(initial=0)))
    flat = (kl + ku + i - j) + j * (2 * kl + ku + 1)
    return perm, kl, ku, flat


def _csc_map(rows: np.ndarray, cols: np.ndarray, size: int):
    """CSC ``(order, indices, indptr)`` of the entries ``(rows, cols)``: the CSC data
    array is ``values[order]`` for values listed in the same order as the entries."""
    tag = np.arange(1, len(rows) + 1, dtype=float)
    K = sps.coo_matrix((tag, (rows, cols)), shape=(size, size)).tocsc()
    K.sort_indices()
    return K.data.astype(np.intp) - 1, K.indices, K.indptr


def kkt_condition(solver: KKTSolver, Mv: np.ndarray, Av: np.ndarray) -> float:
    """Estimated 1-norm condition number of the KKT matrix (``inf`` if it cannot be
    factored): LAPACK's estimate from the band LU when the solver uses one, else from
    the sparse factorization and a few solves (:func:`scipy.sparse.linalg.onenormest`).
    A cheap screen before the dense SVD diagnosis (:func:`.kkt.check_kkt`). The 2-norm
    condition number is at most ``size`` times larger.

    >>> from dalembert.codegen.compiled import SparsePattern
    >>> pattern = SparsePattern(2, 1, np.array([0, 1]), np.array([0, 1]),
    ...                         np.array([0, 0]), np.array([0, 1]))
    >>> bool(kkt_condition(KKTSolver(pattern), np.ones(2), np.ones(2)) < 10)
    True
    """
    if solver.method == "band":
        return solver._band.condition(np.concatenate([Mv, Av]))
    data = np.concatenate([Mv, Av])[solver._csc_src]
    K = sps.csc_matrix((data, solver._indices, solver._indptr), shape=(solver.size,) * 2)
    try:
        solve = solver.factor(Mv, Av)
    except (SingularSystemError, np.linalg.LinAlgError):
        return np.inf
    return condition_1norm(K, solve)
