"""A box dropped onto a floor with spin and sideways speed lands on a corner, rocks on
its edges, slides on its four corners turning, and comes to rest.

References (laws, not the code's own output):

- energy never rises: the impacts are plastic (``e = 0``) and friction, at impacts and
  in between, only dissipates, so the total energy (kinetic, and potential in gravity)
  at the output times is non-increasing, to rounding;
- at rest flat on its four corners, its energy is its potential ``m g C / 2`` (its
  centre ``C / 2`` above the floor) and its velocities 0;
- it never enters the floor (its corners' heights at least 0, to rounding).

The three drops (friction, height, sideways velocity, angular velocity) were drawn at
random; the first rocked on an edge until the contacts switched without end at one
instant, the second too, and the third gained energy (its onset's Newton's method
failed on the box coming to rest, and the friction forces of its start were kept)
and then crept at 5e-8 m/s.
"""

from __future__ import annotations

import numpy as np
import pytest

from dalembert.multibody import Ground, Multibody, RigidBody, plane_contact
from dalembert.multibody.outputs import energy

G, M, A, B, C = 9.81, 2.0, 0.2, 0.15, 0.1
CORNERS = [(sx * A / 2, sy * B / 2) for sx, sy in [(-1, -1), (1, -1), (1, 1), (-1, 1)]]

DROPS = [(0.1586, 0.1004, (-0.2036, -0.2381), (-2.605, -0.68, -2.487)),
         (0.2706, 0.1377, (-0.2669, 1.2198), (-0.674, -2.274, -9.976)),
         (0.7126, 0.1398, (-1.7601, -0.6785), (-2.357, -0.44, -2.71))]


@pytest.mark.parametrize("friction, height, velocity, spin", DROPS)
def test_a_box_dropped_with_spin_lands_and_comes_to_rest_losing_energy(friction, height,
                                                                       velocity, spin):
    inertia = M / 12 * np.diag([B**2 + C**2, A**2 + C**2, A**2 + B**2])
    body = RigidBody("box", M, inertia)
    corners = [plane_contact(f"c{k}", Ground(), body, point=(x, y, -C / 2), friction=friction)
               for k, (x, y) in enumerate(CORNERS)]
    box = Multibody([body], gravity=(0, 0, -G), contacts=corners)
    q0, qd0 = box.initial_state(positions={"box": (0, 0, C / 2 + height)},
                                velocities={"box": (*velocity, 0)},
                                angular_velocities={"box": spin})
    traj = box.simulate((0, 1.5), q0, qd0, t_eval=np.linspace(0, 1.5, 151))
    assert traj.success, traj.message
    assert len(traj.contacts.impacts) > 3  # it lands on a corner and rocks
    total = energy(box, traj)
    assert np.diff(total).max() < 1e-12 * total[0]
    assert abs(total[-1] - M * G * C / 2) < 1e-12
    assert np.abs(traj.qd[-1]).max() < 1e-10
    assert _lowest_corner(traj) > -1e-13


def _lowest_corner(traj) -> float:
    """The lowest height of a corner at the output times."""
    from scipy.spatial.transform import Rotation

    b = np.column_stack([traj[f"box_b{i}"] for i in (1, 2, 3, 0)])  # scalar last
    turns = Rotation.from_quat(b).as_matrix()
    points = np.array([(x, y, -C / 2) for x, y in CORNERS])
    heights = traj["box_z"][:, None] + np.einsum("tij,kj->tki", turns, points)[:, :, 2]
    return float(heights.min())
