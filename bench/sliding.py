"""Sliding friction: dalembert's event-driven Coulomb friction against MuJoCo.

Three workloads with closed forms (gravity ``g = 9.81``):

**A box launched sliding.** A 2 kg box 0.2 x 0.15 x 0.1 m on its four bottom corners
(dalembert: a ``RigidBody`` with four ``plane_contact(..., friction=0.4)``; MuJoCo: a
box geom on a plane) launched at ``v0 = 1.2`` m/s along the angle 0.5 rad from the x
axis, no spin, no push. Every corner slides along the launch direction ``d``, so
friction totals ``-mu m g d``: the centre decelerates at ``mu g`` along a straight
line and stops at ``v0 / (mu g)`` after ``v0^2 / (2 mu g)``, without turning (the
normal forces balance the friction's moment about the centre, and the friction's
moment about the vertical is 0), and then sticks. Measures: the time it comes to rest
(the first sample with speed below ``REST * v0``, or the zero of the line through it
and the sample before if earlier), the time its speed falls to 1% of ``v0`` (against
``0.99 v0 / (mu g)``: the deceleration alone, apart from how it comes to rest), the
distance at the end of the run, the path's largest distance from the straight line
(relative to the distance), the largest yaw (rad) and the deepest corner below the
floor (m).

**A sphere launched sliding without spin** (1 kg, radius 0.1 m, ``mu = 0.3``) at
``v0 = 2`` m/s along 0.5 rad: friction ``mu m g`` slows it and spins it up; the contact
point's slip ``v0 - 7/2 mu g t`` reaches 0 at ``t_r = 2 v0 / (7 mu g)``, from when it
rolls at ``5/7 v0`` (the angular momentum about the contact point is conserved).
Measures: the time rolling starts (slip below ``REST * v0``, read as the rest), the
time the slip falls to 1% of ``v0`` (against ``0.99 t_r``), the speed when rolling
starts and at the end of the run against ``5/7 v0``, the path's largest distance from
the straight line (relative to the distance at the end) and the penetration.

**A block on an incline pushed harder and harder.** The box of the first workload at
rest on its four corners on an incline of 0.2 rad (``tan 0.2 < mu = 0.4``: it sticks),
pushed down the slope through its centre by ``k t`` (``k = 20`` N/s): it sticks until
``k t + m g sin(a) = mu m g cos(a)``, at ``t_s``, then slides with ``x = k (t -
t_s)^3 / (6 m)`` down the slope. Measures: the slip instant (the time it has moved 1
mm down the slope against ``t_s + (6 m 1e-3 / k)^(1/3)``: an instant both tools'
trajectories show, however their sticking creeps; read on the cubic through the
samples around it and their velocities, exact on the slide's cubic), the distance
slid at the end against the closed form, the largest yaw and the penetration.

Tools:

- dalembert, event-driven: the coarsest ``rtol`` (``atol = rtol / 100``) whose
  measures all meet ``TARGET`` (relative errors; yaw in rad; penetration in m), by
  bisection on a log scale to within 5%, and its default tolerances. Measured on its
  own steps (no output grid); the stop, the rolling's start and the slip also read
  from its switch record (``switch_time_error``, beside the shared measures).
- MuJoCo 4.0: the MJCF written here, ``condim=3``, elliptic and pyramidal friction
  cones, its default contact softness and ``solref = 2 dt`` (stiff, critically
  damped), RK4 (and Euler, its default, for one configuration); for the sphere also
  ``condim=6`` with MuJoCo's default rolling and torsional friction (what a user
  asking for rolling resistance gets). Each body first settles at rest on its contacts
  (not timed), then is launched; the measures on every step. Its timestep over a
  ladder: the coarsest meeting ``TARGET`` if any does, else each step's accuracy.

CPU beside wall time, the best of interleaved rounds; model building, code generation
and MuJoCo's settling are not timed. Writes ``bench/results/sliding.json``. Usage:
``python bench/sliding.py [--rounds 3]``.
"""

from __future__ import annotations

import argparse
import json
import math
import platform
import sys
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from bench.contact import coarsest  # the same bisection as the contact bench

OUT = Path(__file__).resolve().parent / "results" / "sliding.json"
G = 9.81
TARGET = 1e-8
#: at rest (or rolling): the speed (or slip) below this fraction of the launch speed
REST = 1e-6
ANGLE = 0.5
D = np.array([math.cos(ANGLE), math.sin(ANGLE)])
LADDER_RTOL = [10.0**-k for k in range(1, 13)]
LADDER_DT = [1e-3, 3e-4, 1e-4, 3e-5, 1e-5]
SETTLE = 0.2  # MuJoCo's bodies rest this long on their soft contacts before the launch

# the box (workloads 1 and 3)
A, B, C, M_BOX, MU_BOX = 0.2, 0.15, 0.1, 2.0, 0.4
CORNERS = np.array([(sx * A / 2, sy * B / 2, -C / 2)
                    for sx, sy in [(-1, -1), (1, -1), (1, 1), (-1, 1)]])
INERTIA_BOX = M_BOX / 12 * np.array([B**2 + C**2, A**2 + C**2, A**2 + B**2])
V0_BOX, T_BOX = 1.2, 0.5
STOP = V0_BOX / (MU_BOX * G)
DISTANCE = V0_BOX**2 / (2 * MU_BOX * G)

# the sphere (workload 2)
R, M_BALL, MU_BALL, V0_BALL, T_BALL = 0.1, 1.0, 0.3, 2.0, 0.5
ROLL = 2 * V0_BALL / (7 * MU_BALL * G)
ROLLING_SPEED = 5 / 7 * V0_BALL

# the incline (workload 3)
SLOPE, K_PUSH, T_INCLINE, MOVED = 0.2, 20.0, 0.6, 1e-3
SLIP = M_BOX * G * (MU_BOX * math.cos(SLOPE) - math.sin(SLOPE)) / K_PUSH
MOVED_AT = SLIP + (6 * M_BOX * MOVED / K_PUSH) ** (1 / 3)
SLID = K_PUSH * (T_INCLINE - SLIP) ** 3 / (6 * M_BOX)


def timed(run: Callable):
    wall, cpu = time.perf_counter(), time.process_time()
    out = run()
    return out, time.perf_counter() - wall, time.process_time() - cpu


# ----------------------------------------------------------------- measures (shared)
def rotation(quat: np.ndarray) -> np.ndarray:
    """Rotation matrices (body -> world) from unit quaternions ``(w, x, y, z)`` rows
    (dalembert's Euler parameters ``b0..b3`` and MuJoCo's ``qpos[3:7]`` alike)."""
    w, x, y, z = quat.T
    return np.stack([
        np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)], -1),
        np.stack([2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)], -1),
        np.stack([2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)], -1)],
        -2)


def yaw(quat: np.ndarray) -> np.ndarray:
    w, x, y, z = quat.T
    return np.arctan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))


def falls_to(t: np.ndarray, s: np.ndarray, level: float, to_zero: bool = False) -> float:
    """The instant the nonnegative ``s`` first falls to ``level``, linear between
    samples. With ``to_zero``: the first sample at or below ``level`` (at rest), or
    earlier, where the line through it and the sample before reaches 0 (a tool
    reaching exactly 0 at a sample is read at that sample; one creeping slowly below
    ``level`` at that sample, not extrapolated past it). ``nan`` if it never does."""
    below = np.flatnonzero(s <= level)
    if len(below) == 0 or below[0] == 0:
        return math.nan
    k = below[0]
    if to_zero:
        return float(min(t[k], t[k - 1] + s[k - 1] / (s[k - 1] - s[k]) * (t[k] - t[k - 1])))
    return float(t[k - 1] + (s[k - 1] - level) / (s[k - 1] - s[k]) * (t[k] - t[k - 1]))


def lowest_corner(pos: np.ndarray, quat: np.ndarray) -> np.ndarray:
    """The box's lowest bottom corner's height above the floor."""
    return pos[:, 2] + np.einsum("kij,cj->kci", rotation(quat), CORNERS)[:, :, 2].min(axis=1)


def box_measures(t, pos, quat, vel) -> dict:
    """The launched box's measures (see the module) from its centre's position and
    velocity and its orientation at each step."""
    speed = np.hypot(vel[:, 0], vel[:, 1])
    rest = falls_to(t, speed, REST * V0_BOX, to_zero=True)
    slowed = falls_to(t, speed, 0.01 * V0_BOX)
    off_line = np.abs(D[0] * pos[:, 1] - D[1] * pos[:, 0])
    return {"stop_time_error": abs(rest / STOP - 1),
            "slowed_time_error": abs(slowed / (0.99 * STOP) - 1),
            "distance_error": abs(math.hypot(pos[-1, 0], pos[-1, 1]) / DISTANCE - 1),
            "path_error": float(off_line.max() / DISTANCE),
            "yaw": float(np.abs(yaw(quat)).max()),
            "penetration": float(max(0.0, -lowest_corner(pos, quat).min())),
            "steps": len(t) - 1}


def ball_measures(t, pos, quat, vel, omega_world) -> dict:
    """The launched sphere's measures (see the module); ``omega_world`` its angular
    velocity in world components."""
    slip_velocity = vel + np.cross(omega_world, np.array([0.0, 0.0, -R]))
    slip = np.hypot(slip_velocity[:, 0], slip_velocity[:, 1])
    speed = np.hypot(vel[:, 0], vel[:, 1])
    rolls = falls_to(t, slip, REST * V0_BALL, to_zero=True)
    below = np.flatnonzero(slip <= REST * V0_BALL)
    at_roll = speed[below[0]] if len(below) else math.nan
    off_line = np.abs(D[0] * pos[:, 1] - D[1] * pos[:, 0])
    return {"roll_time_error": abs(rolls / ROLL - 1),
            "slip_1pc_time_error": abs(falls_to(t, slip, 0.01 * V0_BALL) / (0.99 * ROLL) - 1),
            "rolling_speed_error": abs(at_roll / ROLLING_SPEED - 1),
            "end_speed_error": abs(speed[-1] / ROLLING_SPEED - 1),
            "path_error": float(off_line.max() / math.hypot(pos[-1, 0], pos[-1, 1])),
            "penetration": float(max(0.0, R - pos[:, 2].min())),
            "steps": len(t) - 1}


def reaches(t: np.ndarray, x: np.ndarray, v: np.ndarray, level: float) -> float:
    """The instant ``x`` (rate ``v``) first reaches ``level``, on the cubic through
    the two samples around it with their rates (Hermite: exact where ``x`` is a
    cubic between them, as the pushed block's slide is); ``nan`` if it never does."""
    above = np.flatnonzero(x >= level)
    if len(above) == 0 or above[0] == 0:
        return math.nan
    k = above[0]
    h = t[k] - t[k - 1]
    x0, x1, m0, m1 = x[k - 1] - level, x[k] - level, v[k - 1] * h, v[k] * h
    # x0 h00(s) + m0 h10(s) + x1 h01(s) + m1 h11(s) in powers of s, highest first
    cubic = [2 * x0 + m0 - 2 * x1 + m1, -3 * x0 - 2 * m0 + 3 * x1 - m1, m0, x0]
    roots = [r.real for r in np.roots(cubic) if abs(r.imag) < 1e-9 and -1e-12 <= r.real
             <= 1 + 1e-12]
    s = min(roots) if roots else (0.0 - x0) / (x1 - x0)  # a line if rounding hides it
    return float(t[k - 1] + s * h)


def incline_measures(t, pos, quat, vel) -> dict:
    """The pushed box's measures; ``pos`` in the incline's frame (x down the slope)."""
    moved = pos[:, 0] - pos[0, 0]
    return {"slip_time_error": abs(reaches(t, moved, vel[:, 0], MOVED) / MOVED_AT - 1),
            "slid_error": abs(moved[-1] / SLID - 1),
            "yaw": float(np.abs(yaw(quat)).max()),
            "penetration": float(max(0.0, -lowest_corner(pos, quat).min())),
            "steps": len(t) - 1}


#: read from dalembert's switch record only; not a measure both tools share
NOT_COMPARED = ("steps", "switch_time_error")


def meets(r: dict) -> bool:
    return all(v <= TARGET for k, v in r.items() if k not in NOT_COMPARED)  # nan fails


# ------------------------------------------------------------------------- dalembert
def dalembert_box(gravity=(0.0, 0.0, -G), push: bool = False):
    from dalembert import t as time_symbol
    from dalembert.multibody import Force, Ground, Multibody, RigidBody, plane_contact

    body = RigidBody("box", M_BOX, INERTIA_BOX)
    corners = [plane_contact(f"c{k}", Ground(), body, point=tuple(p), friction=MU_BOX)
               for k, p in enumerate(CORNERS)]
    forces = [Force(body, (K_PUSH * time_symbol, 0, 0))] if push else []
    return Multibody([body], gravity=gravity, contacts=corners, forces=forces)


def dalembert_case(workload: str):
    """``simulate(rtol)`` (``None``: the defaults) and ``measure(traj)``, compiled."""
    from dalembert.multibody import Ground, Multibody, RigidBody, plane_contact

    if workload == "box":
        mb = dalembert_box()
        q0, qd0 = mb.initial_state(positions={"box": (0, 0, C / 2)},
                                   velocities={"box": (*(V0_BOX * D), 0)})
        end, name, event = T_BOX, "box", STOP
    elif workload == "ball":
        body = RigidBody("ball", M_BALL, (0.4 * M_BALL * R**2,) * 3)
        mb = Multibody([body], gravity=(0, 0, -G), contacts=[
            plane_contact("floor", Ground(), body, radius=R, friction=MU_BALL)])
        q0, qd0 = mb.initial_state(positions={"ball": (0, 0, R)},
                                   velocities={"ball": (*(V0_BALL * D), 0)})
        end, name, event = T_BALL, "ball", ROLL
    else:  # the incline: the floor level, gravity turned (x down the slope)
        mb = dalembert_box(gravity=(G * math.sin(SLOPE), 0, -G * math.cos(SLOPE)), push=True)
        q0, qd0 = mb.initial_state(positions={"box": (0, 0, C / 2)})
        end, name, event = T_INCLINE, "box", SLIP

    def simulate(rtol: float | None):
        options = {} if rtol is None else {"rtol": rtol, "atol": rtol / 100}
        return mb.simulate((0.0, end), q0, qd0, **options)

    def measure(traj) -> dict:
        if not traj.success:
            raise RuntimeError(f"dalembert's {workload} run failed: {traj.message}")
        pos = np.column_stack([traj[f"{name}_{c}"] for c in "xyz"])
        quat = np.column_stack([traj[f"{name}_b{k}"] for k in range(4)])
        vel = np.column_stack([traj[f"{name}_{c}_dot"] for c in "xyz"])
        # the stop, the rolling's start or the slip as the run's switch record has it
        switch = {"switch_time_error": abs(traj.contacts.switches[1].t / event - 1)
                  if len(traj.contacts.switches) > 1 else math.nan}
        if workload == "box":
            return box_measures(traj.t, pos, quat, vel) | switch
        if workload == "incline":
            return incline_measures(traj.t, pos, quat, vel) | switch
        quat_rate = np.column_stack([traj[f"{name}_b{k}_dot"] for k in range(4)])
        # the angular velocity in world components: 2 G(b) b' (G the left-hand matrix)
        w, x, y, z = quat.T
        g_matrix = np.stack([np.stack([-x, w, -z, y], -1), np.stack([-y, z, w, -x], -1),
                             np.stack([-z, -y, x, w], -1)], -2)
        omega = 2 * np.einsum("kij,kj->ki", g_matrix, quat_rate)
        return ball_measures(traj.t, pos, quat, vel, omega) | switch

    simulate(None)  # code generated and compiled: not timed
    return simulate, measure


# ---------------------------------------------------------------------------- MuJoCo
#: name -> (cone, stiff solref, integrator, condim); the sphere's condim=6 row only
MUJOCO_CONFIGS = {
    "elliptic, default solref, RK4": ("elliptic", False, "RK4", 3),
    "elliptic, solref 2dt, RK4": ("elliptic", True, "RK4", 3),
    "elliptic, solref 2dt, Euler": ("elliptic", True, "Euler", 3),
    "pyramidal, default solref, RK4": ("pyramidal", False, "RK4", 3),
    "pyramidal, solref 2dt, RK4": ("pyramidal", True, "RK4", 3),
    "elliptic, solref 2dt, RK4, condim 6": ("elliptic", True, "RK4", 6),
}


def mujoco_xml(workload: str, dt: float, cone: str, stiff: bool, integrator: str,
               condim: int) -> str:
    """The MJCF: the floor a plane, the body with a free joint; friction ``mu`` on both
    geoms (MuJoCo takes the larger), torsional and rolling friction MuJoCo's defaults
    (used only with ``condim=6``). The incline: the floor level, gravity turned, the
    push a motor along x (world) on the free joint, its control ``k t``."""
    solref = f' solref="{2 * dt} 1"' if stiff else ""
    if workload == "ball":
        mu, inertia = MU_BALL, np.full(3, 0.4 * M_BALL * R**2)
        geom, mass, z = f'type="sphere" size="{R}"', M_BALL, R
    else:
        mu, inertia = MU_BOX, INERTIA_BOX
        geom, mass, z = f'type="box" size="{A / 2} {B / 2} {C / 2}"', M_BOX, C / 2
    friction = f'condim="{condim}" friction="{mu} 0.005 0.0001"{solref}'
    gravity = (f"{G * math.sin(SLOPE)} 0 {-G * math.cos(SLOPE)}" if workload == "incline"
               else f"0 0 {-G}")
    actuator = ('<actuator><motor joint="free" gear="1 0 0 0 0 0" ctrllimited="false"/>'
                "</actuator>" if workload == "incline" else "")
    return f"""<mujoco><option timestep="{dt}" gravity="{gravity}" integrator="{integrator}"
  cone="{cone}"/>
<worldbody><geom type="plane" size="5 5 0.1" {friction}/>
<body pos="0 0 {z}"><freejoint name="free"/><geom {geom} {friction}/>
<inertial pos="0 0 0" mass="{mass}" diaginertia="{inertia[0]} {inertia[1]} {inertia[2]}"/>
</body></worldbody>{actuator}</mujoco>"""


def mujoco_case(workload: str, config: str, dt: float):
    """``simulate()`` (the timed rollout from the settled, launched state) and
    ``measure(states)``: the body first rests ``SETTLE`` s on its soft contacts."""
    import mujoco
    from mujoco import rollout

    m = mujoco.MjModel.from_xml_string(mujoco_xml(workload, dt, *MUJOCO_CONFIGS[config]))
    d = mujoco.MjData(m)
    kind = mujoco.mjtState.mjSTATE_FULLPHYSICS
    state = np.empty(mujoco.mj_stateSize(m, kind))
    mujoco.mj_getState(m, d, state, kind)
    nsettle = round(SETTLE / dt)
    control = np.zeros((nsettle, m.nu))
    settled, _ = rollout.rollout(m, d, state, control=control if m.nu else None,
                                 nstep=nsettle)
    mujoco.mj_setState(m, d, settled[0, -1], kind)
    d.time = 0.0
    d.qvel[:] = 0.0
    if workload == "box":
        d.qvel[:2] = V0_BOX * D
    elif workload == "ball":
        d.qvel[:2] = V0_BALL * D
    start = np.empty_like(state)
    mujoco.mj_getState(m, d, start, kind)
    end = {"box": T_BOX, "ball": T_BALL, "incline": T_INCLINE}[workload]
    nstep = round(end / dt)
    # the motor's control, held over each step: k t at the step's middle (the push's
    # mean over the step)
    push = (K_PUSH * dt * (np.arange(nstep) + 0.5))[:, None] if workload == "incline" \
        else None

    def simulate() -> np.ndarray:
        states, _ = rollout.rollout(m, d, start, control=push, nstep=nstep)
        return np.vstack([start, states[0]])

    nq = m.nq

    def measure(states: np.ndarray) -> dict:
        t, pos, quat = states[:, 0], states[:, 1:4], states[:, 4:8]
        vel, omega_body = states[:, 1 + nq:4 + nq], states[:, 4 + nq:7 + nq]
        if workload == "box":
            return box_measures(t, pos, quat, vel)
        if workload == "incline":
            return incline_measures(t, pos, quat, vel)
        # a free joint's angular velocity is in the body frame
        omega = np.einsum("kij,kj->ki", rotation(quat), omega_body)
        return ball_measures(t, pos, quat, vel, omega)

    return simulate, measure


# ------------------------------------------------------------------------------ runs
def workload_record(workload: str, configs: list[str]) -> tuple[dict, dict]:
    """Accuracy of every setting tried (not timed) and the runs to time."""
    simulate, measure = dalembert_case(workload)
    rtol, found = coarsest(lambda r: measure(simulate(r)), LADDER_RTOL, meets)
    default = measure(simulate(None))
    record: dict = {"dalembert": {
        "rtol": rtol, "at_rtol": found.get(rtol), "default": default,
        "ladder": {f"{k:.3g}": v for k, v in sorted(found.items())}}}
    timed_runs = {"dalembert, default": lambda: simulate(None)}
    if rtol is not None:
        timed_runs[f"dalembert, rtol {rtol:.3g}"] = lambda: simulate(rtol)
    record["mujoco"] = {}
    for config in configs:
        cases: dict[float, tuple] = {}

        def run(dt: float, config: str = config, cases: dict = cases) -> dict:
            cases[dt] = mujoco_case(workload, config, dt)
            go, measure_m = cases[dt]
            return measure_m(go())

        dt, ladder = coarsest(run, LADDER_DT, meets)
        shown = dt if dt is not None else min(ladder)
        record["mujoco"][config] = {
            "timestep": dt, "meets_target": dt is not None, "shown_timestep": shown,
            "ladder": {f"{k:.3g}": v for k, v in sorted(ladder.items())}}
        if "condim 6" in config or "Euler" in config:
            timed_runs[f"mujoco {config}, dt {shown:g}"] = cases[shown][0]
        else:  # its finest (or meeting) step and its default-sized one
            for step in sorted({shown, 1e-3}):
                timed_runs[f"mujoco {config}, dt {step:g}"] = cases[step][0]
    return record, timed_runs


def time_rounds(timed_runs: dict, rounds: int) -> dict:
    """The best CPU and wall time of each run over interleaved, rotated rounds."""
    best: dict = {name: {"cpu_s": math.inf, "wall_s": math.inf} for name in timed_runs}
    names = list(timed_runs)
    for k in range(rounds):
        for name in names[k % len(names):] + names[:k % len(names)]:
            _, wall, cpu = timed(timed_runs[name])
            best[name]["cpu_s"] = min(best[name]["cpu_s"], cpu)
            best[name]["wall_s"] = min(best[name]["wall_s"], wall)
    return best


def finite(value):
    """``value`` for JSON: NumPy numbers as floats, nan (never reached) as null."""
    if isinstance(value, dict):
        return {k: finite(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [finite(v) for v in value]
    if isinstance(value, (float, np.floating)):
        return None if math.isnan(value) else float(value)
    return value


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--rounds", type=int, default=3)
    args = parser.parse_args()
    import mujoco

    without_condim6 = [c for c in MUJOCO_CONFIGS if "condim 6" not in c]
    record: dict = {
        "target": TARGET, "rest": REST, "rounds": args.rounds,
        "machine": {"python": platform.python_version(), "platform": platform.platform(),
                    "mujoco": mujoco.__version__},
        "box": {"v0": V0_BOX, "mu": MU_BOX, "angle": ANGLE, "t_end": T_BOX,
                "stop": STOP, "distance": DISTANCE},
        "ball": {"v0": V0_BALL, "mu": MU_BALL, "radius": R, "angle": ANGLE,
                 "t_end": T_BALL, "roll": ROLL, "rolling_speed": ROLLING_SPEED},
        "incline": {"slope": SLOPE, "k": K_PUSH, "mu": MU_BOX, "t_end": T_INCLINE,
                    "slip": SLIP, "moved": MOVED, "moved_at": MOVED_AT, "slid": SLID}}
    for workload, configs in (("box", without_condim6), ("ball", list(MUJOCO_CONFIGS)),
                              ("incline", without_condim6)):
        accuracy, timed_runs = workload_record(workload, configs)
        record[workload].update(accuracy)
        record[workload]["timings"] = time_rounds(timed_runs, args.rounds)
        print(f"--- {workload}")
        d = accuracy["dalembert"]
        print(f"dalembert rtol {d['rtol']}: {d['at_rtol']}\n  default: {d['default']}")
        for config, r in accuracy["mujoco"].items():
            shown = r["shown_timestep"]
            print(f"mujoco {config}: meets {r['meets_target']}, at {shown:g}: "
                  f"{r['ladder'][f'{shown:.3g}']}")
        for name, t in record[workload]["timings"].items():
            print(f"  {name:50s} CPU {t['cpu_s']:.4f} s  wall {t['wall_s']:.4f} s")
    OUT.parent.mkdir(parents=True, exist_ok=True)
    OUT.write_text(json.dumps(finite(record), indent=1) + "\n")


if __name__ == "__main__":
    main()
