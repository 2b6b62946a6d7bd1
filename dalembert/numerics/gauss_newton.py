"""Least-change projection onto ``psi(q) = 0``: Gauss-Newton with minimum-norm steps.

The one routine behind every dense projection of positions onto holonomic
constraints: consistent initial values, the fallback of the per-step projector,
the start of a static equilibrium search. Each step is ``dq = -J^+ psi`` over the
coordinates allowed to move (``J = dpsi/dq``; :func:`~.least_squares.min_norm_solve`),
with singular values below :data:`~dalembert.numerics.rank.RANK_RTOL` times the
largest cut: with dependent constraints ``J`` has singular values at rounding level,
and LAPACK's default cut-off (``eps * max(shape)``) can keep them and divide rounding
noise by them.

Newton stops at :data:`POSITION_TOL` or once a step makes no progress
(:func:`newton_progress`: near the rounding floor of large coordinates, a step must
halve the largest residual); the caller then judges the result against
:data:`ACCEPT_TOL` (relative to the coordinates' size) and raises its own error,
which knows what it was projecting. With ``line_search`` a step that makes no
progress far from the constraints is halved up to :data:`MAX_HALVINGS` times before
the iteration gives up (a full step from far off can overshoot a curved constraint).

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
        Halve a step that makes no progress, far from the constraints, instead of
        stopping.
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
        found = _descend(psi, q, cols, step, values, scale, line_search)
        if found is None:
            break  # rounding floor reached (or divergence, judged below)
        q, values, residual = found
    return Projected(q, residual, residual <= max(POSITION_TOL, ACCEPT_TOL * scale))


def newton_progress(new: np.ndarray, values: np.ndarray, scale: float) -> bool:
    """Whether a Newton step that took the residuals from ``values`` to ``new`` made
    progress: it halved the largest residual or, while that is above the acceptance
    level (:data:`ACCEPT_TOL` times ``scale``, far from rounding), reduced ``|psi|``.

    Far from the constraints a full step can gain less than half and still be on its
    way: a pendulum of length 2 started at distance 1 from its pivot goes from
    ``x^2 + y^2 - 4 = -3`` to ``2.25``, then converges quadratically. Near the rounding
    floor only halving counts, or the floor would never be detected.

    Parameters
    ----------
    new, values
        The residuals after and before the step.
    scale
        ``max(1, max|q|)``, the size of the coordinates.

    Examples
    --------
    >>> newton_progress(np.array([2.25]), np.array([-3.0]), 1.0)
    True
    >>> newton_progress(np.array([0.9e-11]), np.array([1e-11]), 1.0)
    False
    """
    residual, new_residual = _largest(values), _largest(new)
    if new_residual < 0.5 * residual:
        return True
    return bool(residual > ACCEPT_TOL * scale
                and np.linalg.norm(new) < np.linalg.norm(values))


def _descend(psi, q, cols, step, values, scale, line_search):
    """The next point: the full step if it makes progress (:func:`newton_progress`);
    with a line search and far from rounding, the first of the halved steps that
    does; else ``None``."""
    far = _largest(values) > ACCEPT_TOL * scale
    alpha = 1.0
    for _ in range(MAX_HALVINGS if line_search and far else 1):
        trial = q.copy()
        trial[cols] -= alpha * step
        new = np.asarray(psi(trial), dtype=float)
        if newton_progress(new, values, scale):
            return trial, new, _largest(new)
        alpha /= 2
    return None


def _largest(values: np.ndarray) -> float:
    """``max|values|``, infinite if any is not finite."""
    if not np.all(np.isfinite(values)):
        return float("inf")
    return float(np.abs(values).max(initial=0.0))
