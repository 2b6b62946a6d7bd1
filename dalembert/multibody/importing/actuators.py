"""MuJoCo actuators -> dalembert actuators driven by inputs.

A MuJoCo ``motor`` (fixed gain, no bias, no activation dynamics) in a hinge or a slide
applies ``gear * gain * ctrl`` as the joint's torque or force: it becomes a
:class:`~dalembert.multibody.Actuator` of value ``gear * gain * u``, ``u`` an input
named after the actuator (its ``ctrl``), given with ``simulate(inputs=...)``. A
``position`` or ``velocity`` servo (fixed gain, affine bias) adds MuJoCo's bias
``b0 + b1 gear qpos + b2 gear qvel``, ``qpos`` the dalembert joint coordinate plus
``qpos0`` (a hinge's angle taken in ``(-pi, pi]`` from ``qpos0``: a servo's pull
differs from MuJoCo's once the hinge turns more than half a turn from the file's pose)
and ``qvel`` its rate. Other actuators (muscles, activation dynamics, tendon and site
transmissions) and control or force ranges (clamping) are left out and listed in the
warning.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import sympy as sp

from ..drivers import Actuator, joint_coordinate, joint_coordinate_rate
from ..joints import Joint
from .bodies import ReferencePose, identifier

#: MuJoCo's enum values: a joint transmission, fixed gain, no bias, no dynamics.
JOINT_TRANSMISSION, FIXED_GAIN, NO_BIAS, NO_DYNAMICS = 0, 0, 0, 0
#: An affine bias ``b0 + b1 length + b2 velocity``: position and velocity servos.
AFFINE_BIAS = 1


@dataclass
class ImportedActuators:
    """The actuators read, their inputs, and those left out."""

    actuators: list[Actuator] = field(default_factory=list)
    inputs: list[sp.Symbol] = field(default_factory=list)
    unsupported: list[str] = field(default_factory=list)


def read_actuators(pose: ReferencePose, joints: dict[int, Joint], taken: set[str],
                   disabled: bool) -> ImportedActuators:
    """Every motor in a hinge or a slide, as an actuator of an input.

    Parameters
    ----------
    pose
        The model at its reference pose.
    joints
        The dalembert hinges and slides, by MuJoCo joint id.
    taken
        Names already given (the inputs' are added).
    disabled
        MuJoCo's ``disableflags`` turn the actuators off.
    """
    model = pose.model
    out = ImportedActuators()
    for a in range(model.nu):
        mujoco_name = model.actuator(a).name
        what = f"actuator {mujoco_name or a!r}"
        if disabled:
            out.unsupported.append(f"{what} (actuation disabled in the model)")
            continue
        j = int(model.actuator_trnid[a, 0])
        if not (model.actuator_trntype[a] == JOINT_TRANSMISSION and j in joints):
            out.unsupported.append(f"{what} (acts through a tendon, a site, a body, or a "
                                   "joint that is not one hinge or one slide)")
            continue
        if (model.actuator_gaintype[a] != FIXED_GAIN
                or model.actuator_biastype[a] not in (NO_BIAS, AFFINE_BIAS)
                or model.actuator_dyntype[a] != NO_DYNAMICS):
            out.unsupported.append(f"{what} (a muscle, a user gain or bias, or activation "
                                   "dynamics)")
            continue
        if model.actuator_ctrllimited[a] or model.actuator_forcelimited[a]:
            out.unsupported.append(f"the control or force range of {what} (not clamped)")
        name = identifier(mujoco_name, f"actuator{a}", taken)
        u = sp.Symbol(name)
        gear = float(model.actuator_gear[a, 0])
        force = float(model.actuator_gainprm[a, 0]) * u
        if model.actuator_biastype[a] == AFFINE_BIAS:  # a servo: MuJoCo's length is gear*qpos
            b0, b1, b2 = (float(b) for b in model.actuator_biasprm[a, :3])
            qpos = joint_coordinate(joints[j]) + float(model.qpos0[model.jnt_qposadr[j]])
            force += b0 + b1 * gear * qpos + b2 * gear * joint_coordinate_rate(joints[j])
        out.actuators.append(Actuator(name, joints[j], gear * force))
        out.inputs.append(u)
    return out
