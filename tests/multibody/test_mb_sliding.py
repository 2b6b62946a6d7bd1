"""Coulomb friction on a Multibody's contacts in the event-driven contact mode (the
sliding contacts' friction as loads, ``multibody/contacts.py`` ``SlidingFriction``).

References (closed forms): a disk launched sliding upright without spin rolls from
``t = v0 / (3 mu g)`` at ``2/3 v0`` (its moment about the axis ``m r^2 / 2``); a sphere
launched sliding in any direction on a plane rolls from ``2 |v0| / (7 mu g)`` at
``5/7 v0`` (its sliding velocity keeps its direction and shrinks at ``7/2 mu g``); a
ball rolling off a rough dome from rest at ``theta0`` leaves it at
``cos(theta) = 10/17 cos(theta0)``. A particle sliding on a sphere in space (its
sliding velocity three world components of rank 2) against its sliding equations
integrated by SciPy. The bodies turn through quaternions, so the values hold to the
integration's tolerance.
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


DOME, BEAD = 1.0, 0.05  # radii of a fixed sphere and of a particle's sphere on it
REACH = DOME + BEAD


def on_the_dome(theta0: float, v0: float = 0.0):
    """A particle (a sphere of radius ``BEAD``) on a fixed sphere, ``theta0`` from its
    top in the x-z plane, moving at ``v0`` along y; its contact's sliding velocity is
    three world components of rank 2."""
    bead = Particle("p", 1.0)
    mb = Multibody([bead], contacts=[sphere_contact("dome", Ground(), bead, DOME, BEAD,
                                                    friction=mu)])
    r0 = REACH * np.array([np.sin(theta0), 0.0, np.cos(theta0)])
    q0, qd0 = mb.initial_state(positions={"p": tuple(r0)}, velocities={"p": (0, v0, 0)})
    return mb, q0, qd0, r0


def test_a_particle_sliding_on_a_sphere_in_space_stops_and_sticks():
    """Against the sliding equations in Cartesian coordinates, integrated by SciPy:
    ``a = g + (N/m) (n - mu v/|v|)`` with ``N/m = g n_z - |v|^2 / L`` (the normal force
    that keeps it on the sphere); it stops where ``tan(theta) < mu`` and sticks."""
    from scipy.integrate import solve_ivp

    mb, q0, qd0, r0 = on_the_dome(0.1, 0.3)
    traj = mb.simulate((0.0, 0.5), q0, qd0)
    assert traj.success, traj.message

    def sliding(t, s):
        r, v = s[:3], s[3:]
        n = r / np.linalg.norm(r)
        normal = g * n[2] - v @ v / np.linalg.norm(r)
        return np.r_[v, np.array([0.0, 0.0, -g]) + normal * (n - mu * v / np.linalg.norm(v))]

    def stops(t, s):
        return np.linalg.norm(s[3:]) - 1e-12
    stops.terminal = True
    ref = solve_ivp(sliding, (0.0, 0.5), np.r_[r0, 0.0, 0.3, 0.0], method="DOP853",
                    rtol=1e-13, atol=1e-15, events=stops)
    (stop,) = [s.t for s in traj.contacts.switches[1:]]
    assert abs(stop - ref.t_events[0][0]) < 1e-9
    assert np.abs(traj.q[-1] - ref.y[:3, -1]).max() < 1e-9
    assert np.abs(traj.qd[traj.t >= stop]).max() < 1e-12  # stuck: tan(0.1) < mu


@pytest.mark.parametrize("theta0", [0.2, 0.5])  # tan 0.2 < mu = 0.3 < tan 0.5
def test_a_particle_at_rest_on_a_sphere_sticks_or_slides_down(theta0):
    """From rest it sticks where ``tan(theta0) < mu``; else it slides down its meridian,
    ``L theta'' = g sin(theta) - mu (g cos(theta) - L theta'^2)``."""
    from scipy.integrate import solve_ivp

    mb, q0, qd0, r0 = on_the_dome(theta0)
    traj = mb.simulate((0.0, 0.4), q0, qd0)
    assert traj.success, traj.message
    if np.tan(theta0) < mu:
        assert np.abs(traj.q[-1] - r0).max() < 1e-12
        return
    ref = solve_ivp(lambda t, s: [s[1], (g * np.sin(s[0]) - mu * (g * np.cos(s[0])
                                                                   - REACH * s[1] ** 2)) / REACH],
                    (0.0, 0.4), [theta0, 0.0], method="DOP853", rtol=1e-13, atol=1e-15)
    theta = ref.y[0, -1]
    assert np.abs(traj.q[-1] - REACH * np.array([np.sin(theta), 0.0, np.cos(theta)])).max() \
        < 1e-9


def test_a_ball_rolls_off_a_rough_dome_at_cos_theta_ten_seventeenths():
    """A ball (radius r, moment ``2/5 m r^2``) rolling without slipping from rest at
    ``theta0`` on a fixed sphere: ``7/10 v^2 = g L (cos(theta0) - cos(theta))`` and it
    leaves where ``g cos(theta) = v^2 / L``, at ``cos(theta) = 10/17 cos(theta0)``."""
    r = 0.1
    ball = RigidBody("ball", 1.0, np.eye(3) * 2 / 5 * r**2)
    mb = Multibody([ball], contacts=[sphere_contact("dome", Ground(), ball, DOME, r,
                                                    friction=np.inf)])
    reach, theta0 = DOME + r, 0.05
    q0, qd0 = mb.initial_state(
        positions={"ball": (reach * np.sin(theta0), 0.0, reach * np.cos(theta0))})
    traj = mb.simulate((0.0, 1.6), q0, qd0)
    assert traj.success, traj.message
    leaves = traj.contacts.switches[1]
    assert leaves.closed == ()
    x, _, z = leaves.q[:3]
    assert abs(z / np.hypot(x, z) - 10 / 17 * np.cos(theta0)) < 1e-10
    assert abs(leaves.q[1]) < 1e-12  # it rolls down its meridian


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
