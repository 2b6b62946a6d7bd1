"""The augmented function at rest: constrained extremum, equilibrium, small oscillations.

Stationarity of ``Phi + lambda^T psi`` with respect to ``x`` and ``lambda`` gives a
constrained extremum; with ``Phi = V`` it gives static equilibrium, the
multipliers being the reactions at rest. Linearizing about it on the constraint
manifold gives the natural frequencies and modes.
"""

from .equilibrium import Equilibrium, equilibrium
from .extremum import (
    Extremum,
    StationarityConditions,
    all_extrema,
    extremum,
    stationarity_conditions,
)
from .linearize import Linearization, StateSpace, linearize

__all__ = [
    "Equilibrium",
    "Extremum",
    "Linearization",
    "StateSpace",
    "StationarityConditions",
    "all_extrema",
    "equilibrium",
    "extremum",
    "linearize",
    "stationarity_conditions",
]
