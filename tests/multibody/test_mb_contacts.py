"""Contacts of a Multibody (``multibody/contacts.py``), run event-driven.

References (closed forms): a ball on a floor (impact times ``t_1 (1 + 2 sum e^j)``);
a 3D rod (a quaternion rigid body) falling tilted without rotation onto a floor, its
lower end striking first: the impulse from Newton's law at the end and the angular
momentum balance about the centre (``P = (1 + e) v / (1/m + r_x^2 / I)``,
``w+ = r_x P / I``), the same formula as the hand-written rod of
``tests/solvers/contact``; two spheres colliding head on (momentum, Newton's law on the
relative velocity).
"""

from __future__ import annotations

import numpy as np
import pytest
import sympy as sp

from dalembert import ModelError
from dalembert.multibody import (
    Ground,
    Multibody,
    Particle,
    RigidBody,
    plane_contact,
    sphere_contact,
)
from dalembert.multibody.rotations import G_matrix

g = 9.81


def test_ball_on_a_floor_bounces_at_the_closed_form_times():
    ball = Particle("ball", 1.0)
    mb = Multibody([ball], contacts=[plane_contact("floor", Ground(), ball, radius=0.1,
                                                   restitution=0.8)])
    q0, qd0 = mb.initial_state(positions={"ball": (0, 0, 1.1)},
                               velocities={"ball": (0.3, 0, 0)})
    traj = mb.simulate((0.0, 2.0), q0, qd0)
    t1 = np.sqrt(2 / g)
    expected = t1 + 2 * t1 * np.cumsum(np.r_[0.0, 0.8 ** np.arange(1, 3)])
    assert np.abs(traj.contacts.impact_times - expected).max() < 1e-12
    assert traj["ball_z"].min() > 0.1 - 1e-14  # the sphere never enters the floor
    assert np.abs(traj["ball_x"] - 0.3 * traj.t).max() < 1e-12  # frictionless


@pytest.mark.parametrize("e", [0.0, 1.0])
def test_rod_striking_with_one_end(e):
    m, L, theta, h = 2.0, 1.5, 0.4, 0.3
    inertia = m * L**2 / 12
    rod = RigidBody("rod", m, np.diag([1e-3, inertia, inertia]))  # along body x
    ends = [plane_contact(f"end{k}", Ground(), rod, point=(s * L / 2, 0, 0),
                          restitution=e) for k, s in enumerate((-1, 1))]
    mb = Multibody([rod], contacts=ends, gravity=(0, 0, -g))
    # turned about y so that body x points along (c, 0, s): the end at -L/2 is the lower
    # one, h above the floor
    c, s = np.cos(theta), np.sin(theta)
    R = np.array([[c, 0, -s], [0, 1, 0], [s, 0, c]])  # x -> (c, 0, s)
    centre = np.array([0.0, 0.0, h + L / 2 * s])
    q0, qd0 = mb.initial_state(positions={"rod": centre}, orientations={"rod": R})
    traj = mb.simulate((0.0, np.sqrt(2 * h / g) + 1e-3), q0, qd0)
    first = traj.contacts.impacts[0]
    v = np.sqrt(2 * g * h)
    assert abs(first.t - np.sqrt(2 * h / g)) < 1e-12
    # the lower end at r = -L/2 (c, 0, s) from the centre; the impulse P along z
    r_x = -L / 2 * c
    P = (1 + e) * v / (1 / m + r_x**2 / inertia)
    names = traj.coordinate_names
    qd = dict(zip(names, first.qd_after))  # the velocity of each coordinate
    b = np.array([dict(zip(names, traj.q[0]))[f"rod_b{k}"] for k in range(4)])  # unturned
    w = 2 * G_matrix(b) @ np.array([qd[f"rod_b{k}"] for k in range(4)])
    assert abs(qd["rod_z"] - (-v + P / m)) < 1e-10
    # w_y: the z-impulse at x-offset r_x gives a moment about y of -r_x P
    assert abs(w[1] - (-r_x * P / inertia)) < 1e-10
    assert abs(first.impulses[0] - P) < 1e-10 and first.impulses[1] == 0.0


def test_two_spheres_collide_head_on():
    a, b = Particle("a", 1.0), Particle("b", 3.0)
    mb = Multibody([a, b], contacts=[sphere_contact("touch", a, b, 0.1, 0.2,
                                                    restitution=0.5)], gravity=(0, 0, 0))
    q0, qd0 = mb.initial_state(positions={"a": (0, 0, 0), "b": (1.0, 0, 0)},
                               velocities={"a": (2.0, 0, 0)})
    traj = mb.simulate((0.0, 1.0), q0, qd0)
    assert abs(traj.contacts.impact_times[0] - 0.7 / 2.0) < 1e-12
    va, vb = traj["a_x_dot"][-1], traj["b_x_dot"][-1]
    assert abs(va + 3 * vb - 2.0) < 1e-12  # momentum
    assert abs((vb - va) - 0.5 * 2.0) < 1e-12  # Newton's law on the relative velocity


def test_contact_bad_input_is_named():
    ball = Particle("ball", 1.0)
    with pytest.raises(ModelError, match="contact 'floor': the restitution"):
        plane_contact("floor", Ground(), ball, restitution=2.0)
    with pytest.raises(ModelError, match="contact 'floor': the radius"):
        plane_contact("floor", Ground(), ball, radius=-1.0)
    with pytest.raises(ModelError, match="contact 'touch': the radius_a"):
        sphere_contact("touch", ball, Particle("b", 1.0), 0.0, 0.1)
    other = Particle("stranger", 1.0)
    with pytest.raises(ModelError, match="contact 'floor'"):
        Multibody([ball], contacts=[plane_contact("floor", Ground(), other)])
    e = sp.Symbol("e")
    mb = Multibody([ball], contacts=[plane_contact("floor", Ground(), ball, restitution=e)],
                   parameters={e: 0.5})
    assert e in mb.parameters


@pytest.mark.parametrize("e", [0.0, 0.5])
def test_pendulum_against_a_joint_limit(e):
    """A link on a hinge released at ``theta0`` swings down onto its lower stop (above
    the hanging position): it arrives with the energy's rate
    ``w^2 = 2 m g d (cos(lower) - cos(theta0)) / I_hinge`` and leaves at ``-e`` times
    it; plastic (e = 0), it rests on the stop, gravity pressing it there."""
    from dalembert.multibody import Revolute, joint_limit, joint_positions, joint_velocities

    m, d, theta0, lower = 1.5, 0.4, 1.0, 0.3
    inertia = 0.02  # about the centre, for the hinge's axis
    link = RigidBody("link", m, (inertia, inertia, inertia))
    hinge = Revolute("hinge", Ground(), link, (0, 0, 0), (0, 0, d), axis_a=(0, 1, 0))
    stop = joint_limit("stop", hinge, lower, 1.2, restitution=e)
    mb = Multibody([link], [hinge], contacts=[stop], gravity=(0, 0, -g))
    c, s = np.cos(theta0), np.sin(theta0)
    R = np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])  # turned by theta0 about y
    q0, qd0 = mb.initial_state(positions={"link": R @ (0, 0, -d)}, orientations={"link": R})
    traj = mb.simulate((0.0, 1.5), q0, qd0)
    assert traj.success, traj.message
    first = traj.contacts.impacts[0]
    names = traj.coordinate_names
    angle = joint_positions(mb, dict(zip(names, traj.q[0])), joints=["hinge"])
    assert abs(angle.array[0] - theta0) < 1e-12  # the angle is measured as we set it
    # at the impact: on the stop, the closed-form rate before, -e times it after
    before = joint_velocities(mb, _state(names, traj, first.t), dict(zip(names, first.qd_before)),
                              joints=["hinge"]).array[0]
    after = joint_velocities(mb, _state(names, traj, first.t), dict(zip(names, first.qd_after)),
                             joints=["hinge"]).array[0]
    rate = np.sqrt(2 * m * g * d * (np.cos(lower) - np.cos(theta0)) / (inertia + m * d**2))
    assert abs(before + rate) < 1e-9 and abs(after - e * rate) < 1e-9
    final = joint_positions(mb, dict(zip(names, traj.q[-1])), joints=["hinge"]).array[0]
    if e == 0.0:  # at rest on the stop from the impact on
        assert [s.closed for s in traj.contacts.switches] == [(), (0,)]
        assert abs(final - lower) < 1e-12
    else:  # bounced (and at rest on the stop after the bounces below rest_speed)
        assert lower - 1e-12 < final < 1.2


def _state(names, traj, t):
    """The positions at ``t`` (unchanged through an impact): the switch recorded there."""
    switch = next(s for s in traj.contacts.switches if s.t == t)
    return dict(zip(names, switch.q))
