"""A box on its four bottom corners in the time-stepping contact mode: four coplanar
contacts, whose normal impulses are not unique (the Delassus matrix's normal block
has rank 3), each with Coulomb friction.

References (closed forms): at rest the normal impulses add up to ``m g h`` a step;
sliding on the floor it decelerates at ``mu g`` (``v = v0 - mu g t``) and stops at
``v0 / (mu g)``, flat (no yaw, no tipping); on an incline it sticks when
``tan(alpha) < mu``, else slides at ``g (sin(alpha) - mu cos(alpha))``. A corner's
friction must oppose the sliding velocity it leaves: its tangential Delassus block is
anisotropic (the box's rotation couples the two tangents), and the sticking impulse
scaled onto the disk pushes askew (measured: the box yawed, braked at 0.94 mu g).
"""

from __future__ import annotations

import numpy as np
import pytest

from dalembert.multibody import Ground, Multibody, RigidBody, plane_contact
from dalembert.multibody.rotations import elementary_rotation

g, mu, H = 9.81, 0.5, 1e-3
A, B, C, M = 0.2, 0.15, 0.1, 2.0


def _box(alpha: float = 0.0) -> Multibody:
    inertia = M / 12 * np.diag([B**2 + C**2, A**2 + C**2, A**2 + B**2])
    box = RigidBody("box", M, inertia)
    normal = (-np.sin(alpha), 0.0, np.cos(alpha))
    corners = [plane_contact(f"c{k}", Ground(), box, normal=normal, friction=mu,
                             point=(sx * A / 2, sy * B / 2, -C / 2))
               for k, (sx, sy) in enumerate([(-1, -1), (1, -1), (1, 1), (-1, 1)])]
    return Multibody([box], gravity=(0, 0, -g), contacts=corners)


def _normals(traj) -> np.ndarray:
    return sum(traj.multiplier(f"c{k}_1") for k in range(4))


def test_a_box_dropped_flat_lands_and_rests_on_its_corners():
    mb = _box()
    q0, qd0 = mb.initial_state(positions={"box": (0, 0, C / 2 + 0.02)})
    traj = mb.simulate((0.0, 0.3), q0, qd0, contact_mode="time-stepping",
                       contact_step=H)
    assert traj.success, traj.message
    rest = traj.t > 0.15
    assert np.abs(_normals(traj)[rest] - M * g).max() < 1e-9  # impulse m g h a step
    assert np.abs(traj["box_z"][rest] - C / 2).max() < 1e-12
    for c in "xyz":
        assert np.abs(traj[f"box_{c}_dot"][rest]).max() < 1e-12


def test_a_box_sliding_on_its_corners_decelerates_at_mu_g_flat():
    v0 = 1.0
    mb = _box()
    q0, qd0 = mb.initial_state(positions={"box": (0, 0, C / 2)},
                               velocities={"box": (v0, 0, 0)})
    traj = mb.simulate((0.0, 0.3), q0, qd0, contact_mode="time-stepping",
                       contact_step=H)
    assert traj.success, traj.message
    stops = v0 / (mu * g)
    v = traj["box_x_dot"]
    sliding = traj.t < stops - H
    assert np.abs(v[sliding] - (v0 - mu * g * traj.t[sliding])).max() < 1e-9
    assert np.abs(v[traj.t > stops + H]).max() < 1e-12
    assert np.abs(traj["box_y_dot"]).max() < 1e-12  # no sideways drift
    assert np.abs(_normals(traj)[1:] - M * g).max() < 1e-9
    assert np.abs(traj["box_z"] - C / 2).max() < 1e-12  # not tipped, not lifted


@pytest.mark.parametrize("alpha", [0.4, 0.5])
def test_a_box_on_an_incline_sticks_or_slides(alpha):
    mb = _box(alpha)
    R = elementary_rotation("y", -alpha)
    q0, qd0 = mb.initial_state(positions={"box": R @ np.array([0.0, 0.0, C / 2])},
                               orientations={"box": R})
    traj = mb.simulate((0.0, 0.2), q0, qd0, contact_mode="time-stepping",
                       contact_step=H)
    assert traj.success, traj.message
    velocity = np.column_stack([traj[f"box_{c}_dot"] for c in "xyz"])
    down = R @ np.array([-1.0, 0.0, 0.0])  # along the slope, downhill
    # the normal impulses, split among the corners as they may, hold the weight's part
    # into the slope
    assert np.abs(_normals(traj)[1:] - M * g * np.cos(alpha)).max() < 1e-9
    if np.tan(alpha) < mu:
        assert np.abs(velocity).max() < 1e-12
    else:
        a = g * (np.sin(alpha) - mu * np.cos(alpha))
        assert np.abs(velocity @ down - a * traj.t).max() < 1e-9
        assert np.abs(velocity - np.outer(velocity @ down, down)).max() < 1e-9
