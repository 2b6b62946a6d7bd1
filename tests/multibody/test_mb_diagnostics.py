"""Bad multibody input: joint points in the wrong frame, joints that lock the mechanism.

A dependent but mobile mechanism (a door on two coaxial hinges, 10 hinge rows on
7 coordinates) must still be accepted: its degree of freedom is counted (its motion
is checked against the compound pendulum in ``test_loops.py``).
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from dalembert import ConstraintError
from dalembert.multibody import (
    Distance,
    Fixed,
    Ground,
    JointPointWarning,
    Multibody,
    Particle,
    Revolute,
    RigidBody,
    Spherical,
    check_mobility,
)
from dalembert.multibody.rotations import elementary_rotation

ROD = (0.01, 0.01, 0.0002)   # a slender rod of length ~0.35 and mass 1: gyration radius 0.1


def test_far_body_point_warns_naming_joint_and_body():
    rod = RigidBody("rod", 1.0, ROD)
    with pytest.warns(JointPointWarning, match=r"joint 'pin': point_b .* body 'rod', 50 times"):
        Multibody([rod], [Spherical("pin", Ground(), rod, point_b=(0.0, 0.0, 5.0))])
    with warnings.catch_warnings():
        warnings.simplefilter("error", JointPointWarning)   # a point at the rod's end is fine
        Multibody([rod], [Spherical("pin", Ground(), rod, point_b=(0.0, 0.0, 0.17))])


def test_world_point_given_for_a_body_point_is_diagnosed_at_the_initial_state():
    rod = RigidBody("rod", 1.0, ROD)
    # the pin is at world (0, 0, 1); the rod hangs below it, center at (0, 0, 0.8), turned
    R = elementary_rotation("x", np.pi)   # body z points down
    pin = Spherical("pin", Ground(), rod, point_a=(0.0, 0.0, 1.0), point_b=(0.0, 0.0, 1.0))
    mb = Multibody([rod], [pin])
    with pytest.warns(JointPointWarning, match=r"'pin'.*point_b \(0.0, 0.0, 1.0\) is where the "
                      r"joint is in world coordinates.*'rod': use point_b=\(0.0, 0.0, -0.2\)"):
        mb.initial_state(positions={rod: (0.0, 0.0, 0.8)}, orientations={rod: R})
    # the suggested point closes the joint
    ok = Multibody([rod], [Spherical("pin", Ground(), rod, (0.0, 0.0, 1.0), (0.0, 0.0, -0.2))])
    with warnings.catch_warnings():
        warnings.simplefilter("error", JointPointWarning)
        ok.initial_state(positions={rod: (0.0, 0.0, 0.8)}, orientations={rod: R})


def test_zero_freedom_names_every_joint():
    p = Particle("p", 1.0)
    rods = [Distance(f"rod{k}", Ground(), p, 1.0, point_a=a)
            for k, a in enumerate([(1, 0, 0), (0, 1, 0), (0, 0, 1)])]
    mb = Multibody([p], rods)
    q0, _ = mb.initial_state()
    with pytest.raises(ConstraintError, match=r"no degree of freedom.*rod0 \(Distance: 1 rows\);"
                       r" rod1 .*; rod2 "):
        check_mobility(mb, q0)


def test_zero_freedom_names_the_dependent_rows():
    # four rods on one particle: rank 3, the fourth rod's row depends on the first three
    p = Particle("p", 1.0)
    anchors = [(1, 0, 0), (0, 1, 0), (0, 0, 1), (1, 1, 1)]
    rods = [Distance(f"rod{k}", Ground(), p, float(np.linalg.norm(a)), point_a=a)
            for k, a in enumerate(anchors)]
    mb = Multibody([p], rods)
    q0, _ = mb.initial_state()
    with pytest.raises(ConstraintError, match=r"rank\(A\) = 3 independent rows on 3 coordinates"
                       r".*rod3 \(Distance: 1 rows; rows rod3_1 depend on the others\)"):
        check_mobility(mb, q0)


def test_door_on_two_coaxial_hinges_keeps_its_one_degree_of_freedom():
    # 10 hinge rows + 1 quaternion row on 7 coordinates, rank 6: mobile, not an error.
    # (Its motion against the compound pendulum is checked in test_loops.py.)
    body = RigidBody("door", 2.0, (0.2, 0.3, 0.1))
    joints = [Revolute(f"hinge{k}", Ground(), body, point_a=(0.0, 0.0, z),
                       point_b=(-0.4, 0.0, z), axis_a=(0.0, 0.0, 1.0))
              for k, z in enumerate([-0.3, 0.3])]
    mb = Multibody([body], joints)
    q0, _ = mb.initial_state(positions={"door": (0.4, 0.0, 0.0)})
    assert check_mobility(mb, q0) == 1


def test_fixed_body_elsewhere_still_builds():
    # a weld alone leaves zero freedom for its body, but a second free body keeps the system
    # mobile: no error
    a, b = RigidBody("a", 1.0, (1, 1, 1)), RigidBody("b", 1.0, (1, 1, 1))
    mb = Multibody([a, b], [Fixed("weld", Ground(), a)])
    q0, _ = mb.initial_state()
    assert check_mobility(mb, q0) == 6


def test_the_warnings_of_a_mechanism_point_at_the_callers_line():
    """InitialConditionsAdjusted and DeprecationWarning (native=) of Multibody.simulate,
    InitialConditionsAdjusted of initial_state, the
    RedundantConstraintsWarning of a ring, a JointPointWarning: at this file's lines."""
    rod = RigidBody("rod", 1.0, ROD)
    pin = Spherical("pin", Ground(), rod, (0.0, 0.0, 0.0), (0.0, 0.0, 0.17))
    mb = Multibody([rod], [pin])
    q0, _ = mb.initial_state(positions={rod: (0.0, 0.0, -0.2)})  # 0.03 off the pin
    calls = {
        "InitialConditionsAdjusted": lambda: mb.simulate((0.0, 0.01), q0),
        "DeprecationWarning": lambda: mb.simulate((0.0, 0.01), q0, native=False),
        "RedundantConstraintsWarning": lambda: ring_run(),
        "quaternion": lambda: mb.initial_state(orientations={rod: (2.0, 0.0, 0.0, 0.0)}),
        "JointPointWarning": lambda: Multibody(
            [rod], [Spherical("far", Ground(), rod, point_b=(0.0, 0.0, 5.0))]),
    }
    for what, call in calls.items():
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            call()
        kind = "InitialConditionsAdjusted" if what == "quaternion" else what
        assert kind in [w.category.__name__ for w in caught], (what, caught)
        assert all(w.filename == __file__ for w in caught), \
            (what, [(w.category.__name__, w.filename, w.lineno) for w in caught])


def ring_run():
    from dalembert.multibody import ring, ring_state
    mb = ring(4, 0.5, 1.0, 0.02)
    return mb.simulate((0.0, 0.01), *ring_state(mb, 4, 0.5))
