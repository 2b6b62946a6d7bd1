"""Soak test: ten million steps of a 16-link chain (not run in CI).

Workload: ``dalembert.multibody.chain(16, 1.0, 1.0, 0.05)``, planar (revolute pins,
``PlanarBody`` links: 48 coordinates, 32 constraint rows; ``--spatial`` for the 3D
chain of spherical joints and quaternion bodies), every link tilted 30 degrees
and released from rest; DOP853 with projection at the default tolerances, the
whole loop in C. The run goes on in legs of about ``LEG_STEPS`` steps, each a
``simulate`` call from the state where the last one ended, until ``--steps``
(default 1e7) are taken: the steps per simulated second grow several times as the
motion spreads over the links, so the length of the run is not known in advance,
and the repeated calls also show whether anything is kept from one to the next.
It reports:

- the largest position and velocity constraint residuals (at the legs' outputs);
- the energy drift, ``max |E(t) - E(0)| / (E(0) - E_rest)`` over the legs' ends (the
  chain is conservative: T + V is constant), and its value at the end;
- the resident memory before the first leg, after the last, and after every leg
  (a leak would make it grow with the steps);
- steps per second.

It writes ``bench/results/soak.json`` and prints a line per leg, and exits with status
1 (saying why) if the memory grew by more than ``MAX_GROWTH_MB`` after the first tenth
of the legs (flat memory: a leak of one byte per step would add 9 MB over 9e6 steps)
or a constraint residual exceeded ``MAX_RESIDUAL``. Usage (``make soak``):
``python bench/soak.py [--steps N] [--spatial] [--out bench/results]``.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import resource
import time
import warnings
from pathlib import Path

import numpy as np
import scipy
import sympy

import dalembert
from dalembert.multibody import chain

N_LINKS, ANGLE = 16, np.radians(30.0)
#: Steps per leg (about) and outputs per leg (evenly spaced, the leg's end included).
LEG_STEPS, LEG_OUTPUTS = 100_000, 20
#: What the run must keep: resident memory after the first tenth of the legs within
#: this many MB of the end (the first legs load code and fill caches), and position and
#: velocity residuals under this at every output.
MAX_GROWTH_MB, MAX_RESIDUAL = 5.0, 1e-10


def resident_mb() -> float:
    """The process's resident memory now (Linux: /proc/self/statm), in MB."""
    pages = int(Path("/proc/self/statm").read_text().split()[1])
    return pages * os.sysconf("SC_PAGE_SIZE") / 1e6


def build(spatial: bool):
    """The chain and its start: all links tilted by ANGLE in the x-z (3D) or x-y plane."""
    mb = chain(N_LINKS, 1.0, 1.0, 0.05, joint="spherical" if spatial else "revolute",
               planar=not spatial)
    names = [b.name for b in mb.bodies]
    if spatial:
        c, s = np.cos(ANGLE), np.sin(ANGLE)
        tilt = np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])
        q0, qd0 = mb.initial_state(
            positions={n: tilt @ [0, 0, -(k + 0.5)] for k, n in enumerate(names)},
            orientations=dict.fromkeys(names, tilt))
    else:
        q0, qd0 = mb.initial_state(
            positions={n: ((k + 0.5) * np.sin(ANGLE), -(k + 0.5) * np.cos(ANGLE))
                       for k, n in enumerate(names)},
            orientations=dict.fromkeys(names, ANGLE))
    return mb.system, q0, qd0


def rest_energy() -> float:
    """T + V of the chain hanging straight down at rest (unit masses, lengths, g = 9.81):
    link k's center is k - 1/2 below the pivot."""
    return -9.81 * sum(k + 0.5 for k in range(N_LINKS))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=float, default=1e7)
    parser.add_argument("--spatial", action="store_true", help="the 3D chain")
    parser.add_argument("--out", default=str(Path(__file__).parent / "results"))
    args = parser.parse_args()
    warnings.simplefilter("ignore", dalembert.InitialConditionsAdjusted)
    system, q0, qd0 = build(args.spatial)
    system.simulate((0.0, 1.0), q0, qd0)  # code and runtime built before the clock starts

    e_rest = rest_energy()
    t, q, qd = 0.0, q0, qd0
    steps = evaluations = 0
    residual = velocity_residual = drift = 0.0
    e0 = None
    legs, leg_s = [], 100.0
    before = resident_mb()
    start = time.perf_counter()
    while steps < args.steps:
        leg_s = leg_s * min(1.0, (args.steps - steps) / LEG_STEPS)
        t_end = t + leg_s
        traj = system.simulate((t, t_end), q, qd, t_eval=np.linspace(t, t_end, LEG_OUTPUTS + 1))
        assert traj.status == "finished", traj.message
        if e0 is None:
            e0 = traj.energy[0]
        leg_drift = np.abs(traj.energy - e0).max() / (e0 - e_rest)
        steps += traj.stats["n_steps"]
        evaluations += traj.stats["nfev"]
        residual = max(residual, float(traj.position_residual.max()))
        velocity_residual = max(velocity_residual, float(traj.velocity_residual.max()))
        drift = max(drift, float(leg_drift))
        t, q, qd = t_end, traj.q[-1], traj.qd[-1]
        legs.append({"t": round(t, 3), "steps": steps,
                     "wall_s": round(time.perf_counter() - start, 1),
                     "relative_energy_drift": float((traj.energy[-1] - e0) / (e0 - e_rest)),
                     "rss_mb": round(resident_mb(), 1)})
        print(json.dumps(legs[-1]), flush=True)
        # the next leg about LEG_STEPS steps long, at this leg's steps per simulated second
        leg_s = leg_s * LEG_STEPS / max(traj.stats["n_steps"], 1)
    wall = time.perf_counter() - start
    after = resident_mb()
    growth = after - legs[len(legs) // 10]["rss_mb"]
    failures = ([f"the resident memory grew by {growth:.1f} MB after the first tenth of "
                 f"the legs (at most {MAX_GROWTH_MB} allowed)"] if growth > MAX_GROWTH_MB
                else []) + \
        ([f"a constraint residual reached {max(residual, velocity_residual):.1e} (at most "
          f"{MAX_RESIDUAL:g} allowed)"] if max(residual, velocity_residual) > MAX_RESIDUAL
         else [])

    record = {
        "workload": f"multibody.chain({N_LINKS}, 1.0, 1.0, 0.05), "
                    + ("3D, spherical joints" if args.spatial else "planar, revolute pins")
                    + f", tilted {np.degrees(ANGLE):.0f} degrees, released from rest",
        "method": "DOP853, projection, default tolerances (rtol 1e-11, atol 1e-13), C loop; "
                  f"legs of about {LEG_STEPS} steps, each from the last one's end",
        "loop": system.plan((0.0, 1.0), q0, qd0).loop,
        "simulated_s": round(t, 3), "steps": steps, "evaluations": evaluations,
        "legs": len(legs), "wall_s": round(wall, 1), "steps_per_s": round(steps / wall),
        "max_position_residual": residual, "max_velocity_residual": velocity_residual,
        "max_relative_energy_drift": drift,
        "final_relative_energy_drift": legs[-1]["relative_energy_drift"],
        "rss_mb_before": round(before, 1), "rss_mb_after": round(after, 1),
        "max_rss_mb": round(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024 / 1e6, 1),
        "rss_growth_mb_after_first_tenth": round(growth, 1), "passed": not failures,
        "machine": {"python": platform.python_version(), "platform": platform.platform(),
                    "cpus": os.cpu_count(), "dalembert": dalembert.__version__,
                    "numpy": np.__version__, "scipy": scipy.__version__,
                    "sympy": sympy.__version__},
        "legs_record": legs,
    }
    print(json.dumps({k: v for k, v in record.items() if k != "legs_record"}, indent=2))
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    path = out / "soak.json"
    path.write_text(json.dumps(record, indent=2) + "\n")
    print(f"wrote {path}")
    if failures:
        raise SystemExit("soak failed: " + "; ".join(failures))


if __name__ == "__main__":
    main()
