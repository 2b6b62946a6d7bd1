"""Plots and animations of a run with contacts mark its impacts.

Reference: the bouncing ball of the gallery (``e = 0.8``, dropped from ``h0 = 1``)
strikes at ``t_1 (1 + 2 (e + ... + e^k))``, ``t_1 = sqrt(2 h0 / g)``; each plot
against time draws a line at each of these, and an animation's frame says how many
impacts came since the frame before.
"""

from __future__ import annotations

import numpy as np
import pytest
from matplotlib.axes import Axes
from matplotlib.text import Text

from dalembert.examples import load
from dalembert.plotting import animate, plot_coordinates, plot_energy_error, plot_multipliers

g, e, h0 = 9.81, 0.8, 1.0
T_END = 3.0


@pytest.fixture(scope="module")
def bounces():
    example = load("bouncing-ball")
    system = example.build()
    traj = system.simulate((0.0, T_END), **example.INITIAL,
                           t_eval=np.linspace(0.0, T_END, 201))
    t1 = np.sqrt(2 * h0 / g)
    times = t1 * (1 + 2 * np.cumsum(np.r_[0.0, e ** np.arange(1, 30)]))
    return system, traj, times[times <= T_END]


@pytest.mark.parametrize("plot", [plot_coordinates, plot_energy_error, plot_multipliers])
def test_plots_against_time_draw_a_line_at_each_impact(plot, bounces, tmp_path, monkeypatch):
    _, traj, expected = bounces
    marked: list[float] = []
    line = Axes.axvline

    def recorded(self, x=0, *args, **kwargs):
        marked.append(float(x))
        return line(self, x, *args, **kwargs)

    monkeypatch.setattr(Axes, "axvline", recorded)
    plot(traj, tmp_path / "figure.png")
    assert len(marked) == len(expected) > 3
    assert np.abs(np.array(marked) - expected).max() < 1e-12


def test_animation_frames_say_when_impacts_came(bounces, tmp_path, monkeypatch):
    system, traj, expected = bounces
    captions: list[str] = []
    set_text = Text.set_text

    def recorded(self, text):
        captions.append(str(text))
        return set_text(self, text)

    monkeypatch.setattr(Text, "set_text", recorded)
    animate(traj, tmp_path / "ball.gif", system=system, frames=40)
    frames = [c for c in captions if "t = " in c]
    assert len(frames) == 40
    shown = [float(c.split("t = ")[1].split()[0]) for c in frames]
    counted = 0
    for before, (caption, now) in zip(shown, list(zip(frames, shown))[1:]):
        due = int(np.count_nonzero((expected > before + 1e-3) & (expected <= now + 1e-3)))
        said = 0 if "impact" not in caption else 1 if caption.endswith("impact") else \
            int(caption.split()[-2])
        assert said == due, (caption, before, now)
        counted += said
    assert counted == np.count_nonzero(expected > shown[0])
