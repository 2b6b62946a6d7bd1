"""Constrained extrema by the method of Lagrange multipliers.

The problem

    extremize  Phi(x)   subject to   psi_k(x) = 0,   k = 1, ..., m,

with ``x`` the ``n`` variables, is replaced by the stationarity of the
*augmented function*

    Phi_bar(x, lambda) = Phi(x) + lambda^T psi(x),

whose gradient with respect to ``x`` and ``lambda`` gives ``n + m`` equations

    grad Phi(x) + J(x)^T lambda = 0,      psi(x) = 0,

where ``J = d psi / d x`` is the ``m x n`` constraint Jacobian.

Sign convention: the multipliers enter with a **plus** sign, so at a
constrained extremum ``grad Phi = -J^T lambda``. A constraint given as
``sympy.Eq(lhs, rhs)`` means ``psi = lhs - rhs``; flipping the sides of a
constraint flips the sign of its multiplier.

:func:`extremum` solves these equations numerically by Newton's method (exact
Jacobian from SymPy) from a guess, falling back to :func:`scipy.optimize.root`;
:func:`all_extrema` solves them symbolically for small polynomial problems;
:func:`stationarity_conditions` returns the equations themselves. Each point is
classified from the Hessian of the augmented function restricted to the tangent
space of the constraints, ``H_red = Z^T H Z`` with ``Z`` an orthonormal basis of
the null space of ``J``.

The work is split over this package: :mod:`.inputs` reads and checks the input,
:mod:`.problem` compiles the equations, :mod:`.guess` builds the starting point,
:mod:`.newton` solves numerically, :mod:`.augmented` symbolically, and
:mod:`.classification` checks the constraint rank and classifies the point. All
public names are importable from this module.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from .augmented import StationarityConditions, stationarity_conditions, symbolic_points
from .classification import KINDS, classify_point, raise_if_dependent
from .guess import starting_point
from .newton import check_settings, solve
from .problem import Array, Problem, max_abs, prepare

__all__ = [
    "KINDS",
    "Extremum",
    "StationarityConditions",
    "all_extrema",
    "extremum",
    "stationarity_conditions",
]


@dataclass(frozen=True, eq=False)
class Extremum:
    """A stationary point of ``Phi`` on the constraint set, with its classification.

    Attributes
    ----------
    x : numpy.ndarray
        Values of the variables, in the order they were given.
    multipliers : numpy.ndarray
        Lagrange multipliers ``lambda_1 .. lambda_m`` (``grad Phi = -J^T lambda``).
    kind : str
        One of :data:`KINDS`.
    value : float
        ``Phi(x)``.
    residual : float
        Largest absolute value of the stationarity equations at the point.
    reduced_hessian_eigenvalues : numpy.ndarray
        Ascending eigenvalues of ``Z^T H Z`` (``n - m`` of them).
    iterations : int
        Newton iterations used (0 for :func:`all_extrema`).
    variable_names : tuple of str
        Names of the variables, in order.
    method : str
        How the point was found: ``"newton"``, ``"newton after
        scipy.optimize.root(hybr)"`` (or ``lm``), or ``"symbolic"``.
    """

    x: Array
    multipliers: Array
    kind: str
    value: float
    residual: float
    reduced_hessian_eigenvalues: Array
    iterations: int
    variable_names: tuple[str, ...]
    method: str = "newton"

    def __post_init__(self) -> None:
        for name in ("x", "multipliers", "reduced_hessian_eigenvalues"):
            array = np.array(getattr(self, name), dtype=float)
            array.setflags(write=False)
            object.__setattr__(self, name, array)

    def by_name(self) -> dict[str, float]:
        """Map each variable name to its value."""
        return {name: float(v) for name, v in zip(self.variable_names, self.x, strict=True)}

    def multipliers_by_name(self) -> dict[str, float]:
        """Map ``"lambda_1"`` ... ``"lambda_m"`` to the multipliers."""
        return {f"lambda_{k + 1}": float(v) for k, v in enumerate(self.multipliers)}

    def __str__(self) -> str:
        point = ", ".join(f"{k} = {v:.12g}" for k, v in self.by_name().items())
        lambdas = ", ".join(f"{k} = {v:.12g}" for k, v in self.multipliers_by_name().items())
        eigenvalues = ", ".join(f"{v:.6g}" for v in self.reduced_hessian_eigenvalues)
        return (
            f"{self.kind} with value {self.value:.12g}\n"
            f"  at {point}\n"
            f"  multipliers: {lambdas or 'none'}\n"
            f"  reduced Hessian eigenvalues: {eigenvalues or 'none'}\n"
            f"  residual {self.residual:.3g} after {self.iterations} iterations ({self.method})"
        )


def extremum(
    phi: object,
    constraints: object,
    variables: object,
    guess: Mapping[object, float] | Sequence[float] | NDArray[np.floating] | None = None,
    *,
    parameters: Mapping[object, float] | None = None,
    tol: float = 1e-12,
    max_iter: int = 50,
) -> Extremum:
    """Find and classify a stationary point of ``Phi`` on ``psi(x) = 0`` near a guess.

    Newton's method is applied to ``grad Phi + J^T lambda = 0, psi = 0`` with the
    exact Jacobian (the KKT matrix ``[[H, J^T], [J, 0]]``, ``H`` the Hessian of the
    augmented function), a backtracking line search on the residual, and the
    initial multipliers from least squares at the guess. If Newton fails,
    :func:`scipy.optimize.root` (``hybr``, then ``lm``) is tried from the guess and
    its result polished by Newton.

    Parameters
    ----------
    phi : sympy.Expr
        The function ``Phi`` to extremize.
    constraints : sequence of sympy.Expr or sympy.Eq
        Constraints ``psi_k = 0``; ``Eq(lhs, rhs)`` means ``lhs - rhs = 0``.
        May be empty (unconstrained stationary point).
    variables : sequence of sympy.Symbol or functions of time
        The unknowns; functions of time such as ``dynamicsymbols("q")`` are
        treated as plain unknowns.
    guess : mapping or sequence of float, optional
        Starting point, keyed by variable (symbol, function or name) or in
        variable order. Variables not mentioned start at 1.0 (the default for
        all), which avoids the origin where many constraint gradients vanish.
    parameters : mapping, optional
        Numeric values of the other free symbols, keyed by symbol or name.
    tol : float
        Absolute tolerance on each stationarity residual. An equation whose terms
        are so large that ``tol`` is below its rounding error is accepted at
        ``64 eps sum_j |K_ij| |z_j|`` instead (``K`` the KKT matrix, ``z = (x,
        lambda)``); ``Extremum.residual`` reports what was reached.
    max_iter : int
        Maximum number of Newton iterations per attempt (Newton from the guess,
        then Newton after each ``scipy.optimize.root`` method).

    Returns
    -------
    Extremum

    Raises
    ------
    TooManyConstraintsError
        More constraints than variables.
    MissingParameterError
        A free symbol has no value in ``parameters``.
    GuessError
        The guess names an unknown variable, has the wrong length, or is not finite.
    DependentConstraintsError
        The constraint gradients are dependent at the point found.
    ExtremumConvergenceError
        No stationary point found near the guess.

    Examples
    --------
    >>> import sympy as sp
    >>> x, y = sp.symbols("x y")
    >>> e = extremum(x * y, [x**2 + y**2 - 1], [x, y], guess={"x": 0.8, "y": 0.6})
    >>> e.kind
    'maximum'
    >>> round(e.value, 12), round(float(e.multipliers[0]), 12)
    (0.5, -0.5)
    >>> {name: round(v, 6) for name, v in e.by_name().items()}
    {'x': 0.707107, 'y': 0.707107}
    """
    check_settings(tol, max_iter)
    problem = prepare(phi, constraints, variables, parameters)
    attempt = solve(problem, starting_point(guess, problem), tol, max_iter)
    return _make_extremum(problem, attempt.z, attempt.iterations, attempt.label)


def all_extrema(
    phi: object,
    constraints: object,
    variables: object,
    *,
    parameters: Mapping[object, float] | None = None,
) -> list[Extremum]:
    """All isolated real stationary points, found with :func:`sympy.solve`.

    Meant for small polynomial (or rational) problems; float parameter values
    are converted to exact rationals first. Points are sorted by ``x``. Points
    where the constraint gradients are dependent and no multipliers exist are not
    stationary points of the augmented function and are not found.

    Parameters
    ----------
    phi, constraints, variables, parameters
        As for :func:`extremum`.

    Returns
    -------
    list of Extremum
        Empty if there is no real stationary point.

    Raises
    ------
    SymbolicSolveError
        The equations are not rational, SymPy cannot solve them, or the
        stationary points form a continuum.
    DependentConstraintsError
        The constraint gradients are dependent at a stationary point.

    Examples
    --------
    >>> import sympy as sp
    >>> x, y = sp.symbols("x y")
    >>> [(e.kind, round(e.value, 12)) for e in all_extrema(x + y, [x**2 + y**2 - 2], [x, y])]
    [('minimum', -2.0), ('maximum', 2.0)]
    """
    problem = prepare(phi, constraints, variables, parameters, exact=True)
    extrema = [_make_extremum(problem, z, 0, "symbolic") for z in symbolic_points(problem)]
    return sorted(extrema, key=lambda e: tuple(e.x))


def _make_extremum(problem: Problem, z: Array, iterations: int, method: str) -> Extremum:
    """Check the constraint rank at ``z = (x, lambda)`` and classify the point."""
    n = problem.n
    residual, matrix = problem.kkt(z)
    x, hessian, jacobian = z[:n], matrix[:n, :n], matrix[n:, :n]
    raise_if_dependent(problem, x, jacobian)
    eigenvalues, kind = classify_point(hessian, jacobian)
    return Extremum(
        x=x,
        multipliers=z[n:],
        kind=kind,
        value=problem.objective(x),
        residual=max_abs(residual),
        reduced_hessian_eigenvalues=eigenvalues,
        iterations=iterations,
        variable_names=problem.names,
        method=method,
    )
