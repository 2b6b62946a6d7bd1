"""Every exception and warning dalembert raises, in one place.

Every error names the offending item (coordinate, parameter, constraint) and says
what to do about it. Errors subclass :class:`DalembertError` and the built-in
exception a user would expect (``ValueError`` for bad input, ``RuntimeError`` for
numerical failure), so generic ``except`` clauses keep working; warnings subclass
:class:`DalembertWarning`. ``docs/errors.md`` lists when each is raised.
"""

from __future__ import annotations

import os
import sys
from types import FrameType

# --------------------------------------------------------------------------- errors


class DalembertError(Exception):
    """Base class of every error raised by dalembert."""


class ModelError(DalembertError, ValueError):
    """The model (coordinates, energies, forces, constraints) is malformed."""


class ParameterError(ModelError):
    """A parameter has no numeric value, or a value is not a finite number."""


class MissingParameterError(ParameterError):
    """A free symbol that is not a variable has no numeric value."""


class ConstraintError(ModelError):
    """A constraint is malformed, redundant, or too many for the coordinates."""


class TooManyConstraintsError(ConstraintError):
    """There are more constraints than variables."""


class DependentConstraintsError(ConstraintError):
    """The constraint gradients are linearly dependent at the point found.

    ``indices`` holds the 0-based positions (in ``constraints``) of the
    constraints taking part in the dependency.
    """

    def __init__(self, message: str, indices: tuple[int, ...] = ()) -> None:
        super().__init__(message)
        self.indices = indices


class InconsistentConstraintsError(ConstraintError):
    """The holonomic constraints cannot be satisfied near the guess."""


class InitialConditionError(DalembertError, ValueError):
    """Initial conditions name unknown coordinates, are not finite, or cannot be made consistent."""


class InputError(DalembertError, ValueError):
    """A model's inputs have no value, a value of no known form, or a function giving them
    raised or returned something that is not a finite number of the right shape."""


class GuessError(DalembertError, ValueError):
    """A guess names an unknown variable, has the wrong length, or is not finite."""


class NotAnEquilibriumError(DalembertError, ValueError):
    """The point given to ``linearize`` is not a static equilibrium."""


class SingularSystemError(DalembertError, RuntimeError):
    """The KKT matrix [[M, A^T], [A, 0]] is singular, so accelerations are not determined."""


class ContactError(DalembertError, RuntimeError):
    """Contacts that cannot go on: an impact or a set of closed contacts with no solution
    meeting the contact laws, an endless cascade of switches at one instant."""


class CompileError(DalembertError, RuntimeError):
    """The C route is unavailable for these expressions (unsupported function, no compiler)."""


class UnsafeCacheError(CompileError):
    """The code cache folder belongs to another user or is writable by others, so a
    library planted there could run as you; it is not used."""


class ModelFileError(ModelError):
    """A model file (MJCF or URDF) that cannot be read or compiled, or that describes
    what dalembert cannot model (the message names the file and the problem)."""


class TrajectoryFileError(DalembertError, ValueError):
    """A file is not a trajectory ``Trajectory.load`` can read (or ``save`` cannot write it)."""


class ExtremumConvergenceError(DalembertError, RuntimeError):
    """No stationary point of the augmented function was found near the guess."""


class EquilibriumNotFoundError(DalembertError, RuntimeError):
    """Newton's method found no static equilibrium near the guess."""


class MarginalStabilityError(DalembertError, RuntimeError):
    """The constrained stiffness is singular (raised only with ``on_marginal="raise"``)."""


class SymbolicSolveError(DalembertError, RuntimeError):
    """SymPy could not find the isolated stationary points symbolically."""


class NonholonomicLinearizationError(DalembertError, NotImplementedError):
    """``linearize`` handles holonomic constraints only."""


class TimeLimitExceeded(BaseException):
    """Raised asynchronously in the thread of a run whose function of yours (an input,
    an event, an ensemble's output) has kept it past its time limit (``timeout=``)
    (:mod:`dalembert.solvers.running.watchdog`). A ``BaseException`` like
    ``KeyboardInterrupt``, so that a function's ``except Exception`` does not swallow
    it; the run catches it and ends with status ``"timeout"``: it never reaches you."""


# --------------------------------------------------------------------------- warnings


class EnsembleError(DalembertError, ValueError):
    """An ensemble that cannot run as given: a case column naming nothing, no cases, a
    bad scheduler or store (see :mod:`dalembert.ensemble`)."""


class DalembertWarning(UserWarning):
    """Base class of every warning issued by dalembert."""


class DoubleCountingWarning(DalembertWarning):
    """A generalized force repeats a conservative force already in the potential energy."""


class InitialConditionsAdjusted(DalembertWarning):
    """Initial conditions violated the constraints and were projected onto them."""


class StiffStabilizationWarning(DalembertWarning):
    """A Baumgarte gain so high that an explicit method must take tiny steps."""


class IntegrationWarning(DalembertWarning):
    """Integration stopped early; the trajectory holds the part computed so far."""


class RedundantConstraintsWarning(DalembertWarning):
    """Dependent constraints: the motion is unique, their multipliers are not."""


class SingularConfigurationWarning(DalembertWarning):
    """The run passed near a singular configuration of the constraints (they nearly lost
    rank): named, with the times; the multipliers there are the minimum-norm ones."""


class JointPointWarning(DalembertWarning):
    """A joint point looks as if it were given in the wrong frame."""


class UnsupportedModelFeatureWarning(DalembertWarning):
    """An imported model (MJCF or URDF) uses features dalembert does not model (contact,
    tendons, joint limits...): one warning lists them all, none is dropped silently."""


class NativeUnavailableWarning(DalembertWarning):
    """The C runtime or a model's C code is unavailable, so a slower path is taken."""


class BadCacheEntryWarning(DalembertWarning):
    """A cached library was found damaged or foreign; it was not loaded but rebuilt."""


class EnsembleWarning(DalembertWarning):
    """Some cases of an ensemble failed, were lost with a worker or did not run (the
    others are returned; ``result.retry()`` runs the failed ones again)."""


__all__ = [
    "BadCacheEntryWarning",
    "CompileError",
    "ConstraintError",
    "ContactError",
    "DalembertError",
    "DalembertWarning",
    "DependentConstraintsError",
    "DoubleCountingWarning",
    "EnsembleError",
    "EnsembleWarning",
    "EquilibriumNotFoundError",
    "ExtremumConvergenceError",
    "GuessError",
    "InconsistentConstraintsError",
    "InitialConditionError",
    "InitialConditionsAdjusted",
    "InputError",
    "IntegrationWarning",
    "JointPointWarning",
    "MarginalStabilityError",
    "MissingParameterError",
    "ModelError",
    "ModelFileError",
    "NativeUnavailableWarning",
    "NonholonomicLinearizationError",
    "NotAnEquilibriumError",
    "ParameterError",
    "RedundantConstraintsWarning",
    "SingularConfigurationWarning",
    "SingularSystemError",
    "StiffStabilizationWarning",
    "SymbolicSolveError",
    "TooManyConstraintsError",
    "TrajectoryFileError",
    "UnsafeCacheError",
    "UnsupportedModelFeatureWarning",
]


# ------------------------------------------------------------------- where warnings point

#: The package's folder: frames of files under it are dalembert's own.
_PACKAGE = os.path.dirname(os.path.abspath(__file__)) + os.sep


def user_stacklevel() -> int:
    """The ``stacklevel`` that makes a warning point at the user's line: the first frame,
    going out from the function that warns, whose file is outside the dalembert package.

    Call it in the ``warnings.warn`` call itself, so that it counts from the function
    that warns (``stacklevel=1``); a warning raised where no frame is the user's (all
    dalembert's, e.g. a worker thread's) points at the function that warns.

    Examples
    --------
    Called from outside the package, level 1 is the caller itself:

    >>> user_stacklevel()
    1
    """
    frame: FrameType | None = sys._getframe(1)
    level = 1
    while frame is not None and os.path.abspath(frame.f_code.co_filename).startswith(_PACKAGE):
        frame = frame.f_back
        level += 1
    return level if frame is not None else 1
