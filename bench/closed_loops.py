"""Benchmark: a closed loop with dependent constraint rows, in the C loop.

Workload: :func:`dalembert.multibody.ring`, six rods (0.5 m, 1 kg, r = 2 cm) closed
into a hexagon hung from one vertex, tilted 0.6 rad and turning at 1 rad/s about the
pivot's hinge axis (:func:`~dalembert.multibody.ring_state`), 10 s simulated at the
default tolerances with 101 outputs. Two rings swing the same planar motion:

- ``revolute``: 3D hinges (axes along y) close a planar loop, so 3 of the 42 rows are
  combinations of the others; the kept rows are solved in the C loop and the
  minimum-norm multipliers reported;
- ``spherical``: ball joints, all rows independent (the reference cost).

Each ring runs in the C loop and in the Python loop, best of ``--repeats`` (the
compiled code warm). The JSON records the seconds, the steps and evaluations, the
ratio revolute / spherical in C (the target: within 2x) and the largest difference
between the two loops' positions over the first 1.5 s (the same trajectory to 1e-10;
the motion is chaotic, and later the loops' rounding differences have grown).

Usage: ``python bench/closed_loops.py [--repeats 5] [--out bench/results]``.
"""

from __future__ import annotations

import argparse
import json
import platform
import time
import warnings
from pathlib import Path

import numpy as np

from dalembert.multibody import ring, ring_state

N, LENGTH, MASS, RADIUS, T_END = 6, 0.5, 1.0, 0.02, 10.0


def run(joint: str, backend: str, repeats: int) -> dict[str, object]:
    mb = ring(N, LENGTH, MASS, RADIUS, joint=joint)
    q0, qd0 = ring_state(mb, N, LENGTH)
    times = np.linspace(0.0, T_END, 101)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the dependent rows are reported by a warning
        mb.simulate((0.0, 0.1), q0, qd0, backend=backend)  # build and compile first
        seconds, traj = [], None
        for _ in range(repeats):
            start = time.perf_counter()
            traj = mb.simulate((0.0, T_END), q0, qd0, t_eval=times, backend=backend)
            seconds.append(time.perf_counter() - start)
    assert traj is not None
    return {"seconds": min(seconds), "all_seconds": seconds,
            "n_steps": traj.stats["n_steps"], "nfev": traj.stats["nfev"],
            "position_residual": float(traj.position_residual.max()),
            "energy_change": float(np.ptp(traj.energy) / abs(traj.energy[0])), "q": traj.q}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--out", type=Path, default=Path(__file__).parent / "results")
    args = parser.parse_args()
    records = {(joint, backend): run(joint, backend, args.repeats)
               for joint in ("revolute", "spherical") for backend in ("c", "python")}
    summary = {
        "revolute_over_spherical_c": records["revolute", "c"]["seconds"]
        / records["spherical", "c"]["seconds"],
        "python_over_c_revolute": records["revolute", "python"]["seconds"]
        / records["revolute", "c"]["seconds"],
        "loops_max_position_difference_1_5_s": float(np.abs(
            records["revolute", "c"]["q"][:16] - records["revolute", "python"]["q"][:16]).max()),
    }
    out = {"machine": platform.platform(), "python": platform.python_version(),
           "workload": {"rods": N, "length": LENGTH, "mass": MASS, "radius": RADIUS,
                        "t_end": T_END, "outputs": 101},
           "summary": summary,
           "records": [{"joint": j, "backend": b, **{k: v for k, v in r.items() if k != "q"}}
                       for (j, b), r in records.items()]}
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "closed_loops.json").write_text(json.dumps(out, indent=2))
    print(json.dumps(summary, indent=2))


if __name__ == "__main__":
    main()
