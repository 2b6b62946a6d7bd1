"""The Rolling joint against closed forms: a sphere rolling down an incline.

A uniform sphere (``I = 2/5 m r^2``) rolling without slipping on a plane inclined
by ``alpha`` accelerates down the slope at ``(5/7) g sin(alpha)`` (energy with
``w = v / r``: ``(7/10) m v^2 = m g sin(alpha) s``), and a sideways velocity stays
constant; its angular velocity is ``n x v / r``; the contact force, at the contact
point ``x - r n``, is ``m g cos(alpha) n`` plus the friction
``-(2/7) m g sin(alpha)`` along the downhill direction. The disk is validated in
``tests/examples/test_coin.py`` against the Euler-angle rolling disk.
"""

from __future__ import annotations

import numpy as np
import pytest

from dalembert import ModelError
from dalembert.multibody import (
    Multibody,
    Particle,
    RigidBody,
    Rolling,
    angular_velocities,
    joint_reactions,
    point_positions,
)

M, R, ALPHA, G = 2.0, 0.3, 0.4, 9.81
N = np.array([np.sin(ALPHA), 0.0, np.cos(ALPHA)])      # the plane's normal
DOWN = np.array([np.cos(ALPHA), 0.0, -np.sin(ALPHA)])  # downhill, in the plane
SIDE = np.cross(N, DOWN)


@pytest.fixture(scope="module")
def rolled():
    ball = RigidBody("ball", M, np.full(3, 0.4 * M * R**2))
    mb = Multibody([ball], [Rolling("roll", ball, R, normal=N)], gravity=(0.0, 0.0, -G))
    u, w = 0.5, 0.8
    v0 = u * DOWN + w * SIDE
    q0, qd0 = mb.initial_state(positions={ball: R * N}, velocities={ball: v0},
                               angular_velocities={ball: np.cross(N, v0) / R})
    t = np.linspace(0.0, 2.0, 41)
    return mb, mb.simulate((0.0, 2.0), q0, qd0, t_eval=t), u, w


def test_sphere_rolls_down_the_incline_at_five_sevenths_g(rolled):
    mb, traj, u, w = rolled
    t = traj.t
    x = point_positions(mb, traj, "ball")
    a = 5 / 7 * G * np.sin(ALPHA)
    ref = R * N + np.outer(u * t + a * t**2 / 2, DOWN) + np.outer(w * t, SIDE)
    assert np.abs(x - ref).max() < 1e-9
    v = np.column_stack([traj[f"ball_{c}_dot"] for c in "xyz"])
    omega = angular_velocities(mb, traj, "ball")
    assert np.abs(omega - np.cross(N, v) / R).max() < 1e-9


def test_contact_force_at_the_contact_point(rolled):
    mb, traj, *_ = rolled
    reaction = joint_reactions(mb, traj)["roll"]
    F_ref = M * G * (np.cos(ALPHA) * N - 2 / 7 * np.sin(ALPHA) * DOWN)
    ball = reaction["ball"]
    assert np.abs(ball.force_world - F_ref).max() < 1e-9 * M * G
    contact = point_positions(mb, traj, "ball") - R * N
    assert np.abs(ball.point_world - contact).max() < 1e-12
    # the force acts at the contact point: no torque about it
    assert np.abs(ball.torque_world).max() < 1e-9 * M * G * R
    assert np.abs(reaction["ground"].force_world + F_ref).max() < 1e-9 * M * G
    # multiplier 1 is the normal force (height row), 2 and 3 the friction components
    lam = traj.multiplier("roll_1")
    assert np.abs(lam - M * G * np.cos(ALPHA)).max() < 1e-9 * M * G


def test_rolling_needs_a_rigid_body_and_a_positive_radius():
    with pytest.raises(ModelError, match=r"'roll'.*RigidBody.*particle"):
        Rolling("roll", Particle("p", 1.0), 0.1)
    with pytest.raises(ModelError, match=r"'roll'.*radius must be positive"):
        Rolling("roll", RigidBody("b", 1.0, (1, 1, 1)), 0.0)
    with pytest.raises(ModelError, match=r"'roll'.*axis_b is the zero vector"):
        Rolling("roll", RigidBody("b", 1.0, (1, 1, 1)), 0.1, axis=(0, 0, 0))
