"""Animations of a mechanism along a :class:`~dalembert.Trajectory`, as GIF or HTML.

The mechanism is drawn as polylines at each frame's configuration ``q``:

- ``draw(system, q)``, when given (the gallery examples define one): a list of
  ``(k, 2)`` or ``(k, 3)`` arrays;
- otherwise, for a system built by :class:`dalembert.multibody.Multibody` (or the
  ``Multibody`` itself), its stick figure: links from mass centers to joint
  points, rolling contacts, springs and body axes (3D).

3D drawings are shown in a 3D axes, or projected on a coordinate plane with
``plane="xz"`` (``"xy"``, ``"yz"``). The file type follows the suffix: ``.gif``
(written by Pillow) or ``.html`` (a self-contained page of PNG frames with play,
pause and a slider). Figures are plain :class:`matplotlib.figure.Figure` objects
on an Agg canvas: no pyplot, no backend switching, no screen. The axes, grid and
labels are drawn once and only the mechanism and the time are redrawn per frame
(blitting): about ten times faster than redrawing the figure.
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
from .modes import PLANES, Plane

SUFFIXES = (".gif", ".html")
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
    if draw is not None:
        return lambda q: draw(system, q)
    from ..multibody.builder import Multibody  # only a multibody draws itself

    mb = system if isinstance(system, Multibody) else \
        getattr(getattr(system, "definition", None), "multibody", None)
    if not isinstance(mb, Multibody):
        raise ValueError(
            "nothing to draw: give draw=draw(system, q) returning polylines, or a system "
            "built by dalembert.multibody.Multibody (or the Multibody itself)"
        )
    return mb.stick_figure


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


def _limits(all_lines: list[Lines]) -> NDArray[np.float64]:
    pts = np.vstack([p for lines in all_lines for p in lines])
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    half = max(float((hi - lo).max()) / 2, 1e-9) * 1.1
    mid = (lo + hi) / 2
    return np.column_stack([mid - half, mid + half])   # equal scale on every axis


def _figure(dim: int, limits: NDArray[np.float64],
            plane: Plane | None) -> tuple[Figure, FigureCanvasAgg, Axes]:
    """The figure, its Agg canvas and its axes (3D axes when ``dim`` is 3)."""
    fig = Figure(figsize=(4.8, 4.8), dpi=80)
    canvas = FigureCanvasAgg(fig)
    if dim == 3:
        ax = fig.add_subplot(projection="3d")
        ax.set_xlim(*limits[0])
        ax.set_ylim(*limits[1])
        ax.set_zlim(*limits[2])
        ax.set_xlabel("x")
        ax.set_ylabel("y")
        ax.set_zlabel("z")
    else:
        ax = fig.add_subplot()
        ax.set_xlim(*limits[0])
        ax.set_ylim(*limits[1])
        ax.set_aspect("equal")
        fig.subplots_adjust(left=0.16)   # room for the y label
        labels = plane or "xy"
        ax.set_xlabel(labels[0])
        ax.set_ylabel(labels[1])
        ax.grid(True, alpha=0.3)
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
        multibody stick figure.
    frames, fps
        At most ``frames`` evenly spread outputs, played at ``fps``.
    plane
        Project 3D drawings on ``"xy"``, ``"xz"`` or ``"yz"`` (default: 3D axes).
    title
        Figure title (the time is appended).

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
    if path.suffix.lower() not in SUFFIXES:
        raise ValueError(f"{path}: the animation is written as .gif or .html, "
                         f"not {path.suffix or 'no suffix'!r}")
    idx, all_lines = mechanism_frames(traj, system, draw, frames, plane)
    dims = {p.shape[1] for lines in all_lines for p in lines}
    if not dims <= {2, 3} or len(dims) != 1:
        raise ValueError(f"draw must return polylines with 2 or 3 columns, all alike; got {dims}")
    dim = dims.pop()
    fig, canvas, ax = _figure(dim, _limits(all_lines), plane)
    n_lines = max(len(lines) for lines in all_lines)
    artists = [ax.plot(*([[]] * dim), "o-", lw=2, ms=3)[0] for _ in range(n_lines)]
    label = ax.set_title("")

    def update(k: int) -> list[Artist]:
        lines = all_lines[k]
        for j, artist in enumerate(artists):
            _set_points(artist, lines[j] if j < len(lines) else np.empty((0, dim)))
        label.set_text(f"{title + '   ' if title else ''}t = {traj.t[idx[k]]:.3f}")
        return [*artists, label]

    images = _render(fig, canvas, [*artists, label], update, len(idx))
    path.parent.mkdir(parents=True, exist_ok=True)
    if path.suffix.lower() == ".gif":
        # one palette, from the first frame, for all: quantizing each frame anew is
        # most of the time of a GIF
        palette = images[0].quantize(colors=128)
        frames_p = [im.quantize(palette=palette, dither=Image.Dither.NONE) for im in images]
        frames_p[0].save(path, save_all=True, append_images=frames_p[1:], loop=0,
                         duration=round(1000.0 / fps))
    else:
        path.write_text(_html_player(images, fps, title or "animation"), encoding="utf-8")
    return path


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
