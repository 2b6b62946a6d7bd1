"""A stick figure of a multibody system at one configuration, as 3D polylines.

Used by :func:`dalembert.plotting.animate` (through ``Multibody.stick_figure``)
and by the multibody gallery examples' ``draw(system, q)``. Drawn, all in world
coordinates:

- every joint: a line from each moving body's mass center to its joint point,
  so a chain shows as its links, and a ground joint point as a single point;
- a rolling joint: center -> contact point, and a disk's rim;
- every spring: a line between its two points;
- the axes through the mass center, each of half-length the body's radius of
  gyration, of every rigid body that no joint or spring holds (nothing else shows
  how it turns), or of every rigid body with ``body_axes=True`` (they show a spin
  that the links do not, as a top's, but clutter a chain's links);
- a particle, and a rigid body drawn without its axes: its mass center as a point.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from .bodies import Body, Ground, TurningBody
from .diagnostics import radius_of_gyration
from .joints import Free
from .rolling import Rolling
from .types import FloatArray, Numbers

if TYPE_CHECKING:
    from .builder import Multibody

_RIM_POINTS = 25
#: ``{body name: (center, R)}``: each moving body's pose at one configuration.
Poses = dict[str, tuple[FloatArray, FloatArray]]


def _poses(mb: Multibody, q: FloatArray) -> Poses:
    """``{body name: (center, R)}`` from a state vector in coordinate order."""
    out: Poses = {}
    k = 0
    for body in mb.bodies:
        n = len(body.coordinates)
        x, R = body.pose(q[k:k + n])
        out[body.name] = (x[0], R[0])
        k += n
    return out


def _point(poses: Poses, body: Body, point: FloatArray) -> FloatArray:
    if isinstance(body, Ground):
        return np.asarray(point, dtype=float)
    x, R = poses[body.name]
    return x + R @ point


def _rim(joint: Rolling, x: FloatArray, R: FloatArray) -> FloatArray:
    a = R @ joint.axis_b
    e1 = np.cross(a, [1.0, 0.0, 0.0] if abs(a[0]) < 0.9 else [0.0, 1.0, 0.0])
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(a, e1)
    ang = np.linspace(0.0, 2 * np.pi, _RIM_POINTS)
    return x + joint.radius * (np.outer(np.cos(ang), e1) + np.outer(np.sin(ang), e2))


def stick_figure(mb: Multibody, q: Numbers, *,
                 body_axes: bool | None = None) -> list[FloatArray]:
    """Polylines ``(k, 3)`` (world) of ``mb`` at the configuration ``q``.

    Parameters
    ----------
    mb
        The mechanism.
    q
        Its configuration, in the order of ``mb.system.coordinate_names``.
    body_axes
        Draw each rigid body's axes through its mass center (``True``), no body's
        (``False``), or those of the bodies that no joint or spring holds (``None``).

    Examples
    --------
    >>> from dalembert.multibody import chain
    >>> mb = chain(2, 1.0, 1.0, 0.1)
    >>> q0, _ = mb.initial_state(positions={"link1": (0, 0, -0.5), "link2": (0, 0, -1.5)})
    >>> lines = stick_figure(mb, [q0[n] for n in mb.system.coordinate_names])
    >>> lines[1].tolist()
    [[0.0, 0.0, -0.5], [0.0, 0.0, 0.0]]
    """
    poses = _poses(mb, np.asarray(q, dtype=float))
    lines: list[FloatArray] = []
    # a Free joint holds nothing: no stick (its body keeps its axes)
    joints = [j for j in mb.joints if not isinstance(j, Free)]
    for j in joints:
        if isinstance(j, Rolling):
            x, R = poses[j.body_b.name]
            contact = j.contact_points(x[None], R[None])[0]
            lines.append(np.array([x, contact]))
            if j.is_disk:
                lines.append(_rim(j, x, R))
            continue
        for body, point in ((j.body_a, j.point_a), (j.body_b, j.point_b)):
            if isinstance(body, Ground):
                lines.append(np.asarray(point, dtype=float)[None].copy())
            else:
                lines.append(np.array([poses[body.name][0], _point(poses, body, point)]))
    for s in mb.springs:
        lines.append(np.array([_point(poses, s.body_a, s.point_a),
                               _point(poses, s.body_b, s.point_b)]))
    held = {b.name for j in joints for b in (j.body_a, j.body_b)}
    held |= {b.name for s in mb.springs for b in (s.body_a, s.body_b)}
    for body in mb.bodies:
        x, R = poses[body.name]
        axes = body.name not in held if body_axes is None else body_axes
        if not (axes and isinstance(body, TurningBody)):
            lines.append(x[None].copy())
            continue
        k = radius_of_gyration(body)
        lines.extend(np.array([x - k * R[:, i], x + k * R[:, i]]) for i in range(3))
    return lines
