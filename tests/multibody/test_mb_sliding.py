"""Coulomb friction on a Multibody's contacts in the event-driven contact mode (the
sliding contacts' friction as loads, ``multibody/contacts.py`` ``SlidingFriction``).

References (closed forms): a disk launched sliding upright without spin rolls from
``t = v0 / (3 mu g)`` at ``2/3 v0`` (its moment about the axis ``m r^2 / 2``); a sphere
launched sliding in any direction on a plane rolls from ``2 |v0| / (7 mu g)`` at
``5/7 v0`` (its sliding velocity keeps its direction and shrinks at ``7/2 mu g``). The
bodies turn through quaternions, so the values hold to the integration's tolerance.
"""

from __future__ import annotations

import numpy as np
import pytest

from dalembert.multibody import (
    Ground,
    Multibody,
    Particle,
    RigidBody,
    disk_contact,
    plane_contact,
    sphere_contact,
)

g, mu = 9.81, 0.3


def test_a_disk_launched_sliding_rolls_from_v0_over_3_mu_g_at_two_thirds():
    r, v0 = 0.3, 1.5
    wheel = RigidBody("wheel", 1.0, np.diag([r**2 / 4, r**2 / 2, r**2 / 4]))  # axis y
    mb = Multibody([wheel], contacts=[disk_contact("rim", Ground(), wheel, r,
                                                   axis=(0, 1, 0), friction=mu)])
    q0, qd0 = mb.initial_state(positions={"wheel": (0, 0, r)},
                               velocities={"wheel": (v0, 0, 0)})
    traj = mb.simulate((0.0, 0.5), q0, qd0)
    assert traj.success, traj.message
    t_roll = traj.contacts.switches[1].t
    assert abs(t_roll - v0 / (3 * mu * g)) < 1e-10
    rolling = traj.t >= t_roll
    assert np.abs(traj["wheel_x_dot"][rolling] - 2 / 3 * v0).max() < 1e-10
    friction = traj.multiplier("rim_friction_1")
    assert np.abs(friction[~rolling] + mu * g).max() < 1e-10  # -mu m g while it slides
    assert np.abs(friction[rolling]).max() < 1e-10  # rolling on a level floor: none
    assert np.abs(traj.multiplier("rim_1") - g).max() < 1e-10


def test_a_sphere_launched_sliding_sideways_rolls_at_five_sevenths():
    r, v0 = 0.1, np.array([2.0, 1.0])
    ball = RigidBody("ball", 1.0, np.eye(3) * 0.4 * r**2)
    mb = Multibody([ball], contacts=[plane_contact("floor", Ground(), ball, radius=r,
                                                   friction=mu)])
    q0, qd0 = mb.initial_state(positions={"ball": (0, 0, r)},
                               velocities={"ball": (*v0, 0.0)})
    traj = mb.simulate((0.0, 0.5), q0, qd0)
    assert traj.success, traj.message
    t_roll = traj.contacts.switches[1].t
    assert abs(t_roll - 2 * np.linalg.norm(v0) / (7 * mu * g)) < 1e-10
    rolling = traj.t >= t_roll
    for k, axis in enumerate("xy"):
        assert np.abs(traj[f"ball_{axis}_dot"][rolling] - 5 / 7 * v0[k]).max() < 1e-10
    force = np.hypot(traj.multiplier("floor_friction_1"), traj.multiplier("floor_friction_2"))
    assert np.abs(force[~rolling] - mu * g).max() < 1e-10


def test_finite_friction_between_spheres_in_space_is_refused_event_driven():
    a, b = Particle("a", 1.0), Particle("b", 1.0)
    mb = Multibody([a, b], contacts=[sphere_contact("touch", a, b, 0.1, 0.1, friction=0.3)],
                   gravity=(0, 0, 0))
    q0, qd0 = mb.initial_state(positions={"a": (0, 0, 0), "b": (0.3, 0, 0)})
    with pytest.raises(ValueError, match=r"'touch' has finite friction between spheres in "
                                         r"space.*contact_mode='time-stepping'"):
        mb.simulate((0.0, 0.1), q0, qd0)


def test_a_box_sliding_on_four_corners_stops_flat_at_v0_over_mu_g():
    """Four coplanar corner contacts: their normal forces and, once it sticks, their
    friction forces are statically indeterminate; the motion is not. Sliding at
    ``v0`` (along x and y), the box decelerates at ``mu g`` and stops at
    ``|v0| / (mu g)``, ``|v0|^2 / (2 mu g)`` away, without tipping."""
    a, b, c = 0.4, 0.3, 0.2
    box = RigidBody("box", 1.0, np.diag([(b * b + c * c) / 3, (a * a + c * c) / 3,
                                         (a * a + b * b) / 3]))
    corners = [plane_contact(f"c{i}", Ground(), box, point=(sx * a, sy * b, -c), friction=mu)
               for i, (sx, sy) in enumerate([(1, 1), (1, -1), (-1, 1), (-1, -1)])]
    mb = Multibody([box], contacts=corners)
    v0 = np.array([2.0, 0.5])
    q0, qd0 = mb.initial_state(positions={"box": (0, 0, c)}, velocities={"box": (*v0, 0)})
    traj = mb.simulate((0.0, 1.0), q0, qd0)
    assert traj.success, traj.message
    speed = np.linalg.norm(v0)
    (t_stop,) = [s.t for s in traj.contacts.switches[1:]]
    assert abs(t_stop - speed / (mu * g)) < 1e-12
    travel = v0 * speed / (2 * mu * g)
    assert abs(traj["box_x"][-1] - travel[0]) < 1e-12
    assert abs(traj["box_y"][-1] - travel[1]) < 1e-12
    assert np.abs(traj["box_z"] - c).max() < 1e-12
    normal = sum(traj.multiplier(f"c{i}_1") for i in range(4))
    assert np.abs(normal - g).max() < 1e-10  # the weight, however it is shared
    friction = np.hypot(sum(traj.multiplier(f"c{i}_friction_1") for i in range(4)),
                        sum(traj.multiplier(f"c{i}_friction_2") for i in range(4)))
    sliding = traj.t < t_stop
    assert np.abs(friction[sliding] - mu * g).max() < 1e-10
    assert np.abs(friction[~sliding]).max() < 1e-10  # at rest on a level floor
