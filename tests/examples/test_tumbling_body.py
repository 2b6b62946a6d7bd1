"""The tumbling body against Euler's equations integrated separately.

Independent answer: ``I w' = (I w) x w`` (body frame, principal axes) with SciPy;
the quaternion body's angular velocity must follow it, and it must flip (the
intermediate-axis spin reverses). Energy, world angular momentum and the unit
norm are conserved (the module's checks).
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from dalembert.examples import tumbling_body as ex
from dalembert.multibody import angular_velocities, multibody_of

T = np.linspace(0.0, ex.T_END, 201)


@pytest.fixture(scope="module")
def run():
    system = ex.build()
    return system, system.simulate((0.0, ex.T_END), **ex.INITIAL, t_eval=T)


def test_follows_euler_equations_and_flips(run):
    system, traj = run
    inertia = np.array(ex.INERTIA)

    def euler(_t, w):
        return np.cross(inertia * w, w) / inertia

    ref = solve_ivp(euler, (0.0, ex.T_END), ex.OMEGA0, t_eval=T, method="DOP853",
                    rtol=1e-12, atol=1e-14).y.T
    w = angular_velocities(multibody_of(system), traj, "body", frame="body")
    # each pass near the separatrix (a flip) amplifies the integrators' errors: the two
    # agree to ~1e-6 of |w| = 2 after several flips, a wrong model differs by O(1)
    assert np.abs(w - ref).max() < 5e-6
    assert w[:, 1].min() < -1.9 and w[:, 1].max() > 1.9   # it flips, and back


def test_conservation_checks(run):
    system, traj = run
    errors = ex.checks(system, traj)
    assert errors["relative energy error"] < 1e-9
    assert errors["relative angular momentum error"] < 1e-9
    assert errors["quaternion norm error"] < 1e-13
