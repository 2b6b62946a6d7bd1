"""Numeric solution of the stationarity equations ``grad Phi + J^T lambda = 0, psi = 0``.

Newton's method with the exact KKT matrix and a backtracking line search on the
residual norm; if it fails, :func:`scipy.optimize.root` (``hybr``, then ``lm``)
from the same start, polished by Newton. When every attempt fails the error says
what was tried, and names dependent or nearly tangent constraints if the search
ended (nearly) on the constraint set.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass

import numpy as np
import scipy.optimize

from ..errors import ExtremumConvergenceError
from ..numerics.least_squares import min_norm_solve
from .classification import dependent_constraints, raise_if_dependent
from .problem import Array, KKTFunction, Problem, all_finite, max_abs, point_text

_EPS = float(np.finfo(float).eps)
#: Relative cut of singular values in a Newton step: LAPACK's default for small
#: systems (``eps * max(shape)``), the sparse solve's regularization for large ones.
NEWTON_RCOND: float | None = None


@dataclass(frozen=True)
class Attempt:
    """Outcome of one search: the last iterate ``z = (x, lambda)`` and how it ended."""

    z: Array
    residual: float
    iterations: int
    converged: bool
    label: str  # how the point was found, reported as Extremum.method
    note: str = ""  # why the search stopped, if it failed


def check_settings(tol: float, max_iter: int) -> None:
    """Raise ``ValueError`` unless ``tol > 0`` is finite and ``max_iter`` a positive int."""
    if not (math.isfinite(tol) and tol > 0):
        raise ValueError(f"tol must be a positive finite number, got {tol!r}")
    if isinstance(max_iter, bool) or not isinstance(max_iter, int) or max_iter < 1:
        raise ValueError(f"max_iter must be a positive integer, got {max_iter!r}")


def solve(problem: Problem, z0: Array, tol: float, max_iter: int) -> Attempt:
    """A converged attempt from ``z0``: Newton, else root-finding then Newton.

    Raises
    ------
    DependentConstraintsError
        The best attempt is nearly feasible where the constraint gradients are
        dependent.
    ExtremumConvergenceError
        No attempt converged.
    """
    first = newton_iterations(problem.kkt, z0, tol, max_iter, "newton")
    if first.converged:
        return first
    attempts = [first]
    for method in ("hybr", "lm"):
        attempt = root_then_newton(problem.kkt, z0, tol, max_iter, method)
        if attempt.converged:
            total = first.iterations + attempt.iterations
            return Attempt(attempt.z, attempt.residual, total, True, attempt.label)
        attempts.append(attempt)
    best = min(attempts, key=lambda a: a.residual)
    _raise_if_dependent_near_feasible(problem, best.z, tol)
    message = _convergence_message(problem, z0, attempts, tol, max_iter)
    raise ExtremumConvergenceError(message + _tangency_hint(problem, best.z))


def _accepted(residual: Array, matrix: Array, z: Array, tol: float) -> bool:
    """Each equation is below ``tol`` or below the rounding level of its own terms."""
    rounding = 64 * _EPS * (np.abs(matrix) @ np.abs(z))
    return bool(np.all(np.abs(residual) <= np.maximum(tol, rounding)))


def newton_iterations(
    kkt: KKTFunction, z0: Array, tol: float, max_iter: int, label: str
) -> Attempt:
    z = np.array(z0, dtype=float)
    residual, matrix = kkt(z)
    if not all_finite(residual, matrix):
        return Attempt(z, math.inf, 0, False, label, "equations not finite at the start")
    for k in range(max_iter):
        if _accepted(residual, matrix, z, tol):
            return Attempt(z, max_abs(residual), k, True, label)
        # the minimum-norm step: the KKT matrix may be singular (see min_norm_solve)
        step = min_norm_solve(matrix, -residual, rcond=NEWTON_RCOND)
        found = _line_search(kkt, z, residual, step)
        if found is None:
            return Attempt(z, max_abs(residual), k, False, label, "residual stopped decreasing")
        z, residual, matrix = found
    converged = _accepted(residual, matrix, z, tol)
    return Attempt(z, max_abs(residual), max_iter, converged, label, "iteration limit reached")


def _line_search(
    kkt: KKTFunction, z: Array, residual: Array, step: Array
) -> tuple[Array, Array, Array] | None:
    """Halve the step until the residual norm decreases enough (Armijo, 30 halvings)."""
    norm = float(np.linalg.norm(residual))
    alpha = 1.0
    for _ in range(30):
        trial = z + alpha * step
        r, k = kkt(trial)
        if all_finite(r, k) and np.linalg.norm(r) <= (1 - 1e-4 * alpha) * norm:
            return trial, r, k
        alpha /= 2
    return None


def root_then_newton(
    kkt: KKTFunction, z0: Array, tol: float, max_iter: int, method: str
) -> Attempt:
    label = f"newton after scipy.optimize.root({method})"
    try:
        with warnings.catch_warnings(), np.errstate(all="ignore"):
            warnings.simplefilter("ignore", RuntimeWarning)
            solution = scipy.optimize.root(kkt, z0, jac=True, method=method)
    except (ValueError, ArithmeticError, np.linalg.LinAlgError) as exc:
        return Attempt(z0, math.inf, 0, False, label, f"scipy failed: {exc}")
    if not np.all(np.isfinite(solution.x)):
        return Attempt(z0, math.inf, 0, False, label, "scipy returned non-finite values")
    return newton_iterations(kkt, solution.x, tol, max_iter, label)


def _convergence_message(
    problem: Problem, z0: Array, attempts: list[Attempt], tol: float, max_iter: int
) -> str:
    first, *others = attempts
    tried = "; ".join(f"{a.label} reached residual {a.residual:.3g}" for a in others)
    return (
        f"no stationary point of the augmented function found near the guess "
        f"({point_text(problem, z0[: problem.n])}). Newton's method stopped after "
        f"{first.iterations} of at most {max_iter} iterations ({first.note}) with "
        f"residual {first.residual:.3g} > tol = {tol:g}; then {tried}. Try another "
        f"guess closer to the expected extremum, or check that the constraints can "
        f"be satisfied and that a stationary point exists."
    )


def _raise_if_dependent_near_feasible(problem: Problem, z: Array, tol: float) -> None:
    if not np.all(np.isfinite(z)):
        return
    residual, matrix = problem.kkt(z)
    n = problem.n
    if np.all(np.isfinite(matrix)) and max_abs(residual[n:]) <= math.sqrt(tol):
        context = "no stationary point found near the guess; "
        raise_if_dependent(problem, z[:n], matrix[n:, :n], context)


def _tangency_hint(problem: Problem, z: Array) -> str:
    """A note if the search ended nearly feasible where constraint gradients nearly align."""
    n = problem.n
    residual, matrix = problem.kkt(z)
    if not all_finite(residual, matrix):
        return ""
    if max_abs(residual[n:]) > 1e-3:
        return ""
    indices = dependent_constraints(matrix[n:, :n], rtol=1e-2)
    if not indices:
        return ""
    return (
        f" At the point reached ({point_text(problem, z[:n])}) the gradients of constraints "
        f"{', '.join(map(str, indices))} are nearly dependent: the constraints may be "
        "tangent there, where Lagrange multipliers need not exist."
    )
