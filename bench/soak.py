"""Soak test: ten million steps of a 16-link chain in one simulation (not run in CI).

Workload: ``dalembert.multibody.chain(16, 1.0, 1.0, 0.05)``, planar (revolute pins,
``PlanarBody`` links: 48 coordinates, 32 constraint rows; ``--spatial`` for the 3D
chain of spherical joints and quaternion bodies), every link tilted 30 degrees
and released from rest; DOP853 with projection at the default tolerances, the
whole loop in C. A short calibration run gives the steps per simulated second;
the soak then simulates long enough for ``--steps`` steps (default 1e7) in one
``simulate`` call, with outputs at 2001 evenly spaced times, and reports:

- the largest position and velocity constraint residuals at the outputs;
- the energy drift, ``max |E(t) - E(0)| / (E(0) - E_rest)`` (the chain is
  conservative: T + V is constant) and its value at the end;
- the resident memory before and after the run, and sampled every few seconds
  during it (a leak would make it grow with the steps);
- steps per second.

It writes ``bench/results/soak.json``. Usage:
``python bench/soak.py [--steps N] [--spatial] [--out bench/results]``.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import resource
import threading
import time
import warnings
from pathlib import Path

import numpy as np
import scipy
import sympy

import dalembert
from dalembert.multibody import chain

N_LINKS, ANGLE = 16, np.radians(30.0)
OUTPUTS = 2001
#: Seconds between two samples of the resident memory during the run.
SAMPLE_EVERY = 5.0


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

    calibration = system.simulate((0.0, 20.0), q0, qd0, t_eval=[20.0])
    per_second = calibration.stats["n_steps"] / 20.0
    t_end = float(np.ceil(args.steps / per_second))
    print(f"{per_second:.1f} steps per simulated second: simulating {t_end:.0f} s")

    samples: list[tuple[float, float]] = []
    done = threading.Event()
    start = time.perf_counter()

    def sample() -> None:  # the C loop releases the GIL between and inside its calls
        while not done.wait(SAMPLE_EVERY):
            samples.append((round(time.perf_counter() - start, 1), round(resident_mb(), 1)))

    before = resident_mb()
    sampler = threading.Thread(target=sample, daemon=True)
    sampler.start()
    start = time.perf_counter()
    traj = system.simulate((0.0, t_end), q0, qd0, t_eval=np.linspace(0.0, t_end, OUTPUTS))
    wall = time.perf_counter() - start
    done.set()
    sampler.join()
    after = resident_mb()

    e_rest = rest_energy()
    drift = (traj.energy - traj.energy[0]) / (traj.energy[0] - e_rest)
    steps = traj.stats["n_steps"]
    record = {
        "workload": f"multibody.chain({N_LINKS}, 1.0, 1.0, 0.05), "
                    + ("3D, spherical joints" if args.spatial else "planar, revolute pins")
                    + f", tilted {np.degrees(ANGLE):.0f} degrees, released from rest",
        "method": "DOP853, projection, default tolerances (rtol 1e-11, atol 1e-13), C loop",
        "loop": system.plan((0.0, 1.0), q0, qd0).loop,
        "status": traj.status, "simulated_s": t_end, "steps": steps,
        "evaluations": traj.stats["nfev"], "wall_s": round(wall, 1),
        "steps_per_s": round(steps / wall),
        "max_position_residual": float(traj.position_residual.max()),
        "max_velocity_residual": float(traj.velocity_residual.max()),
        "max_relative_energy_drift": float(np.abs(drift).max()),
        "final_relative_energy_drift": float(drift[-1]),
        "rss_mb_before": round(before, 1), "rss_mb_after": round(after, 1),
        "rss_mb_samples": samples,
        "max_rss_mb": round(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024 / 1e6, 1),
        "machine": {"python": platform.python_version(), "platform": platform.platform(),
                    "cpus": os.cpu_count(), "dalembert": dalembert.__version__,
                    "numpy": np.__version__, "scipy": scipy.__version__,
                    "sympy": sympy.__version__},
    }
    print(json.dumps({k: v for k, v in record.items() if k != "rss_mb_samples"}, indent=2))
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    path = out / "soak.json"
    path.write_text(json.dumps(record, indent=2) + "\n")
    print(f"wrote {path}")


if __name__ == "__main__":
    main()
