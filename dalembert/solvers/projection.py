"""Projection of a state onto the constraint manifold (least change).

Positions: Gauss-Newton on ``psi(q, t) = 0`` with the minimum-norm step
``dq = -J^+ psi``, ``J = dpsi/dq`` restricted to the coordinates allowed to move.
Velocities: the linear projection onto ``A qd + b = 0``, again minimum norm.
Used for consistent initial values and, after every step, to remove drift.

After every step :class:`StepProjector` does the same in time linear in the size
of the mechanism: the minimum-norm step is the solution of the KKT system
``[[I, J^T], [J, 0]] [dq; nu] = [0; -psi]``, factored once per projection with
the sparse solver of the dynamics (:class:`~dalembert.solvers.kkt.sparse.KKTSolver`) and reused
for every Newton iteration (simplified Newton: the drift after one step is at
tolerance level, so each iteration gains ~10 digits and one or two reach the
rounding floor). Velocities are projected with ``A`` at the new positions. With
dependent constraints the same solves use the independent rows measured at the
start (``kept``; as the C loop does): where the rank is constant, the zero set of
the kept rows is that of all rows, and the dropped rows follow. If the fast path
fails, it falls back to the dense least-squares functions below (positions through
:func:`~dalembert.numerics.gauss_newton.gauss_newton`, which says why both cut
small singular values at :data:`~dalembert.numerics.rank.RANK_RTOL`).
"""

from __future__ import annotations

import numpy as np

from ..codegen.compiled import NumericModel, SparsePattern
from ..errors import InitialConditionError, SingularSystemError
from ..numerics.gauss_newton import (
    ACCEPT_TOL,
    MAX_NEWTON,
    POSITION_TOL,
    gauss_newton,
    newton_progress,
)
from ..numerics.rank import RANK_RTOL
from .kkt.sparse import kkt_solver, matvec
from .pattern_cache import PatternCache, read_only


def project_positions(
    num: NumericModel, t: float, q: np.ndarray, free: np.ndarray | None = None
) -> np.ndarray:
    """Nearest ``q`` (over the ``free`` coordinates) with ``psi(q, t) = 0``.

    Raises :class:`InitialConditionError` when Newton does not converge.
    """
    rows = list(num.holonomic_rows)
    if not rows:
        return q
    found = gauss_newton(lambda x: num.position_constraint(t, x),
                         lambda x: num.velocity_constraint(t, x)[0][rows], q, free,
                         line_search=True)  # initial values may be far off
    if found.converged:
        return found.q
    raise InitialConditionError(
        f"could not satisfy the holonomic constraints at t={t:g}: Newton (least change) "
        f"stalled with the largest residual {found.residual:.3e}"
    )


def project_velocities(
    num: NumericModel, t: float, q: np.ndarray, qd: np.ndarray, free: np.ndarray | None = None,
    rows: np.ndarray | None = None,
) -> np.ndarray:
    """Nearest ``qd`` (over the ``free`` coordinates) with ``A qd + b = 0`` (on the
    constraint ``rows`` only, if given: a contact run's bilateral ones)."""
    if num.m == 0 or (rows is not None and not len(rows)):
        return qd
    A, b = num.velocity_constraint(t, q)
    if rows is not None:
        A, b = A[rows], b[rows]
    qd = np.array(qd, dtype=float)
    cols = np.arange(num.n) if free is None else np.flatnonzero(free)
    residual = A @ qd + b
    qd[cols] -= np.linalg.lstsq(A[:, cols], residual, rcond=RANK_RTOL)[0]
    return qd


#: Simplified-Newton iterations of the fast position projection before falling back.
FAST_NEWTON = 4


def _unit_mass(pattern: SparsePattern, _: object) -> SparsePattern:
    """The pattern of a unit mass matrix and ``A`` (the projections' metric)."""
    diagonal = read_only(np.arange(pattern.n))
    return SparsePattern(pattern.n, pattern.m, diagonal, diagonal, pattern.A_rows,
                         pattern.A_cols)


#: Each pattern's unit-mass pattern.
_UNIT_MASS: PatternCache[SparsePattern] = PatternCache(_unit_mass, "unit-mass patterns")


class StepProjector:
    """``project(t, y)``: the state projected onto the constraints (see module docstring).

    Parameters
    ----------
    num
        The compiled equations bound to parameter values.
    kept
        The independent constraint rows when some are dependent (measured at the
        initial state), else ``None``: the projections solve with these rows.

    Examples
    --------
    >>> from dalembert.examples import cartesian_pendulum
    >>> num = cartesian_pendulum.build().numeric()
    >>> y = StepProjector(num)(0.0, np.array([0.1, -1.1, 1.0, 0.0]))
    >>> round(float(np.hypot(y[0], y[1])), 12), round(float(y[0] * y[2] + y[1] * y[3]), 12)
    (1.0, 0.0)
    """

    def __init__(self, num: NumericModel, kept: np.ndarray | None = None) -> None:
        self.num = num
        n, pat = num.n, num.pattern
        unit = _UNIT_MASS.get(pat)
        self._ones = np.ones(n)
        holonomic = np.array(num.holonomic_rows, dtype=np.intp)
        solved = np.ones(num.m, dtype=bool)
        if kept is not None:
            solved[:] = False
            solved[kept] = True
        self._rows = None if solved.all() else np.flatnonzero(solved)  # velocities
        self._psi = solved[holonomic]  # the entries of psi the position steps solve for
        self._velocity = kkt_solver(unit, self._rows)
        rows = holonomic[self._psi]
        self._position = kkt_solver(unit, None if len(rows) == num.m else rows)
        self._zeros = np.zeros(n)

    def __call__(self, t: float, y: np.ndarray) -> np.ndarray:
        layout = self.num.layout
        q, qd = layout.split(y)
        try:
            q = self.positions(t, q)
            return layout.join(q, self.velocities(t, q, qd))
        except (SingularSystemError, np.linalg.LinAlgError):
            pass
        q = project_positions(self.num, t, q)
        return layout.join(q, project_velocities(self.num, t, q, qd))

    def positions(self, t: float, q: np.ndarray, refactor: bool = False) -> np.ndarray:
        """Simplified Newton with one factorization; the dense path if it stalls.

        ``refactor`` makes it full Newton (a factorization per iteration, up to
        ``MAX_NEWTON``), for initial values that may be far from the constraints.
        """
        num = self.num
        if not num.holonomic_rows:
            return q
        psi = num.position_constraint(t, q)
        residual = np.abs(psi).max()
        if residual <= POSITION_TOL:
            return q
        solve = self._position.factor(self._ones, num.velocity_sparse(t, q)[0])
        for _ in range(MAX_NEWTON if refactor else FAST_NEWTON):
            if refactor:
                solve = self._position.factor(self._ones, num.velocity_sparse(t, q)[0])
            trial = q + solve(np.concatenate([self._zeros, -psi[self._psi]]))[: num.n]
            psi_trial = num.position_constraint(t, trial)
            new_residual = np.abs(psi_trial).max()
            # full Newton starts from initial values, maybe far: any progress counts
            progressed = (newton_progress(psi_trial, psi, max(1.0, np.abs(q).max()))
                          if refactor else new_residual < 0.5 * residual)
            if not progressed:
                break
            q, psi, residual = trial, psi_trial, new_residual
            if residual <= POSITION_TOL:
                return q
        if residual <= ACCEPT_TOL * max(1.0, np.abs(q).max()):
            return q
        return project_positions(num, t, q)

    def velocities(self, t: float, q: np.ndarray, qd: np.ndarray) -> np.ndarray:
        """Minimum-norm change of ``qd`` onto ``A qd + b = 0`` (``A`` at ``q``)."""
        num = self.num
        if num.m == 0:
            return qd
        Av, b = num.velocity_sparse(t, q)
        pat = num.pattern
        residual = matvec(pat.A_rows, pat.A_cols, Av, qd, num.m) + b
        if self._rows is not None:
            residual = residual[self._rows]
        step = self._velocity.factor(self._ones, Av)(np.concatenate([self._zeros, -residual]))
        return qd + step[: num.n]
