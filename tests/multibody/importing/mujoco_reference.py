"""MuJoCo's own simulation of a model file, and the bodies' poses from both sides.

MuJoCo runs at tight settings: the RK4 integrator, a step of 1e-4 s, and contact,
friction loss and (unless asked) joint limits disabled: what dalembert leaves out of an
imported model (and lists in its warning). Its body frames (``xpos``, ``xmat``) are compared
with the same frames computed from dalembert's body coordinates (the mass center and
the Euler parameters, moved to the MuJoCo body frame's origin).
"""

from __future__ import annotations

import mujoco
import numpy as np

from dalembert.multibody import mujoco_state, rotation_matrix

STEP = 1e-4


def tight(model: mujoco.MjModel, limits: bool = False) -> mujoco.MjModel:
    """``model`` set to RK4 with a 1e-4 s step, without contact, friction loss (or
    limits)."""
    model.opt.integrator = mujoco.mjtIntegrator.mjINT_RK4
    model.opt.timestep = STEP
    model.opt.disableflags |= int(mujoco.mjtDisableBit.mjDSBL_CONTACT)
    model.opt.disableflags |= int(mujoco.mjtDisableBit.mjDSBL_FRICTIONLOSS)
    if not limits:
        model.opt.disableflags |= int(mujoco.mjtDisableBit.mjDSBL_LIMIT)
    return model


def mujoco_run(model: mujoco.MjModel, qpos, qvel, times, ctrl=None):
    """MuJoCo's body frames ``(xpos (k, nbody, 3), xmat (k, nbody, 3, 3))`` at ``times``
    (multiples of the step), and the data at the end."""
    data = mujoco.MjData(model)
    data.qpos[:], data.qvel[:] = qpos, qvel
    if ctrl is not None:
        data.ctrl[:] = ctrl
    mujoco.mj_forward(model, data)
    steps = np.rint(np.asarray(times) / model.opt.timestep).astype(int)
    xpos, xmat, done = [], [], 0
    for n in steps:
        if n > done:
            mujoco.mj_step(model, data, nstep=int(n - done))
            done = n
        mujoco.mj_kinematics(model, data)
        xpos.append(data.xpos.copy())
        xmat.append(data.xmat.reshape(-1, 3, 3).copy())
    return np.array(xpos), np.array(xmat), data


def dalembert_frames(mb, traj):
    """The MuJoCo body frames of every imported body along ``traj``:
    ``{mujoco body id: (xpos (k, 3), xmat (k, 3, 3))}``."""
    out = {}
    for name, body in mb.imported.bodies.items():
        x = np.column_stack([traj[f"{name}_{c}"] for c in "xyz"])
        R = rotation_matrix(np.column_stack([traj[f"{name}_b{i}"] for i in range(4)]))
        out[body.mujoco_id] = (mb.imported.body_origins(name, x, R), R)
    return out


def largest_difference(mb, traj, model, qpos, qvel, times, ctrl=None, **simulate):
    """The largest difference, over ``times`` and every body, between MuJoCo's body
    origins and rotation matrices and dalembert's (the simulation already run)."""
    xpos, xmat, _ = mujoco_run(model, qpos, qvel, times, ctrl)
    worst = 0.0
    for k, (x, R) in dalembert_frames(mb, traj).items():
        worst = max(worst, float(np.abs(x - xpos[:, k]).max()),
                    float(np.abs(R - xmat[:, k]).max()))
    return worst


def compare(mb, model, qpos, qvel, t_end, ctrl=None, inputs=None, samples=11):
    """Both simulations from MuJoCo's ``(qpos, qvel)``: the largest difference of the
    body frames over ``[0, t_end]`` (``samples`` times)."""
    times = np.linspace(0.0, t_end, samples)
    q0, qd0 = mujoco_state(mb, qpos, qvel)
    kwargs = {} if inputs is None else {"inputs": inputs}
    traj = mb.simulate((0.0, t_end), q0, qd0, t_eval=times, **kwargs)
    return largest_difference(mb, traj, model, qpos, qvel, times, ctrl), traj
