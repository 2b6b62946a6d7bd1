"""KKT solves with the near dependencies of the constraint rows left out, in band form.

Near a singular configuration some combinations ``V`` of the (unit-length) rows of
``A`` are nearly dependent (:mod:`dalembert.numerics.gram`). The careful steps
(:mod:`~dalembert.solvers.singular.careful`) enforce every other combination and
leave those out: with
``P = I - V V^T``,

    M x = f + A^T lambda,     P (A x - c) = 0,     V^T lambda = 0,

the rank-revealing, minimum-norm treatment of dependent rows, for a moment. Written
with the left-out combinations' own unknowns ``s``, it is the bordered system

    [ M   A^T   0 ] [  x      ]   [ f ]
    [ A   0     V ] [ -lambda ] = [ c ]
    [ 0   V^T   0 ] [  s      ]   [ 0 ]

whose matrix is regular where the KKT matrix alone is nearly singular. It is solved
by block elimination on the band LU (:class:`~.factorization.BandLU`, linear in the
mechanism) of the *regularized* KKT matrix ``[[M, A^T], [A, -eps I]]``, which stays
regular however the rows depend on each other, and refined on the bordered system
itself (its residual computed without the shift): each iteration removes the shift's
effect on a kept combination of squared singular value ``sigma^2`` by the factor
``eps / (sigma^2 + eps)`` (the proximal, augmented Lagrangian iteration of Bayo and
Ledesma's formulation, seen from the multipliers) and the rounding of the
elimination, which is large where ``eps`` is tiny, alike. With ``eps`` at
:data:`SHIFT` of the largest and every kept combination's ``sigma^2`` above
``TRUNCATE**2`` of it (:mod:`dalembert.numerics.singular`), :data:`PROXIMAL`
iterations reach rounding.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from scipy.linalg import lu_factor, lu_solve

from ...codegen.compiled import SparsePattern
from .factorization import BandLU
from .sparse import matvec

#: The regularization of the KKT matrix, relative to the largest eigenvalue of
#: ``A M^-1 A^T`` (rows scaled to unit length; ``M`` by its mean diagonal).
SHIFT = 1e-12
#: Refinement iterations removing the regularization and the elimination's rounding:
#: ``(SHIFT / TRUNCATE**2)**4`` is below rounding.
PROXIMAL = 4

#: ``solve(top, bottom) -> (x, lambda)``.
Solve = Callable[[np.ndarray, np.ndarray], tuple[np.ndarray, np.ndarray]]


class TruncatedKKT:
    """The truncated KKT solve (module docstring) for the rows ``rows`` of a pattern.

    Parameters
    ----------
    pattern
        The model's sparsity pattern.
    rows
        The constraint rows taken, in this order (a row of the solve is ``rows[k]``).
    unit_mass
        ``M = I`` (the projection of positions: minimum-norm steps) instead of the
        model's mass matrix.

    Examples
    --------
    A particle in the plane on two lines at an angle of 1e-9: the near dependency
    (their difference) left out, it stops on their mean direction's normal only.

    >>> pattern = SparsePattern(2, 2, np.array([0, 1]), np.array([0, 1]),
    ...                         np.array([0, 1, 1]), np.array([1, 0, 1]))
    >>> solver = TruncatedKKT(pattern, np.arange(2))
    >>> A = np.array([1.0, 1e-9, 1.0])             # rows (0, 1) and (1e-9, 1)
    >>> V = np.array([[1.0], [-1.0]]) / np.sqrt(2)   # their difference
    >>> solve = solver.factor(np.ones(2), A, np.ones(2), V, 2.0)
    >>> x, lam = solve(np.array([0.0, -1.0]), np.zeros(2))   # gravity along -y
    >>> bool(np.allclose(x, 0.0, atol=1e-8)), bool(np.allclose(lam, 0.5))
    (True, True)
    """

    def __init__(self, pattern: SparsePattern, rows: np.ndarray, unit_mass: bool = False) -> None:
        n = pattern.n
        self.n = n
        rows = np.asarray(rows, dtype=np.intp)
        self.size = len(rows)
        place = np.full(pattern.m, -1)
        place[rows] = np.arange(self.size)
        self._entries = np.flatnonzero(place[pattern.A_rows] >= 0)
        self._a_row = place[pattern.A_rows[self._entries]]
        a_col = self._a_col = pattern.A_cols[self._entries]
        if unit_mass:
            m_rows = m_cols = np.arange(n)
        else:
            m_rows, m_cols = pattern.M_rows, pattern.M_cols
        n_m, n_a = len(m_rows), len(self._entries)
        diagonal = n + np.arange(self.size)
        entry_rows = np.concatenate([m_rows, a_col, n + self._a_row, diagonal])
        entry_cols = np.concatenate([m_cols, n + self._a_row, a_col, diagonal])
        src = np.concatenate([np.arange(n_m), n_m + np.arange(n_a), n_m + np.arange(n_a),
                              n_m + n_a + np.arange(self.size)])
        self._band = BandLU(entry_rows.astype(np.intp), entry_cols.astype(np.intp), src,
                            n + self.size)
        self._unit = np.ones(n) if unit_mass else None
        self._m_entries = (np.asarray(m_rows, dtype=np.intp), np.asarray(m_cols, dtype=np.intp))
        self._on_diagonal = np.flatnonzero(m_rows == m_cols)
        self._diagonal_row = np.asarray(m_rows)[self._on_diagonal]

    def transposed_product(self, Av: np.ndarray, scale: np.ndarray, V: np.ndarray) -> np.ndarray:
        """``(D A)^T V`` for the rows of the solve scaled by ``scale`` (``D``), ``V`` by
        row of the solve (columns)."""
        a = np.asarray(Av, dtype=float)[self._entries] * scale[self._a_row]
        out = np.zeros((self.n, V.shape[1]))
        np.add.at(out, self._a_col, a[:, None] * V[self._a_row])
        return out

    def factor(self, Mv: np.ndarray | None, Av: np.ndarray, scale: np.ndarray,
               V: np.ndarray, largest: float) -> Solve:
        """The solve for ``M`` (values on the pattern; ignored with ``unit_mass``),
        ``A`` (all its values) with the rows scaled by ``scale`` (by row of the solve),
        the combinations ``V`` (columns, by row of the solve) left out.

        ``largest`` is the largest eigenvalue of the scaled rows' Gram matrix (sets
        the shift). ``solve(top, bottom)`` returns ``(x, lambda)``, the multipliers of
        the scaled rows, for the right-hand sides ``f`` and ``c`` (``c`` of the
        scaled rows). Raises :class:`~dalembert.errors.SingularSystemError` if the
        matrix cannot be factored (a coordinate without inertia).
        """
        n, size = self.n, self.size
        mass = self._unit if self._unit is not None else np.asarray(Mv, dtype=float)
        diagonal = np.bincount(self._diagonal_row, weights=mass[self._on_diagonal],
                               minlength=n)
        mass_scale = float(diagonal[diagonal > 0].mean()) if np.any(diagonal > 0) else 1.0
        eps = SHIFT * largest / mass_scale
        a = np.asarray(Av, dtype=float)[self._entries] * scale[self._a_row]
        solve_k = self._band.factor(np.concatenate([mass, a, np.full(size, -eps)]))
        k = V.shape[1]
        if k:
            border = np.zeros((n + size, k))
            border[n:] = V
            X = solve_k(border)
            capacitance = lu_factor(V.T @ X[n:])
        m_rows, m_cols = self._m_entries
        a_row, a_col = self._a_row, self._a_col

        def kkt_times(z: np.ndarray) -> np.ndarray:
            """``[[M, A^T], [A, 0]] z`` (``A`` of the scaled rows)."""
            q, y = z[:n], z[n:]
            return np.concatenate([
                matvec(m_rows, m_cols, mass, q, n) + matvec(a_col, a_row, a, y, n),
                matvec(a_row, a_col, a, q, size)])

        def correction(r: np.ndarray, r_border: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
            """The bordered system with the shifted matrix, by block elimination."""
            z = solve_k(r)
            if not k:
                return z, np.zeros(0)
            t = lu_solve(capacitance, V.T @ z[n:] - r_border)
            return z - X @ t, t

        def solve(top: np.ndarray, bottom: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
            rhs = np.concatenate([top, bottom])
            z, t = np.zeros(n + size), np.zeros(k)
            for _ in range(PROXIMAL):  # refinement on the unshifted bordered system
                r = rhs - kkt_times(z)
                if k:
                    r[n:] -= V @ t
                dz, dt = correction(r, -(V.T @ z[n:]) if k else np.zeros(0))
                z, t = z + dz, t + dt
            return z[:n], -z[n:]

        return solve
