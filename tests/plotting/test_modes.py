"""Drawings of a mechanism at rest and of its mode shapes: real PNGs, rods kept rigid."""

from __future__ import annotations

import types

import numpy as np
import pytest

from dalembert.errors import InitialConditionError
from dalembert.examples import cartesian_pendulum, double_pendulum
from dalembert.plotting import plot_mechanism, plot_mode_shapes

PNG_MAGIC = b"\x89PNG\r\n\x1a\n"


def assert_png(path) -> None:
    data = path.read_bytes()
    assert data[:8] == PNG_MAGIC
    assert len(data) > 5000  # axes, labels and lines, not an empty canvas


@pytest.fixture(scope="module")
def double():
    system = double_pendulum.build()
    eq = system.equilibrium(double_pendulum.EQUILIBRIUM_GUESS)
    return system, eq, system.linearize(eq)


def test_mechanism_png(tmp_path):
    system = cartesian_pendulum.build()
    path = plot_mechanism(cartesian_pendulum.draw, system, [0.6, -0.8], tmp_path / "a" / "m.png")
    assert path == tmp_path / "a" / "m.png"
    assert_png(path)


@pytest.mark.parametrize("mode", [0, 1])
def test_mode_shapes_png_with_rigid_rods(mode, double, tmp_path):
    system, eq, lin = double
    drawn = []

    def recording_draw(sys_, q):
        drawn.append(np.array(q))
        return double_pendulum.draw(sys_, q)

    assert_png(plot_mode_shapes(recording_draw, system, lin, eq, tmp_path / "mode.png",
                                mode=mode))
    displaced = [q for q in drawn if np.abs(q - eq.q).max() > 1e-3]
    assert len(displaced) == 2  # + and - the mode
    for q in displaced:
        nodes = double_pendulum.draw(system, q)[0]
        # projected back onto the constraints: both rods keep length l = 1
        np.testing.assert_allclose(np.linalg.norm(np.diff(nodes, axis=0), axis=1), 1.0,
                                   rtol=1e-12)
        # and displaced along the mode: x2 / x1 = 1 +- sqrt(2) to first order
        ratio = q[2] / q[0]
        assert ratio == pytest.approx([1 + np.sqrt(2), 1 - np.sqrt(2)][mode], rel=0.1)


def test_mode_index_out_of_range(double, tmp_path):
    system, eq, lin = double
    with pytest.raises(ValueError, match="mode must be between 0 and 1"):
        plot_mode_shapes(double_pendulum.draw, system, lin, eq, tmp_path / "m.png", mode=2)


def test_bad_polyline_is_named(tmp_path):
    def draw(system, q):
        return [np.array([[0.0, 0.0], [1.0, 1.0]]), np.array([1.0, 2.0, 3.0])]

    with pytest.raises(ValueError, match=r"polyline 1 .* \(k, 2\)"):
        plot_mechanism(draw, cartesian_pendulum.build(), [0.0, -1.0], tmp_path / "m.png")


def test_unreachable_amplitude_asks_for_a_smaller_one(double, tmp_path):
    _, eq, lin = double

    def refuse(q, **_):
        raise InitialConditionError("Newton stalled")

    stubborn = types.SimpleNamespace(consistent_initial_state=refuse)
    with pytest.raises(ValueError, match="smaller amplitude"):
        plot_mode_shapes(double_pendulum.draw, stubborn, lin, eq, tmp_path / "m.png",
                         amplitude=0.5)
    assert not (tmp_path / "m.png").exists()


def test_3d_polylines_are_projected_on_a_plane(tmp_path):
    def draw(system, q):
        return [np.array([[0.0, 0.0, 0.0], [q[0], 0.0, q[1]]])]

    system = cartesian_pendulum.build()
    assert_png(plot_mechanism(draw, system, [0.6, -0.8], tmp_path / "xz.png"))
    with pytest.raises(ValueError, match="plane must be one of"):
        plot_mechanism(draw, system, [0.6, -0.8], tmp_path / "bad.png", plane="zx")
