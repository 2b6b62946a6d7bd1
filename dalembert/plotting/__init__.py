"""Off-screen (Agg) PNG plots of trajectories: coordinates, energy drift, residuals,
multipliers and 2D paths; drawings of a mechanism at rest and of its mode shapes;
:func:`view`, a 3D page of a trajectory for the browser.
Figures are matplotlib ``Figure`` objects saved directly, never pyplot: no backend is
selected or needed."""

from .animation import animate
from .modes import plot_mechanism, plot_mode_shapes
from .trajectory_plots import (
    plot_all,
    plot_coordinates,
    plot_energy_error,
    plot_multipliers,
    plot_path,
    plot_residuals,
    relative_drift,
)
from .viewer import view

__all__ = [
    "animate",
    "plot_all",
    "plot_coordinates",
    "plot_energy_error",
    "plot_mechanism",
    "plot_mode_shapes",
    "plot_multipliers",
    "plot_path",
    "plot_residuals",
    "relative_drift",
    "view",
]
