"""Reading user expressions: SymPy objects and numbers only, never strings.

``sympy.sympify`` turns a string into an expression by evaluating it as Python
code (``parse_expr`` is an ``eval``, restricted namespace or not), so a string
given as an energy, a force or a constraint could run anything. dalembert
therefore reads expressions with ``sympify(..., strict=True)``, which accepts
SymPy objects and plain numbers only, and refuses a string with a message
saying how to build the expression instead.
"""

from __future__ import annotations

from collections.abc import Iterable

import sympy as sp

from ..errors import ModelError

#: How to build an expression without a string, for the messages.
BUILD_HINT = ("build it from SymPy objects, e.g. x, y = dalembert.coordinates('x y'); "
              "m, g = sympy.symbols('m g'); T = m / 2 * x.diff()**2")


def sympify_strict(value: object, what: str) -> sp.Basic:
    """``value`` as a SymPy object: SymPy objects and numbers pass, strings do not.

    Parameters
    ----------
    value
        A SymPy object or a number (int, float, NumPy scalar).
    what
        The input's name for the message (``"the kinetic energy"``).

    Raises :class:`~dalembert.errors.ModelError` for a string (SymPy would
    evaluate it as Python code) or anything else SymPy does not convert strictly.

    >>> sympify_strict(2.5, "the mass")
    2.50000000000000
    >>> sympify_strict("x**2", "the kinetic energy")  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    dalembert.errors.ModelError: the kinetic energy is the string 'x**2'; dalembert does not ...
    """
    if isinstance(value, (str, bytes)):
        raise ModelError(f"{what} is the string {_short(value)}; dalembert does not parse "
                         f"strings (SymPy would evaluate it as Python code): {BUILD_HINT}")
    try:
        return sp.sympify(value, strict=True)
    except (sp.SympifyError, TypeError, ValueError) as exc:
        raise ModelError(f"{what} is not a SymPy expression or a number: "
                         f"{_short(value)} ({type(value).__name__})") from exc


def sympify_checked(expr: object, what: str) -> sp.Expr:
    """A scalar SymPy expression (see :func:`sympify_strict`); a matrix is refused.

    >>> sympify_checked(sp.Matrix([1]), "the potential energy")  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    dalembert.errors.ModelError: the potential energy must be ... a 1 x 1 matrix: Matrix([[1]])
    """
    result = sympify_strict(expr, what)
    if isinstance(result, (sp.MatrixBase, sp.MatrixExpr)) or hasattr(result, "shape"):
        shape = " x ".join(str(d) for d in result.shape)
        raise ModelError(f"{what} must be a scalar SymPy expression, got a {shape} "
                         f"matrix: {_short(result)}")
    if not isinstance(result, sp.Expr):
        raise ModelError(f"{what} must be a scalar SymPy expression, got "
                         f"{type(result).__name__}: {_short(result)}")
    return result


def listed(values: object, argument: str, what: str,
           error: type[Exception] = ModelError) -> list[object]:
    """``list(values)`` for a sequence argument; anything else (a number, a string) is
    refused with ``error`` naming the argument and what it must hold.

    >>> listed(42, "coordinates", "coordinates")
    Traceback (most recent call last):
    ...
    dalembert.errors.ModelError: coordinates must be a sequence of coordinates, got 42
    """
    if isinstance(values, (str, bytes)) or not isinstance(values, Iterable):
        raise error(f"{argument} must be a sequence of {what}, got {_short(values)}")
    return list(values)


def _short(value: object) -> str:
    text = repr(value) if isinstance(value, (str, bytes)) else str(value)
    return text if len(text) <= 80 else text[:77] + "..."
