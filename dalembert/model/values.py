"""Values keyed by coordinate, as users give them: one reader, one default rule.

Initial positions and velocities, equilibrium guesses and linearization points
are all read here: a mapping from coordinate (a ``dynamicsymbols`` function, a
plain symbol or a name) to a number, or a sequence in coordinate order. A
coordinate a mapping leaves out is zero.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from ..errors import InitialConditionError, ModelError
from .coordinates import key_name
from .expressions import listed

#: What users pass for ``q0``, ``qd0``, a guess: by coordinate, in order, or nothing.
#: A mapping's keys are coordinates (SymPy, which has no types) or their names; its key
#: type is invariant, so ``Mapping[object, float]`` would refuse a ``dict[str, float]``.
CoordinateValues = Mapping[Any, float] | Sequence[float] | np.ndarray | None


def coordinate_values(values: CoordinateValues, names: Sequence[str], what: str) -> np.ndarray:
    """Read ``values`` into an array in coordinate order (missing coordinates: zero).

    Parameters
    ----------
    values
        A mapping by coordinate (or name), a sequence of ``len(names)`` numbers, or
        ``None`` (all zero).
    names
        The coordinate names, in order.
    what
        The argument's name for error messages (``"q0"``, ``"guess"``...).

    Raises :class:`~dalembert.errors.InitialConditionError` naming the coordinate
    that is unknown or not a finite number.

    >>> coordinate_values({"y": -1.0}, ("x", "y"), "q0")
    array([ 0., -1.])
    >>> coordinate_values({"x": 0.5, "y": -1.0}, ("x", "y"), "q0")
    array([ 0.5, -1. ])
    """
    n = len(names)
    if values is None:
        return np.zeros(n)
    if isinstance(values, Mapping):
        vec = np.zeros(n)
        rows = _rows(values, names)
        if rows is not None:  # every key a coordinate, every value a number: at once
            vec[rows[0]] = rows[1]
            values = {}
        position = {name: i for i, name in enumerate(names)} if values else {}
        for key, value in values.items():
            name = key_name(key)
            if name not in position:
                raise InitialConditionError(
                    f"{what} names {name!r}, which is not a coordinate "
                    f"(the coordinates are {', '.join(names)})"
                )
            vec[position[name]] = _number(value, f"{what}[{name!r}]")
    else:
        try:
            vec = np.asarray(values, dtype=float).ravel()
        except (TypeError, ValueError) as exc:
            raise InitialConditionError(f"{what} must be numbers, got {values!r}") from exc
        if vec.size != n:
            raise InitialConditionError(
                f"{what} has {vec.size} values for {n} coordinates ({', '.join(names)})"
            )
    bad = [names[int(i)] for i in np.flatnonzero(~np.isfinite(vec))]
    if bad:
        raise InitialConditionError(f"{what} is not finite for {', '.join(bad)}")
    return vec


def _rows(values: Mapping[Any, Any], names: Sequence[str]
          ) -> tuple[list[int] | slice, np.ndarray] | None:
    """The positions and numbers of ``values`` read at once, or ``None`` unless every
    key is a distinct coordinate and every value a finite number (the entry-by-entry
    reading then says what is wrong; NumPy reads ``None`` as NaN)."""
    # every name in order (as a mechanism's initial_state gives them): no key to look up
    keys: list[int] | None = None
    try:
        if tuple(values) != tuple(names):
            position = {name: i for i, name in enumerate(names)}
            keys = [position[key_name(key)] for key in values]
        numbers = np.array(list(values.values()), dtype=float)
    except (KeyError, ModelError, TypeError, ValueError):
        return None
    if (numbers.shape != (len(values),) or not np.isfinite(numbers).all()
            or (keys is not None and len(set(keys)) != len(keys))):
        return None
    return (slice(None) if keys is None else keys), numbers


def _number(value: object, what: str) -> float:
    try:
        return float(value)  # type: ignore[arg-type]
    except (TypeError, ValueError) as exc:
        raise InitialConditionError(f"{what} = {value!r} is not a number") from exc


def free_mask(fixed: Sequence[object] | None, names: Sequence[str]) -> np.ndarray:
    """Boolean mask of the coordinates a projection may change (all but ``fixed``).

    >>> free_mask(["x"], ("x", "y")).tolist()
    [False, True]
    """
    free = np.ones(len(names), dtype=bool)
    for key in listed(fixed or (), "fixed", "coordinates", InitialConditionError):
        name = key_name(key)
        if name not in names:
            raise InitialConditionError(f"fixed names {name!r}, which is not a coordinate")
        free[list(names).index(name)] = False
    return free
