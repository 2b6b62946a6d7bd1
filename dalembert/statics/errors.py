"""Exceptions raised by :mod:`dalembert.statics.extremum`.

Each subclasses a :mod:`dalembert.errors` class and the built-in exception a user
would expect (``ValueError`` for bad input, ``RuntimeError`` for a failed search).
"""

from __future__ import annotations

from ..errors import ConstraintError, DalembertError, ParameterError

__all__ = [
    "DependentConstraintsError",
    "ExtremumConvergenceError",
    "GuessError",
    "MissingParameterError",
    "SymbolicSolveError",
    "TooManyConstraintsError",
]


class ExtremumConvergenceError(DalembertError, RuntimeError):
    """No stationary point of the augmented function was found near the guess."""


class DependentConstraintsError(ConstraintError):
    """The constraint gradients are linearly dependent at the point found.

    ``indices`` holds the 0-based positions (in ``constraints``) of the
    constraints taking part in the dependency.
    """

    def __init__(self, message: str, indices: tuple[int, ...] = ()) -> None:
        super().__init__(message)
        self.indices = indices


class TooManyConstraintsError(ConstraintError):
    """There are more constraints than variables."""


class GuessError(DalembertError, ValueError):
    """A guess names an unknown variable, has the wrong length, or is not finite."""


class MissingParameterError(ParameterError):
    """A free symbol that is not a variable has no numeric value."""


class SymbolicSolveError(DalembertError, RuntimeError):
    """SymPy could not find the isolated stationary points symbolically."""
