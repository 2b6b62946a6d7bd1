"""The starting point ``z0 = (x0, lambda0)`` of the numeric search for an extremum.

``x0`` comes from the user's guess (a mapping or a sequence, default 1.0 for
each variable); ``lambda0`` is the least-squares solution of
``J(x0)^T lambda = -grad Phi(x0)``.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping
from typing import Any

import numpy as np
import sympy as sp
from sympy.core.function import AppliedUndef

from ..errors import GuessError
from ..model.coordinates import key_name
from .problem import Array, Problem, all_finite, point_text


def starting_point(guess: object, problem: Problem) -> Array:
    """``(x0, lambda0)`` from the guess, with least-squares multipliers.

    Raises
    ------
    GuessError
        The guess names an unknown variable, has the wrong length, is not finite,
        or the function or constraints are not finite there.
    """
    x0 = _initial_point(guess, problem)
    return np.concatenate([x0, _least_squares_multipliers(problem, x0)])


def _initial_point(guess: object, problem: Problem) -> Array:
    if guess is None:
        return np.ones(problem.n)
    if isinstance(guess, Mapping):
        x0 = _guess_from_mapping(guess, problem)
    elif isinstance(guess, (str, bytes)) or not isinstance(guess, Iterable):
        raise GuessError(f"guess must be a mapping or a sequence of numbers, got {guess!r}")
    else:
        x0 = _guess_from_sequence(list(guess), problem)
    bad = [f"{n}={v}" for n, v in zip(problem.names, x0, strict=True) if not math.isfinite(v)]
    if bad:
        raise GuessError(f"guess is not finite: {', '.join(bad)}; give finite starting values")
    return x0


def _guess_from_mapping(guess: Mapping[Any, object], problem: Problem) -> Array:
    x0 = np.ones(problem.n)
    for key, value in guess.items():
        index = _variable_index(key, problem)
        x0[index] = _guess_float(problem.names[index], value)
    return x0


def _variable_index(key: object, problem: Problem) -> int:
    if isinstance(key, str):
        # A string may be the name ("q") or the printed variable ("q(t)").
        wanted = key.strip()
        spellings = [
            (name, str(v)) for v, name in zip(problem.variables, problem.names, strict=True)
        ]
        matches = [i for i, pair in enumerate(spellings) if wanted in pair]
    elif isinstance(key, (sp.Symbol, AppliedUndef)):
        matches = [i for i, name in enumerate(problem.names) if name == key_name(key)]
    else:
        matches = []
    if not matches:
        raise GuessError(
            f"guess names {key!r}, which is not a variable (variables: {', '.join(problem.names)})"
        )
    return matches[0]


def _guess_from_sequence(values: list[object], problem: Problem) -> Array:
    if len(values) != problem.n:
        raise GuessError(
            f"guess has {len(values)} values but there are {problem.n} variables "
            f"({', '.join(problem.names)})"
        )
    return np.array([_guess_float(n, v) for n, v in zip(problem.names, values, strict=True)])


def _guess_float(name: str, value: object) -> float:
    try:
        return float(value)  # type: ignore[arg-type]
    except (TypeError, ValueError) as exc:
        raise GuessError(f"guess for {name} ({value!r}) is not a number") from exc


def _least_squares_multipliers(problem: Problem, x0: Array) -> Array:
    m = len(problem.multipliers)
    residual, matrix = problem.kkt(np.concatenate([x0, np.zeros(m)]))
    if not all_finite(residual, matrix):
        raise GuessError(
            f"the function or constraints are not finite at the guess "
            f"({point_text(problem, x0)}); choose another guess"
        )
    n = problem.n
    if m == 0:
        return np.zeros(0)
    gradient, jacobian = residual[:n], matrix[n:, :n]
    return np.linalg.lstsq(jacobian.T, -gradient, rcond=None)[0]
