"""Single rigid bodies in Euler parameters against conservation laws and closed forms.

1. Torque-free asymmetric body spun near its intermediate axis (it flips, the
   Dzhanibekov effect): energy and the world angular momentum are conserved, the
   quaternion stays unit.
2. Torque-free axisymmetric body (``I1 = I2``): Euler's equations give
   ``w1' = -W w2``, ``w2' = W w1`` with ``W = (I3 - I1)/I1 w3``, so the body-frame
   angular velocity precesses: ``w1 + i w2 = w0 exp(i W t)``, ``w3`` constant.
3. Heavy symmetric top on a ball joint at a fixed pivot, in steady precession:
   with ``theta`` the tilt, ``w3`` the spin component and ``I1`` the transverse
   inertia about the pivot, the Lagrangian in Euler angles gives the condition
   ``m g l = w3 I3 phi' - I1 phi'^2 cos(theta)`` (e.g. Goldstein, sec. 5.7).
   The pivot reaction is then ``m (a - g)`` with the centripetal
   ``a = -phi'^2 l sin(theta) e_r``, and its torque about the pivot vanishes.
"""

from __future__ import annotations

import numpy as np
import pytest

from dalembert.multibody import (
    Ground,
    Multibody,
    RigidBody,
    Spherical,
    angular_momentum,
    angular_velocities,
    energy,
    joint_reactions,
    point_positions,
)
from dalembert.multibody.rotations import elementary_rotation


@pytest.mark.validation
def test_intermediate_axis_flip_conserves_energy_and_momentum():
    body = RigidBody("body", 2.0, [[1.0, 0.05, 0.0], [0.05, 2.0, 0.0], [0.0, 0.0, 3.0]])
    mb = Multibody([body], gravity=(0.0, 0.0, 0.0))
    # principal axes of the (non-diagonal) tensor: spin close to the middle one
    _, vecs = np.linalg.eigh(body.inertia)
    w0 = 2.0 * vecs[:, 1] + 1e-3 * vecs[:, 0] + 1e-3 * vecs[:, 2]
    q0, qd0 = mb.initial_state(angular_velocities={body: w0}, angular_velocity_frame="body")
    traj = mb.simulate((0.0, 100.0), q0, qd0)
    assert traj.success
    # it flips: the spin about the middle axis reverses sign
    w_mid = angular_velocities(mb, traj, body, "body") @ vecs[:, 1]
    assert w_mid.min() < -1.9 and w_mid.max() > 1.9
    E = energy(mb, traj)
    H = angular_momentum(mb, traj)
    assert np.abs(E - E[0]).max() / E[0] < 1e-10
    assert np.abs(H - H[0]).max() / np.linalg.norm(H[0]) < 1e-10
    b = np.column_stack([traj[f"body_b{i}"] for i in range(4)])
    assert np.abs(np.linalg.norm(b, axis=1) - 1).max() <= 1e-13
    # the core's own energy (from the symbolic T) agrees with the numeric one
    assert np.abs(traj.energy - E).max() < 1e-12 * E[0]


@pytest.mark.validation
def test_axisymmetric_body_precession_in_body_frame():
    I1, I3, w3, w0 = 1.0, 1.6, 3.0, 0.4
    body = RigidBody("disk", 1.5, (I1, I1, I3))
    mb = Multibody([body], gravity=(0.0, 0.0, 0.0))
    R0 = elementary_rotation("x", 0.4) @ elementary_rotation("z", 1.0)
    q0, qd0 = mb.initial_state(orientations={body: R0}, angular_velocities={body: (w0, 0, w3)},
                               angular_velocity_frame="body")
    t = np.linspace(0.0, 10.0, 201)
    traj = mb.simulate((0.0, 10.0), q0, qd0, t_eval=t)
    w = angular_velocities(mb, traj, body, "body")
    W = (I3 - I1) / I1 * w3
    ref = np.column_stack([w0 * np.cos(W * t), w0 * np.sin(W * t), np.full_like(t, w3)])
    assert np.abs(w - ref).max() < 1e-9


def top_state(mb, top, theta, l, phi_dot, w3):
    """Tilted about world y by ``theta``; precessing at ``phi_dot`` about world z."""
    R = elementary_rotation("y", theta)
    k = R[:, 2]
    psi_dot = w3 - phi_dot * np.cos(theta)
    w = np.array([0.0, 0.0, phi_dot]) + psi_dot * k
    x = l * k
    return mb.initial_state(positions={top: x}, orientations={top: R},
                            velocities={top: np.cross(w, x)}, angular_velocities={top: w})


@pytest.mark.validation
@pytest.mark.parametrize("root", ["slow", "fast"])
def test_heavy_top_steady_precession_and_pivot_reaction(root):
    m, l, I1c, I3, g = 1.0, 0.2, 0.03, 0.04, 9.81
    theta, w3 = 0.5, 50.0
    top = RigidBody("top", m, (I1c, I1c, I3))
    pivot = Spherical("pivot", Ground(), top, point_b=(0.0, 0.0, -l))
    mb = Multibody([top], [pivot], gravity=(0.0, 0.0, -g))
    I1 = I1c + m * l**2
    a, b, c = I1 * np.cos(theta), -I3 * w3, m * g * l
    disc = np.sqrt(b * b - 4 * a * c)
    phi_dot = (-b - disc) / (2 * a) if root == "slow" else (-b + disc) / (2 * a)
    q0, qd0 = top_state(mb, top, theta, l, phi_dot, w3)
    t = np.linspace(0.0, 3.0, 121)
    traj = mb.simulate((0.0, 3.0), q0, qd0, t_eval=t)
    axis = point_positions(mb, traj, top) / l
    tilt = np.arccos(np.clip(axis[:, 2], -1, 1))
    azimuth = np.unwrap(np.arctan2(axis[:, 1], axis[:, 0]))
    assert np.abs(tilt - theta).max() < 1e-8
    assert np.abs(azimuth - phi_dot * t).max() < 1e-8 * max(1.0, phi_dot * t[-1])
    # pivot reaction on the top: m (a - g), no torque about the pivot
    rho = l * np.sin(theta)
    e_r = np.column_stack([np.cos(phi_dot * t), np.sin(phi_dot * t), 0 * t])
    F_ref = -m * phi_dot**2 * rho * e_r + np.array([0.0, 0.0, m * g])
    reaction = joint_reactions(mb, traj)["pivot"]
    scale = np.abs(F_ref).max()
    assert np.abs(reaction["top"].force_world - F_ref).max() < 1e-8 * scale
    assert np.abs(reaction["top"].torque_world).max() < 1e-8 * scale * l
    assert np.abs(reaction["ground"].force_world + F_ref).max() < 1e-8 * scale
    # body frame: the axial component (along body z, the symmetry axis at tilt theta)
    # and the transverse magnitude do not depend on the spin angle
    k = np.column_stack([np.sin(theta) * np.cos(phi_dot * t),
                         np.sin(theta) * np.sin(phi_dot * t), np.full_like(t, np.cos(theta))])
    axial = np.einsum("ki,ki->k", F_ref, k)
    transverse = np.sqrt(np.einsum("ki,ki->k", F_ref, F_ref) - axial**2)
    F_body = reaction["top"].force_body
    assert np.abs(F_body[:, 2] - axial).max() < 1e-8 * scale
    assert np.abs(np.hypot(F_body[:, 0], F_body[:, 1]) - transverse).max() < 1e-8 * scale
