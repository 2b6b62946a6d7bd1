"""A Multibody's numeric code, assembled part by part, equals the global derivation.

The reference is the route every plain System takes: the whole mechanism's
Lagrangian and constraints (``system.model``), derived and compiled as one
(:func:`dalembert.codegen.compiled.compile_equations`). Mechanisms cover every
joint type, particles and rigid bodies, rolling, and all loads (world/body forces,
a time-dependent torque, a spring-damper with and without rest length).
"""

from __future__ import annotations

import numpy as np
import pytest
import sympy as sp

from dalembert import DoubleCountingWarning
from dalembert import t as time
from dalembert.codegen.compiled import compile_equations
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
    Rolling,
    Spherical,
    SpringDamper,
    Torque,
    Universal,
    chain,
)
from dalembert.multibody.parts import multibody_parts


def every_joint():
    a = RigidBody("a", 1.2, (0.1, 0.2, 0.3))
    b = RigidBody("b", 0.8, [[0.2, 0.01, 0.0], [0.01, 0.3, 0.02], [0.0, 0.02, 0.25]])
    c = RigidBody("c", 1.2, (0.1, 0.2, 0.3))
    d = RigidBody("d", 0.5, (0.05, 0.05, 0.08))
    e = RigidBody("e", 1.0, (0.4, 0.4, 0.4))
    wheel = RigidBody("wheel", 2.0, (0.25, 0.5, 0.25))
    p, r = Particle("p", 0.3), Particle("r", 0.3)
    joints = [
        Revolute("hinge", Ground(), a, (0, 0, 1), (0, 0, 0.5), axis_a=(0, 1, 0)),
        Universal("cardan", a, b, (0, 0, -0.5), (0, 0, 0.5)),
        Prismatic("slider", b, c, (0, 0, -0.5), (0, 0, 0.5), axis_a=(0, 0, 1)),
        Fixed("weld", c, d, (0.1, 0, -0.5), (0, 0, 0.2)),
        Spherical("ball", d, e, (0, 0, -0.2), (0, 0, 0.4)),
        Distance("rod", e, p, 0.7, point_a=(0, 0, -0.4)),
        PointOnPlane("wall", Ground(), r, normal=(1, 1, 0)),
        Spherical("ball2", Ground(), p, (2, 0, -1)),
        Rolling("roll", wheel, 0.5, axis=(0, 1, 0)),
    ]
    loads = dict(
        forces=[Force(a, (0.3, 0, 0), point=(0, 0.1, 0), frame="body"),
                Force(p, (0, sp.sin(time), 0))],
        torques=[Torque(b, (0, 0, 0.2 * sp.cos(time)), frame="world"),
                 Torque(e, (0.1, 0, 0), frame="body")],
        springs=[SpringDamper("s1", Ground(), r, 3.0, 0.4, 0.2, point_a=(1, 0, 0)),
                 SpringDamper("s2", c, e, 5.0, 0.0, 0.1, point_a=(0, 0.1, 0))],
    )
    return Multibody([a, b, c, d, e, p, r, wheel], joints, **loads)


def assert_same_numerics(mb, rng, states=4):
    fast = mb.system.compiled
    whole = compile_equations(mb.system.equations())
    assert fast.holonomic_rows == whole.holonomic_rows
    p = np.zeros(0)
    for _ in range(states):
        t, q, qd = rng.normal(), rng.normal(size=fast.n), rng.normal(size=fast.n)
        pairs = [*zip(fast.kkt_blocks(t, q, qd, p), whole.kkt_blocks(t, q, qd, p)),
                 *zip(fast.velocity_constraint(t, q, p), whole.velocity_constraint(t, q, p)),
                 (fast.position_values(t, q, p), whole.position_values(t, q, p)),
                 (fast.energy_values(t, q, qd, p), whole.energy_values(t, q, qd, p))]
        for a, b in pairs:
            np.testing.assert_allclose(a, b, rtol=1e-12, atol=1e-12)


def test_every_joint_and_load_matches_the_global_derivation():
    mb = every_joint()
    assert mb.system.constraint_names == mb.system.model.constraints.names
    assert mb.system.coordinate_names == mb.system.model.coords.names
    assert_same_numerics(mb, np.random.default_rng(0))


@pytest.mark.parametrize("joint", ["spherical", "revolute"])
def test_chain_matches_the_global_derivation(joint):
    assert_same_numerics(chain(4, 1.0, 1.0, 0.05, joint=joint), np.random.default_rng(1))


def test_identical_links_share_one_part():
    """A chain has three kinds of piece: the link, the top joint, the joints between links."""
    parts = multibody_parts(chain(40, 1.0, 1.0, 0.05))
    assert sorted(p.instances for p in parts) == [1, 39, 40]
    mixed = Multibody([RigidBody("u", 1.0, (1, 2, 3)), RigidBody("v", 2.0, (1, 2, 3))])
    assert len(multibody_parts(mixed)) == 2  # different masses: two body kinds


def test_gravity_given_again_as_a_force_is_reported():
    bob = RigidBody("bob", 2.0, (1, 1, 1))
    mb = Multibody([bob], forces=[Force(bob, (0, 0, -2.0 * 9.81))])
    with pytest.warns(DoubleCountingWarning, match="counted twice"):
        mb.system.compiled  # noqa: B018


def test_rigid_body_rotation_rows_are_eulers_equations():
    """The Euler parameters' rows of a rigid body's ``f`` are the compact
    ``-4 E(bdot)^T J w`` (not the expanded cubic of the derivation), and the
    accelerations they give satisfy Euler's equations ``J wdot + w x J w = 0``
    (body frame, no torque) for a full inertia tensor."""
    J = np.array([[0.2, 0.01, -0.03], [0.01, 0.3, 0.02], [-0.03, 0.02, 0.25]])
    mb = Multibody([RigidBody("b", 0.8, J)], gravity=(0.0, 0.0, 0.0))
    (part,) = multibody_parts(mb)
    # the derivation's expanded rows have 276 operations each here
    assert all(sp.count_ops(row) < 150 for row in part.equations.f[3:7])
    rng = np.random.default_rng(5)
    for _ in range(5):
        b = rng.normal(size=4)
        b /= np.linalg.norm(b)
        bd = rng.normal(size=4)
        bd -= (bd @ b) * b  # on the unit sphere's tangent
        q, qd = np.r_[rng.normal(size=3), b], np.r_[rng.normal(size=3), bd]
        qdd, _ = mb.system.accelerations(0.0, q, qd)
        E = elementary_E(b)
        w, wdot = 2 * E @ bd, 2 * E @ qdd[3:]  # E(bd) bd = 0
        np.testing.assert_allclose(J @ wdot + np.cross(w, J @ w), 0.0, atol=1e-12)
        np.testing.assert_allclose(qdd[:3], 0.0, atol=1e-12)


def elementary_E(b: np.ndarray) -> np.ndarray:
    """``E(b)`` written out here (w_body = 2 E(b) bdot), independently of the package."""
    b0, b1, b2, b3 = b
    return np.array([[-b1, b0, b3, -b2], [-b2, -b3, b0, b1], [-b3, b2, -b1, b0]])
