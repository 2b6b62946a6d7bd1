"""The 3D viewer's page without a browser: what it embeds, checked against geometry and
mechanics (joint points that coincide, a hanging bob's tension), and its errors."""

from __future__ import annotations

import base64
import json
import re

import numpy as np
import pytest
import sympy as sp
from scipy.spatial.transform import Rotation
from viewer_runs import LINK, swinging_chain

from dalembert import Holonomic, System, cli
from dalembert.examples import load
from dalembert.model.coordinates import coordinates
from dalembert.multibody import Distance, Ground, Multibody, Particle
from dalembert.plotting import view
from dalembert.plotting.viewer.page import viewer_script


def scene_of_page(path) -> dict:
    text = path.read_text(encoding="utf-8")
    match = re.search(r'<script id="dalembert-scene" type="application/json">(.*?)</script>',
                      text, re.S)
    assert match, "the page embeds its scene"
    return json.loads(match.group(1))


def decoded(scene: dict, key: str, dtype: str, shape: tuple[int, ...]) -> np.ndarray:
    return np.frombuffer(base64.b64decode(scene[key]), dtype=dtype).reshape(shape)


def test_page_is_one_file_with_the_script_and_no_network(tmp_path):
    traj, mb = swinging_chain(3, 1.0, 11)
    path = view(traj, mb.system, tmp_path / "deep" / "chain.html", title="three <links>")
    text = path.read_text(encoding="utf-8")
    assert text.startswith("<!DOCTYPE html>") and "<title>three &lt;links&gt;</title>" in text
    assert viewer_script().replace("</script", "<\\/script") in text
    # nothing loaded from elsewhere: no src/href attribute, no module import by URL
    assert not re.search(r'\b(src|href)\s*=', text)
    assert not re.search(r'import\s*\(\s*["\']http', text)


def test_joint_points_of_neighbouring_links_meet_in_the_embedded_poses(tmp_path):
    """Link k's bottom and link k+1's top, each from its own embedded position and
    quaternion, are the same point (the joint) at every frame; the top link's top is
    the origin. The poses went through float32 and int16."""
    traj, mb = swinging_chain(4, 2.0, 201)
    scene = scene_of_page(view(traj, mb.system, tmp_path / "c.html", frame_rate=10))
    frames = len(decoded(scene, "t", "<f4", (-1,)))
    assert frames == 21
    p = decoded(scene, "positions", "<f4", (frames, 4, 3)).astype(float)
    q = decoded(scene, "quaternions", "<i2", (frames, 4, 4)) / 32767.0
    ends = np.empty((frames, 4, 2, 3))
    for b in range(4):
        R = Rotation.from_quat(q[:, b]).as_matrix()
        for side, z in enumerate((LINK / 2, -LINK / 2)):
            ends[:, b, side] = p[:, b] + R @ np.array([0.0, 0.0, z])
    # a quaternion component is stored to 1/32767: about 3e-5 rad, 1e-6 at half a link
    assert np.abs(ends[:, 0, 0]).max() < 1e-4 * LINK
    assert np.abs(ends[:, 1:, 0] - ends[:, :-1, 1]).max() < 1e-4 * LINK
    # and the chain's bottom is where the rigid swing puts it at each frame's time
    t = decoded(scene, "t", "<f4", (-1,)).astype(float)
    theta = 0.5 * np.sin(2 * np.pi * t / 3)
    assert np.abs(ends[:, 3, 1, 0] + 4 * LINK * np.sin(theta)).max() < 1e-4 * LINK
    shapes = scene["shapes"]
    assert [s["kind"] for s in shapes if s["body"] >= 0] == ["cylinder"] * 4
    assert [j["name"] for j in scene["joints"]] == ["joint1", "joint2", "joint3", "joint4"]


def test_hanging_bob_arrow_is_its_weight_upwards(tmp_path):
    """A 2 kg bob hanging at rest on a rod under g = 10: the rod pulls it up with 20 N."""
    bob = Particle("bob", 2.0)
    mb = Multibody([bob], [Distance("rod", Ground(), bob, 1.0)], gravity=(0, 0, -10))
    traj = mb.simulate((0, 1), *mb.initial_state(positions={bob: (0, 0, -1)}),
                       t_eval=np.linspace(0, 1, 5))
    scene = scene_of_page(view(traj, mb, tmp_path / "bob.html"))
    forces = scene["forces"]
    stored = decoded(forces, "values", "<i2", (5, 1, 3)) * forces["unit"]
    assert np.abs(stored - [0.0, 0.0, 20.0]).max() < 1e-3
    assert scene["up"] == [0.0, 0.0, 1.0] and scene["arrows"][0]["name"] == "rod"
    assert [s["kind"] for s in scene["shapes"]] == ["sphere", "box"]  # the bob, the pivot
    assert scene["traces"] == [{"name": "bob", "body": 0, "point": [0.0, 0.0, 0.0]}]


def test_a_system_of_points_shows_points_and_sticks(tmp_path):
    """Two particles on a plane: one held at distance 1 from the origin, the other at
    distance 1 from the first (a Cartesian double pendulum)."""
    x1, y1, x2, y2 = coordinates("x1 y1 x2 y2")
    system = System([x1, y1, x2, y2],
                    kinetic=(x1.diff()**2 + y1.diff()**2 + x2.diff()**2 + y2.diff()**2) / 2,
                    potential=9.81 * (y1 + y2),
                    constraints=[Holonomic(x1**2 + y1**2 - 1, name="rod1"),
                                 Holonomic((x2 - x1)**2 + (y2 - y1)**2 - 1, name="rod2")])
    traj = system.simulate((0, 1), {"x1": 1.0, "y1": 0.0, "x2": 2.0, "y2": 0.0},
                           t_eval=np.linspace(0, 1, 11))
    scene = scene_of_page(view(traj, system, tmp_path / "points.html"))
    assert scene["bodies"] == ["x1", "x2", "origin"]
    assert sorted(map(tuple, scene["sticks"])) == [(0, 1), (0, 2)]
    assert scene["up"] == [0.0, 1.0, 0.0]
    p = decoded(scene, "positions", "<f4", (11, 3, 3))
    assert np.allclose(p[:, 1, :2], np.column_stack([traj["x2"], traj["y2"]]), atol=1e-6)
    # the arrows are A^T lambda on each point's coordinates
    f = decoded(scene["forces"], "values", "<i2", (11, 2, 3)) * scene["forces"]["unit"]
    scale = np.abs(traj.constraint_forces).max()
    assert np.abs(f[:, 0, :2] - traj.constraint_forces[:, :2]).max() < 1e-4 * scale


def test_frames_follow_the_frame_rate_and_plots_keep_the_whole_run(tmp_path):
    traj, mb = swinging_chain(2, 10.0, 1001)
    scene = scene_of_page(view(traj, mb.system, tmp_path / "c.html"))
    assert len(decoded(scene, "t", "<f4", (-1,))) == 301  # 30 frames per second, both ends
    assert len(decoded(scene["plots"][1], "t", "<f4", (-1,))) == 1001


def test_bad_input_is_named(tmp_path):
    traj, mb = swinging_chain(2, 1.0, 3)
    with pytest.raises(ValueError, match=r"\.html"):
        view(traj, mb.system, tmp_path / "chain.png")
    with pytest.raises(ValueError, match="traces: 'link9' is not a body"):
        view(traj, mb.system, tmp_path / "c.html", traces=["link9"])
    with pytest.raises(ValueError, match="energy must be one of"):
        view(traj, mb.system, tmp_path / "c.html", energy="heat")
    pendulum = load("pendulum")
    with pytest.raises(ValueError, match=r"not one of this system.*link1_x"):
        view(traj, pendulum.build(), tmp_path / "c.html")
    (phi,) = coordinates("phi")
    rotor = System([phi], kinetic=phi.diff()**2 / 2, potential=sp.Integer(0))
    spun = rotor.simulate((0, 1), {"phi": 0.0}, {"phi": 1.0}, t_eval=[0, 1])
    with pytest.raises(ValueError, match=r"nothing to draw.*phi"):
        view(spun, rotor, tmp_path / "c.html")


def test_cli_run_html_writes_the_viewer(tmp_path, capsys):
    out = tmp_path / "run"
    assert cli.main(["run", "pendulum", "--t-end", "0.5", "--points", "26", "--out", str(out),
                     "--no-animation", "--html"]) == 0
    assert (out / "viewer.html").stat().st_size > 500_000
    assert "viewer.html" in capsys.readouterr().out
    page = tmp_path / "elsewhere" / "p.html"
    assert cli.main(["run", "pendulum", "--t-end", "0.5", "--points", "26", "--out", str(out),
                     "--no-animation", "--html", str(page)]) == 0
    assert scene_of_page(page)["title"].startswith("pendulum: ")
    assert cli.main(["run", "pendulum", "--out", str(out), "--html", "p.png"]) == 2
    assert "--html p.png: the viewer writes an .html page" in capsys.readouterr().err
