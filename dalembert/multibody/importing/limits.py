"""MuJoCo joint ranges -> joint limits: unilateral constraints of the mechanism.

A hinge's or slide's ``range`` (``limited``) becomes a
:func:`~dalembert.multibody.joint_limit` on the imported joint: a stop at each end of
the range, closed and opened by the run (:mod:`dalembert.solvers.contact`). dalembert's
hinge angle or slide travel is zero at MuJoCo's ``qpos0`` (:mod:`.joints`), so the
range is moved by it. MuJoCo's limits are soft (a spring and damper, ``solreflimit``);
these are hard stops, plastic (the joint stays on its stop). A hinge's range of a turn
or more, an empty range, and the cone limits of ball joints are left out (listed in the
warning).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

from ..contacts import Contact, joint_limit
from ..joints import Joint
from .bodies import ReferencePose


@dataclass
class ImportedLimits:
    """The joint limits read, the MuJoCo joints they come from, and what was left out."""

    contacts: list[Contact] = field(default_factory=list)
    joints: set[int] = field(default_factory=set)
    unsupported: list[str] = field(default_factory=list)


def read_limits(pose: ReferencePose, by_id: dict[int, Joint]) -> ImportedLimits:
    """The limits of the imported hinges and slides (``by_id``: dalembert's joint by
    MuJoCo joint id).

    Parameters
    ----------
    pose
        The model's reference pose (its ``model``).
    by_id
        The imported hinges and slides.

    Examples
    --------
    >>> import mujoco
    >>> from dalembert.multibody.importing.bodies import reference_pose
    >>> from dalembert.multibody.importing.joints import read_joints
    >>> model = mujoco.MjModel.from_xml_string(
    ...     "<mujoco><worldbody><body><joint name='hinge' range='-30 60'/>"
    ...     "<geom size='.1' mass='1'/></body></worldbody></mujoco>")
    >>> pose = reference_pose(model, "test")
    >>> joints = read_joints(pose, {b.name for b in pose.bodies.values()}, False, False)
    >>> stop = read_limits(pose, joints.by_id).contacts[0]
    >>> stop.name, round(stop.joint.middle, 6), round(stop.joint.half, 6)
    ('hinge_range', 0.261799, 0.785398)
    """
    model: Any = pose.model
    out = ImportedLimits()
    for j, joint in by_id.items():
        if not model.jnt_limited[j]:
            continue
        q0 = float(model.qpos0[model.jnt_qposadr[j]])
        low, high = (float(v) - q0 for v in model.jnt_range[j])
        if model.jnt_type[j] == 3 and high - low >= 2 * math.pi:  # a hinge's whole turn
            out.unsupported.append(f"the range of hinge {joint.name!r} (a turn or more)")
            continue
        if not low < high:  # a joint its file holds still: no stop can model that
            out.unsupported.append(f"the empty range of joint {joint.name!r}")
            continue
        out.contacts.append(joint_limit(f"{joint.name}_range", joint, low, high))
        out.joints.add(j)
    return out
