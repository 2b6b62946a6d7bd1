"""The plotting layer writes real PNG files, headless, for every kind of trajectory."""

from __future__ import annotations

import numpy as np
import pytest

from dalembert.examples import load
from dalembert.plotting import (
    plot_all,
    plot_coordinates,
    plot_energy_error,
    plot_multipliers,
    plot_path,
    plot_residuals,
    relative_drift,
)
from dalembert.trajectory import Trajectory

PNG_MAGIC = b"\x89PNG\r\n\x1a\n"


def synthetic(n_points: int = 50, constraints: tuple[str, ...] = ("rod",)) -> Trajectory:
    """A hand-made trajectory (a circle), so the plots are tested without simulating."""
    t = np.linspace(0.0, 2.0, n_points)
    q = np.column_stack([np.cos(t), np.sin(t)])
    qd = np.column_stack([-np.sin(t), np.cos(t)])
    m = len(constraints)
    energy = 1.0 + 1e-12 * t
    return Trajectory(
        t=t, q=q, qd=qd, qdd=-q, multipliers=np.full((n_points, m), -0.5),
        constraint_forces=-q, kinetic_energy=energy, potential_energy=np.zeros_like(t),
        jacobi_integral=energy, position_residual=np.where(t > 1, 1e-15, 0.0),
        velocity_residual=np.full_like(t, 1e-16), coordinate_names=("x", "y"),
        constraint_names=constraints,
    )


def assert_png(path) -> None:
    data = path.read_bytes()
    assert data[:8] == PNG_MAGIC
    assert len(data) > 5000  # axes, labels and lines, not an empty canvas


@pytest.mark.parametrize("plot", [plot_coordinates, plot_residuals, plot_multipliers, plot_path])
def test_each_plot_writes_a_png(plot, tmp_path):
    path = plot(synthetic(), tmp_path / "sub" / "figure.png")
    assert path == tmp_path / "sub" / "figure.png"
    assert_png(path)


@pytest.mark.parametrize("quantity", ["energy", "jacobi"])
def test_energy_error_plot(quantity, tmp_path):
    assert_png(plot_energy_error(synthetic(), tmp_path / "e.png", quantity=quantity))


def test_energy_error_rejects_unknown_quantity(tmp_path):
    with pytest.raises(ValueError, match="quantity"):
        plot_energy_error(synthetic(), tmp_path / "e.png", quantity="momentum")


def test_plots_without_constraints_or_energy(tmp_path):
    traj = synthetic(constraints=())
    traj.kinetic_energy = np.full_like(traj.t, np.nan)  # a Lagrangian-only model
    for path in plot_all(traj, tmp_path):
        assert_png(path)


def test_relative_drift_against_hand_values():
    assert np.allclose(relative_drift(np.array([-4.0, -3.0, -5.0])), [0.0, 0.25, 0.25])
    # e(0) = 0 has no scale: the absolute change is reported
    assert np.allclose(relative_drift(np.array([0.0, 1e-3])), [0.0, 1e-3])


def test_plot_all_on_a_simulated_pendulum(tmp_path):
    example = load("pendulum")
    system = example.build()
    traj = system.simulate((0.0, 0.5), **example.INITIAL, t_eval=np.linspace(0, 0.5, 26))
    paths = plot_all(traj, tmp_path, system=system, energy="energy", path_xy=("x", "y"))
    names = sorted(p.name for p in paths)
    assert names == ["coordinates.png", "energy.png", "multipliers.png", "path.png",
                     "residuals.png"]
    for path in paths:
        assert_png(path)
