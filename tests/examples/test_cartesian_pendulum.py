"""The Cartesian pendulum against the angle-only pendulum and the closed-form tension."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from dalembert.examples import cartesian_pendulum as example

pytestmark = pytest.mark.filterwarnings("error::dalembert.errors.InitialConditionsAdjusted")

G, L = 9.81, 1.0
T_LONG = 100.0
T_DRIFT = 20.0
TIMES = np.linspace(0.0, T_LONG, 1001)


@pytest.fixture(scope="module")
def system():
    return example.build(g_value=G, l_value=L)


@pytest.fixture(scope="module")
def long_run(system):
    """100 s with the default simulate settings (DOP853, rtol 1e-11, projection)."""
    return system.simulate((0.0, T_LONG), **example.INITIAL, t_eval=TIMES)


def angle_only_pendulum(times: np.ndarray) -> np.ndarray:
    """``theta'' = -(g/l) sin(theta)`` from rest at ``THETA0``, integrated independently."""
    sol = solve_ivp(
        lambda _t, u: [u[1], -G / L * np.sin(u[0])],
        (times[0], times[-1]), [example.THETA0, 0.0],
        method="DOP853", rtol=1e-13, atol=1e-14, t_eval=times,
    )
    assert sol.success
    return sol.y[0]


def test_checks_contract(system):
    traj = system.simulate((0.0, example.T_END), **example.INITIAL)
    errors = example.checks(system, traj)
    assert all(isinstance(v, float) for v in errors.values())
    assert max(errors.values()) < 1e-9


@pytest.mark.validation
def test_same_motion_as_angle_only_pendulum(long_run):
    theta = angle_only_pendulum(TIMES)
    # measured: up to 1.2e-9 in x, 5.6e-10 in y over 100 s (the reference is good to ~3e-12)
    assert np.abs(long_run["x"] - L * np.sin(theta)).max() < 1e-8
    assert np.abs(long_run["y"] + L * np.cos(theta)).max() < 1e-8


@pytest.mark.validation
def test_energy_and_constraints_hold_for_100_seconds(long_run):
    e = long_run.energy
    assert long_run.success
    assert np.abs(e - e[0]).max() / abs(e[0]) < 1e-9  # measured 1.2e-10
    assert long_run.position_residual.max() < 1e-12  # measured 9e-15
    assert long_run.velocity_residual.max() < 1e-12  # measured 9e-16


@pytest.mark.validation
def test_tension_matches_closed_form_at_every_output_time(system, long_run):
    ref = example.closed_form_tension(system, long_run)
    assert ref.min() > 0.5  # the rod stays taut (m g cos(1) at the turning points)
    relative = np.abs(example.tension(system, long_run) - ref) / ref
    assert relative.max() < 1e-8  # measured ~1e-14


@pytest.mark.validation
def test_without_stabilization_the_constraints_drift(system):
    times = TIMES[TIMES <= T_DRIFT]
    raw = system.simulate((0.0, T_DRIFT), **example.INITIAL, t_eval=times, stabilization=None)
    projected = system.simulate((0.0, T_DRIFT), **example.INITIAL, t_eval=times)
    early = raw.position_residual[times <= 2.0].max()
    late = raw.position_residual[times >= T_DRIFT - 2.0].max()
    assert raw.position_residual.max() > 1e-10  # measured 1.1e-9
    assert late > 10 * early  # it grows steadily
    assert projected.position_residual.max() < 1e-12
    assert projected.velocity_residual.max() < 1e-12


@pytest.mark.validation
def test_baumgarte_keeps_the_residuals_bounded(system):
    # 10 s: Baumgarte needs ~2.5x the evaluations of projection here, each costlier
    times = TIMES[TIMES <= T_DRIFT / 2]
    traj = system.simulate((0.0, T_DRIFT / 2), **example.INITIAL, t_eval=times,
                           stabilization="baumgarte")
    pos, vel = traj.position_residual, traj.velocity_residual
    # measured 2.9e-12 (position) and 3.3e-11 (velocity), flat over the run
    assert pos.max() < 1e-10
    assert vel.max() < 1e-9
    assert pos[len(pos) // 2:].max() < 10 * pos[: len(pos) // 2].max() + 1e-12
