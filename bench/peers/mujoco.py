"""MuJoCo: the chain in minimal coordinates (ball or hinge joints), RK4.

Each link is a body whose frame sits at its top joint, with an explicit
``<inertial>`` (the solid cylinder's mass and principal inertia at the center,
``L/2`` below) and a cylinder geom that does not collide. Contacts, joint damping
and armature are off, so the model is the same conservative chain. The time step
starts at 1e-2 and is halved until the energy target is met. Joint coordinates
are minimal, so the constraint residual is zero by construction. One evaluation =
``mj_forward`` (accelerations; the joint reaction forces would need
``mj_rnePostConstraint`` in addition).
"""

from __future__ import annotations

import time

import numpy as np

from .common import I_A, I_T, T_END, G, L, M, R, energy_error, omega, tilt, time_call
from .ladder import climb

TOOL = "mujoco"
STEPS = tuple(1e-2 / 2**k for k in range(12))


def versions() -> dict:
    import mujoco

    return {"mujoco": mujoco.__version__}


def xml(workload: str, n: int, dt: float) -> str:
    """The MJCF model text."""
    joint = '<joint type="ball"/>' if workload == "spherical" else \
        '<joint type="hinge" axis="0 1 0"/>'
    body = (f'<inertial pos="0 0 {-L / 2}" mass="{M}" diaginertia="{I_T} {I_T} {I_A}"/>'
            f'<geom type="cylinder" size="{R} {L / 2}" pos="0 0 {-L / 2}" contype="0" '
            f'conaffinity="0" mass="0"/>{joint}')
    tree = ""
    for k in reversed(range(n)):
        pos = "0 0 0" if k == 0 else f"0 0 {-L}"
        tree = f'<body name="link{k + 1}" pos="{pos}">{body}{tree}</body>'
    return (f'<mujoco><option timestep="{dt}" integrator="RK4" gravity="0 0 {-G}">'
            f'<flag energy="enable" contact="disable"/></option>'
            f'<compiler angle="radian" inertiafromgeom="false"/>'
            f"<worldbody>{tree}</worldbody></mujoco>")


def build(workload: str, n: int, dt: float = 1e-2):
    import mujoco

    start = time.perf_counter()
    model = mujoco.MjModel.from_xml_string(xml(workload, n, dt))
    return model, time.perf_counter() - start


def initial_data(model, workload: str):
    """Link 1 tilted and turning, the other joints straight and still (relative)."""
    import mujoco

    data = mujoco.MjData(model)
    rot = tilt()
    if workload == "spherical":
        quat = np.zeros(4)
        mujoco.mju_mat2Quat(quat, rot.ravel())
        data.qpos[:4] = quat
        data.qvel[:3] = rot.T @ omega(workload)  # ball joint velocity: body frame
    else:
        data.qpos[0] = np.arctan2(rot[0, 2], rot[0, 0])
    mujoco.mj_forward(model, data)
    return data


def run(workload: str, n: int) -> dict:
    import mujoco

    _, cold = build(workload, n)
    model, warm = build(workload, n)
    data = initial_data(model, workload)
    e0 = float(data.energy.sum())
    eval_s = time_call(lambda: mujoco.mj_forward(model, data))

    def attempt(dt: float) -> dict:
        model.opt.timestep = dt
        state = initial_data(model, workload)
        steps = round(T_END / dt)
        start = time.perf_counter()
        mujoco.mj_step(model, state, nstep=steps)
        simulate_s = time.perf_counter() - start
        mujoco.mj_forward(model, state)
        return {"setting": {"integrator": "RK4", "timestep": dt}, "simulate_s": simulate_s,
                "evaluations": 4 * steps, "steps": steps, "initial_energy": e0,
                "energy_error": energy_error(e0, float(state.energy.sum()), n),
                "residual": 0.0, "finished": bool(np.all(np.isfinite(state.qpos)))}

    record = climb(attempt, STEPS)
    record.update(build_s=cold, build_warm_s=warm, eval_s=eval_s, coordinates=model.nq,
                  constraints=0, residual_note="minimal coordinates: no constraints",
                  build_note="MjModel.from_xml_string twice in one process")
    return record
