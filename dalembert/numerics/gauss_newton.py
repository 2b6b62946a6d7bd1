"""Least-change projection onto ``psi(q) = 0``: Gauss-Newton with minimum-norm steps.

The one routine behind every dense projection of positions onto holonomic
constraints: consistent initial values, the fallback of the per-step projector,
the start of a static equilibrium search. Each step is ``dq = -J^+ psi`` over the
coordinates allowed to move (``J = dpsi/dq``; :func:`~.least_squares.min_norm_solve`),
with singular values below :data:`~dalembert.numerics.rank.RANK_RTOL` times the
largest cut: with dependent constraints ``J`` has singular values at rounding level,
and LAPACK's default cut-off (``eps * max(shape)``) can keep them and divide rounding
noise by them.

Newton stops at :data:`POSITION_TOL` or once a step no longer halves the largest
residual (the rounding floor of large coordinates); the caller then judges the
result against :data:`ACCEPT_TOL` (relative to the coordinates' size) and raises
its own error, which knows what it was projecting. With ``line_search`` a step
that does not reduce ``|psi|`` is halved up to :data:`MAX_HALVINGS` times before
the iteration gives up (for starting points far from the constraints).

>>> import numpy as np
>>> circle = lambda q: np.array([q @ q - 1.0])
>>> gradient = lambda q: 2.0 * q[None, :]
>>> found = gauss_newton(circle, gradient, np.array([3.0, 4.0]))
>>> found.converged, np.round(found.q, 12).tolist()
(True, [0.6, 0.8])
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from .least_squares import min_norm_solve

#: Target for the largest constraint residual.
POSITION_TOL = 1e-14
#: A residual Newton cannot reduce further is accepted below this times ``max(1, |q|)``.
ACCEPT_TOL = 1e-10
MAX_NEWTON = 50
#: Halvings of a step in the line search before it counts as stalled.
MAX_HALVINGS = 30


@dataclass(frozen=True)
class Projected:
    """The end of a projection: ``q``, its largest residual and whether it is accepted."""

    q: np.ndarray
    residual: float
    converged: bool


def gauss_newton(
    psi: Callable[[np.ndarray], np.ndarray],
    jacobian: Callable[[np.ndarray], np.ndarray],
    q: np.ndarray,
    free: np.ndarray | None = None,
    *,
    line_search: bool = False,
    max_iter: int = MAX_NEWTON,
) -> Projected:
    """Project ``q`` onto ``psi(q) = 0`` moving only the ``free`` coordinates.

    Parameters
    ----------
    psi
        The constraint residuals at ``q`` (one per holonomic row).
    jacobian
        ``dpsi/dq`` at ``q``, one row per residual, one column per coordinate.
    q
        The starting point (not modified).
    free
        Boolean mask of the coordinates that may change (default: all).
    line_search
        Halve a step that does not reduce ``|psi|`` (2-norm) instead of stopping.
    max_iter
        Gauss-Newton iterations at most.

    Returns
    -------
    Projected
        ``converged`` is true when the residual reached the target, or stalled at
        most :data:`ACCEPT_TOL` times ``max(1, max|q|)``.
    """
    q = np.array(q, dtype=float)
    cols = np.arange(q.size) if free is None else np.flatnonzero(free)
    scale = max(1.0, float(np.abs(q).max(initial=0.0)))
    values = np.asarray(psi(q), dtype=float)
    residual = _largest(values)
    for _ in range(max_iter):
        if residual <= POSITION_TOL:
            break
        J = np.asarray(jacobian(q), dtype=float)[:, cols]
        step = min_norm_solve(J, values)
        found = _descend(psi, q, cols, step, values, residual, line_search)
        if found is None:
            break  # rounding floor reached (or divergence, judged below)
        q, values, residual = found
    return Projected(q, residual, residual <= max(POSITION_TOL, ACCEPT_TOL * scale))


def _descend(psi, q, cols, step, values, residual, line_search):
    """The next point: the full step if it halves the largest residual; with a line
    search, the first of the halved steps that reduces ``|psi|``; else ``None``."""
    norm = float(np.linalg.norm(values))
    alpha = 1.0
    for _ in range(MAX_HALVINGS if line_search else 1):
        trial = q.copy()
        trial[cols] -= alpha * step
        new = np.asarray(psi(trial), dtype=float)
        new_residual = _largest(new)
        if (line_search and np.linalg.norm(new) < norm) or new_residual < 0.5 * residual:
            return trial, new, new_residual
        alpha /= 2
    return None


def _largest(values: np.ndarray) -> float:
    """``max|values|``, infinite if any is not finite."""
    if not np.all(np.isfinite(values)):
        return float("inf")
    return float(np.abs(values).max(initial=0.0))
