"""Contact benchmarks: dalembert's contact modes against MuJoCo, Pinocchio and Clarabel.

**The bouncing ball.** A 1 kg ball dropped from 1 m onto a floor with Newton's
restitution e = 0.8 (gravity 9.81). Closed forms: the impacts at
``t_1 (1 + 2 (e + ... + e^k))`` with ``t_1 = sqrt(2 h0 / g)``, the apexes at
``e^(2k) h0``. What each tool reaches over the first ``APEXES`` bounces: the apex
heights' largest relative error, the restitution it shows (the ratio of successive
apex heights, square-rooted), the penetration into the floor, and its time (CPU beside
wall, the best of interleaved rounds).

- dalembert: ``Unilateral(y, restitution=0.8)``, the coarsest ``rtol`` (bisection on a
  log scale, within 5%) whose apexes meet ``TARGET``.
- MuJoCo (soft contact): a sphere on a plane with ``solref = (-k, -b)`` (a contact
  spring and damper per unit mass) and ``solimp`` near 1, the damping set for e = 0.8
  by the linear oscillator's ``e = exp(-pi zeta / sqrt(1 - zeta^2))``, RK4; the
  coarsest timestep meeting ``TARGET``, if one in the ladder does, else the accuracy
  of its finest step; timed at its finest step and at 1e-3.
- Pinocchio: ``aba`` free flight (semi-implicit Euler), the crossing located within
  the step, ``impulseDynamics`` with restitution e at it; the same ladder as MuJoCo.

**The falling 16-link chain** (the gallery's falling chain with 17 masses, the
time-stepping mode) against the same chain in MuJoCo (MJCF written here: hinges, a
sphere at each mass, a plane): penetration, rod lengths, horizontal momentum, the
energy at rest against the closed form, the time it settles; each tool's coarsest step
meeting ``CHAIN_TARGET``, timed.

**LCPs**: Clarabel against dalembert's exact LCP solver (``bench/lcp.py``).

Writes ``bench/results/contact.json``. Usage: ``python bench/contact.py [--rounds 5]``
(about three minutes).
"""

from __future__ import annotations

import argparse
import json
import math
import platform
import time
from pathlib import Path

import numpy as np

OUT = Path(__file__).resolve().parent / "results" / "contact.json"
G, H0, E = 9.81, 1.0, 0.8
APEXES = 8
TARGET = 1e-6
T_END = 3.8  # 8 apexes after the first impacts, for e up to about 0.85
T1 = math.sqrt(2 * H0 / G)
IMPACTS = T1 + 2 * T1 * np.cumsum(np.r_[0.0, E ** np.arange(1, APEXES + 1)])
APEX_TIMES = IMPACTS[:APEXES] + E ** np.arange(1, APEXES + 1) * T1
APEX_HEIGHTS = E ** (2 * np.arange(1, APEXES + 1)) * H0


def apex_measures(z: np.ndarray) -> dict:
    """A stepped run's apexes against ``e^(2k) h0`` (its own apexes: the first drop has
    none), its penetration and the restitution its apexes show, from the heights ``z``
    at every step."""
    inner = (z[1:-1] > z[:-2]) & (z[1:-1] >= z[2:]) & (z[1:-1] > 1e-3)
    apexes = z[1:-1][inner][:APEXES]
    if len(apexes) < APEXES:
        apexes = np.r_[apexes, np.full(APEXES - len(apexes), np.nan)]
    return {"apex_error": float(np.abs(apexes / APEX_HEIGHTS - 1).max()),
            "penetration": float(max(0.0, -z.min())),
            "restitution": float(np.sqrt(apexes[1:] / apexes[:-1]).mean())}


def timed(run):
    wall, cpu = time.perf_counter(), time.process_time()
    out = run()
    return out, time.perf_counter() - wall, time.process_time() - cpu


# ------------------------------------------------------------------------- dalembert
def dalembert_case():
    from dalembert import System, Unilateral, coordinates

    (y,) = coordinates("y")
    ball = System([y], kinetic=y.diff() ** 2 / 2, potential=G * y,
                  constraints=[Unilateral(y, name="floor", restitution=E)])
    ball.simulate((0.0, 0.1), {"y": H0})  # code generated and compiled: not timed

    def run(rtol: float):
        traj = ball.simulate((0.0, T_END), {"y": H0}, rtol=rtol, atol=rtol * 1e-2,
                             t_eval=APEX_TIMES)
        steps = ball.simulate((0.0, T_END), {"y": H0}, rtol=rtol, atol=rtol * 1e-2)
        return {"apex_error": float(np.abs(traj.q[:, 0] / APEX_HEIGHTS - 1).max()),
                "penetration": float(max(0.0, -steps.q.min())),
                "restitution": float(np.sqrt(traj.q[1:, 0] / traj.q[:-1, 0]).mean()),
                "impact_time_error": float(np.abs(traj.contacts.impact_times[:APEXES]
                                                  - IMPACTS[:APEXES]).max())}

    def timed_run(rtol: float):
        return ball.simulate((0.0, T_END), {"y": H0}, rtol=rtol, atol=rtol * 1e-2,
                             t_eval=APEX_TIMES)

    return run, timed_run


# ---------------------------------------------------------------------------- MuJoCo
RADIUS, STIFFNESS = 0.05, 1e6


def mujoco_case():
    import mujoco

    zeta = -math.log(E) / math.sqrt(math.pi**2 + math.log(E) ** 2)
    damping = 2 * zeta * math.sqrt(STIFFNESS)

    def model(dt: float):
        xml = f"""<mujoco><option timestep="{dt}" gravity="0 0 -{G}" integrator="RK4"/>
        <worldbody><geom type="plane" size="5 5 .1" solref="-{STIFFNESS} -{damping}"
          solimp="0.9999 0.9999 0.001"/>
        <body pos="0 0 {H0 + RADIUS}"><freejoint/>
          <geom type="sphere" size="{RADIUS}" mass="1" solref="-{STIFFNESS} -{damping}"
            solimp="0.9999 0.9999 0.001"/></body></worldbody></mujoco>"""
        m = mujoco.MjModel.from_xml_string(xml)
        return m, mujoco.MjData(m)

    def simulate(dt: float):
        """The ball's height at every step, stepped in C by MuJoCo's rollout."""
        from mujoco import rollout

        m, d = model(dt)
        kind = mujoco.mjtState.mjSTATE_FULLPHYSICS
        start = np.empty(mujoco.mj_stateSize(m, kind))
        mujoco.mj_getState(m, d, start, kind)
        states, _ = rollout.rollout(m, d, start, nstep=round(T_END / dt))
        return states[0, :, 1 + 2] - RADIUS  # time, then qpos: x, y, z, quaternion

    def run(dt: float):
        return apex_measures(simulate(dt))

    return run, simulate


# ------------------------------------------------------------------------- Pinocchio
def pinocchio_case():
    """The ball as a Pinocchio user steps it: one prismatic z joint, free flight by
    semi-implicit Euler on ``aba`` at a fixed step, the floor's crossing located by
    linear interpolation within the step, where ``impulseDynamics`` (the gap's
    Jacobian, restitution ``E``) gives the velocity after the impact; a ladder over the
    step. The apexes are the sampled maxima, as for MuJoCo."""
    import pinocchio as pin

    model = pin.Model()
    inertia = pin.Inertia(1.0, np.zeros(3), np.eye(3) * 1e-3)
    joint = model.addJoint(0, pin.JointModelPZ(), pin.SE3.Identity(), "z")
    model.appendBodyToJoint(joint, inertia, pin.SE3.Identity())
    model.gravity.linear = np.array([0.0, 0.0, -G])
    data = model.createData()
    jacobian = np.ones((1, 1))  # the gap is the joint's coordinate
    tau = np.zeros(1)

    def simulate(dt: float) -> np.ndarray:
        steps = round(T_END / dt)
        z = np.empty(steps + 1)
        q, v = np.array([H0]), np.zeros(1)
        z[0] = H0
        for k in range(steps):
            a = pin.aba(model, data, q, v, tau)
            v_next = v + dt * a
            q_next = q + dt * v_next
            if q_next[0] < 0.0 <= q[0]:  # crossed the floor in this step
                s = q[0] / (q[0] - q_next[0])  # where, linearly
                v_hit = v + s * (v_next - v)
                v_after = pin.impulseDynamics(model, data, np.array([0.0]), v_hit,
                                              jacobian, E, 0.0)
                q_next = np.array([0.0]) + (1 - s) * dt * v_after
                v_next = np.array(v_after) + (1 - s) * dt * a
            q, v = q_next, v_next
            z[k + 1] = q[0]
        return z

    def run(dt: float) -> dict:
        return apex_measures(simulate(dt))

    return run, simulate

# ------------------------------------------------------------ the falling 16-link chain
# The gallery's falling chain (dalembert.examples.falling_chain) with 16 links: 17
# point masses joined by rigid rods, each above a frictionless plastic table, dropped
# tilted and moving sideways. Independent measures: the horizontal momentum (the table
# and the rods push vertically and internally: conserved), the depth below the table,
# the rods' lengths, and the energy at rest: lying flat, every rod horizontal, the
# masses all move at the one horizontal speed the momentum leaves, so the rest energy
# is ``N m V^2 / 2`` (potential 0), whatever the chain's folding on the table.
LINKS, LINK, TILT, DROP, SIDEWAYS, MASS = 16, 0.15, 0.35, 0.25, 0.4, 0.1
MASSES = LINKS + 1
CHAIN_END = 2.0  # the last mass lands by about 0.5 s; most runs settle by 1.1 s
REST_ENERGY = MASSES * MASS * SIDEWAYS**2 / 2
#: The shared target: nothing more than 1 mm below the table at any time (a
#: table-top simulation's visible tolerance, a 150th of the rods' 15 cm), the energy
#: at rest within 1% of the rest energy (1.4 mJ: the 1.7 kg chain lifted 0.08 mm, or
#: a 0.5% error in its sliding speed; the largest over the last REST_WINDOW), the
#: horizontal momentum within 1% and the rods within 1e-3 of their length at every
#: recorded instant.
CHAIN_TARGET = {"penetration": 1e-3, "rest_energy_error": 1e-2,
                "momentum_error": 1e-2, "rod_error": 1e-3}
#: The energy at rest is taken over the run's last REST_WINDOW seconds (its largest
#: error there: a step's chatter on the table shows whatever its phase at the end).
REST_WINDOW = 0.25
#: Settled: from then on every mass within 1 mm of the table and the energy within 1%
#: of the rest energy.
SETTLED = (1e-3, 1e-2)


def chain_measures(t: np.ndarray, x: np.ndarray, z: np.ndarray, vx: np.ndarray,
                   vz: np.ndarray) -> dict:
    """The measures of one chain run from its masses' positions and velocities at the
    instants ``t`` (rows) -- the same for both tools."""
    energy = MASS * ((vx**2 + vz**2).sum(axis=1) / 2 + G * z.sum(axis=1))
    error = np.abs(energy / REST_ENERGY - 1)
    rods = np.hypot(np.diff(x, axis=1), np.diff(z, axis=1))
    still = (np.abs(z) <= SETTLED[0]).all(axis=1) & (error <= SETTLED[1])
    moving = np.flatnonzero(~still)
    settled = float(t[moving[-1] + 1]) if len(moving) and moving[-1] + 1 < len(t) else (
        math.nan if len(moving) else float(t[0]))
    if settled > t[-1] - REST_WINDOW:  # still for less than the rest window: not settled
        settled = math.nan
    return {"penetration": float(max(0.0, -z.min())),
            "penetration_at_end": float(max(0.0, -z[-1].min())),
            "rest_energy_error": float(error[t >= t[-1] - REST_WINDOW].max()),
            "largest_vertical_speed_at_rest": float(
                np.abs(vz[t >= t[-1] - REST_WINDOW]).max()),
            "momentum_error": float(np.abs(vx.sum(axis=1) / (MASSES * SIDEWAYS) - 1).max()),
            "rod_error": float(np.abs(rods / LINK - 1).max()),
            "settled_time": settled}


def chain_meets(r: dict) -> bool:
    return all(r[k] <= v for k, v in CHAIN_TARGET.items())


def dalembert_chain():
    """The chain as the gallery builds it (``falling_chain.build`` with 17 masses):
    ``run(h) -> measures`` and the timed run (``contact_mode="time-stepping"``)."""
    import sympy as sp

    from dalembert import Holonomic, System, Unilateral, coordinates

    m, g = sp.symbols("m g", positive=True)
    X = coordinates(" ".join(f"x{k}" for k in range(MASSES)))
    Y = coordinates(" ".join(f"y{k}" for k in range(MASSES)))
    rods = [Holonomic((X[k + 1] - X[k]) ** 2 + (Y[k + 1] - Y[k]) ** 2 - LINK**2,
                      name=f"rod{k}") for k in range(LINKS)]
    table = [Unilateral(y, name=f"table{k}") for k, y in enumerate(Y)]
    chain = System([*X, *Y], kinetic=m / 2 * sum(c.diff() ** 2 for c in (*X, *Y)),
                   potential=m * g * sum(Y), constraints=rods + table,
                   parameters={m: MASS, g: G}, name="falling chain")
    q0 = {f"x{k}": k * LINK * math.cos(TILT) for k in range(MASSES)}
    q0.update({f"y{k}": DROP + k * LINK * math.sin(TILT) for k in range(MASSES)})
    qd0 = {f"x{k}": SIDEWAYS for k in range(MASSES)}

    def simulate(h: float, end: float = CHAIN_END):
        return chain.simulate((0.0, end), q0, qd0=qd0, contact_mode="time-stepping",
                              contact_step=h)

    simulate(2e-3, 0.01)  # code generated and compiled: not timed

    def run(h: float) -> dict:
        traj = simulate(h)
        q, qd = traj.q, traj.qd
        out = chain_measures(traj.t, q[:, :MASSES], q[:, MASSES:], qd[:, :MASSES],
                             qd[:, MASSES:])
        out["constraint_residual"] = float(traj.position_residual.max())
        out["status"] = traj.status
        return out

    return run, simulate


def mujoco_chain_xml(dt: float, radius: float = 0.005, default_solref: bool = False) -> str:
    """The same chain in MJCF: the first mass on an x and a z slide, each link a body
    on a hinge about y at the mass before it, a point mass (its rotational inertia
    1e-9, nothing) at the link's end with a sphere of ``radius`` for the contact; the
    plane ``radius`` below z = 0, so a sphere touches it when its mass's height (the
    dalembert gap) is 0. Frictionless (``condim=1``); the spheres collide with the
    plane only. Contact softness: ``solref`` time constant ``2 dt`` (the stiffest
    MuJoCo allows at a step, its documented rule), critically damped; or MuJoCo's
    default (0.02 s) with ``default_solref``."""
    solref = "" if default_solref else f'solref="{2 * dt} 1"'
    links = "".join(
        f'<body pos="{LINK if k > 1 else 0} 0 0"><joint type="hinge" axis="0 1 0"/>'
        f'<inertial pos="{LINK} 0 0" mass="{MASS}" diaginertia="1e-9 1e-9 1e-9"/>'
        f'<geom type="sphere" size="{radius}" pos="{LINK} 0 0" {solref}/>'
        for k in range(1, MASSES))
    return f"""<mujoco><option timestep="{dt}" gravity="0 0 -{G}"/>
    <default><geom contype="1" conaffinity="0" condim="1" mass="0"/></default>
    <worldbody><geom type="plane" size="10 10 .1" pos="0 0 -{radius}" contype="0"
      conaffinity="1" {solref}/>
    <body pos="0 0 {DROP}"><joint type="slide" axis="1 0 0"/><joint type="slide" axis="0 0 1"/>
      <inertial pos="0 0 0" mass="{MASS}" diaginertia="1e-9 1e-9 1e-9"/>
      <geom type="sphere" size="{radius}" {solref}/>
      {links}{"</body>" * LINKS}</body></worldbody></mujoco>"""


def mujoco_chain(default_solref: bool = False):
    """``run(dt) -> measures`` and the timed run (MuJoCo's rollout, in C)."""
    import mujoco
    from mujoco import rollout

    def simulate(dt: float):
        m = mujoco.MjModel.from_xml_string(mujoco_chain_xml(dt, default_solref=default_solref))
        d = mujoco.MjData(m)
        d.qpos[2] = -TILT  # the first hinge: the chain tilted up by TILT
        d.qvel[0] = SIDEWAYS
        kind = mujoco.mjtState.mjSTATE_FULLPHYSICS
        start = np.empty(mujoco.mj_stateSize(m, kind))
        mujoco.mj_getState(m, d, start, kind)
        states, _ = rollout.rollout(m, d, start, nstep=round(CHAIN_END / dt))
        return m, np.vstack([start, states[0]])

    def run(dt: float) -> dict:
        m, states = simulate(dt)
        nq = m.nq
        t, qpos, qvel = states[:, 0], states[:, 1:1 + nq], states[:, 1 + nq:1 + 2 * nq]
        # the masses from the joint angles (a hinge about y turns x towards -z); the
        # slides from the first body's place, DROP up
        angle = np.cumsum(qpos[:, 2:], axis=1)
        rate = np.cumsum(qvel[:, 2:], axis=1)
        zeros = np.zeros((len(t), 1))
        x = qpos[:, :1] + np.hstack([zeros, np.cumsum(LINK * np.cos(angle), axis=1)])
        z = DROP + qpos[:, 1:2] + np.hstack([zeros, np.cumsum(-LINK * np.sin(angle), axis=1)])
        vx = qvel[:, :1] + np.hstack([zeros, np.cumsum(-LINK * np.sin(angle) * rate, axis=1)])
        vz = qvel[:, 1:2] + np.hstack([zeros, np.cumsum(-LINK * np.cos(angle) * rate, axis=1)])
        return chain_measures(t, x, z, vx, vz)

    return run, simulate

# ------------------------------------------------------------------------------ runs
def coarsest(run, ladder, meets):
    """The coarsest setting of ``ladder`` (finest last) whose result meets, refined by
    bisection on a log scale to within 5%; ``None`` if even the finest does not."""
    results = {}
    passing = None
    for setting in ladder:
        results[setting] = run(setting)
        if meets(results[setting]):
            passing = setting
            break
    if passing is None:
        return None, results
    i = ladder.index(passing)
    if i == 0:
        return passing, results
    lo, hi = passing, ladder[i - 1]  # lo meets, hi does not
    while hi / lo > 1.05:
        mid = math.sqrt(lo * hi)
        results[mid] = run(mid)
        lo, hi = (mid, hi) if meets(results[mid]) else (lo, mid)
    return lo, results


def robust(found: dict, meets) -> float | None:
    """The coarsest setting tried from which every finer one tried meets too."""
    kept = None
    for setting in sorted(found):  # finest first
        if not meets(found[setting]):
            break
        kept = setting
    return kept


def ball(record: dict, rounds: int) -> None:
    """The bouncing ball: dalembert, MuJoCo and Pinocchio; interleaved timing."""
    def meets(r):
        return r["apex_error"] <= TARGET

    run, timed_run = dalembert_case()
    rtol, found = coarsest(run, [10.0 ** -k for k in range(2, 13)], meets)
    record["dalembert"] = {"rtol": rtol, "at_rtol": found[rtol] if rtol else None}
    peers: dict = {}
    simulators: dict = {}
    for name, case, ladder in (
            ("mujoco", mujoco_case, [1e-3, 3e-4, 1e-4, 3e-5, 1e-5]),
            ("pinocchio", pinocchio_case, [1e-3, 3e-4, 1e-4, 3e-5, 1e-5])):
        try:
            peer_run, simulators[name] = case()
        except ImportError:
            peers[name] = "not installed"
            continue
        dt, peer_found = coarsest(peer_run, ladder, meets)
        shown = dt if dt is not None else min(peer_found)
        peers[name] = {"timestep": dt, "meets_target": dt is not None,
                       "shown_timestep": shown, "at_timestep": peer_found[shown],
                       "ladder": {f"{k:g}": v for k, v in sorted(peer_found.items())}}
    record["peers"] = peers
    timings: list[dict] = []
    for _ in range(rounds):  # interleaved: a slow spell falls on all alike
        row = {}
        _, row["dalembert_wall_s"], row["dalembert_cpu_s"] = timed(lambda: timed_run(rtol))
        for name, simulate in simulators.items():  # its coarsest step and the one shown
            for step in sorted({1e-3, peers[name]["shown_timestep"]}):
                _, row[f"{name}_{step:g}_wall_s"], row[f"{name}_{step:g}_cpu_s"] = \
                    timed(lambda step=step, simulate=simulate: simulate(step))
        timings.append(row)
    record["rounds"] = timings
    record["best"] = {key: min(r[key] for r in timings) for key in timings[0]}


def chain(record: dict, rounds: int) -> None:
    """The falling 16-link chain: dalembert time-stepping against MuJoCo."""
    out: dict = {"links": LINKS, "masses": MASSES, "link": LINK, "mass": MASS,
                 "t_end": CHAIN_END, "rest_energy": REST_ENERGY, "target": CHAIN_TARGET,
                 "rest_window": REST_WINDOW,
                 "settled": {"height": SETTLED[0], "energy": SETTLED[1]}}
    run, simulate = dalembert_chain()
    ladder = [4e-2, 2e-2, 1e-2, 5e-3, 2e-3, 1e-3]
    step, found = coarsest(run, ladder, chain_meets)
    for h in ladder:  # every rung too: the settling is chaotic, not monotonic in h
        if h not in found:
            found[h] = run(h)
    steady = robust(found, chain_meets)
    out["dalembert"] = {"step": step, "steady_step": steady,
                        "ladder": {f"{k:g}": v for k, v in sorted(found.items())}}
    timed_runs = {f"dalembert_{h:g}": (lambda h=h: simulate(h))
                  for h in sorted({s for s in (step, steady) if s is not None})}
    try:
        mj_run, mj_simulate = mujoco_chain()
        dt, mj_found = coarsest(mj_run, [4e-3, 2e-3, 1e-3, 5e-4, 2.5e-4, 1e-4, 5e-5, 2.5e-5],
                                chain_meets)
        shown = dt if dt is not None else min(mj_found)
        out["mujoco"] = {"timestep": dt, "meets_target": dt is not None,
                         "shown_timestep": shown, "at_timestep": mj_found[shown],
                         "ladder": {f"{k:g}": v for k, v in sorted(mj_found.items())}}
        for s in sorted({shown, 2e-3}):  # and MuJoCo's default step
            timed_runs[f"mujoco_{s:g}"] = lambda s=s: mj_simulate(s)
        # what a user who leaves the contact's softness at its default gets (not timed)
        soft_run, _ = mujoco_chain(default_solref=True)
        soft_dt, soft_found = coarsest(soft_run, [2e-3, 1e-3, 2.5e-4, 1e-4, 5e-5],
                                       chain_meets)
        out["mujoco_default_solref"] = {
            "timestep": soft_dt, "meets_target": soft_dt is not None,
            "ladder": {f"{k:g}": v for k, v in sorted(soft_found.items())}}
    except ImportError:
        out["mujoco"] = "not installed"
    timings: list[dict] = []
    for _ in range(rounds):
        row = {}
        for name, go in timed_runs.items():
            _, row[f"{name}_wall_s"], row[f"{name}_cpu_s"] = timed(go)
        timings.append(row)
    out["rounds"] = timings
    out["best"] = {key: min(r[key] for r in timings) for key in timings[0]}
    record["chain"] = out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--rounds", type=int, default=5)
    args = parser.parse_args()

    record: dict = {"target_apex_error": TARGET, "apexes": APEXES, "e": E, "h0": H0,
                    "machine": {"python": platform.python_version(),
                                "platform": platform.platform()}}
    ball(record, args.rounds)
    chain(record, args.rounds)
    try:
        import lcp

        record["lcp"] = lcp.run()
    except ImportError as exc:  # qpsolvers or Clarabel missing
        record["lcp"] = f"not run: {exc}"
    OUT.parent.mkdir(parents=True, exist_ok=True)
    OUT.write_text(json.dumps(record, indent=1, default=float) + "\n")
    print(json.dumps({k: record[k] for k in ("dalembert", "peers", "best")}, indent=1,
                     default=float)[:4000])
    print(json.dumps({k: v for k, v in record["chain"].items() if k != "rounds"},
                     indent=1, default=float)[:6000])


if __name__ == "__main__":
    main()
