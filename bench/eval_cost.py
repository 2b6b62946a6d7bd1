"""Benchmark: cost of one right-hand-side evaluation and of a simulation vs mechanism size.

Workload: ``dalembert.multibody.chain(n, 1.0, 1.0, 0.05)`` (1 kg, 1 m, radius 5 cm
cylinders on spherical joints, ``7 n`` coordinates, ``4 n`` constraints), every
link tilted 30 degrees in the x-z plane, the whole chain turning at 0.1 rad/s
about the vertical (a small out-of-plane velocity), simulated for 10 s with
DOP853 at ``rtol=1e-8, atol=1e-10`` (enough for the target: relative energy
error <= 1e-6, constraint residual <= 1e-10, both recorded).

For each ``n``, in a fresh process: the build time (derive + generate; the C
library comes from the disk cache when present, ``cold`` says whether it was
compiled), then the microseconds of one call of each per-evaluation stage (best
of several timed batches, since the machine is shared):

- ``values``: the generated code (``kkt_sparse``: M and A values, f, c),
- ``solve``: the KKT solve on the path chosen for this pattern (``band``: LAPACK band
  LU in reverse Cuthill-McKee order; ``dense`` and ``splu`` are timed too, for the
  record),
- ``rhs``: one full right-hand side ``F(t, y)`` as the Python loop calls it,
- ``project``: one projection of a perturbed state (positions and velocities),
- ``native_rhs``, ``native_project``: the same in the C loop
  (:mod:`dalembert.solvers.native`; its block/Schur solve instead of the band LU),

and the simulation's wall time, steps, evaluations and errors, in the C loop (the
default) and in the Python loop (``simulate_python_s``). ``baseline``
holds the per-evaluation times before this work (commit 2665f48, NumPy code,
dense KKT and lstsq projection, OpenBLAS default threads).

Usage: ``python bench/eval_cost.py [--sizes 2 4 8 16 32 64] [--t-end 10] [--out bench/results]``.
"""

from __future__ import annotations

import argparse
import json
import platform
import subprocess
import sys
import time
from pathlib import Path

#: Microseconds per call at commit 2665f48 (same machine, shared, default BLAS threads).
BASELINE = {
    2: {"values": 67, "solve": 30, "rhs": 137, "project": 330},
    4: {"values": 167, "solve": 69, "rhs": 263, "project": 493},
    16: {"values": 635, "solve": 81709, "rhs": 80564, "project": 2569},
    "note": "16-link chain, 20 s at the default tolerances (rtol 1e-11): ~1000 s wall, "
            "3252 steps; the dense 176 x 176 KKT solve hit OpenBLAS thread contention",
}


def workload(n: int, tilt_deg: float = 30.0, spin: float = 0.1):
    """``(system, q0, qd0)`` of the standard chain workload."""
    import numpy as np

    from dalembert.multibody import chain

    mb = chain(n, 1.0, 1.0, 0.05)
    tilt = np.radians(tilt_deg)
    down = np.array([np.sin(tilt), 0.0, -np.cos(tilt)])
    side = np.array([0.0, 1.0, 0.0])
    R = np.column_stack([np.cross(side, -down), side, -down])  # body z along the link, up
    w = np.array([0.0, 0.0, spin])
    top = np.zeros(3)
    pos, ori, vel, rates = {}, {}, {}, {}
    for link in mb.bodies:
        center = top + down / 2
        pos[link], ori[link], vel[link], rates[link] = center, R, np.cross(w, center), w
        top = top + down
    q0, qd0 = mb.initial_state(pos, ori, vel, rates)
    return mb.system, q0, qd0


def best_time(fn, batches: int = 5, seconds: float = 0.15) -> float:
    """Microseconds per call: the best of ``batches`` batches (shared machine)."""
    fn()
    best = float("inf")
    for _ in range(batches):
        count, start = 0, time.perf_counter()
        while time.perf_counter() - start < seconds:
            fn()
            count += 1
        best = min(best, (time.perf_counter() - start) / count)
    return 1e6 * best


def measure(n: int, t_end: float, rtol: float, atol: float) -> dict:
    """All numbers for one ``n`` (call in a fresh process)."""
    import warnings

    import numpy as np

    from dalembert.codegen import c_backend
    from dalembert.solvers.dynamics import first_order_rhs
    from dalembert.solvers.kkt.sparse import KKTSolver
    from dalembert.solvers.native import native_solver
    from dalembert.solvers.projection import StepProjector

    warnings.simplefilter("ignore")
    system, q0, qd0 = workload(n)
    libs = set((c_backend.cache_dir() / "c").glob("*.so"))
    start = time.perf_counter()
    num = system.numeric()
    build = time.perf_counter() - start
    cold = set((c_backend.cache_dir() / "c").glob("*.so")) != libs
    report = system.consistent_initial_state(q0, qd0)
    q, qd = report.q, report.qd
    y = np.concatenate([q, qd])
    blocks = num.kkt_sparse(0.0, q, qd)
    rhs = first_order_rhs(num)
    project = StepProjector(num)
    chosen = KKTSolver(num.pattern)
    dense, splu = KKTSolver(num.pattern, dense=True), KKTSolver(num.pattern, dense=False)
    row = {
        "n": n, "coordinates": num.n, "constraints": num.m, "backend": num.compiled.backend,
        "build_s": build, "cold_compile": cold, "solve_path": chosen.method,
        "values_us": best_time(lambda: num.kkt_sparse(0.0, q, qd)),
        "solve_us": best_time(lambda: chosen.accelerations(*blocks)),
        "dense_solve_us": best_time(lambda: dense.accelerations(*blocks))
        if num.n + num.m < 1200 else None,
        "splu_solve_us": best_time(lambda: splu.accelerations(*blocks)),
        "rhs_us": best_time(lambda: rhs(0.0, y)),
        "project_us": best_time(lambda: project(0.0, y + 1e-9)),
    }
    native = native_solver(num, y)
    row.update(native_rhs_us=best_time(lambda: native.rhs(0.0, y)),
               native_project_us=best_time(lambda: native.project(0.0, y + 1e-9)))
    start = time.perf_counter()
    system.simulate((0.0, t_end), q0, qd0, rtol=rtol, atol=atol, backend="python")
    row["simulate_python_s"] = time.perf_counter() - start
    start = time.perf_counter()
    traj = system.simulate((0.0, t_end), q0, qd0, rtol=rtol, atol=atol)
    E = traj.energy
    row.update({
        "t_end": t_end, "rtol": rtol, "atol": atol, "simulate_s": time.perf_counter() - start,
        "status": traj.status, "steps": traj.stats.get("n_steps"), "nfev": traj.stats.get("nfev"),
        "energy_rel_error": float(np.abs(E - E[0]).max() / max(abs(E[0]), 1.0)),
        "position_residual": float(traj.position_residual.max()),
        "velocity_residual": float(traj.velocity_residual.max()),
    })
    row["us_per_eval_in_run"] = 1e6 * row["simulate_s"] / max(row["nfev"] or 1, 1)
    return row


def run(sizes: list[int], t_end: float, rtol: float, atol: float) -> list[dict]:
    rows = []
    for n in sizes:
        out = subprocess.run(
            [sys.executable, __file__, "--one", str(n), "--t-end", str(t_end),
             "--rtol", str(rtol), "--atol", str(atol)],
            capture_output=True, text=True, check=True)
        row = json.loads(out.stdout.strip().splitlines()[-1])
        rows.append(row)
        print(f"n={n:4d}  build {row['build_s']:6.1f} s  values {row['values_us']:7.1f} us  "
              f"solve[{row['solve_path']}] {row['solve_us']:7.1f} us  rhs {row['rhs_us']:7.1f} us  "
              f"project {row['project_us']:7.1f} us  C loop: rhs {row['native_rhs_us']:6.1f} us "
              f"project {row['native_project_us']:6.1f} us  "
              f"simulate {row['simulate_s']:7.2f} s "
              f"(Python loop {row['simulate_python_s']:7.2f} s) "
              f"({row['steps']} steps)  dE/E {row['energy_rel_error']:.1e}  "
              f"residual {row['position_residual']:.1e}", flush=True)
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=[2, 4, 8, 16, 32, 64])
    parser.add_argument("--t-end", type=float, default=10.0)
    parser.add_argument("--rtol", type=float, default=1e-8)
    parser.add_argument("--atol", type=float, default=1e-10)
    parser.add_argument("--out", type=Path, default=Path(__file__).parent / "results")
    parser.add_argument("--one", type=int, help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.one:
        print(json.dumps(measure(args.one, args.t_end, args.rtol, args.atol)))
        return
    rows = run(args.sizes, args.t_end, args.rtol, args.atol)
    args.out.mkdir(parents=True, exist_ok=True)
    result = {"workload": __doc__.split("\n\n")[1].replace("\n", " "), "machine":
              platform.platform(), "python": platform.python_version(), "rows": rows,
              "baseline": {str(k): v for k, v in BASELINE.items()}}
    (args.out / "eval_cost.json").write_text(json.dumps(result, indent=2) + "\n")


if __name__ == "__main__":
    main()
