"""The stabilized index-2 (GGL) form of the constrained equations, as an implicit DAE.

Gear, Gupta and Leimkuhler's form, in ``y = [q, v, lambda, mu]``:

    F1 = q' - v + A_h(q, t)^T mu  = 0           (n rows)
    F2 = M(q, t) v' - f(q, v, t) - A(q, t)^T lambda = 0   (n rows)
    F3 = A(q, t) v + b(q, t)      = 0           (the constraint rows kept: velocity level)
    F4 = psi(q, t)                = 0           (their holonomic rows: position level)

``A_h`` holds the holonomic rows of ``A = dpsi/dq``; ``mu`` (one per holonomic row
kept) is zero on the exact solution and keeps ``q`` on ``psi = 0`` without
differentiating the position constraint twice (index 2, not 3). ``lambda`` is the
multiplier of dalembert's sign convention (``M qdd = f + A^T lambda``).

A DAE solver's Newton matrix is ``dF/dy + cj dF/dy'``; every block comes from the
model's generated derivatives, exactly: the KKT residuals' (``residual_jacobians``:
``d r1/dq`` and ``d r1/dqd`` of ``r1 = M qdd - f - A^T lambda`` taken at ``qdd = v'``
are ``dF2/dq`` and ``dF2/dv``) and the GGL ones (``ggl_jacobians``: ``d (A v + b)/dq``
and ``d (A^T mu)/dq``, :mod:`dalembert.equations.ggl`). The matrix is assembled as
sparse entries (:meth:`GGLForm.newton_entries`: its pattern is fixed by the generated
functions' patterns), and given dense (:meth:`GGLForm.newton_matrix`) or in compressed
columns (:class:`CompressedColumns`) to the solver's dense or sparse LU; the residual is
evaluated from the sparse values too, so a long chain costs no dense ``n x n`` product.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..codegen.compiled import NumericModel
from .kkt.sparse import kkt_solver


@dataclass(frozen=True)
class GGLForm:
    """The GGL residual and Newton matrix of a bound model (see the module).

    Parameters
    ----------
    num
        The compiled equations bound to parameter values.
    kept
        The constraint rows solved for (``None``: all); a dependent row left out
        would make the Newton matrix singular.

    Examples
    --------
    The pendulum hanging at rest: every residual vanishes at the consistent start.

    >>> from dalembert.examples import cartesian_pendulum
    >>> form = GGLForm(cartesian_pendulum.build().numeric())
    >>> y, yp = form.start(0.0, np.array([0.0, -1.0]), np.zeros(2))
    >>> y.size, float(np.abs(form.residual(0.0, y, yp)).max())
    (6, 0.0)
    """

    num: NumericModel
    kept: np.ndarray | None = None

    @property
    def rows(self) -> np.ndarray:
        """The constraint rows kept (``lambda``'s entries)."""
        return np.arange(self.num.m) if self.kept is None else np.asarray(self.kept,
                                                                          dtype=np.intp)

    @property
    def holonomic(self) -> np.ndarray:
        """Of the kept rows, the holonomic ones (``mu``'s entries), as row numbers."""
        kept = set(self.rows.tolist())
        return np.array([r for r in self.num.holonomic_rows if r in kept], dtype=np.intp)

    @property
    def _psi_entries(self) -> np.ndarray:
        """Where the holonomic rows kept sit in ``psi`` (in ``holonomic_rows`` order)."""
        kept = set(self.rows.tolist())
        return np.array([j for j, r in enumerate(self.num.holonomic_rows) if r in kept],
                        dtype=np.intp)

    @property
    def size(self) -> int:
        """``N = 2 n + rows + holonomic rows``."""
        return 2 * self.num.n + len(self.rows) + len(self.holonomic)

    @property
    def algebraic(self) -> np.ndarray:
        """The indices of ``lambda`` and ``mu`` in ``y`` (left out of the error test)."""
        return np.arange(2 * self.num.n, self.size)

    def split(self, y: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """``(q, v, lambda, mu)`` of ``y`` (views)."""
        n, k = self.num.n, len(self.rows)
        return y[:n], y[n:2 * n], y[2 * n:2 * n + k], y[2 * n + k:]

    def start(self, t: float, q: np.ndarray, qd: np.ndarray
              ) -> tuple[np.ndarray, np.ndarray]:
        """``(y0, y0')`` at a consistent state: the multipliers and accelerations of the
        KKT solve there, ``mu = 0`` (the algebraic entries of ``y0'`` are not read).

        Parameters
        ----------
        t, q, qd
            A state on the constraints (positions and velocities).
        """
        n, rows = self.num.n, self.rows
        Mv, f, Av, c = self.num.kkt_sparse(t, q, qd)
        solve = kkt_solver(self.num.pattern, self.kept).factor(Mv, Av)
        x = solve(np.concatenate([f, c[rows]]))
        qdd, lam = x[:n], -x[n:]
        y = np.concatenate([q, qd, lam, np.zeros(len(self.holonomic))])
        yp = np.concatenate([qd, qdd, np.zeros(len(rows) + len(self.holonomic))])
        return y, yp

    def _full(self, values: np.ndarray, rows: np.ndarray) -> np.ndarray:
        """A vector over every constraint row, ``values`` on ``rows``, 0 elsewhere."""
        out = np.zeros(self.num.m)
        out[rows] = values
        return out

    def residual(self, t: float, y: np.ndarray, yp: np.ndarray) -> np.ndarray:
        """``[F1, F2, F3, F4]`` (see the module).

        Parameters
        ----------
        t, y, yp
            The time, ``y = [q, v, lambda, mu]`` and its derivative.
        """
        num, rows, hol = self.num, self.rows, self.holonomic
        n, m, pattern = num.n, num.m, num.pattern
        q, v, lam, mu = self.split(y)
        qp, vp = yp[:n], yp[n:2 * n]
        Mv, f, Av, _ = num.kkt_sparse(t, q, v)
        _, b = num.velocity_sparse(t, q)
        psi = num.position_constraint(t, q)
        Ar, Ac = pattern.A_rows, pattern.A_cols

        def transposed(weights: np.ndarray) -> np.ndarray:  # A^T weights
            return np.bincount(Ac, Av * weights[Ar], minlength=n)

        Mvp = np.bincount(pattern.M_rows, Mv * vp[pattern.M_cols], minlength=n)
        Av_v = np.bincount(Ar, Av * v[Ac], minlength=m)
        return np.concatenate([qp - v + transposed(self._full(mu, hol)),
                               Mvp - f - transposed(self._full(lam, rows)),
                               Av_v[rows] + b[rows], psi[self._psi_entries]])

    def newton_entries(self, t: float, y: np.ndarray, yp: np.ndarray, cj: float
                       ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``dF/dy + cj dF/dy'`` as entries ``(rows, columns, values)``, exact; an entry
        may come more than once (the values add). The rows and columns are the same at
        every call (the generated functions' patterns).

        Parameters
        ----------
        t, y, yp
            As in :meth:`residual`.
        cj
            The solver's coefficient of ``dF/dy'``.
        """
        num, rows, hol = self.num, self.rows, self.holonomic
        n, k, pattern = num.n, len(rows), num.pattern
        q, v, lam, mu = self.split(y)
        vp = yp[n:2 * n]
        Mv, _, Av, _ = num.kkt_sparse(t, q, v)
        residual = num.residual_jacobians(t, q, v, vp, self._full(lam, rows))
        r1_q, r1_qd = residual.r1_q, residual.r1_qd
        generated = num.compiled.functions["ggl_jacobians"]
        velocity_q, force_q = generated.layout.blocks
        ggl = generated.layout.split(num.evaluate("ggl_jacobians", t, q, v,
                                                  self._full(mu, hol)))
        # where each constraint row sits among lambda's and mu's entries (-1: not there)
        row_at, hol_at = np.full(num.m, -1), np.full(num.m, -1)
        row_at[rows], hol_at[hol] = np.arange(k), np.arange(len(hol))
        Ar, Ac = pattern.A_rows, pattern.A_cols
        in_rows, in_hol = row_at[Ar] >= 0, hol_at[Ar] >= 0
        vq_rows = row_at[velocity_q.index[0]]
        V, L, U, R3, R4 = n, 2 * n, 2 * n + k, 2 * n, 2 * n + k
        diagonal = np.arange(n)
        parts = [
            (force_q.index[0], force_q.index[1], ggl[1]),             # F1 by q
            (diagonal, diagonal, np.full(n, cj)),
            (diagonal, V + diagonal, np.full(n, -1.0)),               # F1 by v
            (Ac[in_hol], U + hol_at[Ar[in_hol]], Av[in_hol]),         # F1 by mu
            (n + r1_q.rows, r1_q.cols, r1_q.values),                  # F2 by q
            (n + r1_qd.rows, V + r1_qd.cols, r1_qd.values),           # F2 by v
            (n + pattern.M_rows, V + pattern.M_cols, cj * Mv),
            (n + Ac[in_rows], L + row_at[Ar[in_rows]], -Av[in_rows]),  # F2 by lambda
            (R3 + vq_rows[vq_rows >= 0], velocity_q.index[1][vq_rows >= 0],
             ggl[0][vq_rows >= 0]),                                    # F3 by q
            (R3 + row_at[Ar[in_rows]], V + Ac[in_rows], Av[in_rows]),  # F3 by v
            (R4 + hol_at[Ar[in_hol]], Ac[in_hol], Av[in_hol]),         # F4 by q
        ]
        return tuple(np.concatenate([np.asarray(part[i], dtype=dtype) for part in parts])
                     for i, dtype in ((0, np.intp), (1, np.intp), (2, float)))  # type: ignore[return-value]

    def newton_matrix(self, t: float, y: np.ndarray, yp: np.ndarray, cj: float
                      ) -> np.ndarray:
        """``dF/dy + cj dF/dy'`` dense (``N x N``), exact (:meth:`newton_entries`).

        Parameters
        ----------
        t, y, yp, cj
            As in :meth:`newton_entries`.
        """
        i, j, values = self.newton_entries(t, y, yp, cj)
        J = np.zeros((self.size, self.size))
        np.add.at(J, (i, j), values)
        return J


@dataclass(frozen=True)
class CompressedColumns:
    """The Newton matrix's fixed pattern in compressed-column order (what a sparse LU
    such as SuperLU takes), and its values there from :meth:`GGLForm.newton_entries`.

    Parameters
    ----------
    form
        The GGL form.
    t, y, yp
        Any state (only the positions of the entries are read: they are the same at
        every state).

    Examples
    --------
    >>> from dalembert.examples import cartesian_pendulum
    >>> form = GGLForm(cartesian_pendulum.build().numeric())
    >>> y, yp = form.start(0.0, np.array([0.6, -0.8]), np.array([0.8, 0.6]))
    >>> columns = CompressedColumns.of(form, 0.0, y, yp)
    >>> dense = form.newton_matrix(0.0, y, yp, 2.0)
    >>> bool(np.array_equal(columns.dense(columns.values(form, 0.0, y, yp, 2.0)), dense))
    True
    """

    size: int
    rows: np.ndarray
    cols: np.ndarray
    #: For each entry of :meth:`GGLForm.newton_entries`, its place among the values.
    place: np.ndarray = field(repr=False)

    @classmethod
    def of(cls, form: GGLForm, t: float, y: np.ndarray, yp: np.ndarray
           ) -> CompressedColumns:
        """The pattern of ``form``'s Newton matrix (every entry that can be nonzero)."""
        i, j, _ = form.newton_entries(t, y, yp, 1.0)
        keys, place = np.unique(j * form.size + i, return_inverse=True)
        return cls(form.size, keys % form.size, keys // form.size, place.ravel())

    def pattern(self) -> np.ndarray:
        """The pattern as a dense 0/1 matrix."""
        out = np.zeros((self.size, self.size), dtype=np.int8)
        out[self.rows, self.cols] = 1
        return out

    def values(self, form: GGLForm, t: float, y: np.ndarray, yp: np.ndarray, cj: float
               ) -> np.ndarray:
        """The matrix's values in compressed-column order."""
        _, _, entries = form.newton_entries(t, y, yp, cj)
        return np.bincount(self.place, entries, minlength=len(self.rows))

    def dense(self, values: np.ndarray) -> np.ndarray:
        """The matrix from its values (for checks)."""
        out = np.zeros((self.size, self.size))
        out[self.rows, self.cols] = values
        return out
