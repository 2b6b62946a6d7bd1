"""What the 3D viewer draws, as plain numbers: bodies' poses per frame and their shapes.

A :class:`Scene` holds, for the frames kept, each body's world position and rotation
(a quaternion), the shapes drawn in each body's frame, the joints' points (and hinge
axes), the constraint force at each joint, the traced points and the sticks between
points. Two kinds of systems give one:

- a :class:`~dalembert.multibody.Multibody` (or a System it built): a mechanism
  imported from a model file is drawn as its geoms (:mod:`.model_shapes`; a body with
  none to draw, e.g. only planes, as its default shapes); any other as its default
  shapes, since a body carries no geometry of its own. A rigid or
  planar body is drawn as cylinders ("spokes") from its mass center to each of its
  joint and spring points (one cylinder between two points on either side of the
  center; one through the center, as long on both sides, for a body held at one
  point), of the radius a solid cylinder of its mass and axial inertia would have; a
  rigid body with no such point as the uniform box of its inertia; a body rolling on
  a plane as its disk or sphere; a particle as a sphere. The arrows are the joints'
  reactions (:func:`~dalembert.multibody.outputs.joint_reactions`) on the moving body
  of each joint, at its joint point (rolling contacts have none);
- any other System whose coordinates name points (``x<s>, y<s>[, z<s>]`` with a
  common suffix ``<s>``): each point a sphere, a stick between two points held at a
  distance by one constraint (and from the origin for ``x^2 + y^2 (+ z^2) = l^2``),
  arrows the generalized constraint forces ``A^T lambda`` on the point's coordinates.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import sympy as sp
from scipy.spatial.transform import Rotation

from ...multibody.bodies import Body, Ground, Particle, PlanarBody, RigidBody
from ...multibody.builder import Multibody
from ...multibody.joints import Free, Joint, Revolute
from ...multibody.outputs import joint_reactions
from ...multibody.rolling import Rolling
from ...multibody.types import FloatArray
from ...trajectory import Trajectory
from ..drawers import particle_points
from .model_shapes import imported_shapes

#: Traced points chosen when none are named.
DEFAULT_TRACES = 4
#: Relative size of a particle's sphere (of the scene's extent).
POINT_SIZE = 0.025
#: A joint marker's radius at most (of the scene's extent; else a little more than
#: its body's).
JOINT_SIZE = 0.02
#: A spoke's radius: that of a solid cylinder of the body's mass and axial inertia,
#: kept between these fractions of the body's longest spoke (so that a massless-looking
#: or a very thick body still reads as a link).
SPOKE_RADIUS = (0.04, 0.3)


@dataclass
class Scene:
    """The numbers of one page: poses per frame, shapes, joints, forces, traces.

    Parameters
    ----------
    t
        The frames' times, shape ``(F,)``.
    body_names
        The B bodies (or points).
    positions, quaternions
        Each body's world position ``(F, B, 3)`` and rotation ``(F, B, 4)`` as the
        quaternion ``(x, y, z, w)``.
    shapes
        Each a dict: ``body`` (index, -1 for the ground), ``kind`` (``"cylinder"``
        from ``from`` to ``to`` of ``radius``, ``"box"`` at ``center`` of ``size``
        turned by the quaternion ``rotation``, or ``"sphere"`` at ``center`` of
        ``radius``, an ellipsoid if it has ``radii`` and ``rotation``), in the body's
        frame.
    joints
        The joints' markers, each a dict: ``name``, ``body`` (index), ``point`` and
        ``axis`` (a hinge's, or ``None``) in that body's frame, and ``radius``.
    arrows
        Where the constraint forces act, each a dict: ``name``, ``body``, ``point``
        (body frame).
    forces
        The constraint force of each arrow ``(F, len(arrows), 3)`` (world), or
        ``None``.
    traces
        Each a dict: ``name``, ``body``, ``point`` (body frame).
    sticks
        Pairs of body indices joined by a line.
    up
        The world's up direction (against gravity).
    """

    t: FloatArray
    body_names: list[str]
    positions: FloatArray
    quaternions: FloatArray
    shapes: list[dict[str, Any]]
    joints: list[dict[str, Any]] = field(default_factory=list)
    arrows: list[dict[str, Any]] = field(default_factory=list)
    forces: FloatArray | None = None
    traces: list[dict[str, Any]] = field(default_factory=list)
    sticks: list[tuple[int, int]] = field(default_factory=list)
    up: tuple[float, float, float] = (0.0, 0.0, 1.0)

    def bounds(self) -> tuple[FloatArray, float]:
        """The center of the box holding every body's shapes over every frame, and its
        largest side.

        Examples
        --------
        >>> one = Scene(t=np.zeros(1), body_names=["p"], positions=np.zeros((1, 1, 3)),
        ...             quaternions=np.array([[[0.0, 0.0, 0.0, 1.0]]]),
        ...             shapes=[{"body": 0, "kind": "sphere", "center": [0, 0, 0],
        ...                      "radius": 0.5}])
        >>> center, size = one.bounds()
        >>> center.tolist(), size
        ([0.0, 0.0, 0.0], 1.0)
        """
        reach = np.zeros(len(self.body_names))
        lo, hi = np.full(3, np.inf), np.full(3, -np.inf)
        for shape in self.shapes:
            if shape["body"] >= 0:
                reach[shape["body"]] = max(reach[shape["body"]], shape_reach(shape))
            else:  # ground anchors and geoms are part of the picture too
                middle = shape_center(shape)
                lo, hi = np.minimum(lo, middle), np.maximum(hi, middle)
        lo = np.minimum(lo, (self.positions - reach[:, None]).min(axis=(0, 1)))
        hi = np.maximum(hi, (self.positions + reach[:, None]).max(axis=(0, 1)))
        return (lo + hi) / 2, float(max(np.max(hi - lo), 1e-9))


def shape_center(shape: dict[str, Any]) -> FloatArray:
    """A shape's middle point in its body's frame (a cylinder's between its ends).

    Parameters
    ----------
    shape
        A shape of :attr:`Scene.shapes`.

    Examples
    --------
    >>> shape_center({"kind": "cylinder", "from": [0, 0, -1], "to": [0, 0, 2], "radius": 0.5})
    array([0. , 0. , 0.5])
    """
    if shape["kind"] == "cylinder":
        return (np.asarray(shape["from"], dtype=float) + np.asarray(shape["to"], dtype=float)) / 2
    return np.asarray(shape["center"], dtype=float)


def shape_reach(shape: dict[str, Any]) -> float:
    """How far from its body's mass center a shape reaches, at most.

    Parameters
    ----------
    shape
        A shape of :attr:`Scene.shapes`.

    Examples
    --------
    >>> shape_reach({"kind": "cylinder", "from": [0, 0, -1], "to": [0, 0, 2], "radius": 0.5})
    2.5
    """
    if shape["kind"] == "cylinder":
        ends = max(float(np.linalg.norm(shape["from"])), float(np.linalg.norm(shape["to"])))
        return ends + shape["radius"]
    extra = float(np.linalg.norm(shape["size"])) / 2 if shape["kind"] == "box" \
        else shape["radius"]
    return float(np.linalg.norm(shape["center"])) + extra


def sampled(traj: Trajectory, frame_rate: float) -> Trajectory:
    """``traj`` at about ``frame_rate`` outputs per simulated second (all if fewer).

    Parameters
    ----------
    traj
        The trajectory.
    frame_rate
        Frames per second of simulated time; the outputs closest to an even spread
        are kept, the first and last always.

    Examples
    --------
    >>> from dalembert.examples import load
    >>> traj = load("pendulum").build().simulate((0, 2), {"x": 1.0, "y": 0.0},
    ...                                          t_eval=np.linspace(0.0, 2.0, 201))
    >>> few = sampled(traj, 10.0)
    >>> few.t[:3].round(12).tolist(), few.q.shape, few.multipliers.shape
    ([0.0, 0.1, 0.2], (21, 2), (21, 1))
    """
    if isinstance(frame_rate, bool) or not isinstance(frame_rate, (int, float, np.number)) \
            or not 0 < frame_rate < np.inf:
        raise ValueError(f"frame_rate must be a finite positive number (frames per "
                         f"simulated second), got {frame_rate!r}")
    n = len(traj)
    span = float(traj.t[-1] - traj.t[0]) if n else 0.0
    frames = int(np.ceil(span * frame_rate)) + 1
    if frames >= n:
        return traj
    keep = np.unique(np.linspace(0, n - 1, frames).round().astype(int))
    changes = {f.name: getattr(traj, f.name)[keep] for f in dataclasses.fields(traj)
               if isinstance(getattr(traj, f.name), np.ndarray)
               and getattr(traj, f.name).shape[:1] == (n,)}
    return dataclasses.replace(traj, **changes)


# -- multibody systems ---------------------------------------------------------------
def _columns(traj: Trajectory, index: dict[str, int], body: Body) -> FloatArray:
    return traj.q[:, [index[c.name] for c in body.coordinates]]


def _moving_side(joint: Joint) -> tuple[Body, FloatArray, FloatArray] | None:
    """The body a joint's marker and arrow go on (side b unless it is the ground)."""
    for body, point, axis in ((joint.body_b, joint.point_b, joint.axis_b),
                              (joint.body_a, joint.point_a, joint.axis_a)):
        if not isinstance(body, Ground):
            return body, np.asarray(point, dtype=float), np.asarray(axis, dtype=float)
    return None


def _body_points(mb: Multibody) -> dict[str, list[FloatArray]]:
    """Each body's joint and spring points (body frame), the center excluded, no repeats."""
    points: dict[str, list[FloatArray]] = {b.name: [] for b in mb.bodies}
    pieces = [j for j in mb.joints if not isinstance(j, Rolling | Free)] + list(mb.springs)
    for piece in pieces:
        for body, point in ((piece.body_a, piece.point_a), (piece.body_b, piece.point_b)):
            p = np.asarray(point, dtype=float)
            own = points.get(body.name)
            if own is not None and np.linalg.norm(p) > 0 and \
                    not any(np.allclose(p, q) for q in own):
                own.append(p)
    return points


def _opposite(a: FloatArray, b: FloatArray) -> bool:
    """Whether the mass center lies on the segment between ``a`` and ``b``."""
    return bool(np.linalg.norm(np.cross(a, b)) <= 1e-9 * np.linalg.norm(a) * np.linalg.norm(b)
                and a @ b < 0)


def _inertia(body: Body) -> FloatArray:
    if isinstance(body, PlanarBody):
        return np.asarray(body.inertia, dtype=float)
    return np.asarray(getattr(body, "inertia", np.zeros((3, 3))), dtype=float)


def _spoke_radius(body: Body, points: list[FloatArray]) -> float:
    longest = max(float(np.linalg.norm(p)) for p in points)
    inertia, mass = _inertia(body), float(body.mass)
    u = points[0] / np.linalg.norm(points[0])
    axial = float(u @ inertia @ u)
    radius = np.sqrt(max(2 * axial / mass, 0.0)) if mass > 0 else 0.0
    lo, hi = SPOKE_RADIUS
    return float(np.clip(radius, lo * longest, hi * longest))


def _inertia_box(body: RigidBody | PlanarBody, size: float) -> dict[str, Any]:
    """The uniform box of the body's mass and principal inertias (a cube if degenerate)."""
    values, axes = np.linalg.eigh(_inertia(body))
    mass = float(body.mass)
    total = values.sum()
    sides = np.sqrt(np.clip(6 * (total - 2 * values) / mass, 0.0, None)) if mass > 0 \
        else np.zeros(3)
    if not np.all(sides > 1e-3 * max(sides.max(), 1e-300)):
        sides = np.where(sides > 0, sides, max(sides.max(), size))
    if np.linalg.det(axes) < 0:
        axes[:, 2] *= -1
    return {"kind": "box", "center": [0.0, 0.0, 0.0], "size": sides.tolist(),
            "rotation": Rotation.from_matrix(axes).as_quat().tolist()}


def _body_shapes(mb: Multibody, index: int, body: Body, points: list[FloatArray],
                 size: float) -> list[dict[str, Any]]:
    if isinstance(body, Particle):
        return [{"body": index, "kind": "sphere", "center": [0.0, 0.0, 0.0],
                 "radius": POINT_SIZE * size}]
    shapes: list[dict[str, Any]] = []
    for joint in mb.joints:
        if isinstance(joint, Rolling) and joint.body_b is body:
            r = float(joint.radius)
            if joint.is_disk:
                a = np.asarray(joint.axis_b, dtype=float) * 0.06 * r
                shapes.append({"kind": "cylinder", "from": (-a).tolist(), "to": a.tolist(),
                               "radius": r})
            else:
                shapes.append({"kind": "sphere", "center": [0.0, 0.0, 0.0], "radius": r})
    if len(points) == 1:  # a link held at one end: as long again beyond its center
        shapes.append({"kind": "cylinder", "from": (-points[0]).tolist(),
                       "to": points[0].tolist(), "radius": _spoke_radius(body, points)})
    elif len(points) == 2 and _opposite(*points):  # a link between two joints: one piece
        shapes.append({"kind": "cylinder", "from": points[0].tolist(),
                       "to": points[1].tolist(), "radius": _spoke_radius(body, points)})
    elif points:
        radius = _spoke_radius(body, points)
        shapes += [{"kind": "cylinder", "from": [0.0, 0.0, 0.0], "to": p.tolist(),
                    "radius": radius} for p in points]
    elif not shapes and isinstance(body, RigidBody | PlanarBody):
        shapes.append(_inertia_box(body, 0.05 * size))
    return [{"body": index, **s} for s in shapes]


def _shapes(mb: Multibody, bound: Multibody, names: list[str],
            points: dict[str, list[FloatArray]], size: float) -> list[dict[str, Any]]:
    """The bodies' shapes: an imported model's geoms (:mod:`.model_shapes`), else (and
    for a body with none to draw) the default shapes."""
    imported = getattr(mb, "imported", None)
    geoms = imported_shapes(imported.shapes, {n: i for i, n in enumerate(names)}) \
        if imported is not None else {}
    shapes = list(geoms.get(-1, []))
    for i, body in enumerate(bound.bodies):
        shapes += geoms.get(i) or _body_shapes(bound, i, body, points[body.name], size)
    return shapes


def _largest_radius(shapes: list[dict[str, Any]], body: int, default: float) -> float:
    radii = [s["radius"] for s in shapes if s["body"] == body and s["kind"] == "cylinder"]
    return max(radii) if radii else default


def _default_traces(mb: Multibody) -> list[str]:
    """The bodies at the free ends (in one joint at most), else the last body."""
    count = {b.name: 0 for b in mb.bodies}
    for joint in mb.joints:
        for body in joint.bodies:
            if body.name in count:
                count[body.name] += 1
    ends = [name for name, n in count.items() if n <= 1]
    return (ends or [mb.bodies[-1].name])[:DEFAULT_TRACES]


def multibody_scene(mb: Multibody, traj: Trajectory,
                    traces: Sequence[str] | None = None) -> Scene:
    """The scene of a multibody trajectory (already sampled to the frames wanted).

    Parameters
    ----------
    mb
        The mechanism ``traj`` is a trajectory of.
    traj
        Its trajectory, one frame per output.
    traces
        Names of the bodies whose mass centers leave a trace; default: the bodies at
        the free ends of the mechanism (at most four).

    Examples
    --------
    >>> from dalembert.multibody import chain
    >>> mb = chain(2, 1.0, 1.0, 0.1)
    >>> q0, qd0 = mb.initial_state(positions={"link1": (0, 0, -0.5), "link2": (0, 0, -1.5)})
    >>> scene = multibody_scene(mb, mb.simulate((0, 0.1), q0, qd0, t_eval=[0, 0.1]))
    >>> [(s["body"], s["kind"]) for s in scene.shapes], scene.positions.shape
    ([(0, 'cylinder'), (1, 'cylinder'), (-1, 'box')], (2, 2, 3))
    >>> round(scene.shapes[0]["radius"], 12), scene.traces[0]["name"]
    (0.1, 'link2')
    """
    bound = mb.bound(traj.parameters) if mb.parameters else mb
    names = [b.name for b in bound.bodies]
    k = len(traj)
    positions = np.empty((k, len(names), 3))
    quaternions = np.empty((k, len(names), 4))
    column = {name: i for i, name in enumerate(traj.coordinate_names)}
    for i, body in enumerate(bound.bodies):
        x, R = body.pose(_columns(traj, column, body))
        positions[:, i] = x
        quaternions[:, i] = Rotation.from_matrix(R).as_quat()
    size = float(max(np.ptp(positions.reshape(-1, 3), axis=0).max(), 1e-3))
    points = _body_points(bound)
    shapes = _shapes(mb, bound, names, points, size)
    # the picture's size: the centers' spread, or a body's own size if larger (a top)
    size = max([size] + [2 * shape_reach(s) for s in shapes])
    joints, columns = _joints(bound, names, shapes, size)
    forces = None
    if joints and len(traj.constraint_names):
        reactions = joint_reactions(mb, traj)
        forces = np.stack([reactions[j.name][body].force_world for j, body in columns], axis=1)
    chosen = _default_traces(bound) if traces is None else list(traces)
    for name in chosen:
        if name not in names:
            raise ValueError(f"traces: {name!r} is not a body; the bodies are "
                             f"{', '.join(names)}")
    gravity = np.asarray(bound.gravity, dtype=float)
    planar = all(isinstance(b, PlanarBody) for b in bound.bodies)
    up = -gravity / np.linalg.norm(gravity) if np.any(gravity) else \
        np.array([0.0, 1.0, 0.0] if planar else [0.0, 0.0, 1.0])
    arrows = [{key: j[key] for key in ("name", "body", "point")} for j in joints]
    return Scene(t=np.asarray(traj.t, dtype=float), body_names=names, positions=positions,
                 quaternions=quaternions, shapes=shapes, joints=joints, arrows=arrows,
                 forces=forces,
                 traces=[{"name": n, "body": names.index(n), "point": [0.0, 0.0, 0.0]}
                         for n in chosen],
                 up=(float(up[0]), float(up[1]), float(up[2])))


def _joints(mb: Multibody, names: list[str], shapes: list[dict[str, Any]],
            size: float) -> tuple[list[dict[str, Any]], list[tuple[Joint, str]]]:
    """Joint markers (with ground anchors added to ``shapes``) and the force columns."""
    joints: list[dict[str, Any]] = []
    columns: list[tuple[Joint, str]] = []
    for joint in mb.joints:
        side = _moving_side(joint)
        if side is None or isinstance(joint, Rolling | Free):  # Free: holds nothing
            continue
        body, point, axis = side
        index = names.index(body.name)
        radius = min(1.3 * _largest_radius(shapes, index, POINT_SIZE * size),
                     JOINT_SIZE * size)
        joints.append({"name": joint.name, "body": index, "point": point.tolist(),
                       "axis": axis.tolist() if isinstance(joint, Revolute) else None,
                       "radius": radius})
        columns.append((joint, body.name))
        for other, where in ((joint.body_a, joint.point_a), (joint.body_b, joint.point_b)):
            if isinstance(other, Ground):
                shapes.append({"body": -1, "kind": "box", "center":
                               np.asarray(where, dtype=float).tolist(),
                               "size": [1.6 * radius] * 3, "rotation": [0.0, 0.0, 0.0, 1.0]})
    return joints, columns


# -- systems of points ---------------------------------------------------------------
def point_columns(names: Sequence[str]) -> dict[str, list[int]]:
    """The points among coordinate names: ``{x-name: [ix, iy(, iz)]}`` (the points of
    :func:`~dalembert.plotting.drawers.particle_points`, by their ``x`` coordinate).

    Parameters
    ----------
    names
        The coordinate names.

    Examples
    --------
    >>> point_columns(["x1", "y1", "x2", "y2", "theta"])
    {'x1': [0, 1], 'x2': [2, 3]}
    """
    return {names[point[0]]: list(point) for point in particle_points(names)}


def _sticks(system: Any, points: dict[str, list[int]],
            names: Sequence[str]) -> tuple[list[tuple[int, int]], list[int]]:
    """Pairs of points one constraint holds together, and points held to the origin."""
    symbols = {str(s): s for s in system.model.coords.q}
    owner = {names[i]: k for k, cols in enumerate(points.values()) for i in cols}
    pairs: list[tuple[int, int]] = []
    pivoted: list[int] = []
    for expr in system.model.constraints.exprs:
        used = sorted({owner[str(s)] for s in expr.free_symbols if str(s) in owner})
        if len(used) == 2 and (used[0], used[1]) not in pairs:
            pairs.append((used[0], used[1]))
        elif len(used) == 1:
            own = [symbols[names[i]] for i in list(points.values())[used[0]]]
            rest = sp.expand(expr - sum(s**2 for s in own))
            if not rest.free_symbols & set(own):
                pivoted.append(used[0])
    return pairs, pivoted


def points_scene(system: Any, traj: Trajectory,
                 traces: Sequence[str] | None = None) -> Scene:
    """The scene of a System whose coordinates name points (see :func:`point_columns`).

    Parameters
    ----------
    system
        The System ``traj`` is a trajectory of.
    traj
        Its trajectory, one frame per output.
    traces
        The points leaving a trace, by their ``x`` coordinate's name; default: every
        point (the first four).

    Examples
    --------
    >>> from dalembert.examples import load
    >>> pendulum = load("pendulum")
    >>> system = pendulum.build()
    >>> traj = system.simulate((0, 0.5), **pendulum.INITIAL, t_eval=[0, 0.5])
    >>> scene = points_scene(system, traj)
    >>> scene.body_names, scene.sticks, scene.up, scene.forces.shape
    (['x', 'origin'], [(0, 1)], (0.0, 1.0, 0.0), (2, 1, 3))
    """
    names = list(system.coordinate_names)
    points = point_columns(names)
    if not points:
        raise ValueError(
            f"nothing to draw: {getattr(system, 'name', 'the system')!r} is not a "
            "dalembert.multibody system and no coordinates name points (x<s>, y<s>[, z<s>] "
            f"with a common suffix); its coordinates are {', '.join(names)}")
    k, n = len(traj), len(points)
    positions = np.zeros((k, n, 3))
    forces = np.zeros((k, n, 3))
    for i, cols in enumerate(points.values()):
        positions[:, i, :len(cols)] = traj.q[:, cols]
        if traj.constraint_forces.size:
            forces[:, i, :len(cols)] = traj.constraint_forces[:, cols]
    quaternions = np.zeros((k, n, 4))
    quaternions[..., 3] = 1.0
    size = float(max(np.ptp(positions.reshape(-1, 3), axis=0).max(), 1e-3))
    pairs, pivoted = _sticks(system, points, names)
    shapes = [{"body": i, "kind": "sphere", "center": [0.0, 0.0, 0.0],
               "radius": POINT_SIZE * size} for i in range(n)]
    body_names = list(points)
    if pivoted:  # the origin as one more (still) point
        positions = np.concatenate([positions, np.zeros((k, 1, 3))], axis=1)
        quaternions = np.concatenate([quaternions, quaternions[:, :1]], axis=1)
        pairs += [(i, n) for i in pivoted]
        body_names.append("origin")
        shapes.append({"body": n, "kind": "box", "center": [0.0, 0.0, 0.0],
                       "size": [POINT_SIZE * size] * 3, "rotation": [0.0, 0.0, 0.0, 1.0]})
    chosen = body_names[:min(n, DEFAULT_TRACES)] if traces is None else list(traces)
    for name in chosen:
        if name not in points:
            raise ValueError(f"traces: {name!r} is not a point; the points are "
                             f"{', '.join(points)} (named by their x coordinate)")
    three_d = any(len(c) == 3 for c in points.values())
    arrows = [{"name": name, "body": i, "point": [0.0, 0.0, 0.0]}
              for i, name in enumerate(points)]
    return Scene(t=np.asarray(traj.t, dtype=float), body_names=body_names,
                 positions=positions, quaternions=quaternions, shapes=shapes, arrows=arrows,
                 forces=forces if len(traj.constraint_names) else None,
                 traces=[{"name": nm, "body": body_names.index(nm), "point": [0.0, 0.0, 0.0]}
                         for nm in chosen],
                 sticks=pairs, up=(0.0, 0.0, 1.0) if three_d else (0.0, 1.0, 0.0))
