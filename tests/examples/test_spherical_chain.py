"""The 4-link spherical chain: energy and the vertical angular momentum are conserved.

Gravity is vertical and the pivot is on the vertical axis, so nothing exerts a
torque about it: ``H_z`` about the pivot is constant (its value at the start is
computed here from the rigid spin, independently of the code's outputs). The
minimal-coordinate agreement of chains is tested in ``tests/multibody``.
"""

from __future__ import annotations

import numpy as np
import pytest

from dalembert.examples import spherical_chain as ex
from dalembert.multibody import angular_momentum, multibody_of, point_positions
from dalembert.multibody.rotations import rotation_matrix


@pytest.fixture(scope="module")
def run():
    system = ex.build()
    traj = system.simulate((0.0, ex.T_END), **ex.INITIAL, t_eval=np.linspace(0, ex.T_END, 101))
    return system, traj


def test_initial_state_is_assembled(run):
    system, _ = run
    mb = multibody_of(system)
    report = system.consistent_initial_state(**ex.INITIAL)
    assert not report.changed
    assert len(mb.bodies) == ex.N


@pytest.mark.validation
def test_energy_and_vertical_angular_momentum(run):
    system, traj = run
    mb = multibody_of(system)
    # H_z of a rigid spin W about z: W sum(m (x^2 + y^2) + e_z . R I R^T e_z)
    hz0 = 0.0
    for link in mb.bodies:
        x = point_positions(mb, traj, link)[0]
        R0 = rotation_matrix(np.array([traj[f"{link.name}_b{i}"][0] for i in range(4)]))
        hz0 += ex.SPIN * (link.mass * (x[0] ** 2 + x[1] ** 2) + (R0 @ link.inertia @ R0.T)[2, 2])
    hz = angular_momentum(mb, traj)[:, 2]
    assert np.abs(hz - hz0).max() < 1e-9 * abs(hz0)
    errors = ex.checks(system, traj)
    assert errors["relative energy error"] < 1e-9
    assert errors["max position residual"] < 1e-12
    # the chain really moves: the bottom link swings by more than a link length
    bottom = point_positions(mb, traj, f"link{ex.N}")
    assert np.ptp(bottom[:, 2]) > 0.05
