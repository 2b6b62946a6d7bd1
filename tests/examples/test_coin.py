"""The quaternion coin with the Rolling joint against the Euler-angle rolling disk.

Independent answers: the steady-rolling condition (solved here for ``Omega``) and
``dalembert.examples.rolling_disk`` (Euler angles, its own constraints, itself
validated against Newton-Euler equations) started in the same wobbling state: the
center, the disk's axis and the contact force must agree.
"""

from __future__ import annotations

import numpy as np
import pytest

from dalembert.examples import coin, rolling_disk
from dalembert.multibody import joint_reactions, multibody_of, point_positions, rotation_matrices
from dalembert.multibody.rotations import elementary_rotation

M, G, R = coin.M, coin.G, coin.R_COIN
T = np.linspace(0.0, 2.0, 41)


@pytest.fixture(scope="module")
def system():
    return coin.build()


def test_steady_rolling_matches_the_closed_form(system):
    theta, radius = -0.3, 0.5
    omega = np.sqrt(G * np.sin(theta) / (np.cos(theta) * (R * np.sin(theta) / 4 - 1.5 * radius)))
    assert coin.steady_rate(theta, radius) == pytest.approx(omega, rel=1e-14)
    traj = system.simulate((0.0, coin.T_END), **coin.INITIAL, max_step=0.05,
                           t_eval=np.linspace(0.0, coin.T_END, 101))
    mb = multibody_of(system)
    psi = omega * traj.t
    x = point_positions(mb, traj, "coin")
    np.testing.assert_allclose(x[:, 0], radius * np.sin(psi), rtol=0, atol=1e-9)
    np.testing.assert_allclose(x[:, 1], radius * (1 - np.cos(psi)), rtol=0, atol=1e-9)
    F = joint_reactions(mb, traj)["roll"]["coin"].force_world
    F_ref = np.column_stack([-M * radius * omega**2 * np.sin(psi),
                             M * radius * omega**2 * np.cos(psi), np.full_like(psi, M * G)])
    assert np.abs(F - F_ref).max() < 1e-9 * M * G
    errors = coin.checks(system, traj)
    assert max(errors.values()) < 1e-9


def _disk_state() -> dict:
    """A wobbling start in the rolling disk's Euler angles (off the steady state)."""
    th0, psid0, thd0, phid0, psi0 = -0.25, 1.5, 0.8, 9.0, 0.2
    b1 = np.array([np.cos(psi0), np.sin(psi0), 0.0])
    b2 = np.array([-np.cos(th0) * np.sin(psi0), np.cos(th0) * np.cos(psi0), np.sin(th0)])
    v = R * ((phid0 + psid0 * np.sin(th0)) * b1 - thd0 * b2)
    return {"q0": {"x": 0.1, "y": -0.3, "z": R * np.cos(th0), "psi": psi0, "theta": th0,
                   "phi": 0.5},
            "qd0": {"x": v[0], "y": v[1], "z": v[2], "psi": psid0, "theta": thd0,
                    "phi": phid0}}


@pytest.mark.validation
def test_wobbling_coin_matches_the_euler_angle_disk(system):
    start = _disk_state()
    q, qd = start["q0"], start["qd0"]
    # the same pose: heading psi about Z, tilt theta about b1, spin phi about the axis
    Rm = (elementary_rotation("z", q["psi"]) @ elementary_rotation("x", q["theta"])
          @ elementary_rotation("y", q["phi"]))
    w = qd["psi"] * np.array([0, 0, 1.0]) + qd["theta"] * np.array(
        [np.cos(q["psi"]), np.sin(q["psi"]), 0.0]) + qd["phi"] * Rm[:, 1]
    mb = multibody_of(system)
    q0, qd0 = mb.initial_state(positions={"coin": (q["x"], q["y"], q["z"])},
                               orientations={"coin": Rm},
                               velocities={"coin": (qd["x"], qd["y"], qd["z"])},
                               angular_velocities={"coin": w})
    traj = system.simulate((0.0, T[-1]), q0, qd0, t_eval=T)
    disk = rolling_disk.build(M, G, R)
    ref = disk.simulate((0.0, T[-1]), **start, t_eval=T)
    x = point_positions(mb, traj, "coin")
    x_ref = np.column_stack([ref["x"], ref["y"], ref["z"]])
    assert np.abs(x - x_ref).max() < 1e-8
    axis = rotation_matrices(mb, traj, "coin")[:, :, 1]
    psi, th = ref["psi"], ref["theta"]
    axis_ref = np.column_stack([-np.cos(th) * np.sin(psi), np.cos(th) * np.cos(psi), np.sin(th)])
    assert np.abs(axis - axis_ref).max() < 1e-8
    assert np.ptp(th) > 0.05   # genuinely unsteady
    # rolling_disk's multipliers are the world contact force components
    F_ref = ref.multipliers[:, [ref.constraint_names.index(n)
                                for n in ("roll_x", "roll_y", "contact")]]
    F = joint_reactions(mb, traj)["roll"]["coin"].force_world
    assert np.abs(F - F_ref).max() < 1e-8 * M * G
