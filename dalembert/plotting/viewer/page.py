"""The viewer's page: the scene's numbers packed into JSON, and the HTML around them.

Arrays travel as base64 of little-endian binary: times and positions as float32,
rotations as int16 quaternion components (steps of 1/32767, about 3e-5 rad), forces
as int16 steps of the largest force. The script (``viewer.js``: three.js and the
page's code, built by ``viewer/build.sh`` in the repository) is inlined, so the page
is one file that needs no network.
"""

from __future__ import annotations

import base64
import html
import json
from importlib import resources
from typing import Any

import numpy as np

from ...trajectory import Trajectory
from .scene import Scene

#: Points of each plot beside the picture, at most.
PLOT_POINTS = 1200
INT16 = 32767
#: The arrow of the largest constraint force, as a fraction of the scene's size.
ARROW_LENGTH = 0.25


def _b64(values: np.ndarray, dtype: str) -> str:
    data = np.ascontiguousarray(values, dtype=np.dtype(dtype).newbyteorder("<"))
    return base64.b64encode(data.tobytes()).decode("ascii")


def _horizontal_view(scene: Scene) -> list[float]:
    """The side the camera looks from: across the horizontal direction the motion spans
    least, so that a planar motion faces the camera."""
    up = np.asarray(scene.up, dtype=float)
    axes = np.eye(3)
    e1 = axes[int(np.argmin(np.abs(axes @ up)))]
    e1 = e1 - (e1 @ up) * up
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(up, e1)
    p = scene.positions.reshape(-1, 3)
    side = -e2 if np.ptp(p @ e2) <= np.ptp(p @ e1) else e1
    return (side + 0.0).tolist()  # no -0.0


def _plot_rows(n: int) -> np.ndarray:
    return np.unique(np.linspace(0, n - 1, min(n, PLOT_POINTS)).round().astype(int))


def _plots(traj: Trajectory, energy: str) -> list[dict[str, Any]]:
    """The energy drift and the constraint residuals along the whole run."""
    rows = _plot_rows(len(traj))
    t = _b64(traj.t[rows], "f4")
    values = traj.jacobi_integral if energy == "jacobi" else traj.energy
    label = "Jacobi integral h" if energy == "jacobi" else "energy T + V"
    plots = []
    if np.isfinite(values[0]):
        plots.append({"title": f"{label}: change", "log": False, "t": t,
                      "series": [{"name": "h − h(0)" if energy == "jacobi" else "E − E(0)",
                                  "color": "#1f77b4",
                                  "values": _b64(values[rows] - values[0], "f4")}]})
    else:
        plots.append({"title": f"{label}: not recorded", "log": False, "t": t, "series": []})
    plots.append({"title": "constraint residuals", "log": True, "t": t,
                  "series": [{"name": "position", "color": "#2ca02c",
                              "values": _b64(traj.position_residual[rows], "f4")},
                             {"name": "velocity", "color": "#d62728",
                              "values": _b64(traj.velocity_residual[rows], "f4")}]})
    return plots


def scene_json(scene: Scene, traj: Trajectory, energy: str = "energy",
               title: str = "") -> dict[str, Any]:
    """The JSON object the page's script reads.

    Parameters
    ----------
    scene
        What to draw, frame by frame.
    traj
        The whole trajectory (for the plots, at full resolution up to
        :data:`PLOT_POINTS` points).
    energy
        ``"energy"`` (``T + V``) or ``"jacobi"`` (the Jacobi integral) for the plot.
    title
        The page's title.

    Examples
    --------
    >>> from dalembert.examples import load
    >>> from dalembert.plotting.viewer.scene import points_scene
    >>> pendulum = load("pendulum")
    >>> system = pendulum.build()
    >>> traj = system.simulate((0, 0.5), **pendulum.INITIAL, t_eval=[0, 0.25, 0.5])
    >>> data = scene_json(points_scene(system, traj), traj)
    >>> len(base64.b64decode(data["positions"])) == 3 * 2 * 3 * 4, data["view"]
    (True, [0.0, 0.0, 1.0])
    """
    center, extent = scene.bounds()
    forces = None
    if scene.forces is not None and scene.arrows:
        largest = float(np.max(np.linalg.norm(scene.forces, axis=-1)))
        if np.isfinite(largest) and largest > 0:
            unit = float(np.max(np.abs(scene.forces))) / INT16
            forces = {"values": _b64(np.round(np.nan_to_num(scene.forces) / unit), "i2"),
                      "unit": unit, "largest": largest, "length": ARROW_LENGTH * extent}
    return {
        "title": title,
        "t": _b64(scene.t, "f4"),
        "bodies": scene.body_names,
        "positions": _b64(scene.positions, "f4"),
        "quaternions": _b64(np.round(scene.quaternions * INT16), "i2"),
        "shapes": scene.shapes,
        "joints": scene.joints,
        "arrows": scene.arrows,
        "forces": forces,
        "traces": scene.traces,
        "sticks": scene.sticks,
        "up": list(scene.up),
        "center": center.tolist(),
        "extent": extent,
        "view": _horizontal_view(scene),
        "plots": _plots(traj, energy),
    }


def viewer_script() -> str:
    """The bundled script (three.js and the page's code), as shipped in the package.

    Examples
    --------
    >>> "three.js authors" in viewer_script().lower()
    True
    """
    return resources.files(__package__).joinpath("viewer.js").read_text(encoding="utf-8")


_PAGE = """<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8"><title>{title}</title>
<meta name="viewport" content="width=device-width, initial-scale=1">
<style>
html, body {{ margin: 0; height: 100%; font: 13px sans-serif; color: #222; }}
body {{ display: flex; flex-direction: column; }}
#main {{ flex: 1; display: flex; min-height: 0; }}
#view {{ flex: 1; min-width: 0; position: relative; }}
#view canvas {{ display: block; }}
#side {{ width: 340px; padding: 6px; box-sizing: border-box; overflow-y: auto;
         border-left: 1px solid #ddd; position: relative; }}
.cursor {{ position: absolute; width: 1px; background: #d62728; pointer-events: none; }}
#side canvas {{ width: 100%; height: 170px; display: block; margin-bottom: 8px; }}
#bar {{ display: flex; gap: 10px; align-items: center; padding: 6px 8px;
        border-top: 1px solid #ddd; flex-wrap: wrap; }}
#time {{ flex: 1; min-width: 160px; }}
#clock {{ font-family: monospace; min-width: 10em; }}
h1 {{ font-size: 14px; margin: 0 0 6px 0; }}
</style></head><body>
<div id="main"><div id="view"></div>
<div id="side"><h1>{title}</h1>
<canvas id="plot0" height="170"></canvas><canvas id="plot1" height="170"></canvas>
<p>Drag to orbit, scroll to zoom, right-drag to pan.</p></div></div>
<div id="bar">
<button id="play" type="button">Pause</button>
<label>speed <select id="speed">
<option value="0.1">0.1x</option><option value="0.25">0.25x</option>
<option value="0.5">0.5x</option><option value="1" selected>1x</option>
<option value="2">2x</option><option value="4">4x</option></select></label>
<input id="time" type="range" min="0" max="1000" value="0" aria-label="time">
<span id="clock"></span>
<label>forces <input id="force-scale" type="range" min="0" max="300" value="{forces}"
aria-label="force arrow scale"></label>
<label><input id="show-joints" type="checkbox" checked> joints</label>
<label><input id="show-forces" type="checkbox" checked> forces</label>
<label><input id="show-traces" type="checkbox" checked> traces</label>
</div>
<script id="dalembert-scene" type="application/json">{scene}</script>
<script>{script}</script>
</body></html>
"""


def page(data: dict[str, Any]) -> str:
    """The HTML page showing ``data`` (from :func:`scene_json`).

    Parameters
    ----------
    data
        The scene's JSON object.

    Examples
    --------
    >>> text = page({"title": "a <b>", "forces": None})
    >>> "<title>a &lt;b&gt;</title>" in text, text.count("<script")
    (True, 2)
    """
    scene = json.dumps(data, separators=(",", ":"), allow_nan=False).replace("</", "<\\/")
    return _PAGE.format(title=html.escape(str(data.get("title", ""))),
                        forces=100 if data.get("forces") else 0, scene=scene,
                        script=viewer_script().replace("</script", "<\\/script"))
