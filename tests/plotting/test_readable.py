"""Pictures that read, measured: legends beside the data, panels per body and joint,
animations that fill their frame, a plain System of particles animated, and the
trajectory's summary and table for large mechanisms."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest
import sympy as sp
from matplotlib.backends.backend_agg import FigureCanvasAgg
from PIL import Image

from dalembert import Holonomic, System, coordinates
from dalembert.multibody import chain
from dalembert.plotting import animate, plot_coordinates, plot_multipliers, trajectory_plots
from dalembert.plotting.trajectory_plots import MAX_PANELS, PANEL_LINES
from dalembert.trajectory import Trajectory


def synthetic(names, constraints, n_points=41, grow=1.0) -> Trajectory:
    """Column j swings with amplitude grow**j: the later bodies move most."""
    t = np.linspace(0.0, 1.0, n_points)
    n, m = len(names), len(constraints)
    q = np.sin(np.outer(t, 1.0 + np.arange(n))) * grow ** np.arange(n)
    lam = np.cos(np.outer(t, 1.0 + np.arange(m))) * grow ** np.arange(m)
    zeros = np.zeros(n_points)
    return Trajectory(t=t, q=q, qd=q, qdd=q, multipliers=lam, constraint_forces=q,
                      kinetic_energy=zeros + 1.0, potential_energy=zeros, jacobi_integral=zeros,
                      position_residual=zeros, velocity_residual=zeros,
                      coordinate_names=tuple(names), constraint_names=tuple(constraints))


@pytest.fixture
def figures(monkeypatch):
    """The figures the plot functions would save, kept for measuring (drawn once, by
    the measure, as savefig would draw them: the other tests write the PNGs)."""
    kept = []

    def keep(fig, path):
        kept.append(fig)
        return path

    monkeypatch.setattr(trajectory_plots, "_save", keep)
    return kept


def assert_legends_beside_the_data(fig) -> None:
    """No legend overlaps any axes (where the curves are), none leaves the figure."""
    canvas = FigureCanvasAgg(fig)
    canvas.draw()   # the layout as saved
    renderer = canvas.get_renderer()
    frame = fig.bbox
    axes = [ax.get_window_extent(renderer) for ax in fig.axes]
    legends = [ax.get_legend() for ax in fig.axes if ax.get_legend() is not None]
    assert legends
    for legend in legends:
        box = legend.get_window_extent(renderer)
        for area in axes:
            assert not box.overlaps(area), (box, area)
        assert frame.x0 <= box.x0 and box.x1 <= frame.x1 + 0.5
        assert frame.y0 <= box.y0 and box.y1 <= frame.y1 + 0.5
        assert len(legend.get_texts()) <= PANEL_LINES


def test_six_bodies_plot_as_six_panels_with_their_own_curves(figures, tmp_path):
    mb = chain(6, 0.5, 1.0, 0.03, joint="revolute")
    system = mb.system
    traj = synthetic(system.coordinate_names, system.constraint_names)
    assert (len(traj.coordinate_names), len(traj.constraint_names)) == (42, 36)
    plot_coordinates(traj, tmp_path / "q.png", system=system)
    plot_multipliers(traj, tmp_path / "m.png", system=system)
    coords, multipliers = figures
    for fig in figures:
        assert_legends_beside_the_data(fig)
    panels = {ax.get_title(): ax for ax in coords.axes}
    assert sorted(panels) == [f"link{k}" for k in range(1, 7)]
    # each panel holds its body's coordinates, the very columns of the trajectory
    for body, ax in panels.items():
        curves = {line.get_label(): line.get_ydata() for line in ax.get_lines()}
        assert sorted(curves) == ["b0", "b1", "b2", "b3", "x", "y", "z"]
        for label, values in curves.items():
            np.testing.assert_array_equal(values, traj[f"{body}_{label}"])
    # a panel per joint (5 rows each) and one of the unit quaternions (labelled by body)
    titles = sorted(ax.get_title() for ax in multipliers.axes)
    assert titles == [*(f"joint{k}" for k in range(1, 7)), "unit quaternions"]
    quaternions = next(ax for ax in multipliers.axes if ax.get_title() == "unit quaternions")
    for line in quaternions.get_lines():
        np.testing.assert_array_equal(line.get_ydata(),
                                      traj.multiplier(f"{line.get_label()}_unit_quaternion"))


def test_sixteen_bodies_show_the_largest_and_name_the_rest(figures, tmp_path):
    mb = chain(16, 0.5, 1.0, 0.03)
    traj = synthetic(mb.system.coordinate_names, mb.system.constraint_names, grow=1.01)
    plot_coordinates(traj, tmp_path / "q.png", system=mb.system)
    (fig,) = figures
    assert_legends_beside_the_data(fig)
    # the bodies of largest range, found here from the data
    ranges = {f"link{k}": max(np.ptp(traj[f"link{k}_{c}"]) for c in ("x", "y", "z", "b0",
                                                                          "b1", "b2", "b3"))
              for k in range(1, 17)}
    largest = sorted(ranges, key=ranges.get)[-MAX_PANELS:]
    assert sorted(ax.get_title() for ax in fig.axes) == sorted(largest)
    note = fig.get_supxlabel()
    hidden = [name for name in ranges if name not in largest]
    assert f"{16 - MAX_PANELS} bodies: {', '.join(hidden)}" in note   # 7: all named


def test_plain_names_group_by_point_and_single_axes_keep_the_legend_outside(figures, tmp_path):
    names = [f"{a}{k}" for k in range(1, 13) for a in "xy"]
    traj = synthetic(names, (), grow=1.2)
    plot_coordinates(traj, tmp_path / "q.png")
    plot_multipliers(synthetic(["x", "y"], ("rod",)), tmp_path / "m.png")
    many, few = figures
    ranges = {k: max(np.ptp(traj[f"x{k}"]), np.ptp(traj[f"y{k}"])) for k in range(1, 13)}
    largest = sorted(ranges, key=ranges.get)[-MAX_PANELS:]
    assert sorted(ax.get_title() for ax in many.axes) == sorted(f"point {k}" for k in largest)
    assert "3 groups: point 1, point 2, point 3" in many.get_supxlabel()
    assert len(few.axes) == 1
    for fig in figures:
        assert_legends_beside_the_data(fig)


def test_summary_of_a_64_link_chain_stays_short():
    mb = chain(64, 0.5, 1.0, 0.03)
    traj = synthetic(mb.system.coordinate_names, mb.system.constraint_names)
    text = traj.summary()
    assert "448 coordinates: link1_x, link1_y, link1_z, link1_b0, ..., link64_b2, link64_b3" \
        in text
    assert "256 constraints: link1_unit_quaternion" in text
    assert len(text) < 700 and max(len(line) for line in text.splitlines()) < 200
    assert len(repr(traj)) < 200


# -- animations -----------------------------------------------------------------------
def mechanism_box(gif) -> tuple[float, float]:
    """The drawn mechanism's extent over every frame, as fractions of the frame's width
    and height: the coloured pixels (the ticks, labels and title are grey or black)."""
    union = None
    with Image.open(gif) as image:
        for k in range(image.n_frames):
            image.seek(k)
            rgb = np.asarray(image.convert("RGB")).astype(int)
            coloured = (rgb.max(axis=2) - rgb.min(axis=2)) > 60
            union = coloured if union is None else union | coloured
        size = image.size
    cols, rows = np.flatnonzero(union.any(axis=0)), np.flatnonzero(union.any(axis=1))
    return (cols[-1] - cols[0] + 1) / size[0], (rows[-1] - rows[0] + 1) / size[1]


def particles() -> System:
    x1, y1, x2, y2 = coordinates("x1 y1 x2 y2")
    kinetic = sum(v.diff() ** 2 for v in (x1, y1, x2, y2)) / 2
    return System([x1, y1, x2, y2], kinetic=kinetic, potential=sp.S.Zero,
                  constraints=[Holonomic((x1 - x2) ** 2 + (y1 - y2) ** 2 - 1, name="rod")])


def test_a_plain_system_of_particles_is_animated_and_fills_the_frame(tmp_path):
    t = np.linspace(0.0, 2 * np.pi, 30)
    # two particles turning about their middle while it travels 4 to the right
    q = np.column_stack([4 * t / t[-1] + 0.5 * np.cos(t), 0.5 * np.sin(t),
                         4 * t / t[-1] - 0.5 * np.cos(t), -0.5 * np.sin(t)])
    traj = SimpleNamespace(t=t, q=q)
    gif = animate(traj, tmp_path / "two.gif", system=particles(), frames=30)
    with Image.open(gif) as image:
        assert image.size[0] == 640 and image.n_frames == 30
    width, height = mechanism_box(gif)
    assert width >= 0.8 and height >= 0.3   # 5 wide, 1 high: the frame at its flattest


def test_a_3d_chain_fills_its_frame_and_shows_no_body_axes(tmp_path):
    mb = chain(6, 0.5, 1.0, 0.03)
    positions = {f"link{k}": (0.25 * (2 * k - 1), 0.0, -0.1 * k) for k in range(1, 7)}
    turned = np.array([[0.0, 0.0, 1.0], [0.0, 1.0, 0.0], [-1.0, 0.0, 0.0]])  # body z along x
    q0, _ = mb.initial_state(positions=positions,
                             orientations={f"link{k}": turned for k in range(1, 7)})
    q = np.array([q0[n] for n in mb.system.coordinate_names])
    traj = SimpleNamespace(t=np.array([0.0, 1.0]), q=np.tile(q, (2, 1)))
    width, height = mechanism_box(animate(traj, tmp_path / "chain.gif", system=mb.system))
    assert max(width, height) >= 0.8 and width >= 0.6
    # the stick figure: links only, no line centered on a mass center (a body's axis)
    centers = np.array([positions[f"link{k}"] for k in range(1, 7)])
    for line in mb.stick_figure(q):
        if len(line) == 2:
            middle = line.mean(axis=0)
            assert np.linalg.norm(centers - middle, axis=1).min() > 1e-6
    axes = [p for p in mb.stick_figure(q, body_axes=True) if len(p) == 2]
    assert len(axes) == 11 + 18   # the link halves to the 6 joints, three axes per body


def test_nothing_to_draw_says_what_is_needed(tmp_path):
    (phi,) = coordinates("phi")
    system = System([phi], kinetic=phi.diff() ** 2 / 2, potential=sp.S.Zero)
    traj = SimpleNamespace(t=np.zeros(2), q=np.zeros((2, 1)))
    with pytest.raises(ValueError, match=r"no coordinates name points .* give draw="):
        animate(traj, tmp_path / "a.gif", system=system)
