"""A 3D viewer of a trajectory in the browser: one self-contained HTML page.

:func:`view` writes a page that plays the motion with three.js: the bodies as their
shapes (see :mod:`.scene`), the joints marked, the constraint forces as arrows (a
slider scales them), traces of points, play/pause, speed, a time slider, the camera
orbiting with the mouse, and the energy and the constraint residuals plotted beside
it. The script is bundled into the page (:mod:`.page`): the page opens offline.
"""

from __future__ import annotations

import os
from collections.abc import Iterable, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from ...trajectory import Trajectory
from .page import page, scene_json
from .scene import Scene, multibody_scene, points_scene, sampled

#: Frames kept per second of simulated time (the page interpolates between them).
FRAME_RATE = 30.0
ENERGIES = ("energy", "jacobi")

__all__ = ["FRAME_RATE", "Scene", "scene_of", "view"]


def _multibody(system: object) -> Any:
    from ...multibody.builder import Multibody

    if isinstance(system, Multibody):
        return system
    mb = getattr(getattr(system, "definition", None), "multibody", None)
    return mb if isinstance(mb, Multibody) else None


def scene_of(traj: Trajectory, system: object, *, frame_rate: float = FRAME_RATE,
             traces: Sequence[str] | None = None) -> Scene:
    """The scene :func:`view` draws: ``traj`` sampled to ``frame_rate``, as poses and shapes.

    Parameters
    ----------
    traj, system, frame_rate, traces
        As in :func:`view`.

    Examples
    --------
    >>> from dalembert.multibody import chain
    >>> mb = chain(3, 1.0, 1.0, 0.1)
    >>> q0, qd0 = mb.initial_state(
    ...     positions={f"link{k + 1}": (0, 0, -0.5 - k) for k in range(3)})
    >>> traj = mb.simulate((0, 1), q0, qd0, t_eval=[0.0, 0.5, 1.0])
    >>> scene = scene_of(traj, mb.system)
    >>> scene.body_names, [j["name"] for j in scene.joints], scene.forces.shape
    (['link1', 'link2', 'link3'], ['joint1', 'joint2', 'joint3'], (3, 3, 3))
    """
    if not isinstance(traj, Trajectory):
        raise TypeError(f"the viewer shows a Trajectory (what simulate returns, or "
                        f"Trajectory.load), got {type(traj).__name__}")
    mb = _multibody(system)
    names = tuple(mb.system.coordinate_names if mb is not None else
                  getattr(system, "coordinate_names", ()))
    if not names:
        raise TypeError("the viewer draws the trajectory of a System or a Multibody: give "
                        f"the one that made it, got {type(system).__name__}")
    if tuple(traj.coordinate_names) != names:
        raise ValueError(
            "the trajectory is not one of this system: its coordinates are "
            f"{', '.join(traj.coordinate_names)}; the system's are {', '.join(names)}")
    if len(traj) == 0:
        raise ValueError("the trajectory has no output times: nothing to show")
    bad = ~np.all(np.isfinite(traj.q), axis=1)
    if bad.any():
        raise ValueError(f"the trajectory's positions are not finite at t={traj.t[bad][0]:.6g}"
                         f" ({int(bad.sum())} of {len(traj)} output times): nothing to draw "
                         "there; show the part before (traj.t < that time)")
    if isinstance(traces, str):  # one name
        traces = [traces]
    elif traces is not None and not (isinstance(traces, Iterable) and
                                     all(isinstance(n, str) for n in traces)):
        raise TypeError(f"traces must be names of bodies (or points), got {traces!r:.80}")
    few = sampled(traj, frame_rate)
    if mb is not None:
        return multibody_scene(mb, few, traces)
    return points_scene(system, few, traces)


def view(traj: Trajectory, system: object, path: str | os.PathLike, *,
         title: str | None = None, frame_rate: float = FRAME_RATE,
         traces: Sequence[str] | None = None, energy: str = "energy") -> Path:
    """Write a page that shows ``traj`` in 3D in the browser; return its path.

    The page is one HTML file (three.js included, no network needed): the bodies
    move along the trajectory, with play/pause, speed, a time slider, the camera
    orbiting with the mouse, joints marked, constraint forces as arrows scaled by a
    slider, traces of points, and the energy and the constraint residuals plotted
    beside the picture. What the bodies look like is in
    :mod:`dalembert.plotting.viewer.scene`.

    Parameters
    ----------
    traj
        A trajectory of ``system``.
    system
        A System built by :class:`dalembert.multibody.Multibody` (or the
        ``Multibody``), or any System whose coordinates name points ``x<s>, y<s>[,
        z<s>]``.
    path
        The ``.html`` file to write (its folder is made if missing).
    title
        The page's title (default: the system's name).
    frame_rate
        Frames kept per second of simulated time (all outputs if fewer); the page
        interpolates between frames, so this sets the size, not the smoothness.
    traces
        The bodies (or points, by their ``x`` coordinate) whose paths are drawn;
        default: the free ends of a mechanism, or the first points.
    energy
        The plotted quantity: ``"energy"`` (``T + V``) or ``"jacobi"`` (the Jacobi
        integral, conserved when ``T + V`` is not).

    Returns
    -------
    Path
        ``path``.

    Examples
    --------
    A chain of four links swinging in 3D, written to a temporary folder: the page
    holds the bundled three.js and the scene (the browser tests open such pages):

    >>> import pathlib, tempfile
    >>> import numpy as np
    >>> from dalembert.examples import load
    >>> example = load("spherical-chain")
    >>> system = example.build()
    >>> traj = system.simulate((0, 2), **example.INITIAL, t_eval=np.linspace(0, 2, 201))
    >>> with tempfile.TemporaryDirectory() as folder:
    ...     out = view(traj, system, pathlib.Path(folder) / "chain.html")
    ...     text = out.read_text(encoding="utf-8")
    >>> 500_000 < len(text) < 1_000_000, "Three.js Authors" in text, '"link4"' in text
    (True, True, True)
    """
    if not isinstance(path, (str, os.PathLike)):
        raise TypeError(f"path must be the .html file to write, got {path!r:.80} "
                        f"({type(path).__name__})")
    path = Path(path)
    if path.suffix.lower() != ".html":
        raise ValueError(f"{path}: the viewer writes an .html page; give a path ending in .html")
    if energy not in ENERGIES:
        raise ValueError(f"energy must be one of {ENERGIES}, not {energy!r}")
    if _is_dir(path):
        raise IsADirectoryError(f"cannot write the page {str(path)!r}: it is a folder")
    scene = scene_of(traj, system, frame_rate=frame_rate, traces=traces)
    name = title if title is not None else str(getattr(system, "name", "") or "trajectory")
    text = page(scene_json(scene, traj, energy, name))
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(text, encoding="utf-8")
    except (OSError, ValueError) as exc:  # ValueError: a NUL in the path
        reason = getattr(exc, "strerror", None) or str(exc)
        where = "its folder " + repr(str(path.parent)) if not _is_dir(path.parent) else "it"
        raise type(exc)(f"cannot write the page {str(path)!r}: {reason} (writing {where}); "
                        "give another path") from None
    return path


def _is_dir(path: Path) -> bool:
    """Whether ``path`` is a folder (``False`` where asking fails: a name too long)."""
    try:
        return path.is_dir()
    except (OSError, ValueError):
        return False
