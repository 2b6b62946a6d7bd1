"""Housner's rocking block: dalembert's rough contacts (event-driven) against MuJoCo.

A rigid block ``2b x 2h`` (b = 0.2 m, h = 1 m, 1 kg) released at rest tilted 0.1 rad on
one corner, on rough ground, rocks on its corners; each impact keeps the fraction
``r = 1 - 3/2 sin(alpha)^2`` of its angular velocity (``sin(alpha) = b / R``, Housner
1963: angular momentum about the landing corner, the other corner lifting), so the
energy above rest on a corner falls by ``r^2`` at each impact.

Measured the same way for both tools from their trajectories on a 1e-4 s grid: the
impacts are where the tilt crosses 0; the energy of each swing is the block's energy
(kinetic + potential, above resting flat) at the middle of the swing; the restitution
each impact shows is ``sqrt(E_{k+1} / E_k)``, its error against Housner's ``r`` over
the first ``IMPACTS`` impacts; the penetration, the lowest corner below the ground.

- dalembert: the block as a System ``(x, y, theta)`` with two ``Unilateral`` corners,
  ``friction=math.inf`` (rough: no sliding), ``restitution=0``, event-driven, at
  ``rtol`` 1e-6 and the default.
- MuJoCo 4.0: a box (0.2 m deep) with a free joint on a plane, friction 1 (no sliding
  at these forces), RK4, default contact softness and ``solref = 2 dt`` (stiff), at
  timesteps 1e-3 ... 1e-5.

CPU time beside wall, the best of interleaved rounds. Writes
``bench/results/rocking.json``. Usage: ``python bench/rocking.py [--rounds 3]``.
"""

from __future__ import annotations

import argparse
import itertools
import json
import math
import platform
import time
from pathlib import Path

import numpy as np

OUT = Path(__file__).resolve().parent / "results" / "rocking.json"
M, G, B, H, DEPTH = 1.0, 9.81, 0.2, 1.0, 0.2
R = math.hypot(B, H)
I_CM = M * R**2 / 3
HOUSNER = 1 - 1.5 * (B / R) ** 2
TILT = 0.1
T_END = 2.5
GRID = 1e-4
IMPACTS = 3


def timed(run):
    wall, cpu = time.perf_counter(), time.process_time()
    out = run()
    return out, time.perf_counter() - wall, time.process_time() - cpu


def measures(t: np.ndarray, tilt: np.ndarray, energy: np.ndarray,
             lowest: np.ndarray) -> dict:
    """The restitutions the impacts show and the penetration (see the module)."""
    crossings = np.flatnonzero(np.sign(tilt[1:]) != np.sign(tilt[:-1]))
    edges = np.r_[0, crossings, len(t) - 1]
    swings = [energy[(a + b) // 2] - M * G * H for a, b in itertools.pairwise(edges)]
    shown = [math.sqrt(max(e1, 0.0) / e0) for e0, e1 in itertools.pairwise(swings)]
    errors = [abs(s - HOUSNER) / HOUSNER for s in shown[:IMPACTS]]
    return {"impacts_seen": len(crossings), "restitution_shown": shown[:IMPACTS],
            "restitution_error": max(errors) if len(errors) == IMPACTS else math.inf,
            "penetration": float(max(0.0, -lowest.min()))}


def dalembert_block():
    import sympy as sp

    from dalembert import System, Unilateral, coordinates
    from dalembert import t as time_symbol

    x, y, th = coordinates("x y theta")

    def corner(u: float, v: float):
        return (x + u * sp.cos(th) - v * sp.sin(th), y + u * sp.sin(th) + v * sp.cos(th))

    right, left = corner(B, -H), corner(-B, -H)
    block = System(
        [x, y, th], kinetic=M / 2 * (x.diff() ** 2 + y.diff() ** 2) + I_CM / 2 * th.diff() ** 2,
        potential=M * G * y, name="rocking block",
        constraints=[Unilateral(right[1], name="right", friction=math.inf,
                                tangents=[right[0].diff(time_symbol)]),
                     Unilateral(left[1], name="left", friction=math.inf,
                                tangents=[left[0].diff(time_symbol)])])
    c, s = math.cos(-TILT), math.sin(-TILT)
    q0 = {x: -(B * c + H * s), y: -(B * s - H * c), th: -TILT}
    grid = np.arange(0.0, T_END + GRID / 2, GRID)

    def run(rtol: float | None, on_grid: bool = True):
        options = {} if rtol is None else {"rtol": rtol, "atol": rtol / 100}
        return block.simulate((0.0, T_END), q0, t_eval=grid if on_grid else None,
                              **options)

    def measure(traj) -> dict:
        q, qd = traj.q, traj.qd
        energy = M / 2 * (qd[:, 0] ** 2 + qd[:, 1] ** 2) + I_CM / 2 * qd[:, 2] ** 2 \
            + M * G * q[:, 1]
        return measures(traj.t, q[:, 2], energy, _lowest_corner(q))

    run(None)  # generated and compiled: not timed
    return run, measure


def from_impacts(traj) -> dict:
    """The restitution from the impacts' record (angular velocities before and after),
    the way a dalembert user reads it: no output grid."""
    shown = [i.qd_after[2] / i.qd_before[2] for i in traj.contacts.impacts[:IMPACTS]]
    return {"impacts_seen": len(traj.contacts.impacts), "restitution_shown": shown,
            "restitution_error": max(abs(s - HOUSNER) / HOUSNER for s in shown),
            "penetration": float(max(0.0, -_lowest_corner(traj.q).min()))}


def _lowest_corner(q: np.ndarray) -> np.ndarray:
    """The lower bottom corner's height, from ``(x, y, theta)`` rows."""
    return np.minimum(q[:, 1] + B * np.sin(q[:, 2]) - H * np.cos(q[:, 2]),
                      q[:, 1] - B * np.sin(q[:, 2]) - H * np.cos(q[:, 2]))


def mujoco_xml(dt: float, stiff: bool) -> str:
    solref = f' solref="{2 * dt} 1"' if stiff else ""
    # the block turned by -TILT about the world y axis (right corner down, at the origin)
    c, s = math.cos(TILT), math.sin(TILT)
    # R_y(phi) with phi = TILT takes the body corner (b, 0, -h) to (b c - h s, 0, -b s - h c)
    cx, cz = -(B * c - H * s), -(-B * s - H * c)
    qw, qy = math.cos(TILT / 2), math.sin(TILT / 2)
    inertia = f"{M * (DEPTH**2 + 4 * H**2) / 12} {I_CM} {M * (4 * B**2 + DEPTH**2) / 12}"
    return f"""<mujoco><option timestep="{dt}" gravity="0 0 -{G}" integrator="RK4">
<flag energy="enable"/></option>
<worldbody><geom type="plane" size="5 5 0.1" friction="1 0.005 0.0001"{solref}/>
<body name="block" pos="{cx} 0 {cz}" quat="{qw} 0 {qy} 0"><freejoint/>
<geom type="box" size="{B} {DEPTH / 2} {H}"{solref}/>
<inertial pos="0 0 0" mass="{M}" diaginertia="{inertia}"/>
</body></worldbody></mujoco>"""


def mujoco_block(dt: float, stiff: bool):
    import mujoco

    m = mujoco.MjModel.from_xml_string(mujoco_xml(dt, stiff))
    d = mujoco.MjData(m)
    every = max(1, round(GRID / dt))
    steps = round(T_END / dt)

    def run():
        mujoco.mj_resetData(m, d)
        mujoco.mj_forward(m, d)
        rows = []
        for k in range(steps + 1):
            if k % every == 0:
                qw, qy = d.qpos[3], d.qpos[5]
                tilt = -2 * math.atan2(qy, qw)  # dalembert's sign: the right corner down
                z = d.qpos[2]
                # the corners' heights: the centre's, -+ b sin(phi) - h cos(phi)
                phi = 2 * math.atan2(qy, qw)
                lowest = min(z - B * math.sin(phi) - H * math.cos(phi),
                             z + B * math.sin(phi) - H * math.cos(phi))
                rows.append((d.time, tilt, d.energy[0] + d.energy[1] + M * G * 0.0, lowest))
            mujoco.mj_step(m, d)
        return np.array(rows)

    def measure(rows) -> dict:
        # MuJoCo's potential energy is m g z of the centre (0 at the world origin)
        return measures(rows[:, 0], rows[:, 1], rows[:, 2], rows[:, 3])

    return run, measure


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--rounds", type=int, default=3)
    args = parser.parse_args()
    import mujoco

    run_d, measure_d = dalembert_block()
    cases = {f"dalembert rtol={r}": (lambda r=r: run_d(r), measure_d)
             for r in (1e-6, None)}
    cases["dalembert default rtol, impacts' record (no grid)"] = (
        lambda: run_d(None, on_grid=False), from_impacts)
    for dt in (1e-3, 1e-4, 1e-5):
        for stiff in (False, True):
            run_m, measure_m = mujoco_block(dt, stiff)
            cases[f"mujoco dt={dt} {'solref=2dt' if stiff else 'default solref'}"] = \
                (run_m, measure_m)
    results: dict[str, dict] = {}
    for name, (run, measure) in cases.items():
        out, wall, cpu = timed(run)
        results[name] = {**measure(out), "wall_s": wall, "cpu_s": cpu}
    names = list(cases)
    for k in range(1, args.rounds):  # interleaved rounds, rotated
        order = names[k % len(names):] + names[:k % len(names)]
        for name in order:
            _, wall, cpu = timed(cases[name][0])
            results[name]["wall_s"] = min(results[name]["wall_s"], wall)
            results[name]["cpu_s"] = min(results[name]["cpu_s"], cpu)
    record = {"housner": HOUSNER, "b": B, "h": H, "tilt": TILT, "t_end": T_END,
              "grid": GRID, "impacts": IMPACTS, "rounds": args.rounds,
              "machine": platform.platform(), "mujoco": mujoco.__version__,
              "results": results}
    OUT.write_text(json.dumps(record, indent=1))
    for name, r in results.items():
        print(f"{name:40s} restitution error {r['restitution_error']:.1e}  "
              f"penetration {r['penetration']:.1e} m  CPU {r['cpu_s']:.3f} s "
              f"(wall {r['wall_s']:.3f})")


if __name__ == "__main__":
    main()
