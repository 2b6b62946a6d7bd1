"""Joints, loads and reactions against closed forms; input errors name the culprit.

Independent answers: a tilted hinge reduces to ``I_n th'' = m g . (n x rho)``
(``rho`` from the hinge to the mass center, ``I_n`` the inertia about the axis,
integrated here with solve_ivp); a slider on an incline accelerates at ``g . a``;
a particle on a plane at ``g - (g . n) n``; a welded body is in static equilibrium
(the joint force is ``-m g``, its torque about the weld point
``-(x - P) x m g``); a damped spring is the closed-form damped oscillator;
constant or sinusoidal torques about a principal axis integrate by hand.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from dalembert import ConstraintError, InitialConditionError, InitialConditionsAdjusted, ModelError
from dalembert import t as time
from dalembert.multibody import (
    Distance,
    Fixed,
    Force,
    Ground,
    Multibody,
    Particle,
    PointOnPlane,
    Prismatic,
    Revolute,
    RigidBody,
    Spherical,
    SpringDamper,
    Torque,
    angular_velocities,
    chain,
    joint_reactions,
    point_positions,
    rotation_matrices,
)
from dalembert.multibody.rotations import elementary_rotation

G = np.array([0.0, 0.0, -9.81])


def rodrigues(n, th):
    K = np.array([[0, -n[2], n[1]], [n[2], 0, -n[0]], [-n[1], n[0], 0]])
    return np.eye(3) + np.sin(th) * K + (1 - np.cos(th)) * K @ K


@pytest.mark.validation
def test_tilted_revolute_pendulum_and_newton_reaction():
    m, I = 1.5, np.diag([0.02, 0.03, 0.04])
    n = np.array([1.0, 0.0, 1.0]) / np.sqrt(2)   # hinge axis on ground (world)
    s = np.array([0.1, 0.0, -0.3])               # hinge point -> mass center... in body
    P = np.array([0.2, -0.1, 0.5])
    body = RigidBody("door", m, I)
    # body y axis along n at the start: R0 maps (0, 1, 0) to n
    R0 = np.column_stack([np.cross(n, [0, 1.0, 0]) / np.linalg.norm(np.cross(n, [0, 1.0, 0])),
                          n, np.zeros(3)])
    R0[:, 2] = np.cross(R0[:, 0], R0[:, 1])
    hinge = Revolute("hinge", Ground(), body, point_a=P, point_b=-s, axis_a=n, axis_b=(0, 1, 0))
    mb = Multibody([body], [hinge], gravity=G)
    th0, thd0 = 0.3, 1.2
    R = rodrigues(n, th0) @ R0
    rho = R @ s
    q0, qd0 = mb.initial_state(positions={body: P + rho}, orientations={body: R},
                               velocities={body: thd0 * np.cross(n, rho)},
                               angular_velocities={body: thd0 * n})
    t = np.linspace(0, 2.0, 41)
    traj = mb.simulate((0, 2.0), q0, qd0, t_eval=t)

    In = n @ (R0 @ I @ R0.T) @ n + m * (s @ s - (n @ R0 @ s) ** 2)

    def rhs(_, y):
        rho = rodrigues(n, y[0]) @ R0 @ s
        return [y[1], m * G @ np.cross(n, rho) / In]

    sol = solve_ivp(rhs, (0, 2.0), [th0, thd0], method="DOP853", rtol=1e-12, atol=1e-12,
                    t_eval=t)
    x_ref = np.array([P + rodrigues(n, th) @ R0 @ s for th in sol.y[0]])
    assert np.abs(point_positions(mb, traj, body) - x_ref).max() < 1e-9
    # Newton for the mass center: joint force = m a - m g
    a = np.column_stack([traj[f"door_{c}_ddot"] for c in "xyz"])
    F = joint_reactions(mb, traj)["hinge"]["door"].force_world
    assert np.abs(F - m * (a - G)).max() < 1e-9


@pytest.mark.validation
def test_prismatic_slider_on_incline():
    m, ang = 2.0, np.radians(30)
    a = np.array([np.cos(ang), 0.0, np.sin(ang)])
    block = RigidBody("block", m, (0.1, 0.2, 0.3))
    offset = np.array([0.1, 0.0, 0.2])           # joint point on the block (body frame)
    slider = Prismatic("slider", Ground(), block, point_b=offset, axis_a=a, ref_a=(0, 1, 0),
                       axis_b=a, ref_b=(0, 1, 0))
    mb = Multibody([block], [slider], gravity=G)
    v0 = 0.7
    q0, qd0 = mb.initial_state(positions={block: -offset}, velocities={block: v0 * a})
    t = np.linspace(0, 1.5, 16)
    traj = mb.simulate((0, 1.5), q0, qd0, t_eval=t)
    s = v0 * t + 0.5 * (G @ a) * t**2
    x_ref = -offset + s[:, None] * a
    assert np.abs(point_positions(mb, traj, block) - x_ref).max() < 1e-10
    assert np.abs(rotation_matrices(mb, traj, block) - np.eye(3)).max() < 1e-12
    F_ref = m * ((G @ a) * a - G)                 # m a_cm - m g
    r = joint_reactions(mb, traj)["slider"]
    assert np.abs(r["block"].force_world - F_ref).max() < 1e-10
    # no rotation: zero torque about the mass center, so about P it is -(P - x) x F
    assert np.abs(r["block"].torque_cm_world).max() < 1e-10
    assert np.abs(r["block"].torque_world + np.cross(offset, F_ref)).max() < 1e-10


@pytest.mark.validation
def test_welded_body_statics():
    # a beam welded to a post that slides freely along world x: at rest, gravity has no
    # x component, so the pair stays in static equilibrium
    m = 3.0
    post = RigidBody("post", 1.0, (0.2, 0.2, 0.1))
    beam = RigidBody("beam", m, (0.5, 0.4, 0.3))
    P = np.array([0.0, 0.0, 1.0])
    s = np.array([0.6, 0.2, -0.1])               # weld point -> beam mass center
    slide = Prismatic("slide", Ground(), post, axis_a=(1, 0, 0), ref_a=(0, 1, 0))
    weld = Fixed("weld", post, beam, point_a=P, point_b=-s)
    mb = Multibody([post, beam], [slide, weld], gravity=G)
    q0, qd0 = mb.initial_state(positions={beam: P + s})
    traj = mb.simulate((0, 1.0), q0, qd0, t_eval=np.linspace(0, 1, 5))
    assert np.abs(point_positions(mb, traj, beam) - (P + s)).max() < 1e-12
    r = joint_reactions(mb, traj)["weld"]
    assert np.abs(r["beam"].force_world - (-m * G)).max() < 1e-10
    assert np.abs(r["beam"].torque_world - (-np.cross(s, m * G))).max() < 1e-10
    assert np.abs(r["post"].force_world - m * G).max() < 1e-10
    assert np.abs(r["post"].torque_world - np.cross(s, m * G)).max() < 1e-10


@pytest.mark.validation
def test_particle_on_inclined_plane_and_normal_force():
    m = 0.8
    nrm = np.array([0.0, np.sin(0.4), np.cos(0.4)])
    bead = Particle("bead", m)
    plane = PointOnPlane("plane", Ground(), bead, normal=nrm, point_a=(0, 0, 0.5))
    mb = Multibody([bead], [plane], gravity=G)
    v0 = np.array([0.3, 0.0, 0.0])
    x0 = np.array([0.0, 0.0, 0.5])
    t = np.linspace(0, 1.0, 11)
    traj = mb.simulate((0, 1.0), *mb.initial_state(positions={bead: x0}, velocities={bead: v0}),
                       t_eval=t)
    acc = G - (G @ nrm) * nrm
    x_ref = x0 + np.outer(t, v0) + 0.5 * np.outer(t**2, acc)
    assert np.abs(point_positions(mb, traj, bead) - x_ref).max() < 1e-11
    F = joint_reactions(mb, traj)["plane"]["bead"].force_world
    assert np.abs(F - (-m * (G @ nrm) * nrm)).max() < 1e-11


@pytest.mark.validation
def test_damped_spring_closed_form():
    m, k, c, L0 = 1.3, 20.0, 0.5, 1.0
    bob = Particle("bob", m)
    spring = SpringDamper("spring", Ground(), bob, stiffness=k, rest_length=L0, damping=c)
    mb = Multibody([bob], springs=[spring], gravity=G)
    z0 = -1.2
    t = np.linspace(0, 3.0, 31)
    traj = mb.simulate((0, 3.0), *mb.initial_state(positions={bob: (0, 0, z0)}), t_eval=t)
    ze = -(L0 + m * 9.81 / k)
    w0, zeta = np.sqrt(k / m), c / (2 * np.sqrt(k * m))
    wd = w0 * np.sqrt(1 - zeta**2)
    A = z0 - ze
    z_ref = ze + np.exp(-zeta * w0 * t) * (A * np.cos(wd * t) + zeta * w0 * A / wd * np.sin(wd * t))
    assert np.abs(traj["bob_z"] - z_ref).max() < 1e-10
    assert np.abs(traj["bob_x"]).max() < 1e-14


@pytest.mark.validation
def test_body_and_world_torques_and_follower_force():
    I3, m = 0.5, 2.0
    spun = RigidBody("spun", m, (0.3, 0.4, I3))
    pushed = RigidBody("pushed", m, (0.3, 0.4, I3))
    w = 1.7
    loads = dict(
        torques=[Torque(spun, (0, 0, 0.2), frame="body"),
                 Torque(spun, (0, 0, 0.3 * __import__("sympy").sin(time)), frame="world")],
        forces=[Force(pushed, (1.0, 0.0, 0.0), frame="body")],
    )
    mb = Multibody([spun, pushed], gravity=(0, 0, 0), **loads)
    q0, qd0 = mb.initial_state(angular_velocities={pushed: (0, 0, w)})
    t = np.linspace(0, 2.0, 21)
    traj = mb.simulate((0, 2.0), q0, qd0, t_eval=t)
    # spun: w_z = (0.2 t + 0.3 (1 - cos t)) / I3, angle = its integral
    wz = (0.2 * t + 0.3 * (1 - np.cos(t))) / I3
    angle = (0.1 * t**2 + 0.3 * (t - np.sin(t))) / I3
    assert np.abs(angular_velocities(mb, traj, spun)[:, 2] - wz).max() < 1e-10
    R_ref = np.array([elementary_rotation("z", a) for a in angle])
    assert np.abs(rotation_matrices(mb, traj, spun) - R_ref).max() < 1e-10
    # pushed: body-x force while spinning at w: v = (sin wt, 1 - cos wt) / (m w)
    v_ref = np.column_stack([np.sin(w * t), 1 - np.cos(w * t), 0 * t]) / (m * w)
    v = np.column_stack([traj[f"pushed_{c}_dot"] for c in "xyz"])
    assert np.abs(v - v_ref).max() < 1e-10


@pytest.mark.validation
def test_joint_reactions_between_bodies_are_equal_and_opposite():
    mb = chain(2, 1.0, 1.0, 0.05, joint="spherical")
    l1, l2 = mb.body("link1"), mb.body("link2")
    R1 = elementary_rotation("x", 0.5)
    R2 = elementary_rotation("y", -0.4)
    top2 = R1 @ [0, 0, -1.0]
    q0, qd0 = mb.initial_state(
        positions={l1: R1 @ [0, 0, -0.5], l2: top2 + R2 @ [0, 0, -0.5]},
        orientations={l1: R1, l2: R2}, angular_velocities={l1: (0, 0, 3.0), l2: (1.0, 0, 0)})
    with pytest.warns(InitialConditionsAdjusted):  # the rates are made consistent
        traj = mb.simulate((0, 1.0), q0, qd0, t_eval=np.linspace(0, 1, 11))
    r = joint_reactions(mb, traj)["joint2"]
    F1, F2 = r["link1"].force_world, r["link2"].force_world
    scale = np.abs(F1).max()
    assert scale > 1.0
    assert np.abs(F1 + F2).max() < 1e-10 * scale
    assert np.abs(r["link1"].torque_world).max() < 1e-10 * scale
    assert np.abs(r["link2"].torque_world).max() < 1e-10 * scale


# -- bad input ---------------------------------------------------------------------------
def test_inertia_must_be_positive_definite():
    with pytest.raises(ModelError, match=r"'slab'.*not positive definite"):
        RigidBody("slab", 1.0, (1.0, 1.0, 0.0))
    with pytest.raises(ModelError, match=r"'slab'.*symmetric"):
        RigidBody("slab", 1.0, [[1, 0.5, 0], [0, 1, 0], [0, 0, 1]])
    with pytest.raises(ModelError, match="mass of 'slab'"):
        RigidBody("slab", -1.0, (1, 1, 1))


def test_joint_to_a_body_not_in_the_system():
    a, stray = RigidBody("a", 1.0, (1, 1, 1)), RigidBody("stray", 1.0, (1, 1, 1))
    with pytest.raises(ModelError, match=r"joint 'hinge'.*'stray'.*not in this system"):
        Multibody([a], [Revolute("hinge", a, stray)])


def test_quaternion_normalized_with_report_and_zero_rejected():
    body = RigidBody("b", 1.0, (1, 1, 1))
    mb = Multibody([body])
    with pytest.warns(InitialConditionsAdjusted, match="'b' had norm 2"):
        q0, _ = mb.initial_state(orientations={body: (2.0, 0, 0, 0)})
    assert q0["b_b0"] == 1.0
    with pytest.raises(InitialConditionError, match="quaternion of 'b' is zero"):
        mb.initial_state(orientations={"b": (0, 0, 0, 0)})
    with pytest.raises(InitialConditionError, match=r"orientation of 'b'.*orthonormal"):
        mb.initial_state(orientations={"b": 2 * np.eye(3)})


def test_too_many_constraints_named():
    """Counts alone decide nothing (loops have dependent rows): the rank at the start does."""
    body = RigidBody("b", 1.0, (1, 1, 1))
    joints = [Fixed("weld", Ground(), body), Revolute("hinge", Ground(), body)]
    mb = Multibody([body], joints)
    q0, qd0 = mb.initial_state()
    with pytest.raises(ConstraintError, match=r"no degree of freedom.*7 independent rows on 7 "
                       r"coord.*weld \(Fixed: 6 rows\); hinge \(Revolute: 5 rows; rows hinge_1"):
        mb.simulate((0.0, 1.0), q0, qd0)


def test_orientation_joint_on_a_particle_is_rejected():
    p = Particle("p", 1.0)
    with pytest.raises(ModelError, match=r"joint 'hinge'.*particle"):
        Revolute("hinge", Ground(), p)
    with pytest.raises(ModelError, match="particle 'p' has no extent"):
        Spherical("ball", Ground(), p, point_b=(1, 0, 0)).equations()


def test_constraint_names_and_counts():
    a, b = RigidBody("a", 1.0, (1, 1, 1)), RigidBody("b", 1.0, (1, 1, 1))
    counts = {Spherical: 3, Revolute: 5, Prismatic: 5, Fixed: 6}
    for cls, k in counts.items():
        j = cls("j", a, b)
        assert [c.name for c in j.constraints()] == [f"j_{i}" for i in range(1, k + 1)]
    assert len(Distance("d", a, b, 1.0).constraints()) == 1
    mb = Multibody([a, b], [Spherical("ball", a, b)])
    assert mb.system.constraint_names[:2] == ("a_unit_quaternion", "b_unit_quaternion")
