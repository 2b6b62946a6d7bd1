"""Body-level quantities along a :class:`dalembert.Trajectory` of a ``Multibody``.

Positions of body points, rotation matrices, Euler angles, angular velocities,
momenta, energy (evaluated numerically from the states, independently of the
symbolic energy expressions) and joint reactions from the multipliers.

Joint reactions: the rows of joint ``J`` give the generalized constraint force
``Q = A_J^T lambda_J``. On a body's position coordinates it is the force ``F``
(world) the joint exerts on the body; on its Euler parameters it is
``Q_b = 2 E(b)^T tau_body``, so ``tau_body = 1/2 E(b) Q_b`` (``E E^T = I``) is
the torque about the mass center (on a planar body's angle, ``Q_theta`` is the
torque about ``z``; see :meth:`~dalembert.multibody.bodies.Body.center_torque`).
The torque about the joint point ``P`` is ``tau_P = tau_cm - (r_P - x) x F``; it
vanishes for a spherical joint. For a
:class:`~dalembert.multibody.rolling.Rolling` joint ``P`` is the moving contact point.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..trajectory import Trajectory
from .bodies import Body, Ground, TurningBody
from .builder import Multibody
from .drivers import coordinate_values
from .joints import Joint
from .rolling import Rolling
from .rotations import euler_from_matrix
from .types import FloatArray, Frame, Vector


def _columns(traj: Trajectory, body: Body, suffix: str = "") -> FloatArray:
    return np.column_stack([traj[f"{c.name}{suffix}"] for c in body.coordinates])


def _bound(mb: Multibody, traj: Trajectory) -> Multibody:
    """The mechanism with the parameter values ``traj`` was simulated with."""
    return mb.bound(traj.parameters) if mb.parameters else mb


def _body(mb: Multibody, body: Body | str) -> Body:
    """The body of (the bound) ``mb`` called as ``body`` is, or named ``body``."""
    if isinstance(body, Ground):
        return body
    return mb.body(body if isinstance(body, str) else body.name)


def _pose(traj: Trajectory, body: Body) -> tuple[FloatArray, FloatArray]:
    return body.pose(_columns(traj, body))


def _velocity(traj: Trajectory, body: Body) -> FloatArray:
    return body.center_velocity(_columns(traj, body, "_dot"))


def rotation_matrices(mb: Multibody, traj: Trajectory, body: Body | str) -> FloatArray:
    """``R`` (body -> world) at every time, shape ``(k, 3, 3)``; identity for particles.

    Parameters
    ----------
    mb, traj
        The mechanism and a trajectory of its ``system``.
    body
        A body or its name.

    Examples
    --------
    A box turning about ``z`` at 1 rad/s, a quarter turn later:

    >>> from dalembert.multibody import Multibody, RigidBody
    >>> mb = Multibody([RigidBody("box", 1.0, (1, 2, 3))], gravity=(0, 0, 0))
    >>> q0, qd0 = mb.initial_state(angular_velocities={"box": (0, 0, 1.0)})
    >>> traj = mb.simulate((0, np.pi / 2), q0, qd0, t_eval=[np.pi / 2])
    >>> rotation_matrices(mb, traj, "box")[0].round(9) + 0.0
    array([[ 0., -1.,  0.],
           [ 1.,  0.,  0.],
           [ 0.,  0.,  1.]])
    """
    mb = _bound(mb, traj)
    return _pose(traj, _body(mb, body))[1]


def euler_angles(mb: Multibody, traj: Trajectory, body: Body | str,
                 sequence: str = "ZYX") -> FloatArray:
    """Euler angles of a body along the trajectory, shape ``(k, 3)`` (see
    :func:`~dalembert.multibody.rotations.euler_from_matrix`).

    Parameters
    ----------
    mb, traj
        The mechanism and a trajectory of its ``system``.
    body
        A body or its name.
    sequence
        Three axes in SciPy's naming: upper case intrinsic (``"ZYX"``, default),
        lower case extrinsic.

    Examples
    --------
    A box turning about ``z`` at 1 rad/s, a quarter turn later:

    >>> from dalembert.multibody import Multibody, RigidBody
    >>> mb = Multibody([RigidBody("box", 1.0, (1, 2, 3))], gravity=(0, 0, 0))
    >>> q0, qd0 = mb.initial_state(angular_velocities={"box": (0, 0, 1.0)})
    >>> traj = mb.simulate((0, np.pi / 2), q0, qd0, t_eval=[np.pi / 2])
    >>> euler_angles(mb, traj, "box").round(9).tolist() == [[round(np.pi / 2, 9), 0.0, 0.0]]
    True
    """
    mb = _bound(mb, traj)
    return euler_from_matrix(rotation_matrices(mb, traj, body), sequence)


def point_positions(mb: Multibody, traj: Trajectory, body: Body | str,
                    point: Vector = (0.0, 0.0, 0.0)) -> FloatArray:
    """World positions of a body-fixed point (body frame), shape ``(k, 3)``.

    Parameters
    ----------
    mb, traj
        The mechanism and a trajectory of its ``system``.
    body
        A body or its name.
    point
        The point in the body frame (default the mass center).

    Examples
    --------
    A box turning about ``z`` at 1 rad/s, a quarter turn later:

    >>> from dalembert.multibody import Multibody, RigidBody
    >>> mb = Multibody([RigidBody("box", 1.0, (1, 2, 3))], gravity=(0, 0, 0))
    >>> q0, qd0 = mb.initial_state(angular_velocities={"box": (0, 0, 1.0)})
    >>> traj = mb.simulate((0, np.pi / 2), q0, qd0, t_eval=[np.pi / 2])
    >>> (point_positions(mb, traj, "box", (1, 0, 0)).round(9) + 0.0).tolist()
    [[0.0, 1.0, 0.0]]
    """
    mb = _bound(mb, traj)
    body = _body(mb, body)
    if isinstance(body, Ground):
        return np.broadcast_to(np.asarray(point, float), (len(traj), 3)).copy()
    x, R = _pose(traj, body)
    return x + R @ np.asarray(point, dtype=float)


def angular_velocities(mb: Multibody, traj: Trajectory, body: Body | str,
                       frame: Frame = "world") -> FloatArray:
    """Angular velocity in body (``2 E(b) bdot`` for Euler parameters) or world
    components, shape ``(k, 3)``; zero for particles.

    Parameters
    ----------
    mb, traj
        The mechanism and a trajectory of its ``system``.
    body
        A body or its name.
    frame
        ``"world"`` (default) or ``"body"`` components.

    Examples
    --------
    A box turning about ``z`` at 1 rad/s, a quarter turn later:

    >>> from dalembert.multibody import Multibody, RigidBody
    >>> mb = Multibody([RigidBody("box", 1.0, (1, 2, 3))], gravity=(0, 0, 0))
    >>> q0, qd0 = mb.initial_state(angular_velocities={"box": (0, 0, 1.0)})
    >>> traj = mb.simulate((0, np.pi / 2), q0, qd0, t_eval=[np.pi / 2])
    >>> (angular_velocities(mb, traj, "box").round(9) + 0.0).tolist()
    [[0.0, 0.0, 1.0]]
    """
    mb = _bound(mb, traj)
    body = _body(mb, body)
    if frame not in ("world", "body"):
        raise ValueError(f"frame must be 'world' or 'body', got {frame!r}")
    c = _columns(traj, body)
    w = body.angular_velocity_at(c, _columns(traj, body, "_dot"))
    if frame == "body":
        return w
    return np.einsum("kij,kj->ki", body.pose(c)[1], w)


def linear_momentum(mb: Multibody, traj: Trajectory) -> FloatArray:
    """Total ``sum m v`` (world), shape ``(k, 3)``.

    Parameters
    ----------
    mb, traj
        The mechanism and a trajectory of its ``system``.

    Examples
    --------
    A 2 kg particle thrown at 1 m/s along ``x`` under ``g = 10``, after 1 s:

    >>> from dalembert.multibody import Multibody, Particle
    >>> mb = Multibody([Particle("p", 2.0)], gravity=(0, 0, -10.0))
    >>> traj = mb.simulate((0, 1), *mb.initial_state(velocities={"p": (1, 0, 0)}),
    ...                    t_eval=[0.0, 1.0])
    >>> (linear_momentum(mb, traj)[1].round(9) + 0.0).tolist()
    [2.0, 0.0, -20.0]
    """
    mb = _bound(mb, traj)
    P = np.zeros((len(traj), 3))
    for b in mb.bodies:
        P += b.mass * _velocity(traj, b)
    return P


def angular_momentum(mb: Multibody, traj: Trajectory,
                     about: Vector = (0.0, 0.0, 0.0)) -> FloatArray:
    """Total angular momentum about a fixed world point, shape ``(k, 3)``:
    ``sum (x - about) x m v + R I w_body``.

    Parameters
    ----------
    mb, traj
        The mechanism and a trajectory of its ``system``.
    about
        The world point (default the origin).

    Examples
    --------
    The box turning about its axis of inertia 3 at 1 rad/s:

    >>> from dalembert.multibody import Multibody, RigidBody
    >>> mb = Multibody([RigidBody("box", 1.0, (1, 2, 3))], gravity=(0, 0, 0))
    >>> q0, qd0 = mb.initial_state(angular_velocities={"box": (0, 0, 1.0)})
    >>> traj = mb.simulate((0, np.pi / 2), q0, qd0, t_eval=[np.pi / 2])
    >>> (angular_momentum(mb, traj).round(9) + 0.0).tolist()
    [[0.0, 0.0, 3.0]]
    """
    mb = _bound(mb, traj)
    H = np.zeros((len(traj), 3))
    for b in mb.bodies:
        x, R = _pose(traj, b)
        H += np.cross(x - np.asarray(about, dtype=float), b.mass * _velocity(traj, b))
        if isinstance(b, TurningBody):
            w = angular_velocities(mb, traj, b, "body")
            H += np.einsum("kij,jl,kl->ki", R, b.inertia, w)
    return H


def kinetic_energy(mb: Multibody, traj: Trajectory) -> FloatArray:
    """``sum 1/2 m v.v + 1/2 w.I w``, evaluated from the bodies' states.

    Parameters
    ----------
    mb, traj
        The mechanism and a trajectory of its ``system``.

    Examples
    --------
    A 2 kg particle thrown at 1 m/s along ``x`` under ``g = 10``, after 1 s:

    >>> from dalembert.multibody import Multibody, Particle
    >>> mb = Multibody([Particle("p", 2.0)], gravity=(0, 0, -10.0))
    >>> traj = mb.simulate((0, 1), *mb.initial_state(velocities={"p": (1, 0, 0)}),
    ...                    t_eval=[0.0, 1.0])
    >>> kinetic_energy(mb, traj).round(9).tolist()   # 1/2 2 (1^2 + 10^2) at t = 1
    [1.0, 101.0]
    """
    mb = _bound(mb, traj)
    T = np.zeros(len(traj))
    for b in mb.bodies:
        v = _velocity(traj, b)
        T += 0.5 * b.mass * np.einsum("ki,ki->k", v, v)
        if isinstance(b, TurningBody):
            w = angular_velocities(mb, traj, b, "body")
            T += 0.5 * np.einsum("ki,ij,kj->k", w, b.inertia, w)
    return T


def potential_energy(mb: Multibody, traj: Trajectory) -> FloatArray:
    """Gravity ``-sum m g.x`` plus the springs' ``1/2 k (L - L0)^2``.

    Parameters
    ----------
    mb, traj
        The mechanism and a trajectory of its ``system``.

    Examples
    --------
    A 2 kg particle thrown at 1 m/s along ``x`` under ``g = 10``, after 1 s:

    >>> from dalembert.multibody import Multibody, Particle
    >>> mb = Multibody([Particle("p", 2.0)], gravity=(0, 0, -10.0))
    >>> traj = mb.simulate((0, 1), *mb.initial_state(velocities={"p": (1, 0, 0)}),
    ...                    t_eval=[0.0, 1.0])
    >>> potential_energy(mb, traj).round(9).tolist()   # 2 10 z, z = -5 at t = 1
    [0.0, -100.0]
    """
    mb = _bound(mb, traj)
    V = np.zeros(len(traj))
    for b in mb.bodies:
        V -= b.mass * _pose(traj, b)[0] @ mb.gravity
    for s in mb.springs:
        d = (point_positions(mb, traj, s.body_b, s.point_b)
             - point_positions(mb, traj, s.body_a, s.point_a))
        V += 0.5 * s.stiffness * (np.linalg.norm(d, axis=1) - s.rest_length) ** 2
    if mb.joint_springs:
        poses = {b.name: _pose(traj, b) for b in mb.bodies}
        for js in mb.joint_springs:
            V += 0.5 * js.stiffness * (coordinate_values(js.joint, poses) - js.rest) ** 2
    return V


def energy(mb: Multibody, traj: Trajectory) -> FloatArray:
    """Total mechanical energy ``T + V`` along the trajectory.

    Parameters
    ----------
    mb, traj
        The mechanism and a trajectory of its ``system``.

    Examples
    --------
    A 2 kg particle thrown at 1 m/s along ``x`` under ``g = 10``, after 1 s:

    >>> from dalembert.multibody import Multibody, Particle
    >>> mb = Multibody([Particle("p", 2.0)], gravity=(0, 0, -10.0))
    >>> traj = mb.simulate((0, 1), *mb.initial_state(velocities={"p": (1, 0, 0)}),
    ...                    t_eval=[0.0, 1.0])
    >>> energy(mb, traj).round(9).tolist()
    [1.0, 1.0]
    """
    return kinetic_energy(mb, traj) + potential_energy(mb, traj)


@dataclass(frozen=True)
class JointReaction:
    """What joint ``joint`` exerts on ``body``, one row per output time.

    ``force_world``/``force_body``: the force; ``torque_world``/``torque_body``:
    the torque about the joint point ``point_world`` (``torque_cm_world``: about
    the mass center). Body-frame values are in the body's own frame.
    """

    joint: str
    body: str
    point_world: FloatArray
    force_world: FloatArray
    torque_world: FloatArray
    torque_cm_world: FloatArray
    force_body: FloatArray
    torque_body: FloatArray


def joint_reactions(
    mb: Multibody, traj: Trajectory, parameters: Mapping[Any, object] | None = None
) -> dict[str, dict[str, JointReaction]]:
    """Constraint force and torque of every joint on each of its two bodies.

    Returns ``{joint name: {body name: JointReaction}}``. Moving bodies' values
    come from the multipliers; the reaction on ``Ground`` is the opposite wrench
    of the other body's (a joint's equations are invariant under a common rigid
    motion, so its constraint wrench on the pair is self-equilibrated).

    Parameters
    ----------
    mb, traj
        The mechanism and a trajectory of its ``system``.
    parameters
        Parameter values overriding those ``traj`` records (``traj.parameters``).

    Examples
    --------
    A 2 kg bob hanging at rest on a rod: the rod holds it up with ``m g``, and
    pulls the pivot down as much:

    >>> from dalembert.multibody import Distance, Ground, Multibody, Particle
    >>> bob = Particle("bob", 2.0)
    >>> mb = Multibody([bob], [Distance("rod", Ground(), bob, 1.0)], gravity=(0, 0, -10))
    >>> traj = mb.simulate((0, 1), *mb.initial_state(positions={bob: (0, 0, -1)}),
    ...                    t_eval=[1.0])
    >>> rod = joint_reactions(mb, traj)["rod"]
    >>> [(rod[side].force_world[0].round(9) + 0.0).tolist() for side in ("bob", "ground")]
    [[0.0, 0.0, 20.0], [0.0, 0.0, -20.0]]
    """
    system = mb.system  # the mechanism's own (a bound copy would compile again)
    values: dict[Any, object] = {**traj.parameters, **(parameters or {})}
    num = system.numeric(values)
    mb = mb.bound(traj.parameters, parameters) if mb.parameters else mb
    names = system.constraint_names
    k = len(traj)
    coord_index = {c: system.coordinate_names.index(c) for c in system.coordinate_names}
    # A_J^T lambda_J on the columns of the joint's own moving bodies only (all columns of
    # every joint would be joints x outputs x coordinates numbers: 1 GB for 256 links),
    # blocks of one shape gathered together (one NumPy call per shape and output)
    blocks: dict[tuple[int, int], list[tuple[tuple[str, str], list[int], list[int]]]] = {}
    for j in mb.joints:
        rows = [names.index(c) for c in j.constraint_names]
        for body in j.bodies:
            if not isinstance(body, Ground) and rows:  # a Free joint has none: no reaction
                cols = [coord_index[c.name] for c in body.coordinates]
                blocks.setdefault((len(rows), len(cols)), []).append(
                    ((j.name, body.name), rows, cols))
    gathers = {shape: (np.array([rows for _, rows, _ in group]),
                       np.array([cols for _, _, cols in group])) for shape, group in blocks.items()}
    Q_blocks = {shape: np.empty((k, len(group), shape[1])) for shape, group in blocks.items()}
    for i in range(k):
        A, _ = num.velocity_constraint(traj.t[i], traj.q[i])
        lam = traj.multipliers[i]
        for shape, (R, C) in gathers.items():
            Q_blocks[shape][i] = np.einsum("bmn,bm->bn", A[R[:, :, None], C[:, None, :]], lam[R])
    Q_joint = {key: Q_blocks[shape][:, g] for shape, group in blocks.items()
               for g, (key, _, _) in enumerate(group)}
    out: dict[str, dict[str, JointReaction]] = {}
    for j in mb.joints:
        sides = {}
        for body, point in ((j.body_a, j.point_a), (j.body_b, j.point_b)):
            if not isinstance(body, Ground):
                P = _application_points(mb, traj, j, body, point)
                Q = Q_joint.get((j.name, body.name), np.zeros((k, len(body.coordinates))))
                sides[body.name] = _reaction(mb, traj, j.name, body, P, Q)
        for body, point in ((j.body_a, j.point_a), (j.body_b, j.point_b)):
            if isinstance(body, Ground):
                other = next(iter(sides.values()))
                # a rolling contact acts on the ground where it acts on the body
                P = other.point_world if isinstance(j, Rolling) else point
                sides[body.name] = _ground_reaction(j.name, body, P, other)
        out[j.name] = sides
    return out


def _application_points(mb: Multibody, traj: Trajectory, joint: Joint, body: Body,
                        point: FloatArray) -> FloatArray:
    """Where the joint acts on ``body``: its joint point, or a rolling body's contact point."""
    if isinstance(joint, Rolling):
        return joint.contact_points(*_pose(traj, body))
    return point_positions(mb, traj, body, point)


def _reaction(mb: Multibody, traj: Trajectory, joint: str, body: Body,
              P: FloatArray, Q: FloatArray) -> JointReaction:
    c = _columns(traj, body)
    x, R = body.pose(c)
    F = body.center_force(Q)
    tau_cm = body.center_torque(c, Q)
    tau_P = tau_cm - np.cross(P - x, F)
    to_body = np.transpose(R, (0, 2, 1))
    return JointReaction(
        joint, body.name, P, F, tau_P, tau_cm,
        np.einsum("kij,kj->ki", to_body, F), np.einsum("kij,kj->ki", to_body, tau_P),
    )


def _ground_reaction(joint: str, ground: Ground, point: FloatArray,
                     other: JointReaction) -> JointReaction:
    P = np.broadcast_to(np.asarray(point, dtype=float), other.force_world.shape).copy()
    F = -other.force_world
    # the other body's wrench moved to the ground's joint point, then negated
    tau = -(other.torque_world + np.cross(other.point_world - P, other.force_world))
    return JointReaction(joint, ground.name, P, F, tau, tau, F.copy(), tau.copy())
