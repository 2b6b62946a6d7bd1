"""Imported models simulated by dalembert and by MuJoCo itself agree.

The independent answer is MuJoCo's own simulation of the same file at tight settings
(RK4, a step of 1e-4 s; contact, friction loss and limits, which the importer leaves
out and warns of, disabled): every body frame (MuJoCo's ``xpos`` and ``xmat``)
computed from dalembert's body coordinates agrees with MuJoCo's within ``TOLERANCE``
over 1 s, for models without loops. A loop closed by ``connect`` is exact in dalembert
and soft in MuJoCo: the test measures MuJoCo's loop error and bounds the difference by
it. The weld is checked against MuJoCo's run of the same mechanism with the welded body
attached rigidly (no equality at all).
"""

from __future__ import annotations

import copy
import warnings
from pathlib import Path

import mujoco
import numpy as np
import pybullet_data
import pytest
from mujoco_reference import compare, dalembert_frames, mujoco_run, tight

from dalembert.errors import RedundantConstraintsWarning, UnsupportedModelFeatureWarning
from dalembert.multibody import (
    from_mjcf,
    from_urdf,
    joint_positions,
    joint_reactions,
    mujoco_state,
)

FILES = Path(__file__).parent / "files"
# example-robot-data installs its robots in cmeel's prefix beside the packages
ROBOTS = Path(mujoco.__file__).parents[1] / "cmeel.prefix" / "share" / "example-robot-data" \
    / "robots"
#: Body origins (m) and rotation matrix entries agree to this over 1 s (measured: 1e-13
#: to 3e-12, RK4's error at 1e-4 s and dalembert's tolerances rtol 1e-11, atol 1e-13).
TOLERANCE = 1e-10


def _imported(path: Path, read=from_mjcf, compiled=True):
    """The mechanism and MuJoCo's own model of the file (``compiled``), set tight."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UnsupportedModelFeatureWarning)  # tested elsewhere
        mb = read(path)
    return mb, tight(mujoco.MjModel.from_xml_path(str(path))) if compiled else None


def test_double_pendulum_with_spring_damper_and_reference_angle():
    mb, model = _imported(FILES / "double_pendulum.xml")
    error, _ = compare(mb, model, [0.9, -0.4], [0.5, 1.0], 1.0)
    assert error < TOLERANCE


@pytest.mark.validation
def test_triple_pendulum_in_space_with_a_welded_body():
    mb, model = _imported(FILES / "triple_pendulum.xml")
    assert [b.name for b in mb.bodies] == ["l1", "l2", "l3"]  # 'weight' joined to l2
    error, _ = compare(mb, model, [0.8, 0.5, -0.6], [0.0, 1.0, 2.0], 1.0)
    assert error < TOLERANCE


def test_ball_joint_and_hinge_spring():
    mb, model = _imported(FILES / "ball_joint.xml")
    turn = np.array([np.cos(0.3), 0.6 * np.sin(0.3), 0.8 * np.sin(0.3), 0.0])
    error, _ = compare(mb, model, [*turn, 0.4], [1.0, 0.5, 2.0, -1.0], 1.0)
    assert error < TOLERANCE


def test_slide_with_spring_and_motors_as_inputs():
    mb, model = _imported(FILES / "cart_pole.xml")
    assert [u.name for u in mb.inputs] == ["push", "twist"]
    ctrl = [0.4, -0.3]
    error, _ = compare(mb, model, [0.2, 0.5], [0.3, -1.0], 1.0, ctrl=ctrl,
                       inputs={"push": ctrl[0], "twist": ctrl[1]})
    assert error < TOLERANCE


@pytest.mark.validation
def test_hinges_combined_into_universal_and_ball_joints():
    mb, model = _imported(FILES / "universal.xml")
    assert [type(j).__name__ for j in mb.joints] == ["Universal", "Spherical"]
    error, _ = compare(mb, model, [0.3, -0.2, 0.4, 0.1, -0.3], [1.0, 0.5, -1.0, 2.0, 0.5], 1.0)
    assert error < TOLERANCE


def test_position_and_velocity_servos_as_inputs():
    """MuJoCo's servos are affine in the joint's qpos and qvel (``kp (ctrl - gear q) -
    kv gear qdot``, times the gear): a hinge with a reference angle (qpos0 not zero), a
    position servo with damping and a geared one, a velocity servo."""
    xml = """<mujoco><worldbody><body name="rod"><joint name="pin" axis="0 1 0" ref="12"/>
      <geom type="capsule" fromto="0 0 0 0.3 0 -1" size="0.05"/></body></worldbody>
      <actuator><position name="servo" joint="pin" kp="20" kv="2" gear="1.5"/>
      <velocity name="spin" joint="pin" kv="0.5"/></actuator></mujoco>"""
    mb = from_mjcf(xml)
    assert [u.name for u in mb.inputs] == ["servo", "spin"]
    model = tight(mujoco.MjModel.from_xml_string(xml))
    error, _ = compare(mb, model, [0.5], [0.3], 1.0, ctrl=[0.1, 0.4],
                       inputs={"servo": 0.1, "spin": 0.4})
    assert error < TOLERANCE


def test_free_body_tumbling():
    """The brick's center is off its body frame's origin (the box is shifted), so the
    free joint's travel is the frame origin's path, not the mass center's: the Free
    joint's positions are MuJoCo's qpos of the joint (position, quaternion up to sign)."""
    xml = """<mujoco><worldbody><body name="brick" pos="0 0 1"><freejoint name="loose"/>
      <geom type="box" size="0.1 0.2 0.3" pos="0.05 -0.1 0.2"/></body></worldbody></mujoco>"""
    mb = from_mjcf(xml)
    assert [(type(j).__name__, j.name) for j in mb.joints] == [("Free", "loose")]
    model = tight(mujoco.MjModel.from_xml_string(xml))
    qpos, qvel = [0.1, 0.2, 1.0, 1.0, 0.0, 0.0, 0.0], [0.5, 0.0, 3.0, 0.2, 4.0, 0.3]
    error, traj = compare(mb, model, qpos, qvel, 1.0)
    assert error < TOLERANCE
    data = mujoco.MjData(model)
    data.qpos[:], data.qvel[:] = qpos, qvel
    mujoco_qpos = [data.qpos.copy()]
    for _ in range(len(traj) - 1):  # at the trajectory's times, 0.1 s apart
        mujoco.mj_step(model, data, nstep=round(0.1 / model.opt.timestep))
        mujoco_qpos.append(data.qpos.copy())
    expected = np.array(mujoco_qpos)
    ours = joint_positions(mb, traj, rotations="quaternion")
    assert list(ours.names) == [f"loose.{c}" for c in ("x", "y", "z", "qw", "qx", "qy", "qz")]
    sign = np.sign(np.einsum("ki,ki->k", ours.array[:, 3:], expected[:, 3:]))[:, None]
    assert np.abs(ours.array[:, :3] - expected[:, :3]).max() < TOLERANCE
    assert np.abs(sign * ours.array[:, 3:] - expected[:, 3:]).max() < TOLERANCE
    reaction = joint_reactions(mb, traj)["loose"]["brick"]  # it holds nothing
    assert not reaction.force_world.any() and not reaction.torque_world.any()


def test_urdf_chain_from_pybullet_data():
    mb, model = _imported(Path(pybullet_data.getDataPath(), "pendulum5.urdf"), from_urdf)
    assert len(mb.bodies) == 5 and len(mb.joint_springs) == 5  # URDF damping 1.0
    error, _ = compare(mb, model, 0.3 * np.sin(np.arange(5) + 1.0),
                       0.5 * np.cos(np.arange(5)), 1.0)
    assert error < TOLERANCE


@pytest.mark.validation
def test_urdf_arm_ur5_from_example_robot_data():
    """A 6-joint arm whose meshes are named ``package://...``: MuJoCo runs the model the
    importer compiled (the meshes resolved; the URDF's inertials are the file's)."""
    path = ROBOTS / "ur_description" / "urdf" / "ur5_robot.urdf"
    mb, _ = _imported(path, from_urdf, compiled=False)
    model = tight(copy.deepcopy(mb.imported.model))
    assert len(mb.bodies) == 6
    error, _ = compare(mb, model, 0.3 * np.sin(np.arange(6) + 1.0),
                       0.5 * np.cos(np.arange(6)), 1.0)
    assert error < TOLERANCE


@pytest.fixture(scope="module")
def four_bar():
    """dalembert's run of the four-bar from rest at ``qpos0`` (1 s) and its times."""
    mb = from_mjcf(FILES / "four_bar.xml")
    times = np.linspace(0.0, 1.0, 101)
    with warnings.catch_warnings():
        # a planar loop closed by a 3D ball joint: one of its rows repeats the hinges'
        warnings.simplefilter("ignore", RedundantConstraintsWarning)
        traj = mb.simulate((0.0, 1.0), *mujoco_state(mb), t_eval=times)
    return mb, traj, times


def _loop_errors(four_bar, solref: str):
    """The largest difference of the body frames between dalembert and MuJoCo (the file's
    equality at ``solref``), MuJoCo's loop error and dalembert's."""
    mb, traj, times = four_bar
    xml = (FILES / "four_bar.xml").read_text().replace('solref="0.0005 1"',
                                                        f'solref="{solref}"')
    model = tight(mujoco.MjModel.from_xml_string(xml))
    xpos, xmat, _ = mujoco_run(model, model.qpos0, np.zeros(model.nv), times)
    frames = dalembert_frames(mb, traj)
    difference = max(max(np.abs(x - xpos[:, k]).max(), np.abs(R - xmat[:, k]).max())
                     for k, (x, R) in frames.items())
    rocker = model.body("rocker").id
    anchor, ground_point = np.array([0.0, 0.0, -0.6]), np.array([1.0, 0.0, 0.0])
    mujoco_loop = np.linalg.norm(xpos[:, rocker] + xmat[:, rocker] @ anchor - ground_point,
                                 axis=1).max()
    x, R = frames[rocker]
    dalembert_loop = np.linalg.norm(x + R @ anchor - ground_point, axis=1).max()
    return difference, mujoco_loop, dalembert_loop


def test_connect_loop_is_exact_where_mujoco_drifts(four_bar):
    """Measured: MuJoCo's loop opens by 2.3e-7 m with solref 0.0005 (the stiffest its
    1e-4 s step allows), 3.3e-4 m with its default 0.02; dalembert's stays below 1e-14,
    and the bodies agree to 6.7e-7 (stiff) and 8.1e-4 (default), MuJoCo's drift."""
    difference, mujoco_loop, dalembert_loop = _loop_errors(four_bar, "0.0005 1")
    assert dalembert_loop < 1e-12
    assert 1e-8 < mujoco_loop < 1e-6
    assert difference < 1e-5
    difference, mujoco_loop, dalembert_loop = _loop_errors(four_bar, "0.02 1")
    assert 1e-5 < mujoco_loop < 1e-3 and difference < 1e-2


WELDED = """<mujoco><option><flag contact="disable"/></option><worldbody>
  <body name="arm"><joint name="pin" axis="0 1 0"/>
    <geom type="capsule" fromto="0 0 0 0.6 0 0" size="0.03"/>
    {tip}
  </body>{free}</worldbody>{equality}</mujoco>"""
TIP = ('<body name="tip" pos="0.6 0 0.1" euler="20 30 0">{joint}'
       '<geom type="box" size="0.1 0.05 0.02"/></body>')


def test_weld_equality_holds_like_a_rigid_attachment():
    """The weld (an equality on a free body) against MuJoCo's run of the same body
    attached rigidly in the tree (no equality: MuJoCo's answer is exact there)."""
    rigid_xml = WELDED.format(tip=TIP.format(joint=""), free="", equality="")
    rigid = tight(mujoco.MjModel.from_xml_string(rigid_xml))
    data = mujoco.MjData(rigid)
    data.qpos[:], data.qvel[:] = [0.7], [1.5]
    mujoco.mj_forward(rigid, data)
    k = rigid.body("tip").id
    velocity = np.zeros(6)
    mujoco.mj_objectVelocity(rigid, data, mujoco.mjtObj.mjOBJ_XBODY, k, velocity, 0)
    # the arm's frame is the world's at qpos0: the free tip starts where the attached
    # one is, and the weld holds that relative pose
    welded = from_mjcf(WELDED.format(tip="", free=TIP.format(joint="<freejoint/>"),
                                     equality='<equality><weld body1="arm" body2="tip"/>'
                                              '</equality>'))
    assert [type(j).__name__ for j in welded.joints] == ["Revolute", "Free", "Fixed"]
    spin = data.xmat[k].reshape(3, 3).T @ velocity[:3]  # a free joint's: body frame
    qpos = [0.7, *data.xpos[k], *data.xquat[k]]
    qvel = [1.5, *velocity[3:], *spin]
    q0, qd0 = mujoco_state(welded, qpos, qvel)
    times = np.linspace(0.0, 1.0, 11)
    traj = welded.simulate((0.0, 1.0), q0, qd0, t_eval=times)
    xpos, xmat, _ = mujoco_run(rigid, [0.7], [1.5], times)
    frames = dalembert_frames(welded, traj)
    for name, body in welded.imported.bodies.items():
        x, R = frames[body.mujoco_id]
        j = rigid.body(body.mujoco_name).id
        assert np.abs(x - xpos[:, j]).max() < TOLERANCE, name
        assert np.abs(R - xmat[:, j]).max() < TOLERANCE, name

