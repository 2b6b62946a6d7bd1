"""Animations: a GIF and an HTML page, from a draw(system, q) and from a Multibody."""

from __future__ import annotations

from types import SimpleNamespace

import matplotlib
import numpy as np
import pytest
from PIL import Image

from dalembert.multibody import Ground, Multibody, RigidBody, Spherical
from dalembert.plotting import animate
from dalembert.plotting.animation import mechanism_frames


def pendulum_traj(n: int = 12) -> SimpleNamespace:
    t = np.linspace(0.0, 1.0, n)
    th = 0.5 * np.cos(3 * t)
    return SimpleNamespace(t=t, q=np.column_stack([np.sin(th), -np.cos(th)]))


def draw_rod(system, q):
    return [np.array([[0.0, 0.0], q])]


def test_gif_from_a_draw_function(tmp_path):
    backend = matplotlib.get_backend()
    out = animate(pendulum_traj(), tmp_path / "sub" / "pendulum.gif", draw=draw_rod, frames=5,
                  fps=10, title="pendulum")
    with Image.open(out) as gif:
        assert gif.format == "GIF"
        assert gif.n_frames == 5
    assert matplotlib.get_backend() == backend   # no backend switching


def test_frames_follow_the_motion():
    traj = pendulum_traj(11)
    idx, lines = mechanism_frames(traj, draw=draw_rod, frames=3)
    assert idx.tolist() == [0, 5, 10]
    np.testing.assert_array_equal(lines[1][0][1], traj.q[5])


@pytest.fixture(scope="module")
def top():
    body = RigidBody("top", 1.0, (0.03, 0.03, 0.04))
    mb = Multibody([body], [Spherical("pivot", Ground(), body, point_b=(0.0, 0.0, -0.2))])
    R = np.array([[np.cos(0.5), 0, np.sin(0.5)], [0, 1, 0], [-np.sin(0.5), 0, np.cos(0.5)]])
    q0, _ = mb.initial_state(positions={body: 0.2 * R[:, 2]}, orientations={body: R})
    q = np.array([q0[n] for n in mb.system.coordinate_names])
    return mb, SimpleNamespace(t=np.array([0.0, 0.1, 0.2]), q=np.tile(q, (3, 1)))


def test_html_of_a_multibody_stick_figure(top, tmp_path):
    mb, traj = top
    out = animate(traj, tmp_path / "top.html", system=mb.system, frames=3)
    text = out.read_text()
    assert "<html" in text.lower() or "<script" in text.lower()
    assert text.count("data:image/png;base64") >= 3 or "frames[2]" in text
    # the stick figure: pivot (ground point), center -> tip, the body's three axes
    _, lines = mechanism_frames(traj, mb, frames=1)
    tip = next(p for p in lines[0] if p.shape == (2, 3))
    np.testing.assert_allclose(tip[1], [0.0, 0.0, 0.0], atol=1e-15)


def test_projection_and_bad_input(top, tmp_path):
    mb, traj = top
    _, lines = mechanism_frames(traj, mb, frames=1, plane="xz")
    assert all(p.shape[1] == 2 for p in lines[0])
    with pytest.raises(ValueError, match=r"\.gif or \.html"):
        animate(traj, tmp_path / "top.mp4", system=mb)
    with pytest.raises(ValueError, match="nothing to draw"):
        animate(pendulum_traj(), tmp_path / "x.gif", system=object())
    with pytest.raises(ValueError, match="plane must be one of"):
        mechanism_frames(traj, mb, plane="xq")
