"""A compiled MuJoCo model -> a :class:`~dalembert.multibody.Multibody`."""

from __future__ import annotations

import warnings
from typing import Any

import numpy as np

from ...errors import JointPointWarning, ModelError, ModelFileError
from ..builder import Multibody
from .actuators import read_actuators
from .bodies import reference_pose
from .equalities import read_equalities
from .geometry import read_shapes
from .joints import read_joints
from .limits import read_limits
from .model import ImportedModel
from .unsupported import _disabled, model_features, warn_unsupported


def build_multibody(model: Any, label: str, name: str) -> Multibody:
    """The mechanism of ``model``: its bodies, joints, loops, springs, gravity, motors and
    joint limits,
    with :class:`~.model.ImportedModel` as ``mb.imported``; what is left out is warned of
    once (:class:`~dalembert.UnsupportedModelFeatureWarning`).

    Parameters
    ----------
    model
        MuJoCo's compiled ``MjModel``.
    label
        The source, for messages.
    name
        The mechanism's name.
    """
    pose = reference_pose(model, label)
    taken = {b.name for b in pose.bodies.values()}
    try:
        joints = read_joints(pose, taken, _disabled(model, "mjDSBL_SPRING"),
                             _disabled(model, "mjDSBL_DAMPER"))
        loops = read_equalities(pose, taken)
        limits = read_limits(pose, joints.by_id)
        motors = read_actuators(pose, joints.by_id, taken, _disabled(model, "mjDSBL_ACTUATION"))
        gravity = np.zeros(3) if _disabled(model, "mjDSBL_GRAVITY") else model.opt.gravity.copy()
        moving = pose.moving
        if not moving:
            raise ModelFileError(
                f"{label}: no body moves (every body is welded to the world: it has no "
                "joint, and neither has any body between it and the world; MuJoCo fixes a "
                "URDF's root link to the world)")
        with warnings.catch_warnings():
            # the joint points come from the file, in the right frames by construction: the
            # heuristic against hand-given points in the wrong frame does not apply
            warnings.simplefilter("ignore", JointPointWarning)
            mb = Multibody(moving, [*joints.joints, *loops.joints], gravity=tuple(gravity),
                           name=name, joint_springs=joints.springs,
                           actuators=motors.actuators, inputs=motors.inputs,
                           contacts=limits.contacts)
    except ModelFileError:
        raise
    except ModelError as exc:
        raise ModelFileError(f"{label}: {exc}") from None
    unsupported = (*model_features(model, limits.joints), *joints.unsupported,
                   *loops.unsupported, *motors.unsupported, *limits.unsupported)
    mb.imported = ImportedModel(label, pose.imported, joints.names, read_shapes(pose),
                                unsupported, model)
    warn_unsupported(label, unsupported)
    return mb
