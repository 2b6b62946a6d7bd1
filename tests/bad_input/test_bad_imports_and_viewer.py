"""Bad use of what landed since the last probe: MJCF/URDF import and the 3D viewer.

Each case gave a raw error from pathlib, the OS or the JSON encoder, or a wrong message
("no such file" for a folder; a FIFO passed to MuJoCo would block forever); now each
names the problem (docs/errors.md, Multibody and Plotting rows). What a good file or
page gives is checked in tests/multibody/importing and tests/viewer.
"""

from __future__ import annotations

import dataclasses
import os

import numpy as np
import pytest

from dalembert.errors import ModelFileError
from dalembert.examples import load
from dalembert.multibody import from_mjcf, from_urdf
from dalembert.plotting import view

ROD = """<robot name="r"><link name="base"/><link name="rod">{inertial}{collision}</link>
<joint name="pin" type="continuous"><parent link="base"/><child link="rod"/>
<axis xyz="0 1 0"/></joint></robot>"""
INERTIAL = ('<inertial><mass value="1"/><inertia ixx="0.08" iyy="0.08" izz="0.001" '
            'ixy="0" ixz="0" iyz="0"/></inertial>')


@pytest.mark.parametrize(("source", "said"), [
    (None, "the MJCF source must be a path to the file or the XML text, got None "
           "(NoneType)"),
    (42, "the MJCF source must be a path to the file or the XML text, got 42 (int)"),
    (b"<mujoco/>", "the MJCF source is bytes: give a path to the file or the XML text as "
                   "a str (e.g. data.decode())"),
    ("", "the MJCF source is an empty string"),
    ("   ", "the MJCF source is an empty string"),
])
def test_an_mjcf_source_that_is_no_path_or_text(source, said):
    with pytest.raises(ModelFileError) as info:
        from_mjcf(source)
    assert str(info.value).startswith(said)


def test_a_urdf_path_of_the_wrong_type():
    with pytest.raises(ModelFileError, match=r"^the URDF source must be a path to the "
                                             r"file, got None \(NoneType\)$"):
        from_urdf(None)


def test_a_folder_or_a_fifo_is_not_a_model_file(tmp_path):
    with pytest.raises(ModelFileError, match="it is a folder, not a file"):
        from_mjcf(tmp_path)
    fifo = tmp_path / "robot.urdf"
    os.mkfifo(fifo)
    with pytest.raises(ModelFileError, match=r"it is not a regular file \(a FIFO"):
        from_urdf(fifo)  # MuJoCo would wait for a writer forever


@pytest.mark.parametrize(("inertial", "collision", "said"), [
    ("", "", "cannot compile URDF file '.*rod.urdf': MuJoCo says: Error: mass and inertia "
             "of moving bodies must be larger than mjMINVAL Element name 'rod'"),
    (INERTIAL, '<collision><geometry><mesh filename="missing.stl"/></geometry></collision>',
     "cannot compile URDF file '.*rod.urdf': MuJoCo says: Error: Error opening file "
     "'missing.stl'"),
])
def test_a_urdf_without_inertials_or_with_a_missing_mesh(tmp_path, inertial, collision,
                                                         said):
    file = tmp_path / "rod.urdf"
    file.write_text(ROD.format(inertial=inertial, collision=collision))
    with pytest.raises(ModelFileError, match=said):
        from_urdf(file)


@pytest.fixture(scope="module")
def pendulum():
    example = load("pendulum")
    system = example.build()
    return system, system.simulate((0, 0.5), **example.INITIAL, t_eval=[0.0, 0.25, 0.5])


@pytest.mark.parametrize(("path", "error", "said"), [
    (None, TypeError, r"^path must be the .html file to write, got None \(NoneType\)$"),
    (3, TypeError, r"^path must be the .html file to write, got 3 \(int\)$"),
])
def test_a_page_path_of_the_wrong_type(pendulum, path, error, said):
    system, traj = pendulum
    with pytest.raises(error, match=said):
        view(traj, system, path)


def test_a_page_that_cannot_be_written_says_where(pendulum, tmp_path):
    system, traj = pendulum
    (tmp_path / "page.html").mkdir()
    with pytest.raises(IsADirectoryError, match=r"cannot write the page '.*page.html': it "
                                                r"is a folder"):
        view(traj, system, tmp_path / "page.html")
    (tmp_path / "file").write_text("")
    with pytest.raises(OSError, match=r"cannot write the page '.*file/a.html': .* \(writing "
                                      r"its folder '.*file'\); give another path"):
        view(traj, system, tmp_path / "file" / "a.html")
    with pytest.raises(OSError, match=r"cannot write the page '.*': File name too long"):
        view(traj, system, tmp_path / ("a" * 300 + ".html"))
    with pytest.raises(ValueError, match=r"cannot write the page .*: embedded null byte"):
        view(traj, system, f"{tmp_path}/a\0b.html")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["file", "page.html"]


@pytest.mark.parametrize(("traj", "said"), [
    ("traj", "the viewer shows a Trajectory (what simulate returns, or Trajectory.load), "
             "got str"),
    (np.zeros((3, 2)), "the viewer shows a Trajectory (what simulate returns, or "
                       "Trajectory.load), got ndarray"),
])
def test_what_is_not_a_trajectory(pendulum, tmp_path, traj, said):
    with pytest.raises(TypeError) as info:
        view(traj, pendulum[0], tmp_path / "a.html")
    assert str(info.value) == said


@pytest.mark.parametrize("system", [None, "pendulum"])
def test_what_is_not_a_system(pendulum, tmp_path, system):
    with pytest.raises(TypeError, match="the viewer draws the trajectory of a System or a "
                                        "Multibody: give the one that made it, got "):
        view(pendulum[1], system, tmp_path / "a.html")


@pytest.mark.parametrize("rate", [0, -1.0, float("nan"), float("inf"), "30", True])
def test_a_frame_rate_that_is_not_a_finite_positive_number(pendulum, tmp_path, rate):
    system, traj = pendulum
    with pytest.raises(ValueError, match="frame_rate must be a finite positive number "
                                         r"\(frames per simulated second\), got "):
        view(traj, system, tmp_path / "a.html", frame_rate=rate)


def test_traces_as_one_name_or_not_names(tmp_path):
    from dalembert.multibody import chain

    mb = chain(2, 1.0, 1.0, 0.05)
    q0, qd0 = mb.initial_state(positions={"link1": (0, 0, -0.5), "link2": (0, 0, -1.5)})
    traj = mb.simulate((0, 0.2), q0, qd0, t_eval=[0.0, 0.2])
    one = view(traj, mb.system, tmp_path / "one.html", traces="link1").read_text()
    listed = view(traj, mb.system, tmp_path / "listed.html", traces=["link1"]).read_text()
    assert one == listed  # it was read as the bodies 'l', 'i', 'n', 'k', '1'
    with pytest.raises(TypeError, match="traces must be names of bodies"):
        view(traj, mb.system, tmp_path / "a.html", traces=3)


def test_positions_that_are_not_finite(pendulum, tmp_path):
    system, traj = pendulum
    q = traj.q.copy()
    q[1:] = np.nan
    with pytest.raises(ValueError, match=r"the trajectory's positions are not finite at "
                                         r"t=0.25 \(2 of 3 output times\): nothing to draw"):
        view(dataclasses.replace(traj, q=q), system, tmp_path / "a.html")


FREE = ('<mujoco><worldbody><body pos="0 0 1"><freejoint name="base"/><geom size=".1"/>'
        '</body></worldbody></mujoco>')


@pytest.mark.parametrize("qpos", ["a", {"base": 1.0}, [0.0, 0.0, 1.0]])
def test_a_mujoco_state_that_is_not_numbers(qpos):
    from dalembert.errors import InitialConditionError
    from dalembert.multibody import mujoco_state

    with pytest.raises(InitialConditionError, match=r"^qpos must be 7 finite numbers for the "
                                                    r"MJCF string \(MuJoCo's order\), got "):
        mujoco_state(from_mjcf(FREE), qpos=qpos)


def test_a_zero_quaternion_in_a_mujoco_state():
    """MuJoCo takes it as no rotation, without a word."""
    from dalembert.errors import InitialConditionError
    from dalembert.multibody import mujoco_state

    with pytest.raises(InitialConditionError, match=r"the quaternion of joint 'base' "
                                                    r"\(qpos\[3:7\]\) is zero; it has no "
                                                    r"direction"):
        mujoco_state(from_mjcf(FREE), qpos=[0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0])
    q0, _ = mujoco_state(from_mjcf(FREE), qpos=[0.0, 0.0, 2.0, 0.0, 1.0, 0.0, 0.0])
    assert q0["body1_z"] == 2.0 and abs(abs(q0["body1_b1"]) - 1.0) < 1e-12
