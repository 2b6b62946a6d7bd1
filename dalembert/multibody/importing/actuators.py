"""MuJoCo actuators -> dalembert actuators driven by inputs.

A MuJoCo ``motor`` (fixed gain, no bias, no activation dynamics) in a hinge or a slide
applies ``gear * gain * ctrl`` as the joint's torque or force: it becomes a
:class:`~dalembert.multibody.Actuator` of value ``gear * gain * u``, ``u`` an input
named after the actuator (its ``ctrl``), given with ``simulate(inputs=...)``. Other
actuators (position and velocity servos, muscles, tendon and site transmissions) and
control or force ranges (clamping) are left out and listed in the warning.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import sympy as sp

from ..drivers import Actuator
from ..joints import Joint
from .bodies import ReferencePose, identifier

#: MuJoCo's enum values: a joint transmission, fixed gain, no bias, no dynamics.
JOINT_TRANSMISSION, FIXED_GAIN, NO_BIAS, NO_DYNAMICS = 0, 0, 0, 0


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
        if (model.actuator_gaintype[a] != FIXED_GAIN or model.actuator_biastype[a] != NO_BIAS
                or model.actuator_dyntype[a] != NO_DYNAMICS):
            out.unsupported.append(f"{what} (not a motor: a servo, a muscle or activation "
                                   "dynamics)")
            continue
        if model.actuator_ctrllimited[a] or model.actuator_forcelimited[a]:
            out.unsupported.append(f"the control or force range of {what} (not clamped)")
        name = identifier(mujoco_name, f"actuator{a}", taken)
        u = sp.Symbol(name)
        gain = float(model.actuator_gear[a, 0] * model.actuator_gainprm[a, 0])
        out.actuators.append(Actuator(name, joints[j], gain * u))
        out.inputs.append(u)
    return out
