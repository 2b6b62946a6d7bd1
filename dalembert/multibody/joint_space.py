"""Joint coordinates as numbers: what a controller reads instead of the redundant ones.

A mechanism's coordinates are its bodies' poses; a controller, a plot or an LQR design
wants the joints' own: hinge angles, slide travels, ball-joint rotations. Each joint
carries a frame on either side (``Joint.frame``: ``u`` its reference direction, ``w``
its axis, ``v = w x u``) and everything here is measured between them:

=========  ========================  ======================================  =========
joint      position (names)          velocity (names)                        per unit
=========  ========================  ======================================  =========
Revolute   angle ``<j>``             its rate ``<j>``                        rad, rad/s
Prismatic  travel ``<j>``            its rate ``<j>``                        m, m/s
Spherical  rotation ``<j>.rx .ry     relative angular velocity ``<j>.wx      rad, rad/s
           .rz`` (or ``<j>.qw ...``) .wy .wz``
Free       travel ``<j>.x .y .z``,   their rates ``<j>.x .y .z``, the        m, rad;
           rotation as Spherical     relative angular velocity as Spherical  m/s, rad/s
=========  ========================  ======================================  =========

- The hinge angle turns ``u_b`` from ``u_a`` about ``w`` (``atan2(v_a . u_b, u_a . u_b)``,
  as drivers and joint springs measure it, see :mod:`~dalembert.multibody.drivers`);
  along a trajectory it is unwrapped (continuous, not folded into ``(-pi, pi]``).
- The travel is ``w_a . d``, ``d`` from point ``a`` to point ``b``.
- A ball joint's rotation is that of body ``b``'s joint frame relative to body ``a``'s
  (child relative to parent), ``R_rel = (R_a J_a)^T (R_b J_b)`` with ``J = [u v w]``,
  in components of ``a``'s joint frame: the rotation vector ``angle * axis``
  (``rotations="vector"``, default; continuous along a trajectory except through a full
  turn) or the unit quaternion ``(qw, qx, qy, qz)``, scalar first as in
  :mod:`~dalembert.multibody.rotations` (``rotations="quaternion"``; ``qw >= 0`` at
  one state, sign-continuous along a trajectory). With the default frames (``w = z``,
  ``u = x`` on both sides) ``R_rel = R_a^T R_b``.
- A free joint's travel is ``d`` (point ``a`` to point ``b``) in components of ``a``'s
  joint frame, its rates those of these components (as seen turning with ``a``).
- The relative angular velocity ``w_b - w_a`` is given in components of ``a``'s joint
  frame; it is not the rate of the rotation vector (``R_rel' R_rel^T = [w]x``).

A velocity named as a position is that position's rate. Every velocity is linear in
the coordinate rates, ``v = J(q) qd`` (:func:`joint_jacobian`), so by virtual work a
joint torque or force ``tau`` (named as its velocity: a ball joint's three torques are
``<j>.wx .wy .wz``, in ``a``'s joint frame, acting on ``b`` and the opposite on ``a``)
is the generalized force ``J^T tau``: :mod:`~dalembert.multibody.joint_control` uses it
for the actuator torques of inverse dynamics and for linearizations in joint
coordinates. Joints of other kinds (universal, fixed, distance, rolling, drivers) and
ball joints on a particle have no coordinates here.
"""

from __future__ import annotations

from collections.abc import Iterable, Iterator, Mapping, Sequence
from typing import Any, Literal

import numpy as np

from ..errors import ModelError
from ..model.values import CoordinateValues, coordinate_values
from ..trajectory import Trajectory
from .bodies import Body, Ground, Particle, PlanarBody, RigidBody
from .builder import Multibody
from .drivers import coordinate_values as joint_coordinate_values
from .joints import Free, Joint, Prismatic, Revolute, Spherical
from .rotations import G_matrix, quaternion_from_matrix
from .types import FloatArray

#: How a ball joint's rotation is given.
Rotations = Literal["vector", "quaternion"]


class JointValues(Mapping[str, Any]):
    """Numbers by joint coordinate name: a mapping, and the array of all of them.

    Attributes
    ----------
    names : tuple of str
        The names, in the order of the array's last axis.
    array : numpy.ndarray
        ``(len(names),)`` at one state, ``(k, len(names))`` along a trajectory.

    Examples
    --------
    >>> v = JointValues(("hinge", "slide"), np.array([0.5, 2.0]))
    >>> v["hinge"], v.array.tolist(), list(v)
    (0.5, [0.5, 2.0], ['hinge', 'slide'])
    """

    def __init__(self, names: Sequence[str], array: FloatArray) -> None:
        self.names = tuple(names)
        self.array = np.asarray(array, dtype=float)
        self._index = {n: i for i, n in enumerate(self.names)}

    def __getitem__(self, name: str) -> Any:
        i = self._index.get(name)
        if i is None:
            raise KeyError(f"no joint coordinate {name!r}; there are "
                           f"{', '.join(self.names) or 'none'}")
        value = self.array[..., i]
        return float(value) if value.ndim == 0 else value

    def __iter__(self) -> Iterator[str]:
        return iter(self.names)

    def __len__(self) -> int:
        return len(self.names)

    def __repr__(self) -> str:
        return f"JointValues({dict(zip(self.names, self.array.T.tolist()))})"


# -- which joints, and their names -------------------------------------------------------
def has_coordinates(joint: Joint) -> bool:
    """Whether :func:`joint_positions` measures ``joint`` (see the module docstring)."""
    if isinstance(joint, Revolute | Prismatic):
        return True
    return isinstance(joint, Spherical | Free) and not any(isinstance(b, Particle)
                                                    for b in joint.bodies)


def selected_joints(mb: Multibody, joints: Sequence[Joint | str] | None) -> list[Joint]:
    """The joints named (all that have coordinates by default), each checked.

    Parameters
    ----------
    mb
        The mechanism.
    joints
        Joints or their names; ``None``: every joint with coordinates, in order.

    Examples
    --------
    >>> from dalembert.multibody import chain
    >>> [j.name for j in selected_joints(chain(2, 1.0, 1.0, 0.1), None)]
    ['joint1', 'joint2']
    """
    if joints is None:
        return [j for j in mb.joints if has_coordinates(j)]
    if isinstance(joints, str | Joint):
        joints = [joints]
    if not isinstance(joints, Iterable):
        raise TypeError(f"joints must be joints or their names, got {joints!r:.80} "
                        f"({type(joints).__name__}); the joints are "
                        f"{', '.join(j.name for j in mb.joints)}")
    out: list[Joint] = []
    for key in joints:
        name = key.name if isinstance(key, Joint) else str(key)
        joint = mb.joint(name)  # a KeyError lists the joints
        if any(joint is j for j in out):
            raise ValueError(f"joint {name!r} is named twice; name each joint once")
        if not has_coordinates(joint):
            kinds = ("Revolute, Prismatic, and Spherical or Free between bodies that turn "
                     "(not a particle)")
            raise ModelError(f"joint {name!r} ({type(joint).__name__}) has no joint "
                             f"coordinates here; those are measured for {kinds}")
        out.append(joint)
    return out


def position_names(joint: Joint, rotations: Rotations = "vector") -> list[str]:
    """The names of ``joint``'s positions (see the module docstring).

    Parameters
    ----------
    joint
        A joint with coordinates.
    rotations
        ``"vector"`` or ``"quaternion"`` (a ball joint's).

    Examples
    --------
    >>> from dalembert.multibody import chain
    >>> position_names(chain(1, 1.0, 1.0, 0.1).joint("joint1"))
    ['joint1.rx', 'joint1.ry', 'joint1.rz']
    """
    if isinstance(joint, Revolute | Prismatic):
        return [joint.name]
    parts = ("rx", "ry", "rz") if rotations == "vector" else ("qw", "qx", "qy", "qz")
    if isinstance(joint, Free):
        parts = ("x", "y", "z", *parts)
    return [f"{joint.name}.{p}" for p in parts]


def velocity_names(joint: Joint) -> list[str]:
    """The names of ``joint``'s velocities (and of its torques or forces).

    Parameters
    ----------
    joint
        A joint with coordinates.

    Examples
    --------
    >>> from dalembert.multibody import chain
    >>> velocity_names(chain(1, 1.0, 1.0, 0.1).joint("joint1"))
    ['joint1.wx', 'joint1.wy', 'joint1.wz']
    """
    if isinstance(joint, Revolute | Prismatic):
        return [joint.name]
    parts = ("x", "y", "z", "wx", "wy", "wz") if isinstance(joint, Free) else ("wx", "wy", "wz")
    return [f"{joint.name}.{p}" for p in parts]


# -- the state ---------------------------------------------------------------------------
def _state(mb: Multibody, state: Trajectory | CoordinateValues, qd: CoordinateValues | None,
           parameters: Mapping[Any, object] | None,
           ) -> tuple[Multibody, FloatArray, FloatArray, bool]:
    """The bound mechanism and the rows ``(k, n)`` of ``q`` and ``qd``; whether one state."""
    names = mb.system.coordinate_names
    if isinstance(state, Trajectory):
        if qd is not None:
            raise ValueError("give qd with a single state q, not with a trajectory (it has "
                             "its own velocities)")
        bound = mb.bound(state.parameters, parameters) if mb.parameters or parameters \
            else mb
        return bound, np.asarray(state.q), np.asarray(state.qd), False
    q = coordinate_values(state, names, "q")
    qd_ = np.zeros(len(names)) if qd is None else coordinate_values(qd, names, "qd")
    # (values for a mechanism without parameters: bound() says they name nothing)
    bound = mb.bound(parameters) if mb.parameters or parameters else mb
    return bound, q[None], qd_[None], True


class _Poses:
    """Each body's poses and velocities (world) at the rows of ``q``, ``qd``."""

    def __init__(self, mb: Multibody, q: FloatArray, qd: FloatArray) -> None:
        self.k = len(q)
        self.columns: dict[str, list[int]] = {}
        self.values: dict[str, tuple[FloatArray, ...]] = {}
        start = 0
        for body in mb.bodies:
            size = len(body.coordinates)
            cols = list(range(start, start + size))
            start += size
            c, cd = q[:, cols], qd[:, cols]
            x, R = body.pose(c)
            v = body.center_velocity(cd)
            w = np.einsum("kij,kj->ki", R, body.angular_velocity_at(c, cd))
            self.columns[body.name] = cols
            self.values[body.name] = (x, R, v, w, c)

    def of(self, body: Body) -> tuple[FloatArray, ...]:
        """``(x, R, v, w_world, c)`` of ``body``; the ground at rest at the origin."""
        if isinstance(body, Ground):
            zeros = np.zeros((self.k, 3))
            return zeros, np.broadcast_to(np.eye(3), (self.k, 3, 3)), zeros, zeros, zeros
        return self.values[body.name]


def _frame(joint: Joint, side: str) -> FloatArray:
    """``J = [u v w]`` (columns) of the joint frame on a side, in that body's frame."""
    w = np.asarray(joint.axis_a if side == "a" else joint.axis_b, dtype=float)
    u = np.asarray(joint.ref_a if side == "a" else joint.ref_b, dtype=float)
    return np.column_stack([u, np.cross(w, u), w])


def _world_frames(joint: Joint, poses: _Poses) -> tuple[FloatArray, FloatArray]:
    """The two joint frames in world components, ``(k, 3, 3)`` each."""
    Ra, Rb = poses.of(joint.body_a)[1], poses.of(joint.body_b)[1]
    return Ra @ _frame(joint, "a"), Rb @ _frame(joint, "b")


def _points(joint: Joint, poses: _Poses) -> tuple[FloatArray, FloatArray]:
    """The two joint points in world components, ``(k, 3)`` each."""
    xa, Ra = poses.of(joint.body_a)[:2]
    xb, Rb = poses.of(joint.body_b)[:2]
    return (xa + Ra @ np.asarray(joint.point_a, float),
            xb + Rb @ np.asarray(joint.point_b, float))


def _relative_rotation(joint: Joint, poses: _Poses) -> FloatArray:
    Fa, Fb = _world_frames(joint, poses)
    return np.einsum("kji,kjl->kil", Fa, Fb)


def _continuous(b: FloatArray) -> FloatArray:
    """Quaternions with the sign of each chosen next to the previous one's."""
    out = b.copy()
    for i in range(1, len(out)):
        if out[i] @ out[i - 1] < 0:
            out[i] = -out[i]
    return out


def _rotation_vector(b: FloatArray) -> FloatArray:
    """``angle * axis`` of quaternions ``(k, 4)`` (``angle = 2 atan2(|v|, qw)``)."""
    s = np.linalg.norm(b[:, 1:], axis=1)
    angle = 2 * np.arctan2(s, b[:, 0])
    # angle / sin(angle / 2), finite as s -> 0 (where it tends to 2 / qw)
    scale = np.where(s > 1e-8, angle / np.where(s > 1e-8, s, 1.0), 2 / b[:, 0])
    return b[:, 1:] * scale[:, None]


def _joint_positions(joint: Joint, poses: _Poses, rotations: Rotations,
                     single: bool) -> FloatArray:
    if isinstance(joint, Revolute | Prismatic):  # measured as drivers and springs do
        value = joint_coordinate_values(joint, {name: (v[0], v[1])
                                                for name, v in poses.values.items()})
        unwrap = isinstance(joint, Revolute) and not single
        return (np.unwrap(value) if unwrap else value)[:, None]
    b = quaternion_from_matrix(_relative_rotation(joint, poses))
    if not single:
        b = _continuous(b)
    rotation = b if rotations == "quaternion" else _rotation_vector(b)
    if not isinstance(joint, Free):
        return rotation
    Pa, Pb = _points(joint, poses)
    Fa = _world_frames(joint, poses)[0]
    return np.hstack([np.einsum("kji,kj->ki", Fa, Pb - Pa), rotation])


def _joint_velocities(joint: Joint, poses: _Poses) -> FloatArray:
    xa, _, va, wa_, _ = poses.of(joint.body_a)
    xb, _, vb, wb_, _ = poses.of(joint.body_b)
    Fa = _world_frames(joint, poses)[0]
    relative = wb_ - wa_
    if isinstance(joint, Revolute):
        return np.einsum("ki,ki->k", Fa[:, :, 2], relative)[:, None]
    if isinstance(joint, Prismatic):
        Pa, Pb = _points(joint, poses)
        axis = Fa[:, :, 2]
        vpa, vpb = va + np.cross(wa_, Pa - xa), vb + np.cross(wb_, Pb - xb)
        # d/dt (w_a . d): the axis turns with body a
        return (np.einsum("ki,ki->k", axis, vpb - vpa)
                + np.einsum("ki,ki->k", np.cross(wa_, axis), Pb - Pa))[:, None]
    angular = np.einsum("kji,kj->ki", Fa, relative)
    if not isinstance(joint, Free):
        return angular
    Pa, Pb = _points(joint, poses)
    vpa, vpb = va + np.cross(wa_, Pa - xa), vb + np.cross(wb_, Pb - xb)
    # the rates of d's components in the turning frame a: d' - w_a x d
    travel = vpb - vpa - np.cross(wa_, Pb - Pa)
    return np.hstack([np.einsum("kji,kj->ki", Fa, travel), angular])


def joint_positions(
    mb: Multibody,
    state: Trajectory | CoordinateValues,
    *,
    joints: Sequence[Joint | str] | None = None,
    rotations: Rotations = "vector",
    parameters: Mapping[Any, object] | None = None,
) -> JointValues:
    """The joints' positions: hinge angles, slide travels, ball-joint rotations.

    See :mod:`~dalembert.multibody.joint_space` for what is measured and the names.

    Parameters
    ----------
    mb
        The mechanism.
    state
        A :class:`~dalembert.Trajectory` of ``mb.system`` (angles unwrapped along it) or
        one configuration ``q`` (dict by coordinate name or sequence in coordinate order).
    joints
        The joints (or their names) to measure; default every joint with coordinates.
    rotations
        A ball joint's rotation as ``"vector"`` (rotation vector, default) or
        ``"quaternion"``.
    parameters
        Parameter values overriding the mechanism's (a trajectory's own by default).

    Returns
    -------
    JointValues
        By name; ``.array`` is ``(k, p)`` along a trajectory, ``(p,)`` at one state.

    Raises
    ------
    KeyError
        No joint of that name (the message lists them).
    ModelError
        A joint named has no coordinates (a Fixed joint, a Distance...).

    Examples
    --------
    A 2-link planar arm, the first link at 30 degrees, the second bent 90 more:

    >>> from dalembert.multibody import chain
    >>> mb = chain(2, 1.0, 1.0, 0.05, joint="revolute", planar=True)
    >>> q = {"link1_theta": np.pi / 6, "link2_theta": 2 * np.pi / 3}
    >>> angles = joint_positions(mb, q)
    >>> [round(float(np.degrees(angles[name])), 9) for name in angles]
    [30.0, 90.0]
    """
    if rotations not in ("vector", "quaternion"):
        raise ValueError(f"rotations must be 'vector' or 'quaternion', got {rotations!r}")
    bound, q, qd, single = _state(mb, state, None, parameters)
    chosen = [bound.joint(j.name) for j in selected_joints(mb, joints)]
    poses = _Poses(bound, q, qd)
    names = [n for j in chosen for n in position_names(j, rotations)]
    values = [_joint_positions(j, poses, rotations, single) for j in chosen]
    array = np.concatenate(values, axis=1) if values else np.zeros((len(q), 0))
    return JointValues(names, array[0] if single else array)


def joint_velocities(
    mb: Multibody,
    state: Trajectory | CoordinateValues,
    qd: CoordinateValues | None = None,
    *,
    joints: Sequence[Joint | str] | None = None,
    parameters: Mapping[Any, object] | None = None,
) -> JointValues:
    """The joints' velocities: hinge and slide rates, ball joints' relative angular
    velocities (in the parent's joint frame).

    Parameters
    ----------
    mb
        The mechanism.
    state
        A :class:`~dalembert.Trajectory` of ``mb.system`` or one configuration ``q``.
    qd
        With one configuration, the coordinate rates (left out: at rest).
    joints, parameters
        As for :func:`joint_positions`.

    Returns
    -------
    JointValues
        By name (a hinge's rate is named as its angle; a ball joint's components are
        ``<j>.wx .wy .wz``).

    Examples
    --------
    The arm of :func:`joint_positions` with its links turning at 1 and 3 rad/s:

    >>> from dalembert.multibody import chain
    >>> mb = chain(2, 1.0, 1.0, 0.05, joint="revolute", planar=True)
    >>> rates = joint_velocities(mb, {}, {"link1_theta": 1.0, "link2_theta": 3.0})
    >>> rates.array.tolist()
    [1.0, 2.0]
    """
    bound, q, qd_, single = _state(mb, state, qd, parameters)
    chosen = [bound.joint(j.name) for j in selected_joints(mb, joints)]
    poses = _Poses(bound, q, qd_)
    names = [n for j in chosen for n in velocity_names(j)]
    values = [_joint_velocities(j, poses) for j in chosen]
    array = np.concatenate(values, axis=1) if values else np.zeros((len(q), 0))
    return JointValues(names, array[0] if single else array)


# -- the velocity map ----------------------------------------------------------------------
def _body_velocity_maps(body: Body, c: FloatArray) -> tuple[FloatArray, FloatArray]:
    """``(V, W)``: the center's velocity and the world angular velocity as ``V cd``,
    ``W cd`` (``3 x len(coordinates)`` each) at the body's coordinates ``c``."""
    size = len(body.coordinates)
    V, W = np.zeros((3, size)), np.zeros((3, size))
    if isinstance(body, RigidBody):
        V[:, :3] = np.eye(3)
        W[:, 3:] = 2 * G_matrix(c[3:7])
    elif isinstance(body, PlanarBody):
        V[:2, :2] = np.eye(2)
        W[2, 2] = 1.0
    else:
        V[:, :3] = np.eye(3)
    return V, W


def joint_jacobian(
    mb: Multibody,
    q: CoordinateValues,
    *,
    joints: Sequence[Joint | str] | None = None,
    parameters: Mapping[Any, object] | None = None,
) -> tuple[tuple[str, ...], FloatArray]:
    """``J(q)``, the joint velocities' map from the coordinate rates: ``v = J qd``.

    Its transpose maps joint torques and forces (named as the velocities) to the
    generalized forces they exert, ``Q = J^T tau`` (virtual work).

    Parameters
    ----------
    mb
        The mechanism.
    q
        One configuration.
    joints, parameters
        As for :func:`joint_positions`.

    Returns
    -------
    names : tuple of str
        The joint velocities, one per row of ``J``.
    J : numpy.ndarray
        ``(p, n)``, one column per coordinate.

    Examples
    --------
    A hinge's rate is the difference of the planar links' angle rates:

    >>> from dalembert.multibody import chain
    >>> mb = chain(2, 1.0, 1.0, 0.05, joint="revolute", planar=True)
    >>> names, J = joint_jacobian(mb, {})
    >>> names, J[1].tolist()
    (('joint1', 'joint2'), [0.0, 0.0, -1.0, 0.0, 0.0, 1.0])
    """
    bound, q_, qd, _ = _state(mb, q, None, parameters)
    chosen = [bound.joint(j.name) for j in selected_joints(mb, joints)]
    poses = _Poses(bound, q_, qd)
    n = q_.shape[1]
    rows: list[FloatArray] = []
    names: list[str] = []
    for joint in chosen:
        names += velocity_names(joint)
        rows.append(_joint_rows(joint, poses, n))
    return tuple(names), np.concatenate(rows) if rows else np.zeros((0, n))


def _joint_rows(joint: Joint, poses: _Poses, n: int) -> FloatArray:
    """The rows of ``J`` of one joint (at the first row of ``poses``)."""
    Fa = _world_frames(joint, poses)[0][0]
    Pa, Pb = (p[0] for p in _points(joint, poses))
    maps = {}
    for side, body, point in (("a", joint.body_a, Pa), ("b", joint.body_b, Pb)):
        if isinstance(body, Ground):
            continue
        x, _, _, _, c = poses.of(body)
        V, W = _body_velocity_maps(body, c[0])
        r = point - x[0]
        # velocity of the joint point: V cd + w x r = (V - [r]x W) cd
        rx = np.array([[0, -r[2], r[1]], [r[2], 0, -r[0]], [-r[1], r[0], 0]])
        maps[side] = (poses.columns[body.name], V - rx @ W, W)
    out_w = np.zeros((3, n))  # w_b - w_a (world)
    out_v = np.zeros((3, n))  # v_Pb - v_Pa (world)
    sign = {"a": -1.0, "b": 1.0}
    for side, (cols, Vp, W) in maps.items():
        out_w[:, cols] += sign[side] * W
        out_v[:, cols] += sign[side] * Vp
    if isinstance(joint, Revolute):
        return (Fa[:, 2] @ out_w)[None]
    if isinstance(joint, Prismatic):
        row = Fa[:, 2] @ out_v
        if "a" in maps:  # (w_a x axis) . d = (axis x d) . w_a
            cols, _, W = maps["a"]
            row[cols] += np.cross(Fa[:, 2], Pb - Pa) @ W
        return row[None]
    if not isinstance(joint, Free):
        return Fa.T @ out_w
    if "a" in maps:  # - w_a x d = d x w_a
        cols, _, W = maps["a"]
        d = Pb - Pa
        out_v[:, cols] += np.array([[0, -d[2], d[1]], [d[2], 0, -d[0]], [-d[1], d[0], 0]]) @ W
    return np.vstack([Fa.T @ out_v, Fa.T @ out_w])
