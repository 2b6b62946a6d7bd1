"""An imported model's geoms in the viewer's scene, checked against MuJoCo's own
placement of the same geoms (``geom_xpos``, ``geom_xmat`` after ``mj_kinematics``) at
configurations away from the reference pose."""

from __future__ import annotations

import json

import mujoco
import numpy as np
import pytest
from scipy.spatial.transform import Rotation
from test_viewer_page import scene_of_page
from viewer_runs import GEOMS_MJCF, geoms_qpos, posed_run

from dalembert.multibody import from_mjcf
from dalembert.plotting import view
from dalembert.plotting.viewer import scene_of

TOL = 1e-9


@pytest.fixture(scope="module")
def imported():
    with pytest.warns(UserWarning):  # the plane's contact, listed as unsupported
        return from_mjcf(GEOMS_MJCF)


def world_shapes(scene, frame: int) -> list[dict]:
    """The scene's shapes at ``frame`` in world coordinates: centers (a cylinder's ends)
    and rotation matrices, from the body poses the scene carries."""
    out = []
    for s in scene.shapes:
        if s["body"] >= 0:
            x = scene.positions[frame, s["body"]]
            R = Rotation.from_quat(scene.quaternions[frame, s["body"]]).as_matrix()
        else:
            x, R = np.zeros(3), np.eye(3)
        w = dict(s)
        for key in ("center", "from", "to"):
            if key in s:
                w[key] = x + R @ np.asarray(s[key])
        if "rotation" in s:
            w["matrix"] = R @ Rotation.from_quat(s["rotation"]).as_matrix()
        out.append(w)
    return out


def take(shapes: list[dict], kind: str, center: np.ndarray) -> dict:
    """The one shape of ``kind`` centered at ``center`` (removed from ``shapes``)."""
    def middle(s):
        return (s["from"] + s["to"]) / 2 if s["kind"] == "cylinder" else s["center"]
    found = [s for s in shapes if s["kind"] == kind and np.allclose(middle(s), center,
                                                                      atol=TOL, rtol=0)]
    assert len(found) == 1, f"no single {kind} at {center}"
    shapes.remove(found[0])
    return found[0]


@pytest.mark.parametrize("seed", [0, 1])
def test_geoms_are_drawn_where_mujoco_places_them(imported, seed):
    model = imported.imported.model
    qpos = geoms_qpos(model, seed)
    scene = scene_of(posed_run(imported, [model.qpos0, qpos]), imported)
    data = mujoco.MjData(model)
    data.qpos[:] = qpos
    mujoco.mj_kinematics(model, data)
    shapes = world_shapes(scene, 1)
    for g in range(model.ngeom):
        kind = mujoco.mjtGeom(model.geom_type[g]).name[len("mjGEOM_"):].lower()
        x, R, size = data.geom_xpos[g], data.geom_xmat[g].reshape(3, 3), model.geom_size[g]
        if kind == "plane":
            continue  # infinite: not drawn
        if kind in ("cylinder", "capsule"):
            s = take(shapes, "cylinder", x)
            ends = sorted([s["from"], s["to"]], key=lambda p: float(R[:, 2] @ (p - x)))
            assert np.allclose(ends, [x - size[1] * R[:, 2], x + size[1] * R[:, 2]], atol=TOL)
            assert s["radius"] == pytest.approx(size[0])
            if kind == "capsule":  # and a ball at each end
                for end in ends:
                    assert take(shapes, "sphere", end)["radius"] == pytest.approx(size[0])
        elif kind == "box":
            s = take(shapes, "box", x)
            assert np.allclose(s["size"], 2 * size) and np.allclose(s["matrix"], R, atol=TOL)
        elif kind == "sphere":
            assert take(shapes, "sphere", x)["radius"] == pytest.approx(size[0])
        elif kind == "ellipsoid":
            s = take(shapes, "sphere", x)
            assert np.allclose(s["radii"], size) and np.allclose(s["matrix"], R, atol=TOL)
        elif kind == "mesh":  # its bounding box in the geom's frame holds every vertex
            m = model.geom_dataid[g]
            first, count = model.mesh_vertadr[m], model.mesh_vertnum[m]
            vertices = x + model.mesh_vert[first:first + count] @ R.T
            s = next(s for s in shapes if s["kind"] == "box" and s["body"] >= 0
                     and np.allclose(s["matrix"], R, atol=TOL))
            shapes.remove(s)
            local = (vertices - s["center"]) @ s["matrix"]  # in the box's axes
            assert np.allclose(np.abs(local).max(axis=0), np.asarray(s["size"]) / 2, atol=TOL)
        else:
            raise AssertionError(f"the test model has a {kind}")
    # what is left: the anchor of the one joint to the ground (the swivel's)
    assert [(s["kind"], s["body"]) for s in shapes] == [("box", -1)]
    assert np.allclose(shapes[0]["center"], data.xanchor[model.joint("swivel").id], atol=TOL)


def test_the_page_carries_the_scene_shapes(imported, tmp_path):
    model = imported.imported.model
    traj = posed_run(imported, [model.qpos0, geoms_qpos(model, 0)])
    page = scene_of_page(view(traj, imported, tmp_path / "geoms.html"))
    assert page["shapes"] == json.loads(json.dumps(scene_of(traj, imported).shapes))


def test_a_body_with_no_geom_to_draw_keeps_the_default_shapes():
    """The lower rod's only geom is invisible (alpha 0): it is drawn as the default
    link from its joint, as long again beyond its mass center."""
    mb = from_mjcf("""<mujoco><worldbody>
      <body name="upper"><joint axis="0 1 0"/>
        <geom type="capsule" fromto="0 0 0 0 0 -1" size="0.05"/>
        <body name="lower" pos="0 0 -1"><joint axis="0 1 0"/>
          <geom type="capsule" fromto="0 0 0 0 0 -1" size="0.05" rgba="1 1 1 0"/>
        </body></body></worldbody></mujoco>""")
    scene = scene_of(posed_run(mb, [mb.imported.model.qpos0]), mb)
    lower = [s for s in scene.shapes if s["body"] == 1]
    assert [s["kind"] for s in lower] == ["cylinder"]
    assert np.allclose(sorted([lower[0]["from"][2], lower[0]["to"][2]]), [-0.5, 0.5])
    assert [s["kind"] for s in scene.shapes if s["body"] == 0] == ["cylinder", "sphere",
                                                                    "sphere"]
