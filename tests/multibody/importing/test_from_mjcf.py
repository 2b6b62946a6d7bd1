"""What the importer reads from a file, checked against closed forms and the file's own
numbers; what it leaves out (one warning) and what it refuses (clear errors)."""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest
import sympy as sp

import dalembert
from dalembert.errors import ModelError, ModelFileError, UnsupportedModelFeatureWarning
from dalembert.multibody import chain, from_mjcf, from_urdf, mujoco_state, rotation_matrix

FILES = Path(__file__).parent / "files"


def _quiet(source):
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # nothing else may be warned of
        warnings.simplefilter("ignore", UnsupportedModelFeatureWarning)
        return from_mjcf(source)


def test_inertials_from_geoms_and_from_the_file():
    mb = _quiet(FILES / "double_pendulum.xml")
    upper, lower = mb.bodies
    # the file's <inertial>: mass, principal moments turned by iquat (30 deg about y)
    R = rotation_matrix(np.array([0.9659, 0.0, 0.2588, 0.0]) / np.hypot(0.9659, 0.2588))
    assert upper.mass == pytest.approx(1.3, abs=1e-12)
    np.testing.assert_allclose(upper.inertia, R @ np.diag([0.11, 0.1, 0.012]) @ R.T,
                               atol=1e-12)
    # its mass center (0.02, 0, -0.45) in the body frame: the frame's origin seen from it
    np.testing.assert_allclose(mb.imported.bodies["upper"].origin, (-0.02, 0.0, 0.45),
                               atol=1e-12)
    # no <inertial>: MuJoCo's from the geoms (density 1000): a capsule and a sphere
    r, length, ball = 0.04, np.hypot(0.2, 0.8), 0.08
    mass = 1000 * (np.pi * r**2 * length + 4 / 3 * np.pi * r**3 + 4 / 3 * np.pi * ball**3)
    assert lower.mass == pytest.approx(mass, rel=1e-9)


def test_hinge_reference_spring_and_damper_in_radians():
    mb = _quiet(FILES / "double_pendulum.xml")
    (spring,) = mb.joint_springs
    assert spring.joint.name == "shoulder"
    assert (spring.stiffness, spring.damping) == (3.0, 0.2)
    # rest at springref - ref = 25 - 10 degrees from the file's pose
    assert spring.rest == pytest.approx(np.radians(15.0), abs=1e-12)
    assert mb.gravity.tolist() == [0.0, 0.0, -9.81]


def test_bodies_without_joint_join_their_parent():
    mb = _quiet(FILES / "triple_pendulum.xml")
    assert mb.imported.bodies["l2"].members == ("l2", "weight")
    # the box (0.1 x 0.06 x 0.04 m, 1000 kg/m^3) is part of l2's mass
    capsule = 1000 * (np.pi * 0.04**2 * 0.5 + 4 / 3 * np.pi * 0.04**3)
    assert mb.body("l2").mass == pytest.approx(capsule + 1000 * 0.1 * 0.06 * 0.04, rel=1e-9)


def test_shapes_kept_in_the_body_frames():
    mb = _quiet(FILES / "double_pendulum.xml")
    capsule = next(s for s in mb.imported.shapes if s.body == "upper")
    # the capsule's center (0, 0, -0.5) in the MuJoCo frame, seen from the mass center
    np.testing.assert_allclose(capsule.position, (-0.02, 0.0, -0.05), atol=1e-12)
    assert capsule.kind == "capsule" and capsule.size[:2] == pytest.approx((0.05, 0.5))
    assert [s.body for s in mb.imported.shapes] == ["upper", "lower", "lower"]


def test_motors_are_inputs_named_after_the_actuators():
    mb = _quiet(FILES / "cart_pole.xml")
    push, twist = mb.actuators
    assert mb.inputs == (sp.Symbol("push"), sp.Symbol("twist"))
    assert push.value == 5.0 * sp.Symbol("push") and push.joint.name == "rail"
    assert twist.value == 1.0 * sp.Symbol("twist")


def test_one_warning_lists_everything_left_out():
    xml = """<mujoco>
      <worldbody>
        <geom type="plane" size="1 1 0.1"/>
        <body name="a" pos="0 0 1">
          <joint name="j" axis="0 1 0" range="-1 1" limited="true" armature="0.1"
                 frictionloss="0.2"/>
          <geom type="sphere" size="0.1"/>
          <site name="s"/>
        </body>
        <body name="b" pos="0.5 0 1">
          <joint name="cone" type="ball" range="0 0.5" limited="true"/>
          <geom type="sphere" size="0.1"/>
        </body>
      </worldbody>
      <tendon><fixed name="t"><joint joint="j" coef="1"/></fixed></tendon>
      <actuator>
        <position name="servo" joint="j" kp="10"/>
        <general name="lagged" joint="j" dyntype="filter" dynprm="0.1"/>
        <motor name="m" joint="j" ctrlrange="-1 1" ctrllimited="true"/>
        <motor name="thruster" site="s" gear="0 0 1 0 0 0"/>
      </actuator>
    </mujoco>"""
    with pytest.warns(UnsupportedModelFeatureWarning) as caught:
        mb = from_mjcf(xml)
    assert len(caught) == 1
    message = str(caught[0].message)
    for feature in ("contact between geoms", "tendons 't'", "joint limits (range) on "
                    "'cone'", "armature",
                    "friction loss", "actuator 'lagged' (a muscle, a user gain or bias, or "
                    "activation dynamics)",
                    "control or force range of actuator 'm'", "actuator 'thruster'"):
        assert feature in message, feature
    assert mb.imported.unsupported and [a.name for a in mb.actuators] == ["servo", "m"]
    assert "'j'" not in message.split("joint limits")[1].split(";")[0]  # a hinge's: imported
    assert [c.name for c in mb.contacts] == ["j_range"]


def test_disabled_contact_is_not_warned_of():
    xml = """<mujoco><option><flag contact="disable"/></option><worldbody>
      <geom type="plane" size="1 1 0.1"/>
      <body><joint axis="0 1 0"/><geom type="sphere" size="0.1" pos="0 0 -1"/></body>
      </worldbody></mujoco>"""
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        from_mjcf(xml)


@pytest.mark.parametrize(("source", "expected"), [
    ("<mujoco><worldbody><bogus/></worldbody></mujoco>",
     "cannot read the MJCF string: MuJoCo says: .*bogus"),
    ("<mujoco><worldbody><body><joint/><geom size='.1' mass='0'/><body><joint/>"
     "<geom size='.1'/></body></body></worldbody></mujoco>",
     "MuJoCo says: .*mass and inertia of moving bodies"),
    ("<mujoco><worldbody><body><joint type='slide'/><joint type='slide' axis='1 0 0'/>"
     "<geom size='.1'/></body></worldbody></mujoco>",
     "body 'body1' has 2 joints .* slide, slide"),
    ("<mujoco><worldbody><geom size='.1'/></worldbody></mujoco>", "no body moves"),
])
def test_bad_models_give_clear_errors(source, expected):
    with pytest.raises(ModelFileError, match=expected):
        from_mjcf(source)


def test_bad_files_are_named(tmp_path):
    with pytest.raises(ModelFileError, match=r"MJCF file '.*missing\.xml': no such file"):
        from_mjcf(tmp_path / "missing.xml")
    broken = tmp_path / "broken.urdf"
    broken.write_text("<robot name='r'><link name='a'>")
    with pytest.raises(ModelFileError, match=r"cannot read URDF file '.*broken\.urdf': MuJoCo"):
        from_urdf(broken)
    with pytest.raises(ModelFileError, match="from_urdf reads a file"):
        from_urdf("<robot/>")
    assert issubclass(ModelFileError, ValueError)


def test_mujoco_state_needs_an_imported_mechanism():
    with pytest.raises(ModelError, match="not imported from a model file"):
        mujoco_state(chain(1, 1.0, 1.0, 0.1))
    mb = _quiet(FILES / "cart_pole.xml")
    with pytest.raises(dalembert.InitialConditionError, match="qpos must be 2 finite"):
        mujoco_state(mb, qpos=[0.0])


def test_mocap_bodies_are_held_with_the_ground():
    xml = """<mujoco><option><flag contact="disable"/></option><worldbody>
      <body name="handle" mocap="true"><geom size="0.1"/>
        <body name="hook" pos="0 0 -1"><geom size="0.05"/></body></body>
      <body name="swing"><joint axis="0 1 0"/><geom size="0.1" pos="0 0 -1"/></body>
      </worldbody>
      <equality><connect body1="swing" body2="hook" anchor="0 0 -1"/></equality></mujoco>"""
    with pytest.warns(UnsupportedModelFeatureWarning, match="mocap bodies 'handle'"):
        mb = from_mjcf(xml)
    assert [b.name for b in mb.bodies] == ["swing"]
    loop = mb.joints[-1]
    assert loop.body_b.name == "ground"
    np.testing.assert_allclose(loop.point_b, (0.0, 0.0, -1.0), atol=1e-12)  # the hook, world


def test_connect_between_sites_is_the_connect_between_their_bodies():
    xml = """<mujoco><option><flag contact="disable"/></option><worldbody>
      <body name="a"><joint axis="0 1 0"/><geom size=".1" pos="0 0 -1"/>
        <site name="sa" pos="0.2 0 -1"/>
        <body name="b" pos="0 0 -1"><joint axis="0 1 0"/><geom size=".1" pos="0 0 -1"/>
          <site name="sb" pos="0.2 0 0"/></body></body></worldbody>
      <equality>{}</equality></mujoco>"""
    by_body = _quiet(xml.format('<connect body1="a" body2="b" anchor="0.2 0 -1"/>'))
    by_site = _quiet(xml.format('<connect site1="sa" site2="sb"/>'))
    for joint in (by_body.joints[-1], by_site.joints[-1]):
        # the anchor (0.2, 0, -1) from each mass center: a's at (0, 0, -1), b's at (0, 0, -2)
        np.testing.assert_allclose(joint.point_a, (0.2, 0.0, 0.0), atol=1e-12)
        np.testing.assert_allclose(joint.point_b, (0.2, 0.0, 1.0), atol=1e-12)
