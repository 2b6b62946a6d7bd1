"""Animations of a mechanism along a :class:`~dalembert.Trajectory`, as GIF or HTML.

The mechanism is drawn as polylines at each frame's configuration ``q``:

- ``draw(system, q)``, when given (the gallery examples define one): a list of
  ``(k, 2)`` or ``(k, 3)`` arrays;
- otherwise what :func:`~dalembert.plotting.drawers.default_drawer` finds, as
  ``dalembert run`` does: the stick figure of a system built by
  :class:`dalembert.multibody.Multibody` (or the ``Multibody`` itself), else one point
  per particle of a system whose coordinates name points (``x1, y1, x2, y2, ...``).

A drawing of points alone (particles) shows each point with its path so far.

The frame is fitted to the mechanism: the bounds of every drawn point over the whole
motion with a small margin, equal scales on every axis, the figure's shape following
the mechanism's (a 2D drawing) and a default width of :data:`DEFAULT_WIDTH` pixels.
2D drawings have a thin frame with ticks for the scale; 3D drawings (orthographic,
zoomed to the mechanism) no axes at all; ``axes=True`` adds the grid, the axis
labels and the 3D panes. 3D drawings can be projected on a coordinate plane with
``plane="xz"`` (``"xy"``, ``"yz"``). The file type follows the suffix: ``.gif``
(written by Pillow) or ``.html`` (a self-contained page of PNG frames with play,
pause and a slider). Figures are plain :class:`matplotlib.figure.Figure` objects
on an Agg canvas: no pyplot, no backend switching, no screen. The axes are drawn
once and only the mechanism and the time are redrawn per frame (blitting): about
ten times faster than redrawing the figure.
"""

from __future__ import annotations

import base64
import io
import os
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.artist import Artist
from matplotlib.axes import Axes
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from numpy.typing import ArrayLike, NDArray
from PIL import Image

from ..trajectory import Trajectory
from .drawers import default_drawer
from .modes import PLANES, Plane

SUFFIXES = (".gif", ".html")
#: The width of an animation in pixels unless asked otherwise.
DEFAULT_WIDTH = 640
#: The margin around the mechanism, a fraction of its largest extent over the motion.
MARGIN = 0.04
#: The height of a 2D animation over its width stays in these bounds (a hanging chain
#: that hardly swings still gets a frame one can read).
ASPECT_RANGE = (0.5, 1.6)
#: Drawings of more polylines than this are drawn in one colour, not the colour cycle.
CYCLED_LINES = 10
_DPI = 100
#: Pixels above the drawing for the title and the time.
_TITLE_PX = 30
#: ``draw(system, q)``: the polylines of the mechanism at ``q`` (in coordinate order),
#: each a ``(k, 2)`` or ``(k, 3)`` array; ``system`` is what :func:`animate` was given.
AnimationDraw = Callable[[Any, NDArray[np.float64]], Sequence[ArrayLike]]
#: The polylines of one frame.
Lines = list[NDArray[np.float64]]


def frame_indices(n_points: int, frames: int) -> NDArray[np.intp]:
    """At most ``frames`` evenly spread output indices, first and last included.

    Parameters
    ----------
    n_points
        The number of outputs.
    frames
        The most frames wanted (at least 1).

    Examples
    --------
    >>> frame_indices(11, 3).tolist()
    [0, 5, 10]
    """
    if frames < 1:
        raise ValueError(f"frames must be at least 1, got {frames}")
    return np.unique(np.linspace(0, n_points - 1, min(frames, n_points)).round().astype(int))


def _drawer(system: object,
            draw: AnimationDraw | None) -> Callable[[NDArray[np.float64]], Sequence[ArrayLike]]:
    if draw is None:
        draw, why = default_drawer(system)
        if draw is None:
            raise ValueError(f"{why}; give draw=draw(system, q) returning polylines")
    found = draw
    return lambda q: found(system, q)


def mechanism_frames(traj: Trajectory, system: object = None, draw: AnimationDraw | None = None,
                     frames: int = 40,
                     plane: Plane | None = None) -> tuple[NDArray[np.intp], list[Lines]]:
    """The output indices and, for each, the polylines (2 or 3 columns each).

    Parameters
    ----------
    traj, system, draw, frames, plane
        As in :func:`animate`.

    Only ``traj.t`` and ``traj.q`` are used:

    >>> from types import SimpleNamespace
    >>> traj = SimpleNamespace(t=np.arange(3.0), q=np.ones((3, 2)))
    >>> idx, lines = mechanism_frames(traj, draw=lambda s, q: [np.array([[0, 0], q])])
    >>> idx.tolist(), lines[0][0].tolist()
    ([0, 1, 2], [[0.0, 0.0], [1.0, 1.0]])
    """
    if plane is not None and plane not in PLANES:
        raise ValueError(f"plane must be one of {', '.join(PLANES)} or None, got {plane!r}")
    if len(traj.t) == 0:
        raise ValueError("the trajectory has no points to animate")
    render = _drawer(system, draw)
    idx = frame_indices(len(traj.t), frames)
    out: list[Lines] = []
    for i in idx:
        lines = [np.atleast_2d(np.asarray(p, dtype=float)) for p in render(traj.q[i])]
        if plane is not None:
            lines = [p[:, PLANES[plane]] if p.shape[1] == 3 else p for p in lines]
        out.append(lines)
    return idx, out


def _bounds(pts: NDArray[np.float64]) -> NDArray[np.float64]:
    """``[[lo, hi], ...]`` per axis: every point drawn, with a margin of :data:`MARGIN`
    of the largest extent (a mechanism that does not move, or a single point, gets a
    unit box)."""
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    size = float((hi - lo).max())
    pad = MARGIN * size if size > 0 else 0.5
    return np.column_stack([lo - pad, hi + pad])


def _figure(all_lines: list[Lines], plane: Plane | None, width: int,
            axes: bool) -> tuple[Figure, FigureCanvasAgg, Axes]:
    """The figure, its Agg canvas and its axes, fitted to the drawn points."""
    points = np.vstack([p for lines in all_lines for p in lines])
    bounds = _bounds(points)
    if points.shape[1] == 3:
        return _figure_3d(bounds, points, width, axes)
    span = bounds[:, 1] - bounds[:, 0]
    aspect = float(np.clip(span[1] / span[0], *ASPECT_RANGE))
    # pixel margins: tick labels left and below, the title above
    left, right, bottom = (52, 12, 44) if axes else (44, 12, 24)
    inner = width - left - right
    height = round(inner * aspect) + bottom + _TITLE_PX
    fig = Figure(figsize=(width / _DPI, height / _DPI), dpi=_DPI)
    canvas = FigureCanvasAgg(fig)
    ax = fig.add_axes((left / width, bottom / height, inner / width,
                       (height - bottom - _TITLE_PX) / height))
    # equal scales: the side with room to spare is widened about its middle
    box = np.array([inner, height - bottom - _TITLE_PX], dtype=float)
    scale = float((span / box).max())
    middle = bounds.mean(axis=1)
    ax.set_xlim(middle[0] - scale * box[0] / 2, middle[0] + scale * box[0] / 2)
    ax.set_ylim(middle[1] - scale * box[1] / 2, middle[1] + scale * box[1] / 2)
    ax.tick_params(labelsize="small")
    if axes:
        labels = plane or "xy"
        ax.set_xlabel(labels[0])
        ax.set_ylabel(labels[1])
        ax.grid(True, alpha=0.3)
    return fig, canvas, ax


def _figure_3d(bounds: NDArray[np.float64], points: NDArray[np.float64], width: int,
               axes: bool) -> tuple[Figure, FigureCanvasAgg, Axes]:
    """A 3D axes (orthographic, equal scales) zoomed until ``points`` fill it."""
    fig = Figure(figsize=(width / _DPI, width / _DPI), dpi=_DPI)
    canvas = FigureCanvasAgg(fig)
    ax: Any = fig.add_subplot(projection="3d")
    ax.set_proj_type("ortho")
    ax.set_xlim(*bounds[0])
    ax.set_ylim(*bounds[1])
    ax.set_zlim(*bounds[2])
    span = tuple(bounds[:, 1] - bounds[:, 0])
    ax.set_box_aspect(span)
    if axes:
        ax.set_xlabel("x")
        ax.set_ylabel("y")
        ax.set_zlabel("z")
    else:
        ax.set_axis_off()
    # every drawn point, as projected, measured twice: for the figure's height, then for
    # the zoom (about the box's center, the axes' center) that brings the farthest one
    # to the edge. Measured against the figure's area below the title, not the axes'
    # bbox: a 3D axes keeps itself square, so the mechanism is drawn unclipped (animate).
    probe = ax.plot(*points.T, ls="none", color="k")[0]   # a colour: the cycle stays
    for measure in ("height", "zoom"):
        canvas.draw()
        xy = probe.get_transform().transform(np.asarray(probe.get_xydata()))
        reach = np.abs(xy - np.asarray(ax.bbox.corners()).mean(axis=0)).max(axis=0) * 2
        if measure == "height":
            aspect = float(np.clip(reach[1] / reach[0], *ASPECT_RANGE))
            height = round(width * aspect) + _TITLE_PX
            fig.set_size_inches(width / _DPI, height / _DPI)
            ax.set_position((0.0, 0.0, 1.0, 1.0 - _TITLE_PX / height))
    zoom = min(width / reach[0], (height - _TITLE_PX) / reach[1]) / (1 + 2 * MARGIN)
    ax.set_box_aspect(span, zoom=zoom * (0.75 if axes else 1.0))   # room for tick labels
    probe.remove()
    return fig, canvas, ax


def animate(
    traj: Trajectory,
    path: str | os.PathLike,
    *,
    system: object = None,
    draw: AnimationDraw | None = None,
    frames: int = 40,
    fps: float = 15.0,
    plane: Plane | None = None,
    title: str | None = None,
    width: int = DEFAULT_WIDTH,
    axes: bool = False,
) -> Path:
    """Write an animation of the mechanism along ``traj`` to ``path`` (``.gif``/``.html``).

    Parameters
    ----------
    traj
        The simulated trajectory.
    path
        Output file; its suffix picks the format. Parent folders are created.
    system
        The :class:`~dalembert.System` (passed to ``draw``), or a ``Multibody``.
    draw
        ``draw(system, q) -> list of (k, 2) or (k, 3) arrays``; default: the
        multibody stick figure, or the points that the coordinates name
        (:func:`~dalembert.plotting.drawers.default_drawer`).
    frames, fps
        At most ``frames`` evenly spread outputs, played at ``fps``.
    plane
        Project 3D drawings on ``"xy"``, ``"xz"`` or ``"yz"`` (default: 3D axes).
    title
        Figure title (the time is appended).
    width
        The width of the frames in pixels (their height follows the mechanism's shape).
    axes
        Draw the grid, the axis labels and (3D) the panes; by default a 2D drawing
        has a frame with ticks only and a 3D drawing no axes.

    Returns
    -------
    Path
        ``path``.

    Examples
    --------
    >>> import tempfile
    >>> from types import SimpleNamespace
    >>> t = np.linspace(0, 1, 5)
    >>> traj = SimpleNamespace(t=t, q=np.column_stack([np.sin(t), -np.cos(t)]))
    >>> out = animate(traj, tempfile.mkdtemp() + "/swing.gif",
    ...               draw=lambda s, q: [np.array([[0.0, 0.0], q])])
    >>> out.stat().st_size > 0
    True
    """
    path = Path(path)
    if width < 64:
        raise ValueError(f"width must be at least 64 pixels, got {width}")
    if path.suffix.lower() not in SUFFIXES:
        raise ValueError(f"{path}: the animation is written as .gif or .html, "
                         f"not {path.suffix or 'no suffix'!r}")
    idx, all_lines = mechanism_frames(traj, system, draw, frames, plane)
    dims = {p.shape[1] for lines in all_lines for p in lines}
    if not dims <= {2, 3} or len(dims) != 1:
        raise ValueError(f"draw must return polylines with 2 or 3 columns, all alike; got {dims}")
    dim = dims.pop()
    fig, canvas, ax = _figure(all_lines, plane, width, axes)
    n_lines = max(len(lines) for lines in all_lines)
    # points alone (particles) are drawn large, each with its path so far: a point on
    # its own shows no motion
    points_only = all(len(p) == 1 for lines in all_lines for p in lines) and \
        len({len(lines) for lines in all_lines}) == 1
    # a few parts (a top's axes, a four-bar's links) in the colour cycle, many (a chain,
    # whose link halves are two polylines each) in one colour. Unclipped: a 3D axes is
    # square and smaller than a tall or wide mechanism's frame.
    style: dict[str, Any] = {"color": "C0"} if n_lines > CYCLED_LINES else {}
    artists = [ax.plot(*([[]] * dim), "o-", lw=2, ms=8 if points_only else 3, clip_on=False,
                       **style)[0] for _ in range(n_lines)]
    trails = [ax.plot(*([[]] * dim), "-", lw=1, alpha=0.5, clip_on=False,
                      color=artist.get_color())[0]
              for artist in (artists if points_only else [])]
    label = fig.text(0.5, 1.0 - 6 / fig.bbox.height, "", ha="center", va="top")

    def update(k: int) -> list[Artist]:
        lines = all_lines[k]
        for j, artist in enumerate(artists):
            _set_points(artist, lines[j] if j < len(lines) else np.empty((0, dim)))
        for j, trail in enumerate(trails):
            _set_points(trail, np.vstack([frame[j] for frame in all_lines[:k + 1]]))
        label.set_text(f"{title + '   ' if title else ''}t = {traj.t[idx[k]]:.3f}"
                       f"{_impacts_since(traj, idx, k)}")
        return [*trails, *artists, label]

    images = _render(fig, canvas, [*trails, *artists, label], update, len(idx))
    path.parent.mkdir(parents=True, exist_ok=True)
    if path.suffix.lower() == ".gif":
        # one palette for all frames, from the first, middle and last stacked (colours
        # that appear later, such as a path drawn so far, are in it): quantizing each
        # frame anew is most of the time of a GIF
        chosen = [images[0], images[len(images) // 2], images[-1]]
        stack = Image.new("RGB", (images[0].width, images[0].height * 3))
        for k, image in enumerate(chosen):
            stack.paste(image, (0, k * image.height))
        palette = stack.quantize(colors=128)
        frames_p = [im.quantize(palette=palette, dither=Image.Dither.NONE) for im in images]
        frames_p[0].save(path, save_all=True, append_images=frames_p[1:], loop=0,
                         duration=round(1000.0 / fps))
    else:
        path.write_text(_html_player(images, fps, title or "animation"), encoding="utf-8")
    return path


def _impacts_since(traj: Trajectory, idx: NDArray[np.intp], k: int) -> str:
    """``"   impact"`` (or ``"   3 impacts"``) when the run's contacts struck since the
    frame before ``k``, else empty."""
    contacts = getattr(traj, "contacts", None)  # a trajectory-like value may lack it
    if contacts is None or k == 0:
        return ""
    times = contacts.impact_times
    count = int(np.count_nonzero((times > traj.t[idx[k - 1]]) & (times <= traj.t[idx[k]])))
    return "" if not count else "   impact" if count == 1 else f"   {count} impacts"


def _set_points(line: Line2D, p: NDArray[np.float64]) -> None:
    """Give a line its points ``(k, 2)``, or ``(k, 3)`` for a line of 3D axes."""
    if p.shape[1] == 3:
        from mpl_toolkits.mplot3d.art3d import Line3D  # loaded with the 3D axes

        assert isinstance(line, Line3D)  # what a 3D axes plots
        line.set_data_3d(p[:, 0], p[:, 1], p[:, 2])
    else:
        line.set_data(p[:, 0], p[:, 1])


def _render(fig: Figure, canvas: FigureCanvasAgg, animated: list[Artist],
            update: Callable[[int], list[Artist]], n: int) -> list[Image.Image]:
    """The ``n`` frames as RGB images: the static figure once, the ``animated`` artists
    drawn over a copy of it per frame."""
    for artist in animated:
        artist.set_animated(True)   # left out of the full draw below
    canvas.draw()
    background = canvas.copy_from_bbox(fig.bbox)
    images = []
    for k in range(n):
        canvas.restore_region(background)
        for artist in update(k):
            fig.draw_artist(artist)
        rgba = np.asarray(canvas.buffer_rgba())
        images.append(Image.fromarray(rgba[..., :3].copy()))
    return images


_PLAYER = """<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8"><title>{title}</title></head>
<body style="font-family:sans-serif">
<img id="frame" alt="{title}"><br>
<button id="play">pause</button> <input id="slider" type="range" min="0" max="{last}" value="0">
<script>
const frames = [{frames}];
const img = document.getElementById("frame"), slider = document.getElementById("slider");
const button = document.getElementById("play");
let k = 0, playing = true;
function show(i) {{ k = i; img.src = frames[i]; slider.value = i; }}
slider.oninput = () => {{ playing = false; button.textContent = "play"; show(+slider.value); }};
button.onclick = () => {{ playing = !playing; button.textContent = playing ? "pause" : "play"; }};
setInterval(() => {{ if (playing) show((k + 1) % frames.length); }}, {interval});
show(0);
</script></body></html>
"""


def _html_player(images: list[Image.Image], fps: float, title: str) -> str:
    """A self-contained page: the frames as base64 PNGs and a few lines of JavaScript."""
    urls = []
    for image in images:
        buf = io.BytesIO()
        image.save(buf, format="PNG")
        urls.append('"data:image/png;base64,' + base64.b64encode(buf.getvalue()).decode() + '"')
    return _PLAYER.format(title=title.replace("<", "&lt;"), last=len(images) - 1,
                          frames=",\n".join(urls), interval=round(1000.0 / fps))
