"""dalembert: constrained dynamical systems in redundant coordinates.

Write ``T``, ``V``, forces and constraints in SymPy; get the constrained equations
``M qdd = f + A^T lambda``, and simulate them with the multipliers, the constraint
forces and the constraints held to rounding level.
"""

from . import errors
from .errors import *  # noqa: F403  (every error and warning, listed in errors.__all__)
from .model.constraints import Holonomic, Pfaffian
from .model.coordinates import coordinates, t
from .model.forces import PointForce
from .statics import all_extrema, extremum, stationarity_conditions
from .system import System
from .trajectory import Trajectory

__version__ = "0.1.0"

__all__ = [
    *errors.__all__,
    "Holonomic",
    "Pfaffian",
    "PointForce",
    "System",
    "Trajectory",
    "all_extrema",
    "coordinates",
    "extremum",
    "stationarity_conditions",
    "t",
]
