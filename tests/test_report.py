"""dalembert.report: what the animations draw, run_example's animation, the gallery."""

from __future__ import annotations

import re
import types
from pathlib import Path

import numpy as np
import pytest
import sympy as sp
from PIL import Image

from dalembert import System, coordinates, report
from dalembert.examples import heavy_top, whirled_string
from dalembert.plotting.animation import mechanism_frames
from dalembert.plotting.drawers import particle_points


def test_particle_points_groups_by_suffix_and_ignores_angles():
    names = ["x1", "y1", "z1", "x2", "y2", "z2", "theta", "xi"]
    assert particle_points(names) == [(0, 1, 2), (3, 4, 5)]
    assert particle_points(["psi", "phi"]) == []


def test_point_fallback_draws_the_particle_where_the_trajectory_is():
    # whirled-string has no draw() and is no multibody system: its particle is drawn
    system = whirled_string.build()
    draw, how = report.mechanism_drawer(whirled_string, system)
    assert how == "the particles as points"
    traj = system.simulate((0.0, 0.5), **whirled_string.INITIAL, t_eval=np.linspace(0, 0.5, 6))
    idx, lines = mechanism_frames(traj, system, draw, frames=6)
    drawn = np.array([frame[0][0] for frame in lines])
    np.testing.assert_array_equal(drawn, np.column_stack([traj["x"], traj["y"]])[idx])


def test_multibody_example_is_drawn_as_its_stick_figure():
    system = heavy_top.build()
    _, how = report.mechanism_drawer(types.SimpleNamespace(), system)  # ignore its draw()
    assert how == "the multibody stick figure"


def angle_pendulum() -> types.SimpleNamespace:
    """A pendulum in its angle alone: nothing the report knows how to draw."""
    (phi,) = coordinates("phi")
    return types.SimpleNamespace(
        TITLE="pendulum in an angle",
        build=lambda: System([phi], kinetic=phi.diff() ** 2 / 2, potential=-9.81 * sp.cos(phi)),
        INITIAL={"q0": {"phi": 0.5}},
        T_END=0.2,
        checks=lambda system, traj: {"energy drift": float(np.ptp(traj.energy))},
    )


def test_example_with_nothing_to_draw_gets_a_note_and_no_animation(monkeypatch, tmp_path):
    monkeypatch.setattr(report.examples, "load", lambda name: angle_pendulum())
    run = report.run_example("angle", tmp_path, points=11)
    assert not (tmp_path / "animation.gif").exists()
    assert any(n.startswith("no animation: nothing to draw") for n in run.notes)
    assert "no animation" in report.format_run(run)
    assert (tmp_path / "coordinates.png").exists()


def test_run_example_writes_a_gif_of_the_multibody_top(tmp_path):
    run = report.run_example("heavy-top", tmp_path, t_end=0.2, points=21, frames=8, html=True)
    with Image.open(tmp_path / "animation.gif") as gif:
        assert gif.n_frames == 8
    page = (tmp_path / "animation.html").read_text()
    assert page.count("data:image/png;base64") == 8
    assert {p.name for p in run.files} >= {"animation.gif", "animation.html"}


def test_gallery_html_escapes_and_lists_failures():
    page = report.gallery_html([], {"<bad>": "ImportError: no module"}, Path("."))
    assert "&lt;bad&gt;: failed" in page and "<bad>" not in page


@pytest.fixture(scope="module")
def two_example_gallery(tmp_path_factory):
    out = tmp_path_factory.mktemp("gallery")
    text, failed = report.gallery(out, ["pendulum", "four-bar"], t_end=0.3, points=16, frames=5)
    return out, text, failed


def test_gallery_writes_each_example_and_its_checks(two_example_gallery):
    out, text, failed = two_example_gallery
    assert failed == []
    assert (out / "index.md").read_text() == text
    assert "## pendulum:" in text and "## four-bar:" in text
    # the pendulum's rod tension against m v^2/l + m g cos(theta)
    tension = re.search(r"\| tension relative error \| ([-+0-9.e]+) \|", text)
    assert tension and float(tension.group(1)) < 1e-12
    # the four-bar's dependent rows are a note, not a stray warning
    assert "RedundantConstraintsWarning" in text and "dependent" in text
    for name in ("pendulum", "four-bar"):
        with Image.open(out / name / "animation.gif") as gif:
            assert gif.n_frames == 5


def test_gallery_html_shows_files_that_exist(two_example_gallery):
    out, _, _ = two_example_gallery
    page = (out / "index.html").read_text()
    sources = re.findall(r'<img src="([^"]+)"', page)
    assert "pendulum/animation.gif" in sources and "four-bar/animation.gif" in sources
    assert "pendulum/path.png" in sources
    assert all((out / s).is_file() for s in sources)
    assert page.count("<table>") == 2
