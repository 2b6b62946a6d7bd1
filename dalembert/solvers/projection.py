"""Projection of a state onto the constraint manifold (least change).

Positions: Gauss-Newton on ``psi(q, t) = 0`` with the minimum-norm step
``dq = -J^+ psi``, ``J = dpsi/dq`` restricted to the coordinates allowed to move.
Velocities: the linear projection onto ``A qd + b = 0``, again minimum norm.
Used for consistent initial values and, after every step, to remove drift.

Both least-squares solves cut singular values below ``RCOND`` times the largest:
with dependent constraints ``J`` has singular values at rounding level, and
LAPACK's default cut-off (``eps * max(shape)``) can keep them and divide rounding
noise by them.
"""

from __future__ import annotations

import numpy as np

from ..codegen.compiled import NumericModel
from ..errors import InitialConditionError

#: Target for the constraint residual. Where rounding keeps a constraint above it
#: (large coordinates), Newton stops once it no longer halves the residual.
POSITION_TOL = 1e-14
MAX_NEWTON = 50
#: A residual Newton cannot reduce further is accepted below this (rounding floor).
ACCEPT_TOL = 1e-10
#: Relative cut-off for singular values of the constraint Jacobian (see above).
RCOND = 1e-10


def project_positions(
    num: NumericModel, t: float, q: np.ndarray, free: np.ndarray | None = None
) -> np.ndarray:
    """Nearest ``q`` (over the ``free`` coordinates) with ``psi(q, t) = 0``.

    Raises :class:`InitialConditionError` when Newton does not converge.
    """
    rows = list(num.holonomic_rows)
    if not rows:
        return q
    q = np.array(q, dtype=float)
    cols = np.arange(num.n) if free is None else np.flatnonzero(free)
    scale = max(1.0, np.abs(q).max())
    residual = np.abs(num.position_constraint(t, q)).max()
    for _ in range(MAX_NEWTON):
        if residual <= POSITION_TOL:
            return q
        psi = num.position_constraint(t, q)
        J = num.velocity_constraint(t, q)[0][rows][:, cols]
        step = np.linalg.lstsq(J, psi, rcond=RCOND)[0]
        trial = q.copy()
        trial[cols] -= step
        new_residual = np.abs(num.position_constraint(t, trial)).max()
        if not new_residual < 0.5 * residual:
            break  # rounding floor reached (or divergence, judged below)
        q, residual = trial, new_residual
    if residual <= ACCEPT_TOL * scale:
        return q
    raise InitialConditionError(
        f"could not satisfy the holonomic constraints at t={t:g}: Newton (least change) "
        f"stalled with the largest residual {residual:.3e}"
    )


def project_velocities(
    num: NumericModel, t: float, q: np.ndarray, qd: np.ndarray, free: np.ndarray | None = None
) -> np.ndarray:
    """Nearest ``qd`` (over the ``free`` coordinates) with ``A qd + b = 0``."""
    if num.m == 0:
        return qd
    A, b = num.velocity_constraint(t, q)
    qd = np.array(qd, dtype=float)
    cols = np.arange(num.n) if free is None else np.flatnonzero(free)
    residual = A @ qd + b
    qd[cols] -= np.linalg.lstsq(A[:, cols], residual, rcond=RCOND)[0]
    return qd


def project_state(num: NumericModel, t: float, y: np.ndarray) -> np.ndarray:
    """Project a state ``y = [q, qd]`` onto the position and velocity constraints."""
    n = num.n
    q = project_positions(num, t, y[:n])
    return np.concatenate([q, project_velocities(num, t, q, y[n:])])
