"""dalembert: constrained dynamical systems in redundant coordinates.

Write ``T``, ``V``, forces and constraints in SymPy; get the constrained equations
``M qdd = f + A^T lambda``, and simulate them with the multipliers, the constraint
forces and the constraints held to rounding level.
"""

from .ensemble.run import simulate_many as _simulate_many
from .errors import (  # every error and warning (errors.__all__)
    BadCacheEntryWarning,
    CompileError,
    ConstraintError,
    ContactError,
    DalembertError,
    DalembertWarning,
    DependentConstraintsError,
    DoubleCountingWarning,
    EnsembleError,
    EnsembleWarning,
    EquilibriumNotFoundError,
    ExtremumConvergenceError,
    GuessError,
    InconsistentConstraintsError,
    InitialConditionError,
    InitialConditionsAdjusted,
    InputError,
    IntegrationWarning,
    JointPointWarning,
    MarginalStabilityError,
    MissingParameterError,
    ModelError,
    ModelFileError,
    NativeUnavailableWarning,
    NonholonomicLinearizationError,
    NotAnEquilibriumError,
    ParameterError,
    RedundantConstraintsWarning,
    SingularConfigurationWarning,
    SingularSystemError,
    StiffStabilizationWarning,
    SymbolicSolveError,
    TooManyConstraintsError,
    TrajectoryFileError,
    UnsafeCacheError,
    UnsupportedModelFeatureWarning,
)
from .model.constraints import Holonomic, Pfaffian, Unilateral
from .model.coordinates import coordinates, t
from .model.forces import PointForce
from .model.parameters import ParameterSet
from .system import System, install_ensemble
from .trajectory import Trajectory

# System.simulate_many runs an ensemble, a later layer than the System's: wired here, at
# the package's root, which imports both (the ensemble imports only NumPy at once; Dask,
# xarray and pandas when an ensemble runs).
install_ensemble(_simulate_many)

__version__ = "0.1.0"

#: Imported on first use: statics pulls in scipy.optimize, slow to import.
_LAZY = {"all_extrema": "statics", "extremum": "statics", "stationarity_conditions": "statics"}


def __getattr__(name: str) -> object:
    if name in _LAZY:
        import importlib

        value = getattr(importlib.import_module(f".{_LAZY[name]}", __name__), name)
        globals()[name] = value
        return value
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_LAZY))

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
    "Holonomic",
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
    "ParameterSet",
    "Pfaffian",
    "PointForce",
    "RedundantConstraintsWarning",
    "SingularConfigurationWarning",
    "SingularSystemError",
    "StiffStabilizationWarning",
    "SymbolicSolveError",
    "System",
    "TooManyConstraintsError",
    "Trajectory",
    "TrajectoryFileError",
    "Unilateral",
    "UnsafeCacheError",
    "UnsupportedModelFeatureWarning",
    "all_extrema",
    "coordinates",
    "extremum",
    "stationarity_conditions",
    "t",
]
