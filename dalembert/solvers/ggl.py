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
and ``d (A^T mu)/dq``, :mod:`dalembert.equations.ggl`). This first version builds the
matrix dense (``N = 2 n + rows``), which is what IDA's dense linear solver takes; a
band or sparse matrix for long chains is left for later.
"""

from __future__ import annotations

from dataclasses import dataclass

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
        q, v, lam, mu = self.split(y)
        qp, vp = yp[:num.n], yp[num.n:2 * num.n]
        M, f, A, _ = num.kkt_blocks(t, q, v)
        _, b = num.velocity_constraint(t, q)
        psi = num.position_constraint(t, q)
        return np.concatenate([qp - v + A[hol].T @ mu, M @ vp - f - A[rows].T @ lam,
                               A[rows] @ v + b[rows], psi[self._psi_entries]])

    def newton_matrix(self, t: float, y: np.ndarray, yp: np.ndarray, cj: float
                      ) -> np.ndarray:
        """``dF/dy + cj dF/dy'`` (dense, ``N x N``), exact.

        Parameters
        ----------
        t, y, yp
            As in :meth:`residual`.
        cj
            The solver's coefficient of ``dF/dy'``.
        """
        num, rows, hol = self.num, self.rows, self.holonomic
        n, k, h = num.n, len(rows), len(hol)
        q, v, lam, mu = self.split(y)
        vp = yp[n:2 * n]
        M, _, A, _ = num.kkt_blocks(t, q, v)
        r1_q, r1_qd, _, _ = num.residual_jacobians(t, q, v, vp, self._full(lam, rows)).dense()
        generated = num.compiled.functions["ggl_jacobians"]
        blocks = generated.layout.split(num.evaluate("ggl_jacobians", t, q, v,
                                                     self._full(mu, hol)))
        velocity_q, force_q = (pattern.dense(values) for pattern, values
                               in zip(generated.layout.blocks, blocks))
        J = np.zeros((self.size, self.size))
        lam_cols, mu_cols = slice(2 * n, 2 * n + k), slice(2 * n + k, 2 * n + k + h)
        J[:n, :n] = force_q + cj * np.eye(n)
        J[:n, n:2 * n] = -np.eye(n)
        J[:n, mu_cols] = A[hol].T
        J[n:2 * n, :n] = r1_q
        J[n:2 * n, n:2 * n] = r1_qd + cj * M
        J[n:2 * n, lam_cols] = -A[rows].T
        J[2 * n:2 * n + k, :n] = velocity_q[rows]
        J[2 * n:2 * n + k, n:2 * n] = A[rows]
        J[2 * n + k:, :n] = A[hol]
        return J
