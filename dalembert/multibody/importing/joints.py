"""MuJoCo joints -> dalembert joints, springs and dampers.

At the reference pose ``qpos0`` MuJoCo's joint anchor and axis are the same world point
and direction on both bodies, so each joint is built from them: a hinge becomes a
:class:`~dalembert.multibody.Revolute` with one common reference direction, a slide a
:class:`~dalembert.multibody.Prismatic`, a ball a
:class:`~dalembert.multibody.Spherical`, a free joint a :class:`~dalembert.multibody.Free`
joint from the world's origin to the body frame's origin (it constrains nothing; its
travel and rotation, :func:`~dalembert.multibody.joint_positions`, are MuJoCo's
``qpos`` of the joint: the body frame's position and orientation). A dalembert
hinge angle or slide travel is then zero at ``qpos0`` and MuJoCo's ``qpos`` is it plus
``qpos0`` (MuJoCo's ``ref``). Springs (``stiffness``, ``springref``) and ``damping`` on
hinges and slides become :class:`~dalembert.multibody.JointSpring` loads, rest at
``springref - ref``.

A body with two hinges at one anchor with perpendicular axes is a
:class:`~dalembert.multibody.Universal` joint (the first axis turns with the parent, the
second with the body, as in MuJoCo), three hinges at one anchor with independent axes a
:class:`~dalembert.multibody.Spherical` one; the springs, dampers and actuators of such
hinges (on MuJoCo's angles, which dalembert's joint does not have) are left out and
listed in the warning.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from ...errors import ModelFileError
from ..drivers import JointSpring
from ..joints import Free, Joint, Prismatic, Revolute, Spherical, Universal
from ..types import FloatArray
from .bodies import ReferencePose, body_label, identifier

FREE, BALL, SLIDE, HINGE = 0, 1, 2, 3
KINDS = {FREE: "free", BALL: "ball", SLIDE: "slide", HINGE: "hinge"}


@dataclass
class ImportedJoints:
    """The joints and joint springs read, and what was left out."""

    joints: list[Joint] = field(default_factory=list)
    springs: list[JointSpring] = field(default_factory=list)
    #: dalembert joint by MuJoCo joint id (hinges and slides only: what actuators act in)
    by_id: dict[int, Joint] = field(default_factory=dict)
    names: dict[str, str] = field(default_factory=dict)
    unsupported: list[str] = field(default_factory=list)


def perpendicular(w: FloatArray) -> FloatArray:
    """A unit direction perpendicular to ``w``: the world axis least aligned with it,
    made perpendicular (dalembert's own default, so the angle's zero is reproducible).

    Examples
    --------
    >>> perpendicular(np.array([0.0, 0.0, 1.0])).tolist()
    [1.0, 0.0, 0.0]
    """
    u = np.eye(3)[int(np.argmin(np.abs(w)))]
    u = u - u @ w * w
    return u / np.linalg.norm(u)


def read_joints(pose: ReferencePose, taken: set[str], disabled_springs: bool,
                disabled_dampers: bool) -> ImportedJoints:
    """Every joint of the model, body by body.

    Parameters
    ----------
    pose
        The model at its reference pose, with its dalembert bodies.
    taken
        Names already given (joints are added).
    disabled_springs, disabled_dampers
        MuJoCo's ``disableflags`` for springs and dampers.
    """
    import mujoco

    model = pose.model
    data = mujoco.MjData(model)
    mujoco.mj_kinematics(model, data)
    out = ImportedJoints()
    for k in range(1, model.nbody):
        ids = [j for j in range(model.njnt) if model.jnt_bodyid[j] == k]
        if not ids:
            continue
        anchors, axes = data.xanchor[ids].copy(), data.xaxis[ids].copy()
        kinds = [int(model.jnt_type[j]) for j in ids]
        names = [model.joint(j).name for j in ids]
        parent = int(model.body_parentid[k])
        label = ", ".join(repr(n or f"joint{j}") for n, j in zip(names, ids))
        if len(ids) == 1:
            _one_joint(pose, out, ids[0], k, parent, anchors[0], axes[0], taken,
                       disabled_springs, disabled_dampers)
            continue
        joint = _combined(pose, ids, kinds, k, parent, anchors, axes, taken)
        if joint is None:
            raise ModelFileError(
                f"{pose.label}: body {body_label(model, k)!r} has {len(ids)} joints ({label}, "
                f"{', '.join(KINDS[c] for c in kinds)}); dalembert imports one joint per "
                "body, or two hinges at one point with perpendicular axes (a universal "
                "joint), or three hinges at one point (a ball joint); split the body into "
                "bodies of one joint each, each with its own mass")
        out.joints.append(joint)
        loaded = [j for j in ids if (model.jnt_stiffness[j] and not disabled_springs)
                  or (model.dof_damping[model.jnt_dofadr[j]] and not disabled_dampers)]
        if loaded:
            out.unsupported.append(f"springs and dampers of hinges {label} (made one "
                                   f"{type(joint).__name__} joint)")
        for j in ids:
            out.names[model.joint(j).name or f"joint{j}"] = joint.name
    return out


def _one_joint(pose: ReferencePose, out: ImportedJoints, j: int, k: int, parent: int,
               anchor: FloatArray, axis: FloatArray, taken: set[str],
               disabled_springs: bool, disabled_dampers: bool) -> None:
    model = pose.model
    kind = int(model.jnt_type[j])
    mujoco_name = model.joint(j).name
    name = identifier(mujoco_name, f"joint{j}", taken)
    a, b = pose.body_of(parent), pose.body_of(k)
    point_a, point_b = pose.world_point(parent, anchor), pose.world_point(k, anchor)
    joint: Joint
    if kind == FREE:  # its qpos is the body frame's world pose, whatever its parent
        joint = Free(name, pose.bodies[0], b, (0.0, 0.0, 0.0), point_b)
        if model.jnt_stiffness[j] or model.dof_damping[model.jnt_dofadr[j]]:
            out.unsupported.append(f"spring or damping on free joint {mujoco_name!r}")
    elif kind == BALL:
        joint = Spherical(name, a, b, point_a, point_b)
        if model.jnt_stiffness[j] or model.dof_damping[model.jnt_dofadr[j]]:
            out.unsupported.append(f"spring or damping on ball joint {mujoco_name!r}")
    else:
        u = perpendicular(axis)
        cls = Revolute if kind == HINGE else Prismatic
        joint = cls(name, a, b, point_a, point_b,
                    axis_a=pose.world_direction(parent, axis),
                    axis_b=pose.world_direction(k, axis),
                    ref_a=pose.world_direction(parent, u), ref_b=pose.world_direction(k, u))
        out.by_id[j] = joint
        stiffness = 0.0 if disabled_springs else float(model.jnt_stiffness[j])
        damping = 0.0 if disabled_dampers else float(model.dof_damping[model.jnt_dofadr[j]])
        if stiffness or damping:
            q0 = int(model.jnt_qposadr[j])
            rest = float(model.qpos_spring[q0] - model.qpos0[q0])
            if kind == HINGE:  # dalembert's angle lies in (-pi, pi]
                rest = float(np.pi - (np.pi - rest) % (2 * np.pi))
            out.springs.append(JointSpring(identifier(f"{name}_spring", "spring", taken),
                                           joint, stiffness, damping, rest))
    out.joints.append(joint)
    out.names[mujoco_name or f"joint{j}"] = name


def _combined(pose: ReferencePose, ids: Sequence[int], kinds: Sequence[int], k: int,
              parent: int, anchors: FloatArray, axes: FloatArray,
              taken: set[str]) -> Joint | None:
    """Two or three hinges at one point as one joint, or ``None`` if they are not."""
    model = pose.model
    if any(c != HINGE for c in kinds) or len(ids) > 3:
        return None
    if np.ptp(anchors, axis=0).max() > 1e-9 * max(1.0, float(np.abs(anchors).max())):
        return None
    name = identifier("_".join(model.joint(j).name for j in ids), f"joint{ids[0]}", taken)
    a, b = pose.body_of(parent), pose.body_of(k)
    point_a, point_b = pose.world_point(parent, anchors[0]), pose.world_point(k, anchors[0])
    if len(ids) == 2:
        if abs(axes[0] @ axes[1]) > 1e-9:
            return None
        return Universal(name, a, b, point_a, point_b,
                         axis_a=pose.world_direction(parent, axes[0]),
                         axis_b=pose.world_direction(k, axes[1]))
    if abs(np.linalg.det(axes)) < 1e-6:
        return None
    return Spherical(name, a, b, point_a, point_b)

