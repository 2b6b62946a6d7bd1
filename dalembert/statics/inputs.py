"""Reading and checking the user's input to the constrained-extremum functions.

Turns ``phi``, ``constraints``, ``variables`` and ``parameters`` into SymPy
expressions, with an error naming the offending item for each malformed input.
"""

from __future__ import annotations

import math
from collections.abc import Mapping

import sympy as sp
from sympy.core.function import AppliedUndef
from sympy.logic.boolalg import BooleanAtom

from ..errors import (
    ConstraintError,
    MissingParameterError,
    ModelError,
    ParameterError,
    TooManyConstraintsError,
)
from ..model.coordinates import key_name
from ..model.expressions import sympify_strict


def read_problem(
    phi: object, constraints: object, variables: object
) -> tuple[tuple[sp.Basic, ...], sp.Expr, tuple[sp.Expr, ...]]:
    """Checked variables, objective ``Phi`` and constraint expressions ``psi``.

    Raises
    ------
    ModelError
        Malformed variables or objective, or time derivatives anywhere.
    ConstraintError
        A constraint is neither an expression nor an ``Eq``, or is identically
        true or false.
    TooManyConstraintsError
        More constraints than variables.
    """
    variables = check_variables(variables)
    objective = _objective_expression(phi)
    psi = _constraint_expressions(constraints)
    _check_counts(len(psi), variables)
    _reject_derivatives(objective, psi)
    return variables, objective, psi


def check_variables(variables: object) -> tuple[sp.Basic, ...]:
    """The variables as SymPy symbols or functions of time, with distinct names."""
    single = isinstance(variables, sp.Basic)
    items = [variables] if single else list(variables)  # type: ignore[call-overload]
    found = tuple(sympify_strict(v, f"variable {k}") for k, v in enumerate(items))
    if not found:
        raise ModelError("no variables given; pass a list of SymPy symbols")
    for v in found:
        if not isinstance(v, (sp.Symbol, AppliedUndef)):
            raise ModelError(
                f"variable {v} is not a symbol or a function of time such as dynamicsymbols('q')"
            )
    names = [key_name(v) for v in found]
    repeated = sorted({n for n in names if names.count(n) > 1})
    if repeated:
        raise ModelError(f"variable name(s) {', '.join(repeated)} given more than once")
    return found


def _objective_expression(phi: object) -> sp.Expr:
    expr = sympify_strict(phi, "the function to extremize")
    if not isinstance(expr, sp.Expr):
        raise ModelError(f"the function to extremize must be a SymPy expression, got {phi!r}")
    return expr


def _constraint_expressions(constraints: object) -> tuple[sp.Expr, ...]:
    single = isinstance(constraints, (sp.Basic, bool))
    items = [constraints] if single else list(constraints)  # type: ignore[call-overload]
    return tuple(_as_expression(c, k) for k, c in enumerate(items))


def _as_expression(constraint: object, index: int) -> sp.Expr:
    c = sympify_strict(constraint, f"constraint {index}")
    if isinstance(c, BooleanAtom):
        raise ConstraintError(f"constraint {index} is identically {c}; remove it")
    if isinstance(c, sp.Equality):
        return c.lhs - c.rhs
    if not isinstance(c, sp.Expr):
        raise ConstraintError(
            f"constraint {index} ({c}) must be an expression psi (meaning psi = 0) or an Eq"
        )
    return c


def _check_counts(m: int, variables: tuple[sp.Basic, ...]) -> None:
    if m > len(variables):
        raise TooManyConstraintsError(
            f"{m} constraints but only {len(variables)} variables "
            f"({', '.join(key_name(v) for v in variables)}); at most "
            f"{len(variables)} independent constraints can hold at a point"
        )


def _reject_derivatives(objective: sp.Expr, psi: tuple[sp.Expr, ...]) -> None:
    for k, expr in enumerate((objective, *psi)):
        if expr.atoms(sp.Derivative):
            what = "the function to extremize" if k == 0 else f"constraint {k - 1}"
            raise ModelError(f"{what} contains time derivatives; statics needs positions only")


def check_constraints_depend(
    psi: tuple[sp.Expr, ...], unknowns: tuple[sp.Symbol, ...], original: tuple[sp.Expr, ...]
) -> None:
    """Raise :class:`ConstraintError` for a constraint free of every unknown."""
    for k, p in enumerate(psi):
        if not p.free_symbols & set(unknowns):
            raise ConstraintError(f"constraint {k} ({original[k]}) does not involve any variable")


def parameter_values(
    parameters: Mapping[object, float] | None,
    exprs: tuple[sp.Expr, ...],
    unknowns: tuple[sp.Symbol, ...],
    *,
    exact: bool,
) -> dict[sp.Symbol, sp.Expr]:
    """Map each free symbol of ``exprs`` named in ``parameters`` to its value.

    Values become ``sympy.Float``, or exact rationals (shortest decimal) if
    ``exact``. Raises :class:`ParameterError` for a key that is a variable, that
    does not appear, or whose value is not a finite number.
    """
    free = {s.name: s for e in exprs for s in e.free_symbols if s not in unknowns}
    variable_names = {u.name for u in unknowns}
    values: dict[sp.Symbol, sp.Expr] = {}
    for key, value in (parameters or {}).items():
        name = _parameter_name(key)
        if name in variable_names:
            raise ParameterError(f"{name!r} is a variable, not a parameter; remove it")
        if name not in free:
            known = ", ".join(sorted(free)) or "none"
            raise ParameterError(f"{name!r} does not appear in the problem (parameters: {known})")
        values[free[name]] = _number(name, value, exact=exact)
    return values


def _parameter_name(key: object) -> str:
    # key_name raises a plain ModelError; callers of this module expect ParameterError.
    try:
        return key_name(key)
    except ModelError as exc:
        raise ParameterError(f"{key!r} is not a parameter name or symbol") from exc


def _number(name: str, value: object, *, exact: bool) -> sp.Expr:
    try:
        number = float(value)  # type: ignore[arg-type]
    except (TypeError, ValueError) as exc:
        raise ParameterError(f"parameter {name!r} = {value!r} is not a number") from exc
    if not math.isfinite(number):
        raise ParameterError(f"parameter {name!r} = {number} is not finite")
    if not exact:
        return sp.Float(number)
    if isinstance(value, sp.Basic):
        return value
    return sp.Rational(repr(number))  # shortest decimal: 0.1 -> 1/10


def check_fully_numeric(exprs: tuple[sp.Expr, ...], unknowns: tuple[sp.Symbol, ...]) -> None:
    """Raise if ``exprs`` hold anything but ``unknowns`` and numbers.

    Raises :class:`ModelError` for an unknown function of time and
    :class:`MissingParameterError` for symbols without a value.
    """
    functions = sorted({str(f) for e in exprs for f in e.atoms(AppliedUndef)})
    if functions:
        raise ModelError(
            f"{', '.join(functions)} is neither a variable nor a parameter; add it to the variables"
        )
    missing = sorted({s.name for e in exprs for s in e.free_symbols if s not in unknowns})
    if missing:
        example = ", ".join(f"{m!r}: ..." for m in missing)
        raise MissingParameterError(
            f"no numeric value for symbol(s) {', '.join(missing)}; pass "
            f"parameters={{{example}}} or add them to the variables"
        )


def taken_names(
    objective: sp.Expr, psi: tuple[sp.Expr, ...], variables: tuple[sp.Basic, ...]
) -> set[str]:
    """Names of the free symbols and variables, which multipliers must not reuse."""
    symbols = {s.name for e in (objective, *psi) for s in e.free_symbols}
    return symbols | {key_name(v) for v in variables}


def multiplier_symbols(m: int, taken: set[str]) -> tuple[sp.Symbol, ...]:
    """``lambda_1 .. lambda_m``; a name already in ``taken`` becomes a ``Dummy``."""
    names = [f"lambda_{k}" for k in range(1, m + 1)]
    return tuple(sp.Dummy(n) if n in taken else sp.Symbol(n) for n in names)
