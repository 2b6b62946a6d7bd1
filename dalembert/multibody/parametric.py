"""Numbers of a mechanism that may be parameters: a mass, a point, a length, gravity.

Every such number may be given as a float or as a SymPy expression of parameter
symbols (``m``, ``2 * l``). A float is checked when the piece is made (a mass must
be positive); an expression is kept, its symbols become parameters of the system,
and the same check runs on its value when parameter values are bound
(:meth:`dalembert.multibody.Multibody.bound`). Geometry and inertia may not depend
on the coordinates or the time; loads may (see :mod:`.loads`).

Pieces list their parametric attributes in ``PARAMETRIC`` (a scalar or an array of
numbers-or-expressions each), which is what the part-by-part code generation
(:mod:`.parts`) localizes, and what binding substitutes.
"""

from __future__ import annotations

import copy
from collections.abc import Iterable, Mapping, Sequence
from typing import Any, TypeAlias, TypeVar

import numpy as np
import sympy as sp
from sympy.core.function import AppliedUndef

from ..codegen.numpy_printer import expression_values
from ..errors import ModelError
from ..model.coordinates import t
from ..model.expressions import sympify_strict

#: A number or a SymPy expression of parameters.
Scalar: TypeAlias = "float | sp.Expr"
#: A 3-vector (or a 3x3 tensor): floats, or an object array holding expressions.
Array: TypeAlias = np.ndarray

P = TypeVar("P")


def scalar(value: object, what: str) -> Scalar:
    """``value`` as a float, or as an expression of parameter symbols.

    Parameters
    ----------
    value
        A number or a SymPy expression.
    what
        What it is, for the error (``"the mass of 'link'"``).

    Examples
    --------
    >>> scalar(2, "a mass"), scalar(sp.Symbol("m") * 2, "a mass")
    (2.0, 2*m)
    """
    expr = sympify_strict(value, what)
    if not isinstance(expr, sp.Expr):
        raise ModelError(f"{what} must be a number or a SymPy expression, got {value!r}")
    if expr.free_symbols:
        _check_free(expr, what)
        return expr
    try:
        number = float(expr)
    except TypeError as exc:
        raise ModelError(f"{what} must be a real number, got {value!r}") from exc
    if not np.isfinite(number):
        raise ModelError(f"{what} must be finite, got {number}")
    return number


def array(value: object, shape: tuple[int, ...], what: str) -> Array:
    """``value`` as an array of ``shape``: ``float`` when every entry is a number, else
    ``object`` holding floats and expressions.

    Parameters
    ----------
    value
        Nested numbers or expressions (a list, a tuple, a NumPy array, a Matrix).
    shape
        The expected shape, e.g. ``(3,)``.
    what
        What it is, for the error.

    Examples
    --------
    >>> array((0, 0, 1), (3,), "a point")
    array([0., 0., 1.])
    >>> array((0, 0, sp.Symbol("l")), (3,), "a point")
    array([0.0, 0.0, l], dtype=object)
    """
    if isinstance(value, sp.MatrixBase):
        value = value.tolist()
    try:
        raw = np.array(value, dtype=object)
    except (TypeError, ValueError) as exc:
        raise ModelError(f"{what} must be {_shape_text(shape)}, got {value!r}") from exc
    if raw.shape != shape:
        raise ModelError(f"{what} must be {_shape_text(shape)}, got {value!r}")
    entries = [scalar(v, what) for v in raw.ravel()]
    if all(isinstance(e, float) for e in entries):
        return np.array(entries, dtype=float).reshape(shape)
    out = np.empty(len(entries), dtype=object)
    out[:] = entries
    return out.reshape(shape)


def _shape_text(shape: tuple[int, ...]) -> str:
    return {(3,): "3 numbers or expressions", (3, 3): "a 3x3 tensor"}.get(
        shape, f"an array of shape {shape}")


def _check_free(expr: sp.Expr, what: str) -> None:
    """Geometry and inertia are parameters: no coordinate, velocity or time in them."""
    if t in expr.free_symbols or expr.atoms(AppliedUndef) or expr.atoms(sp.Derivative):
        raise ModelError(f"{what} is {expr}, which depends on the motion or the time; a "
                         "mass, an inertia or a geometric size may depend on parameters only")


def is_symbolic(value: object) -> bool:
    """Whether ``value`` (a scalar or an array) holds an expression."""
    if isinstance(value, np.ndarray):
        return value.dtype == object
    return isinstance(value, sp.Basic)


def symbols_of(value: object) -> set[sp.Symbol]:
    """The parameter symbols in ``value``."""
    if isinstance(value, np.ndarray) and value.dtype == object:
        return set().union(*(symbols_of(v) for v in value.ravel()))
    if isinstance(value, sp.Basic):
        return {s for s in value.free_symbols if isinstance(s, sp.Symbol)}
    return set()


def to_sympy(value: Scalar) -> sp.Expr:
    """A scalar for the equations: exact 0 and +-1 (their products vanish or disappear
    from the expressions), ``Float`` for other numbers."""
    if isinstance(value, sp.Basic):
        return value
    if value in (0.0, 1.0, -1.0):
        return sp.Integer(int(value))
    return sp.Float(value)


def sympy_vector(value: Array) -> sp.Matrix:
    """A 3-vector for the equations (see :func:`to_sympy`)."""
    return sp.Matrix([to_sympy(v) for v in value.ravel()])


def evaluate(value: Any, values: Mapping[sp.Symbol, float], what: str,
             memo: dict[sp.Basic, float] | None = None) -> Any:
    """``value`` with its symbols replaced by ``values`` (numbers stay as they are);
    ``memo`` remembers expressions already evaluated (pieces share them)."""
    if not is_symbolic(value):
        return value
    memo = {} if memo is None else memo
    if isinstance(value, np.ndarray):  # floats and expressions (see array())
        return np.array([evaluate(v, values, what, memo) if isinstance(v, sp.Basic) else v
                         for v in value.ravel().tolist()], dtype=float).reshape(value.shape)
    if not isinstance(value, sp.Basic):
        return value
    found = memo.get(value)
    if found is not None:
        return found
    number = value.xreplace({k: sp.Float(float(v)) for k, v in values.items()
                             if k in value.free_symbols})
    if number.free_symbols:
        names = ", ".join(sorted(s.name for s in number.free_symbols))
        raise ModelError(f"{what} needs a value for {names}")
    result = float(number)
    if not np.isfinite(result):
        raise ModelError(f"{what} is {result} with the given parameter values")
    memo[value] = result
    return result


def parametric_symbols(piece: object) -> set[sp.Symbol]:
    """The parameter symbols in a piece's ``PARAMETRIC`` attributes."""
    return set().union(*(symbols_of(getattr(piece, name))
                         for name in getattr(piece, "PARAMETRIC", ())))


def parametric_expressions(pieces: Iterable[object],
                           symbols: Iterable[sp.Symbol]) -> tuple[sp.Expr, ...]:
    """The distinct expressions of the pieces' parametric attributes written in
    ``symbols`` only (what :func:`evaluated_expressions` evaluates; a mechanism
    collects them once).

    Parameters
    ----------
    pieces
        Bodies, joints, loads... (their ``PARAMETRIC`` attributes are read).
    symbols
        The parameter symbols.

    Examples
    --------
    >>> from dalembert.multibody import Particle
    >>> m = sp.Symbol("m")
    >>> parametric_expressions([Particle("p", 2 * m), Particle("q", 2 * m)], [m])
    (2*m,)
    """
    known = set(symbols)
    found: dict[sp.Basic, None] = {}
    for piece in pieces:
        for name in getattr(piece, "PARAMETRIC", ()):
            value = getattr(piece, name)
            entries = value.ravel() if isinstance(value, np.ndarray) else (value,)
            found.update((e, None) for e in entries
                         if isinstance(e, sp.Expr) and e.free_symbols <= known)
    return tuple(found)


def evaluated_expressions(exprs: Sequence[sp.Expr],
                          values: Mapping[sp.Symbol, float]) -> dict[sp.Basic, float]:
    """The expressions ``exprs`` evaluated at ``values`` at once (one generated function
    per set of expressions, kept): the ``memo`` of :func:`with_numbers` for a whole
    mechanism, so that binding new values runs no SymPy. Values that are not finite
    are left out (:func:`evaluate` then names them).

    Parameters
    ----------
    exprs
        Expressions in the symbols of ``values`` (:func:`parametric_expressions`).
    values
        A number per parameter symbol.

    Examples
    --------
    >>> m = sp.Symbol("m")
    >>> evaluated_expressions([2 * m], {m: 1.5})
    {2*m: 3.0}
    """
    symbols = tuple(values)
    try:
        numbers = expression_values(symbols, tuple(exprs),
                                    np.array([values[s] for s in symbols]))
    except ModelError:  # a function NumPy code cannot print: SymPy evaluates them one by one
        return {}
    finite = np.isfinite(numbers).tolist()
    return {e: v for e, v, ok in zip(exprs, np.asarray(numbers, dtype=float).tolist(), finite)
            if ok}


def with_numbers(piece: P, values: Mapping[sp.Symbol, float],
                 memo: dict[sp.Basic, float] | None = None, check: bool = True) -> P:
    """A copy of ``piece`` with its parametric attributes evaluated (the piece itself
    when none is symbolic); the piece's ``check_values`` then checks them (unless
    ``check`` is false: the caller checks them, e.g. many bodies at once). ``memo``: as
    for :func:`evaluate`."""
    names = [n for n in getattr(piece, "PARAMETRIC", ()) if is_symbolic(getattr(piece, n))]
    if not names:
        return piece
    bound = copy.copy(piece)
    label = getattr(piece, "name", type(piece).__name__)
    for name in names:
        setattr(bound, name, evaluate(getattr(piece, name), values, f"{name} of {label!r}",
                                      memo))
    checks = getattr(bound, "check_values", None)
    if check and checks is not None:
        checks()
    return bound
