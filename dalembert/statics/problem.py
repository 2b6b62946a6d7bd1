"""A constrained-extremum problem in plain symbols, with its compiled KKT function.

For ``Phi`` and constraints ``psi``, :func:`prepare` substitutes the parameter
values, builds the stationarity equations of the augmented function
``Phi + lambda^T psi`` and compiles ``z = (x, lambda) -> (residual, K)`` with
``K = [[H, J^T], [J, 0]]`` the exact Jacobian of the residual.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass

import numpy as np
import sympy as sp
from numpy.typing import NDArray

from ..codegen.numpy_printer import generate_function
from ..model.coordinates import key_name
from .inputs import (
    check_constraints_depend,
    check_fully_numeric,
    multiplier_symbols,
    parameter_values,
    read_problem,
)

Array = NDArray[np.float64]
KKTFunction = Callable[[Array], tuple[Array, Array]]


@dataclass(frozen=True)
class Problem:
    """The problem in plain symbols, with parameters substituted and code compiled."""

    variables: tuple[sp.Basic, ...]  # as given by the user
    names: tuple[str, ...]
    unknowns: tuple[sp.Symbol, ...]  # plain symbols standing for the variables
    multipliers: tuple[sp.Symbol, ...]
    constraint_text: tuple[str, ...]
    equations: tuple[sp.Expr, ...]  # gradient of the augmented function, then psi
    kkt: KKTFunction  # z -> (residual, KKT matrix)
    objective: Callable[[Array], float]

    @property
    def n(self) -> int:
        """Number of variables."""
        return len(self.unknowns)


def prepare(
    phi: object,
    constraints: object,
    variables: object,
    parameters: Mapping[object, float] | None,
    *,
    exact: bool = False,
) -> Problem:
    """Check the input, substitute ``parameters`` and compile the KKT function.

    With ``exact``, parameter values become exact rationals (for ``sympy.solve``).
    """
    originals, objective, psi = read_problem(phi, constraints, variables)
    names = tuple(key_name(v) for v in originals)
    # Functions of time become plain symbols: faster to differentiate and to print.
    unknowns = tuple(
        v if isinstance(v, sp.Symbol) else sp.Dummy(n)
        for v, n in zip(originals, names, strict=True)
    )
    swap = {o: u for o, u in zip(originals, unknowns, strict=True) if o is not u}
    objective, psi_plain = objective.xreplace(swap), tuple(p.xreplace(swap) for p in psi)
    check_constraints_depend(psi_plain, unknowns, psi)
    values = parameter_values(parameters, (objective, *psi_plain), unknowns, exact=exact)
    objective = objective.xreplace(values)
    psi_plain = tuple(p.xreplace(values) for p in psi_plain)
    check_fully_numeric((objective, *psi_plain), unknowns)
    multipliers = multiplier_symbols(len(psi), set(names))
    equations, kkt, obj = _compile(objective, psi_plain, unknowns, multipliers)
    text = tuple(str(p) for p in psi)
    return Problem(originals, names, unknowns, multipliers, text, equations, kkt, obj)


def augmented_function(
    objective: sp.Expr, psi: tuple[sp.Expr, ...], multipliers: tuple[sp.Symbol, ...]
) -> sp.Expr:
    """``Phi + sum_k lambda_k psi_k``."""
    return objective + sp.Add(*(lam * p for lam, p in zip(multipliers, psi, strict=True)))


def _compile(
    objective: sp.Expr,
    psi: tuple[sp.Expr, ...],
    unknowns: tuple[sp.Symbol, ...],
    multipliers: tuple[sp.Symbol, ...],
) -> tuple[tuple[sp.Expr, ...], KKTFunction, Callable[[Array], float]]:
    augmented = augmented_function(objective, psi, multipliers)
    residual = sp.Matrix([*(sp.diff(augmented, u) for u in unknowns), *psi])
    args = [*unknowns, *multipliers]
    matrix = residual.jacobian(args)
    # generate_function, not lambdify: it never prints a user's symbol names into code
    both = generate_function("kkt", [("z", args)], [("r", residual), ("K", matrix)],
                             vectors={"r"})
    value = generate_function("objective", [("x", unknowns)], [("phi", sp.Matrix([objective]))])
    size = len(args)

    def kkt(z: Array) -> tuple[Array, Array]:
        with np.errstate(all="ignore"):
            r, k = both(np.asarray(z, dtype=float))
        return np.asarray(r, dtype=float).reshape(size), np.asarray(k, dtype=float).reshape(
            size, size
        )

    def objective_at(x: Array) -> float:
        with np.errstate(all="ignore"):
            return float(value(np.asarray(x, dtype=float))[0][0])

    return tuple(residual), kkt, objective_at


def point_text(problem: Problem, x: Array) -> str:
    """``"x=0.5, y=1"``: the variables at ``x``, for error messages.

    A value under 1e-12 of the point's scale is rounding (a solver's 6.7e-16 where the
    answer is 0) and printed as 0.
    """
    floor = 1e-12 * max(1.0, max_abs(np.asarray(x, dtype=float)))
    return ", ".join(f"{n}={v if abs(v) > floor else 0.0:.6g}"
                     for n, v in zip(problem.names, x, strict=True))


def max_abs(values: Array) -> float:
    """Largest absolute entry, 0 for an empty array."""
    return float(np.max(np.abs(values))) if values.size else 0.0


def all_finite(*arrays: Array) -> bool:
    """Whether every entry of every array is finite."""
    return all(bool(np.all(np.isfinite(a))) for a in arrays)
