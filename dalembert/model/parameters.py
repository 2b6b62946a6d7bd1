"""Numeric values of model parameters.

Parameters are the free SymPy symbols of a model other than time, positions and
velocities. Generated code takes them as one array, so changing a value never
regenerates code.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np
import sympy as sp

from ..errors import ParameterError
from .coordinates import key_name


def resolve_parameters(
    symbols: tuple[sp.Symbol, ...], *value_sets: Mapping[Any, object] | None
) -> np.ndarray:
    """Numeric values for ``symbols``, later value sets overriding earlier ones.

    >>> m, g = sp.symbols("m g")
    >>> resolve_parameters((g, m), {"m": 2.0}, {g: 9.81})
    array([9.81, 2.  ])
    """
    values: dict[str, float] = {}
    for value_set in value_sets:
        values.update(parameter_values(symbols, value_set))
    missing = [s.name for s in symbols if s.name not in values]
    if missing:
        raise ParameterError(
            f"no numeric value for parameter(s) {', '.join(missing)}; pass "
            f"parameters={{{', '.join(repr(m) + ': ...' for m in missing)}}}"
        )
    return np.array([values[s.name] for s in symbols], dtype=float)


def parameter_values(
    symbols: tuple[sp.Symbol, ...], value_set: Mapping[Any, object] | None
) -> dict[str, float]:
    """Check a user's parameter dict: known names, finite numbers. Keyed by name.

    >>> parameter_values((sp.Symbol("m"),), {"m": 2})
    {'m': 2.0}
    """
    names = {s.name for s in symbols}
    values: dict[str, float] = {}
    if value_set is not None and not isinstance(value_set, Mapping):
        raise ParameterError(
            f"parameters must be a dict {{symbol or name: number}}, got {value_set!r} "
            f"({type(value_set).__name__}); e.g. parameters={{'m': 1.0}}"
        )
    for key, value in (value_set or {}).items():
        name = key_name(key)
        if name not in names:
            known = ", ".join(sorted(names)) or "none"
            time = " ('t' is time, dalembert.t, never a parameter)" if name == "t" else ""
            raise ParameterError(
                f"{name!r} is not a parameter of this model (its parameters: {known}){time}"
            )
        values[name] = _finite_float(name, value)
    return values


def _finite_float(name: str, value: Any) -> float:
    try:
        number = float(value)
    except (TypeError, ValueError) as exc:
        raise ParameterError(f"parameter {name!r} = {value!r} is not a number") from exc
    if not np.isfinite(number):
        raise ParameterError(f"parameter {name!r} = {number} is not finite")
    return number
