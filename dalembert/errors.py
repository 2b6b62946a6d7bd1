"""Exceptions and warnings raised by dalembert.

Every error names the offending item (coordinate, parameter, constraint) and says
what to do about it. They subclass the built-in exception a user would expect
(``ValueError`` for bad input, ``RuntimeError`` for numerical failure), so
generic ``except`` clauses keep working.
"""

from __future__ import annotations


class DalembertError(Exception):
    """Base class of every error raised by dalembert."""


class ModelError(DalembertError, ValueError):
    """The model (coordinates, energies, forces, constraints) is malformed."""


class ParameterError(ModelError):
    """A parameter has no numeric value, or a value is not a finite number."""


class ConstraintError(ModelError):
    """A constraint is malformed, redundant, or too many for the coordinates."""


class InitialConditionError(DalembertError, ValueError):
    """Initial conditions name unknown coordinates, are not finite, or cannot be made consistent."""


class SingularSystemError(DalembertError, RuntimeError):
    """The KKT matrix [[M, A^T], [A, 0]] is singular, so accelerations are not determined."""


class DoubleCountingWarning(UserWarning):
    """A generalized force repeats a conservative force already in the potential energy."""


class InitialConditionsAdjusted(UserWarning):
    """Initial conditions violated the constraints and were projected onto them."""


class IntegrationWarning(UserWarning):
    """Integration stopped early; the trajectory holds the part computed so far."""


class RedundantConstraintsWarning(UserWarning):
    """Dependent constraints: the motion is unique, their multipliers are not."""
