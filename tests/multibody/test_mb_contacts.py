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
