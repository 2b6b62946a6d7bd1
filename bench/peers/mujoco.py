"""MuJoCo: the chain in minimal coordinates (ball or hinge joints), RK4.

Each link is a body whose frame sits at its top joint, with an explicit
inertial (the solid cylinder's mass and principal inertia at the center, ``L/2``
below) and a cylinder geom that does not collide; the model is built with the
``MjSpec`` API. Contacts, joint damping and armature are off, so the model is the
same conservative chain. The time step starts at 2e-2 and shrinks by 2^(1/3) until
the energy target is met, then is bisected to within 5% (``ladder.bisect``). Joint
coordinates are minimal, so the constraint residual is zero by construction. One
evaluation = ``mj_forward`` (accelerations; the joint reaction forces would need
``mj_rnePostConstraint`` in addition). The energy flag is off while MuJoCo steps (with it
on, every stage of every step computes the energy: about 25% of a 16-link rollout)
and on only where the energy is measured (:func:`energy`), as dalembert computes it
only at its output times.
"""

from __future__ import annotations

import math
import time

import numpy as np

from .common import I_A, I_T, T_END, G, L, M, R, energy_error, meets, omega, tilt, time_call
from .ladder import Prepared, bisect

TOOL = "mujoco"
#: From 2e-2 (which misses the energy target at every size measured) down by a factor
#: 2^(1/3) a rung: it brackets the largest step meeting the target, which
#: ``ladder.bisect`` then narrows to 5%.
STEPS = tuple(2e-2 / 2 ** (k / 3) for k in range(37))


def versions() -> dict:
    import mujoco

    return {"mujoco": mujoco.__version__}


def spec(workload: str, n: int, dt: float):
    """The model as an ``MjSpec``, each link added as a child of the previous one.

    Built through the API rather than MJCF text: the XML parser refuses a chain
    written as nested bodies beyond about 500 links. The compiler still refuses a
    body tree deeper than 1023 (mujoco 4.0.0).
    """
    import mujoco

    chain = mujoco.MjSpec()
    chain.compiler.degree = False
    chain.compiler.inertiafromgeom = mujoco.mjtInertiaFromGeom.mjINERTIAFROMGEOM_FALSE
    opt = chain.option
    opt.timestep = dt
    opt.integrator = mujoco.mjtIntegrator.mjINT_RK4
    opt.gravity = [0.0, 0.0, -G]
    opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_CONTACT
    parent = chain.worldbody
    for k in range(n):
        body = parent.add_body(name=f"link{k + 1}", pos=[0.0, 0.0, 0.0 if k == 0 else -L],
                               explicitinertial=True, mass=M, ipos=[0.0, 0.0, -L / 2],
                               inertia=[I_T, I_T, I_A])
        body.add_geom(type=mujoco.mjtGeom.mjGEOM_CYLINDER, size=[R, L / 2, 0.0],
                      pos=[0.0, 0.0, -L / 2], contype=0, conaffinity=0, mass=0.0)
        if workload == "spherical":
            body.add_joint(type=mujoco.mjtJoint.mjJNT_BALL)
        else:
            body.add_joint(type=mujoco.mjtJoint.mjJNT_HINGE, axis=[0.0, 1.0, 0.0])
        parent = body
    return chain


#: mujoco 4.0.0's compiler refuses body trees deeper than this (measured: 1023 compiles
#: in ~60 s for the ball chain, 1024 fails after as long).
MAX_DEPTH = 1023


def build(workload: str, n: int, dt: float = 1e-2):
    if n > MAX_DEPTH:  # known in advance: do not spend a minute on the failure
        raise ValueError(f"MuJoCo cannot compile the {n}-link chain: its compiler refuses "
                         f"body trees deeper than {MAX_DEPTH}")
    start = time.perf_counter()
    try:
        model = spec(workload, n, dt).compile()
    except ValueError as exc:  # one line: the suite records the last line of the error
        raise ValueError(f"MuJoCo cannot compile the {n}-link chain: "
                         + " ".join(str(exc).split())) from exc
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


def energy(model, data) -> float:
    """``T + V`` at ``data``'s state: ``mj_forward`` with the energy flag on for this
    call only (the models step with it off)."""
    import mujoco

    flag = int(mujoco.mjtEnableBit.mjENBL_ENERGY)
    model.opt.enableflags |= flag
    try:
        mujoco.mj_forward(model, data)
    finally:
        model.opt.enableflags &= ~flag
    return float(data.energy.sum())


def run(workload: str, n: int) -> dict:
    """The measured record: :func:`prepare`, then the bisection of the step."""
    prepared = prepare(workload, n)
    return {**bisect(prepared), **prepared.info}


def prepare(workload: str, n: int) -> Prepared:
    """The model built twice (cold, warm) and ``attempt(step)``."""
    import mujoco

    _, cold = build(workload, n)
    model, warm = build(workload, n)
    data = initial_data(model, workload)
    e0 = energy(model, data)
    eval_s = time_call(lambda: mujoco.mj_forward(model, data))

    def attempt(dt: float) -> dict:
        steps = math.ceil(T_END / dt - 1e-9)  # the span exactly, at a step <= dt
        model.opt.timestep = T_END / steps
        state = initial_data(model, workload)
        start, cpu = time.perf_counter(), time.process_time()
        mujoco.mj_step(model, state, nstep=steps)
        simulate_s, cpu_s = time.perf_counter() - start, time.process_time() - cpu
        return {"setting": {"integrator": "RK4", "timestep": T_END / steps},
                "simulate_s": simulate_s,
                "cpu_s": cpu_s,
                "evaluations": 4 * steps, "steps": steps, "initial_energy": e0,
                "energy_error": energy_error(e0, energy(model, state), n),
                "residual": 0.0, "finished": bool(np.all(np.isfinite(state.qpos)))}

    info = dict(build_s=cold, build_warm_s=warm, eval_s=eval_s, coordinates=model.nq,
                constraints=0, residual_note="minimal coordinates: no constraints",
                build_note="MjSpec built and compiled twice in one process")
    return Prepared(info, attempt, STEPS, meets)
