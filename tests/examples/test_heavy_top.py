"""The heavy top example against the steady-precession condition, solved here.

``m g l = C w3 Omega - A Omega^2 cos(theta)`` (``A`` about the pivot) has two
roots; started at either, the tilt and the precession rate stay put and the pivot
force is ``m g`` up plus ``m Omega^2 l sin(theta)`` towards the axis. Control: the
gyroscopic approximation ``Omega = m g l / (C w3)`` is not steady (the top nods).
"""

from __future__ import annotations

import numpy as np
import pytest

from dalembert.examples import heavy_top as ex
from dalembert.multibody import joint_reactions, multibody_of, point_positions

T = np.linspace(0.0, ex.T_END, 121)


def roots(theta: float, w3: float) -> tuple[float, float]:
    a = (ex.A0 + ex.M * ex.L**2) * np.cos(theta)
    b, c = -ex.C * w3, ex.M * ex.G * ex.L
    d = np.sqrt(b * b - 4 * a * c)
    return (-b - d) / (2 * a), (-b + d) / (2 * a)


@pytest.fixture(scope="module")
def system():
    return ex.build()


def tilt_and_azimuth(system, traj):
    x = point_positions(multibody_of(system), traj, "top") / ex.L
    return np.arccos(np.clip(x[:, 2], -1, 1)), np.unwrap(np.arctan2(x[:, 1], x[:, 0]))


@pytest.mark.parametrize("which", [0, 1], ids=["slow", "fast"])
def test_steady_precession_at_both_roots(system, which):
    omega = roots(ex.THETA0, ex.SPIN)[which]
    assert ex.precession_rates()[which] == pytest.approx(omega, rel=1e-12)
    traj = system.simulate((0.0, ex.T_END), **ex.steady_state(omega=omega), t_eval=T)
    tilt, azimuth = tilt_and_azimuth(system, traj)
    assert np.abs(tilt - ex.THETA0).max() < 1e-8
    assert np.abs(azimuth - omega * T).max() < 1e-8 * max(1.0, omega * T[-1])
    rho = ex.L * np.sin(ex.THETA0)
    F_ref = np.column_stack([-ex.M * omega**2 * rho * np.cos(omega * T),
                             -ex.M * omega**2 * rho * np.sin(omega * T),
                             np.full_like(T, ex.M * ex.G)])
    F = joint_reactions(multibody_of(system), traj)["pivot"]["top"].force_world
    assert np.abs(F - F_ref).max() < 1e-8 * np.abs(F_ref).max()
    errors = ex.checks(system, traj)
    assert max(errors.values()) < 1e-8


def test_gyroscopic_approximation_nods(system):
    omega = ex.M * ex.G * ex.L / (ex.C * ex.SPIN)
    traj = system.simulate((0.0, 1.0), **ex.steady_state(omega=omega))
    tilt, _ = tilt_and_azimuth(system, traj)
    assert np.abs(tilt - ex.THETA0).max() > 1e-5
