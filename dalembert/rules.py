"""Declared parameters: each public callable's keywords in one table, bound to its signature.

A table maps every keyword-only parameter of a function to the forms its value may
take (:class:`Rule` objects: :class:`OneOf`, :class:`PositiveNumber`...).
:func:`checked_keywords` binds a table to a function: when the function is defined
(at import) it asserts that the table names exactly the function's keyword-only
parameters, and each default is an accepted form; when it is called it checks the
keywords given, once, with one message form naming the parameter, the value and
what is accepted (as scikit-learn's ``validate_params``).

>>> @checked_keywords({"tol": [PositiveNumber()]})
... def solve(x, *, tol=1e-9):
...     return x
>>> solve(1.0, tol=-1)
Traceback (most recent call last):
...
ValueError: The 'tol' parameter of solve must be a finite positive number; got -1.
"""

from __future__ import annotations

import functools
import inspect
import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any, Protocol, TypeVar

import numpy as np

#: The accepted forms of each keyword of one function.
Table = Mapping[str, Sequence["Rule"]]


class Rule(Protocol):
    """One accepted form of a value: ``accepts(value)`` and how to say it."""

    @property
    def description(self) -> str: ...

    def accepts(self, value: object) -> bool: ...


@dataclass(frozen=True)
class OneOf:
    choices: tuple

    @property
    def description(self) -> str:
        return "one of " + ", ".join(repr(c) for c in self.choices)

    def accepts(self, value: object) -> bool:
        return any(value is c or (c is not None and _same(value, c)) for c in self.choices)


def _same(value: object, choice: object) -> bool:
    try:
        return bool(value == choice) and type(value) is type(choice)
    except (TypeError, ValueError):
        return False


@dataclass(frozen=True)
class PositiveNumber:
    """A positive real number: finite, or also ``inf`` (a step limit)."""

    infinite: bool = False

    @property
    def description(self) -> str:
        return "a positive number (inf allowed)" if self.infinite else \
            "a finite positive number"

    def accepts(self, value: object) -> bool:
        if isinstance(value, bool) or not isinstance(value, (int, float, np.number)):
            return False
        v = float(value)
        return v > 0 and (math.isfinite(v) or (self.infinite and v == math.inf))


@dataclass(frozen=True)
class Tolerance:
    """A finite positive number, or an array of them (one per state component)."""

    description: str = "a finite positive number or an array of them"

    def accepts(self, value: object) -> bool:
        if isinstance(value, bool):
            return False
        try:
            array = np.asarray(value)
        except (TypeError, ValueError):
            return False
        if array.dtype.kind not in "iuf":  # strings, objects, booleans, complex
            return False
        return array.size > 0 and array.ndim <= 1 and bool(np.all(np.isfinite(array))
                                                           & np.all(array > 0))


@dataclass(frozen=True)
class Times:
    """A 1-D array of numbers (times; whether they are finite, ordered and inside
    ``t_span`` is checked with ``t_span``, which says where they are not)."""

    description: str = "a 1-D array of times"

    def accepts(self, value: object) -> bool:
        if isinstance(value, (str, bytes)):
            return False
        try:
            array = np.asarray(value)
        except (TypeError, ValueError):
            return False
        return array.ndim == 1 and (array.size == 0 or array.dtype.kind in "iuf")


@dataclass(frozen=True)
class Boolean:
    description: str = "True or False"

    def accepts(self, value: object) -> bool:
        return isinstance(value, (bool, np.bool_))


@dataclass(frozen=True)
class SolverClass:
    description: str = "a scipy.integrate.OdeSolver subclass"

    def accepts(self, value: object) -> bool:
        from scipy.integrate import OdeSolver  # not at import: a large import

        return isinstance(value, type) and issubclass(value, OdeSolver)


@dataclass(frozen=True)
class Callables:
    description: str = "a sequence of callables event(t, q, qd)"

    def accepts(self, value: object) -> bool:
        return (isinstance(value, Sequence) and not isinstance(value, (str, bytes))
                and all(callable(e) for e in value))


@dataclass(frozen=True)
class IsNone:
    description: str = "None"

    def accepts(self, value: object) -> bool:
        return value is None


NONE = IsNone()


@dataclass(frozen=True)
class PositiveInteger:
    description: str = "a positive whole number"

    def accepts(self, value: object) -> bool:
        return not isinstance(value, bool) and isinstance(value, (int, np.integer)) \
            and bool(value > 0)


@dataclass(frozen=True)
class FiniteNumber:
    description: str = "a finite number"

    def accepts(self, value: object) -> bool:
        if isinstance(value, bool) or not isinstance(value, (int, float, np.number)):
            return False
        return math.isfinite(float(value))


@dataclass(frozen=True)
class Items:
    """A sequence, not a string (names...; each item is checked where it is read)."""

    description: str = "a sequence"

    def accepts(self, value: object) -> bool:
        return isinstance(value, (Sequence, np.ndarray, set, frozenset)) \
            and not isinstance(value, (str, bytes))


@dataclass(frozen=True)
class Function:
    description: str = "a function"

    def accepts(self, value: object) -> bool:
        return callable(value)


@dataclass(frozen=True)
class CheckedWhereUsed:
    """Any value here: its form depends on the model or on other arguments, and the
    function that reads it says what is wrong (``description`` names that place)."""

    description: str

    def accepts(self, value: object) -> bool:
        return True


def check_parameters(values: Mapping[str, object], table: Table, caller: str,
                     error: type[Exception] = ValueError) -> None:
    """Raise one uniform error for the first value no rule of its entry accepts.

    Parameters
    ----------
    values
        The keyword arguments to check, by name (every name must be in ``table``).
    table
        The accepted forms of each keyword.
    caller
        The function's name, for the message.
    error
        The exception raised (a ``ValueError`` subclass for a subsystem's own errors).

    Examples
    --------
    >>> check_parameters({"backend": "gpu"}, {"backend": [OneOf(("c", "python"))]},
    ...                  "simulate")
    Traceback (most recent call last):
    ...
    ValueError: The 'backend' parameter of simulate must be one of 'c', 'python'; got 'gpu'.
    """
    for name, value in values.items():
        rules = table[name]
        if not any(rule.accepts(value) for rule in rules):
            forms = " or ".join(rule.description for rule in rules)
            raise error(f"The {name!r} parameter of {caller} must be {forms}; got {value!r}.")


_F = TypeVar("_F", bound=Callable[..., Any])


def checked_keywords(table: Table, *, caller: str | None = None,
                     error: type[Exception] = ValueError) -> Callable[[_F], _F]:
    """Bind ``table`` to a function's keyword-only parameters: checked against the
    signature when the function is defined, and against the arguments when it is called.

    The keywords a caller gives are checked before the function runs (a keyword left
    out takes its default, checked once, at definition). Positional parameters and
    ``**kwargs`` are not in the table: a function passes those on to a checked door
    of their own. The bound table is the function's ``parameter_table``, and the
    function without the check its ``unchecked`` (for a caller that has checked the
    same values already).

    Parameters
    ----------
    table
        The accepted forms of each keyword-only parameter, all of them and no other.
    caller
        The name the messages give (default: the function's name).
    error
        The exception a refused value raises (a ``ValueError`` subclass).

    Raises
    ------
    TypeError
        At definition: the table misses a keyword-only parameter, names one the
        function does not have, or refuses a default.

    Examples
    --------
    >>> checked_keywords({"tol": [PositiveNumber()]})(lambda x, *, rtol=1.0: x)
    ... # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    TypeError: the parameter table of <lambda> does not match its signature: no rule for rtol; ...
    """
    def bind(function: _F) -> _F:
        signature = inspect.signature(function)
        keywords = {p.name: p.default for p in signature.parameters.values()
                    if p.kind is inspect.Parameter.KEYWORD_ONLY}
        name = caller or function.__name__
        _check_table(function.__qualname__, table, keywords)
        rules = dict(table)

        @functools.wraps(function)
        def checked(*args: Any, **kwargs: Any) -> Any:
            try:  # a long array (a t_eval of 1e7 times) takes a while to check
                check_parameters({k: v for k, v in kwargs.items() if k in rules}, rules,
                                 name, error)
            except KeyboardInterrupt:
                raise KeyboardInterrupt(before_running(name)) from None
            return function(*args, **kwargs)

        checked.parameter_table = rules  # type: ignore[attr-defined]
        checked.unchecked = function  # type: ignore[attr-defined]
        return checked  # type: ignore[return-value]

    return bind


def before_running(name: str, doing: str = "its arguments were checked") -> str:
    """What a Ctrl-C landing in ``name`` before it ran anything says.

    Parameters
    ----------
    name
        The function (``simulate``...).
    doing
        What it was doing.

    Examples
    --------
    >>> before_running("simulate")
    'simulate was interrupted while its arguments were checked, before it ran: nothing was lost'
    """
    return f"{name} was interrupted while {doing}, before it ran: nothing was lost"


def unchecked(function: Callable[..., Any]) -> Callable[..., Any]:
    """The body of a function bound to a table by :func:`checked_keywords`, without the
    check: for a caller whose own door has checked the same keywords already.

    Parameters
    ----------
    function
        A function :func:`checked_keywords` returned.

    Examples
    --------
    >>> @checked_keywords({"tol": [PositiveNumber()]})
    ... def solve(x, *, tol=1e-9):
    ...     return tol
    >>> unchecked(solve)(0.0, tol=-1)
    -1
    """
    body: Callable[..., Any] = function.unchecked  # type: ignore[attr-defined]
    return body


def _check_table(where: str, table: Table, keywords: Mapping[str, object]) -> None:
    missing = [k for k in keywords if k not in table]
    extra = [k for k in table if k not in keywords]
    if missing or extra:
        parts = ([f"no rule for {', '.join(missing)}"] if missing else []) + \
            ([f"rules for {', '.join(extra)}, which is not a keyword-only parameter"]
             if extra else [])
        raise TypeError(f"the parameter table of {where} does not match its signature: "
                        + "; ".join(parts))
    for k, default in keywords.items():
        if default is not inspect.Parameter.empty and \
                not any(rule.accepts(default) for rule in table[k]):
            raise TypeError(f"the parameter table of {where} refuses the default of {k}, "
                            f"{default!r}")
