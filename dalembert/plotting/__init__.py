"""Off-screen (Agg) PNG plots of trajectories: coordinates, energy drift, residuals,
multipliers and 2D paths. Importing this package selects matplotlib's Agg backend."""

from .trajectory_plots import (
    plot_all,
    plot_coordinates,
    plot_energy_error,
    plot_multipliers,
    plot_path,
    plot_residuals,
    relative_drift,
)

__all__ = [
    "plot_all",
    "plot_coordinates",
    "plot_energy_error",
    "plot_multipliers",
    "plot_path",
    "plot_residuals",
    "relative_drift",
]
