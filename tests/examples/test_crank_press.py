"""The crank press: a driven slider-crank with no degree of freedom, against the
power balance of its closed-form motion (see the example's docstring), and its own
plot written by ``dalembert run``."""

from __future__ import annotations

import numpy as np
import pytest

from dalembert import report
from dalembert.examples import crank_press as example


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    return report.run_example("crank-press", tmp_path_factory.mktemp("press"), t_end=1.0,
                              points=401, animation=False)


def test_motor_torque_is_the_power_balance(run):
    checks = run.checks
    assert checks["motor torque relative error (power balance)"] < 1e-9
    assert checks["piston position error (closed form)"] < 1e-10
    assert checks["max position residual"] < 1e-12


def test_the_press_load_shows_in_the_torque(run):
    """While pressing, the motor supplies F0 v_B / omega more than without the load."""
    traj = run.trajectory
    x_b = traj["piston_x"]
    pressing = (x_b > example.X_PRESS) & (traj["piston_x_dot"] > 0)
    assert pressing.any() and not pressing.all()
    extra = example.F_PRESS * traj["piston_x_dot"][pressing] / example.OMEGA
    assert extra.max() > 100.0  # the load is not lost in the inertial torque


def test_its_own_plot_is_written(run):
    names = [p.name for p in run.files]
    assert "motor_torque.png" in names
    assert np.all(np.isfinite(run.trajectory.multiplier("motor_1")))
