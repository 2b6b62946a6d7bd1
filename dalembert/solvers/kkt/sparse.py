"""KKT solves in time linear in the size of the mechanism, from the fixed sparsity pattern.

The generated code returns the values of ``M`` and ``A`` on a fixed pattern
(:class:`~dalembert.codegen.compiled.SparsePattern`). :class:`KKTSolver` solves the
dynamics' KKT system with them, dependent rows included, through the factorization
object of :mod:`.factorization`, whose backend is picked once per pattern:

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

import numpy as np

from ...codegen.compiled import SparsePattern
from ...errors import SingularSystemError
from ...numerics.band import bandwidth as _bandwidth  # noqa: F401 (tests measure with it)
from ...numerics.conditioning import condition_1norm
from ...numerics.rank import min_norm_multipliers
from ..pattern_cache import PatternCache
from .dense import DROPPED_ROW_RTOL, _least_squares_kkt
from .factorization import (  # noqa: F401 (BandLU, band_layout and the limits: here too)
    BAND_MAX,
    DENSE_MAX,
    SINGULAR_MESSAGE,
    Backend,
    BandLU,
    SpluFactorization,
    _entries,
    band_condition,
    band_layout,
    band_lu,
    choose_backend,
    kkt_factorization,
    restricted_pattern,
)

_BACKENDS = {backend.value: backend for backend in Backend}


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
    solves the reduced system of those rows, as :func:`~dalembert.solvers.kkt.dense.solve_kkt`
    does; ``dense`` forces (``True``) or forbids (``False``) the dense path. The
    factorizations are :mod:`.factorization`'s, of the pattern of the solved rows
    (``method`` names the backend, chosen once per pattern).

    >>> pattern = SparsePattern(2, 1, np.array([0, 1]), np.array([0, 1]),
    ...                         np.array([0, 0]), np.array([0, 1]))
    >>> KKTSolver(pattern).solve(np.ones(2), np.array([0.0, -2.0]), np.ones(2), np.zeros(1))
    (array([ 1., -1.]), array([1.]))
    """

    def __init__(self, pattern: SparsePattern, kept: np.ndarray | None = None,
                 dense: bool | None = None) -> None:
        self.pattern = pattern
        self.kept = None if kept is None else np.asarray(kept, dtype=np.intp)
        rows = np.arange(pattern.m) if self.kept is None else self.kept
        self.mk = len(rows)
        self.size = pattern.n + self.mk
        #: the pattern of the solved rows (the kept ones renumbered 0..mk-1), and which
        #: of A's values it takes (None: all)
        self.solved: SparsePattern = pattern
        self._a_sel: np.ndarray | None = None
        if self.kept is not None:
            self.solved, self._a_sel = restricted_pattern(pattern, self.kept)
        entries = _entries(self.solved)
        #: the entries of ``K``'s ``M``, ``A^T`` and ``A`` blocks (rows, columns)
        self._rows = entries.rows[:entries.n_ordered]
        self._cols = entries.cols[:entries.n_ordered]
        if dense is not None:
            self.method = "dense" if dense else "splu"
        else:
            self.method = choose_backend(self.solved).value

    @property
    def dense(self) -> bool:
        return self.method == "dense"

    @property
    def _band(self) -> BandLU:
        return band_lu(self.solved)

    def values(self, Mv: np.ndarray, Av: np.ndarray) -> np.ndarray:
        """``[M values, A values]`` of the solved rows' pattern."""
        return np.concatenate([Mv, Av if self._a_sel is None else Av[self._a_sel]])

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
        """A function ``rhs -> K^-1 rhs`` (vector or matrix of columns) for the KKT
        matrix of these values."""
        kkt = kkt_factorization(self.solved, _BACKENDS[self.method])
        kkt.factor(self.values(Mv, Av))
        return kkt.solve_stacked

    def _solve(self, Mv, f, Av, c, multipliers: bool = True):
        """``(qdd, lambda or None, A^T lambda)``; see :func:`.dense._redundant_solve`.
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
    return _SOLVERS.get(pattern, None if kept is None else np.asarray(kept, dtype=np.intp))


#: The solver of each pattern and set of kept rows (index maps only: shared by runs).
_SOLVERS: PatternCache[KKTSolver] = PatternCache(KKTSolver, "KKT solvers")


def kkt_condition(solver: KKTSolver, Mv: np.ndarray, Av: np.ndarray) -> float:
    """Estimated 1-norm condition number of the KKT matrix (``inf`` if it cannot be
    factored): LAPACK's estimate from the band LU when the solver uses one, else from
    the sparse factorization and a few solves (:func:`scipy.sparse.linalg.onenormest`).
    A cheap screen before the dense SVD diagnosis (:func:`.dense.check_kkt`). The 2-norm
    condition number is at most ``size`` times larger.

    >>> from dalembert.codegen.compiled import SparsePattern
    >>> pattern = SparsePattern(2, 1, np.array([0, 1]), np.array([0, 1]),
    ...                         np.array([0, 0]), np.array([0, 1]))
    >>> bool(kkt_condition(KKTSolver(pattern), np.ones(2), np.ones(2)) < 10)
    True
    """
    values = solver.values(Mv, Av)
    if solver.method == "band":
        return band_condition(solver.solved, values)
    K = SpluFactorization(solver.solved).matrix(values)
    try:
        solve = solver.factor(Mv, Av)
    except (SingularSystemError, np.linalg.LinAlgError):
        return np.inf
    return condition_1norm(K, solve)
