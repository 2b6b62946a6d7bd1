"""A MuJoCo state ``(qpos, qvel)`` as a dalembert initial state of an imported mechanism."""

from __future__ import annotations

from typing import Any

import numpy as np

from ...errors import InitialConditionError, ModelError
from ..builder import Multibody
from ..types import Numbers


def mujoco_state(mb: Multibody, qpos: Numbers | None = None,
                 qvel: Numbers | None = None) -> tuple[dict[str, float], dict[str, float]]:
    """``(q0, qd0)`` of an imported mechanism at MuJoCo's state ``qpos``, ``qvel``.

    MuJoCo computes every body's pose and velocity from the joint values; each
    dalembert body takes its own (its mass center's position and velocity, its frame's
    orientation and angular velocity), so the state is consistent with every joint.

    Parameters
    ----------
    mb
        A mechanism from :func:`~dalembert.multibody.from_mjcf` or
        :func:`~dalembert.multibody.from_urdf`.
    qpos, qvel
        MuJoCo's joint positions (``model.nq``) and velocities (``model.nv``); by
        default the reference pose ``qpos0``, at rest.

    Returns
    -------
    tuple of dict
        ``q0`` and ``qd0`` by coordinate name, for :meth:`Multibody.simulate`.

    Examples
    --------
    A rod released at 0.5 rad from hanging (a hinge about ``y`` through the origin, its
    mass center 0.5 m below):

    >>> from dalembert.multibody import from_mjcf
    >>> mb = from_mjcf('''<mujoco><worldbody><body><joint name="pin" axis="0 1 0"/>
    ...   <geom type="capsule" size="0.05" fromto="0 0 0 0 0 -1"/></body></worldbody></mujoco>''')
    >>> q0, qd0 = mujoco_state(mb, qpos=[0.5])
    >>> round(q0["body1_x"], 12), round(q0["body1_z"], 12)  # 0.5 (-sin 0.5, -cos 0.5)
    (-0.239712769302, -0.438791280945)
    """
    import mujoco

    imported = getattr(mb, "imported", None)
    if imported is None:
        raise ModelError(f"{mb!r} was not imported from a model file: give its initial state "
                         "with mb.initial_state(...)")
    model = imported.model
    data = mujoco.MjData(model)
    for values, size, what, target in ((qpos, model.nq, "qpos", data.qpos),
                                       (qvel, model.nv, "qvel", data.qvel)):
        if values is None:
            continue
        try:
            array = np.asarray(values, dtype=float).ravel()
        except (TypeError, ValueError):  # not numbers (a dict, a string)
            array = np.full(0, np.nan)
        if array.shape != (size,) or not np.isfinite(array).all():
            raise InitialConditionError(f"{what} must be {size} finite numbers for "
                                        f"{imported.source} (MuJoCo's order), got "
                                        f"{values!r:.200}")
        if what == "qpos":
            _check_quaternions(model, array, imported.source)
        target[:] = array
    mujoco.mj_forward(model, data)
    positions: dict[str, Any] = {}
    orientations: dict[str, Any] = {}
    velocities: dict[str, Any] = {}
    spins: dict[str, Any] = {}
    velocity = np.zeros(6)
    for name, body in imported.bodies.items():
        k = body.mujoco_id
        R = data.xmat[k].reshape(3, 3)
        center = data.xpos[k] - R @ np.asarray(body.origin)
        # the frame origin's velocity (rotation, then translation; world components)
        mujoco.mj_objectVelocity(model, data, mujoco.mjtObj.mjOBJ_XBODY, k, velocity, 0)
        omega = velocity[:3].copy()
        positions[name], orientations[name] = center, R.copy()
        velocities[name] = velocity[3:] + np.cross(omega, center - data.xpos[k])
        spins[name] = omega
    return mb.initial_state(positions=positions, orientations=orientations,
                            velocities=velocities, angular_velocities=spins)


def _check_quaternions(model: Any, qpos: np.ndarray, source: str) -> None:
    """A ball or free joint's quaternion in ``qpos`` must have a direction: MuJoCo would
    take a zero one as no rotation, without a word."""
    import mujoco

    ball, free = int(mujoco.mjtJoint.mjJNT_BALL), int(mujoco.mjtJoint.mjJNT_FREE)
    for j in range(model.njnt):
        kind = int(model.jnt_type[j])  # (NumPy's integers do not equal MuJoCo's enum)
        if kind not in (ball, free):
            continue
        at = int(model.jnt_qposadr[j]) + (3 if kind == free else 0)
        if not np.linalg.norm(qpos[at:at + 4]) > 1e-12:
            name = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_JOINT, j)
            named = repr(name) if name else f"{j} (unnamed)"
            raise InitialConditionError(
                f"qpos for {source}: the quaternion of joint {named} (qpos[{at}:{at + 4}]) "
                "is zero; it has no direction (give w, x, y, z, e.g. 1, 0, 0, 0)")
