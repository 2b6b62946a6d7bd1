"""Numeric values of model parameters.

Parameters are the free SymPy symbols of a model other than time, positions and
velocities. Generated code takes them as one array, so changing a value never
regenerates code. A name that is not a parameter of the model is an error (a typo
would otherwise pass silently), unless the values are given as
``ParameterSet(values, strict=False)``: one dictionary for several variants of a
model, each taking the values it uses.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
import sympy as sp

from ..errors import ParameterError
from .coordinates import key_name


class ParameterSet(dict):
    """Parameter values by symbol or name, with how to treat names a model lacks.

    Parameters
    ----------
    values
        The values, by symbol or name.
    strict
        ``True`` (the default, as for a plain dict): a name that is not a parameter of
        the model is an error. ``False``: such names are ignored, so that one set
        serves several models.

    Examples
    --------
    >>> m, g, k = sp.symbols("m g k")
    >>> shared = ParameterSet({"m": 2.0, "g": 9.81, "k": 5.0}, strict=False)
    >>> parameter_values((m, g), shared)
    {'m': 2.0, 'g': 9.81}
    """

    def __init__(self, values: Mapping[Any, object] | None = None, *,
                 strict: bool = True) -> None:
        super().__init__(values or {})
        if not isinstance(strict, bool):
            raise ParameterError(f"strict must be True or False, got {strict!r}")
        self.strict = strict


def resolve_parameters(
    symbols: tuple[sp.Symbol, ...], *value_sets: Mapping[Any, object] | None,
    coordinates: Sequence[str] = (), inputs: Sequence[str] = (),
) -> np.ndarray:
    """Numeric values for ``symbols``, later value sets overriding earlier ones.

    Parameters
    ----------
    symbols
        The model's parameters, in the order of the array.
    value_sets
        Values by symbol or name (see :func:`parameter_values`).
    coordinates, inputs
        The model's coordinate and input names, for the message about a name given
        as a parameter that is one of them.

    Examples
    --------
    >>> m, g = sp.symbols("m g")
    >>> resolve_parameters((g, m), {"m": 2.0}, {g: 9.81})
    array([9.81, 2.  ])
    """
    values: dict[str, float] = {}
    for value_set in value_sets:
        values.update(parameter_values(symbols, value_set, coordinates=coordinates,
                                       inputs=inputs))
    missing = [s.name for s in symbols if s.name not in values]
    if missing:
        raise ParameterError(
            f"no numeric value for parameter(s) {', '.join(missing)}; pass "
            f"parameters={{{', '.join(repr(m) + ': ...' for m in missing)}}}"
        )
    return np.array([values[s.name] for s in symbols], dtype=float)


def parameter_values(
    symbols: tuple[sp.Symbol, ...], value_set: Mapping[Any, object] | None, *,
    coordinates: Sequence[str] = (), inputs: Sequence[str] = (),
) -> dict[str, float]:
    """Check a user's parameter dict: known names, finite numbers. Keyed by name.

    Parameters
    ----------
    symbols
        The model's parameters.
    value_set
        Values by symbol or name (a :class:`ParameterSet` says whether names the model
        lacks are errors).
    coordinates, inputs
        The model's coordinate and input names: a parameter named as one of them is
        told where its value goes instead (``q0``, ``inputs=``).

    Examples
    --------
    >>> parameter_values((sp.Symbol("m"),), {"m": 2})
    {'m': 2.0}
    >>> parameter_values((sp.Symbol("m"),), {"x": 0.5}, coordinates=("x", "y"))
    ... # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    dalembert.errors.ParameterError: 'x' is a coordinate of this model, not a parameter: ...
    """
    names = {s.name for s in symbols}
    values: dict[str, float] = {}
    if value_set is not None and not isinstance(value_set, Mapping):
        raise ParameterError(
            f"parameters must be a dict {{symbol or name: number}}, got {value_set!r} "
            f"({type(value_set).__name__}); e.g. parameters={{'m': 1.0}}"
        )
    strict = getattr(value_set, "strict", True)
    for key, value in (value_set or {}).items():
        name = key_name(key)
        if name not in names and not strict:
            continue
        if name not in names:
            known = ", ".join(sorted(names)) or "none"
            _raise_if_other_kind(name, known, coordinates, inputs)
            time = " ('t' is time, dalembert.t, never a parameter)" if name == "t" else ""
            raise ParameterError(
                f"{name!r} is not a parameter of this model (its parameters: {known}){time}; "
                "check the spelling, or, to share one dict among models that use different "
                "names, pass dalembert.ParameterSet(values, strict=False), which skips "
                "the names a model lacks"
            )
        values[name] = _finite_float(name, value)
    return values


def _raise_if_other_kind(name: str, known: str, coordinates: Sequence[str],
                         inputs: Sequence[str]) -> None:
    """A name given as a parameter that is a coordinate or an input: where it goes."""
    if name in coordinates:
        where = "a coordinate of this model, not a parameter: give its initial value in q0"
    elif name in inputs:
        where = ("an input of this model, not a parameter: give its values with inputs= "
                 "(simulate(inputs={...}))")
    else:
        return
    raise ParameterError(f"{name!r} is {where} (its parameters: {known})")


def _finite_float(name: str, value: Any) -> float:
    try:
        number = float(value)
    except (TypeError, ValueError) as exc:
        raise ParameterError(f"parameter {name!r} = {value!r} is not a number") from exc
    if not np.isfinite(number):
        raise ParameterError(f"parameter {name!r} = {number} is not finite")
    return number
