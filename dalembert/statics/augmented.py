"""The augmented function ``Phi + lambda^T psi`` symbolically, and its exact solutions.

:func:`stationarity_conditions` returns the stationarity equations themselves;
:func:`symbolic_points` solves them with :func:`sympy.solve` for
:func:`dalembert.statics.extremum.all_extrema`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import sympy as sp

from ..errors import SymbolicSolveError
from .classification import raise_if_dependent
from .inputs import multiplier_symbols, read_problem, taken_names
from .problem import Array, Problem, augmented_function


@dataclass(frozen=True)
class StationarityConditions:
    """The augmented function and its stationarity equations, symbolically.

    Attributes
    ----------
    objective : sympy.Expr
        ``Phi``.
    constraints : tuple of sympy.Expr
        ``psi_1 .. psi_m`` (``Eq(lhs, rhs)`` becomes ``lhs - rhs``).
    variables : tuple
        The variables as given (symbols or functions of time).
    multipliers : tuple of sympy.Symbol
        ``lambda_1 .. lambda_m``.
    augmented : sympy.Expr
        ``Phi + sum_k lambda_k psi_k``.
    equations : tuple of sympy.Eq
        ``d(augmented)/dx_i = 0`` for each variable, then ``psi_k = 0``.
    """

    objective: sp.Expr
    constraints: tuple[sp.Expr, ...]
    variables: tuple[sp.Basic, ...]
    multipliers: tuple[sp.Symbol, ...]
    augmented: sp.Expr
    equations: tuple[sp.Eq, ...]

    def latex(self) -> str:
        """LaTeX ``aligned`` block: the augmented function, then the equations."""
        n = len(self.variables)
        lines = [rf"\bar{{\Phi}} &= {sp.latex(self.augmented)}"]
        for v, eq in zip(self.variables, self.equations[:n], strict=True):
            lines.append(
                rf"\frac{{\partial \bar{{\Phi}}}}{{\partial {sp.latex(v)}}} &= "
                rf"{sp.latex(eq.lhs)} = 0"
            )
        for k, eq in enumerate(self.equations[n:], start=1):
            lines.append(rf"\psi_{{{k}}} &= {sp.latex(eq.lhs)} = 0")
        return "\\begin{aligned}\n" + " \\\\\n".join(lines) + "\n\\end{aligned}"

    def _repr_latex_(self) -> str:
        return f"$\\displaystyle {self.latex()}$"


def stationarity_conditions(
    phi: object, constraints: object, variables: object
) -> StationarityConditions:
    """Augmented function ``Phi + lambda^T psi`` and its stationarity equations.

    Parameters
    ----------
    phi : sympy.Expr
        The function ``Phi`` to extremize.
    constraints : sequence of sympy.Expr or sympy.Eq
        Constraints ``psi_k = 0``; ``Eq(lhs, rhs)`` means ``lhs - rhs = 0``.
    variables : sequence of sympy.Symbol or functions of time
        The unknowns ``x``; other free symbols stay symbolic.

    Returns
    -------
    StationarityConditions

    Examples
    --------
    >>> import sympy as sp
    >>> x, y = sp.symbols("x y")
    >>> sc = stationarity_conditions(x * y, [x**2 + y**2 - 1], [x, y])
    >>> sc.augmented
    lambda_1*(x**2 + y**2 - 1) + x*y
    >>> [eq.lhs for eq in sc.equations]
    [2*lambda_1*x + y, 2*lambda_1*y + x, x**2 + y**2 - 1]
    """
    originals, objective, psi = read_problem(phi, constraints, variables)
    multipliers = multiplier_symbols(len(psi), taken_names(objective, psi, originals))
    augmented = augmented_function(objective, psi, multipliers)
    gradient = [sp.diff(augmented, v) for v in originals]
    equations = tuple(sp.Eq(e, 0, evaluate=False) for e in (*gradient, *psi))
    return StationarityConditions(objective, psi, originals, multipliers, augmented, equations)


def symbolic_points(problem: Problem) -> list[Array]:
    """Every real solution ``z = (x, lambda)`` of the stationarity equations.

    Raises
    ------
    SymbolicSolveError
        The equations are not rational, ``sympy.solve`` fails, or the solutions
        are not isolated.
    DependentConstraintsError
        A continuum of multipliers at one point, from dependent constraint gradients.
    """
    unknowns = (*problem.unknowns, *problem.multipliers)
    _require_rational(problem.equations, unknowns)
    points = [_real_point(s, problem) for s in _symbolic_solutions(problem, unknowns)]
    return [z for z in points if z is not None]


def _require_rational(equations: tuple[sp.Expr, ...], unknowns: tuple[sp.Symbol, ...]) -> None:
    for eq in equations:
        if not eq.is_rational_function(*unknowns):
            raise SymbolicSolveError(
                f"all_extrema handles polynomial (or rational) problems only, and the "
                f"stationarity equation {eq} = 0 is not one (sympy.solve need not find all "
                "solutions of such equations); use extremum() with a guess near each point"
            )


def _symbolic_solutions(
    problem: Problem, unknowns: tuple[sp.Symbol, ...]
) -> list[dict[sp.Symbol, sp.Expr]]:
    try:
        return sp.solve(list(problem.equations), list(unknowns), dict=True)
    except (NotImplementedError, sp.PolynomialError) as exc:
        raise SymbolicSolveError(
            f"sympy.solve could not solve the stationarity equations ({exc}); "
            "use extremum() with a guess near each point"
        ) from exc


def _real_point(solution: dict[sp.Symbol, sp.Expr], problem: Problem) -> Array | None:
    """The solution as a float vector, None if complex; raise if not isolated."""
    unknowns = (*problem.unknowns, *problem.multipliers)
    undetermined = [
        u for u in unknowns if u not in solution or solution[u].free_symbols & set(unknowns)
    ]
    if undetermined:
        _raise_not_isolated(solution, problem, undetermined)
    values = [complex(sp.N(solution[u], 30)) for u in unknowns]
    if any(abs(v.imag) > 1e-10 * (1 + abs(v.real)) for v in values):
        return None
    return np.array([v.real for v in values])


def _raise_not_isolated(
    solution: dict[sp.Symbol, sp.Expr], problem: Problem, undetermined: list[sp.Symbol]
) -> None:
    # Only multipliers undetermined: a fixed x with dependent constraint gradients.
    if not set(undetermined) & set(problem.unknowns):
        x = np.array([complex(sp.N(solution[u])).real for u in problem.unknowns])
        _, matrix = problem.kkt(np.concatenate([x, np.zeros(len(problem.multipliers))]))
        raise_if_dependent(problem, x, matrix[problem.n :, : problem.n])
    names = dict(zip(problem.unknowns, problem.names, strict=True))
    listed = ", ".join(names.get(u, str(u)) for u in undetermined)
    raise SymbolicSolveError(
        f"the stationary points are not isolated: sympy.solve leaves {listed} undetermined "
        f"({solution}); all_extrema needs isolated points, use extremum() with a guess"
    )
