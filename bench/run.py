"""Benchmark: dalembert against the SymPy path users would otherwise take.

Workload: a planar chain of ``n`` point masses joined by rigid massless rods and
hung from a fixed pivot, released from rest at 30 degrees, simulated for
``T_END`` seconds.

- dalembert: Cartesian coordinates (2n) with n rod constraints; build (derive +
  generate code) and simulate with projection, default tolerances.
- SymPy: minimal (absolute angle) coordinates with ``LagrangesMethod``, then
  ``lambdify`` of the mass matrix and forcing, and ``solve_ivp`` (DOP853) solving
  ``M qdd = f`` at every evaluation, at the same tolerances.

Both are measured in the same run on the same machine; the JSON records build
and simulation seconds, evaluations, the energy error reached and versions.
Ratios, not absolute times, are what to compare on a shared machine.

Usage: ``python bench/run.py [--quick] [--out bench/results]``.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import time
from pathlib import Path

import numpy as np
import scipy
import sympy as sp
from scipy.integrate import solve_ivp
from sympy.physics.mechanics import LagrangesMethod, dynamicsymbols

import dalembert
from dalembert import Holonomic, System

T_END = 10.0
RTOL, ATOL = 1e-11, 1e-13
G, L, M = 9.81, 1.0, 1.0
ANGLE = np.radians(30.0)


def dalembert_chain(n: int) -> dict:
    xs = dynamicsymbols(f"x1:{n + 1}")
    ys = dynamicsymbols(f"y1:{n + 1}")
    start = time.perf_counter()
    kinetic = sum(M / 2 * (x.diff() ** 2 + y.diff() ** 2) for x, y in zip(xs, ys))
    potential = sum(M * G * y for y in ys)
    rods = [Holonomic(xs[0] ** 2 + ys[0] ** 2 - L**2, name="rod1")]
    rods += [
        Holonomic((xs[i] - xs[i - 1]) ** 2 + (ys[i] - ys[i - 1]) ** 2 - L**2, name=f"rod{i + 1}")
        for i in range(1, n)
    ]
    system = System([*xs, *ys], kinetic=kinetic, potential=potential, constraints=rods)
    system.compiled  # derive and generate code now  # noqa: B018
    build_s = time.perf_counter() - start
    k = np.arange(1, n + 1)
    q0 = np.concatenate([k * L * np.sin(ANGLE), -k * L * np.cos(ANGLE)])
    start = time.perf_counter()
    traj = system.simulate((0.0, T_END), q0, np.zeros(2 * n), rtol=RTOL, atol=ATOL)
    simulate_s = time.perf_counter() - start
    e = traj.energy
    return {
        "tool": "dalembert", "n": n, "build_s": build_s, "simulate_s": simulate_s,
        "evaluations": traj.stats["nfev"],
        "energy_error": float(np.abs(e - e[0]).max() / np.abs(e).max()),
        "residual": float(traj.position_residual.max()),
    }


def sympy_chain(n: int) -> dict:
    th = dynamicsymbols(f"th1:{n + 1}")
    thd = [a.diff() for a in th]
    start = time.perf_counter()
    x = y = 0
    kinetic = potential = 0
    for a in th:
        x, y = x + L * sp.sin(a), y - L * sp.cos(a)
        kinetic += M / 2 * (x.diff() ** 2 + y.diff() ** 2)
        potential += M * G * y
    lm = LagrangesMethod(kinetic - potential, th)
    lm.form_lagranges_equations()
    mass = sp.lambdify([th, thd], lm.mass_matrix, cse=True)
    forcing = sp.lambdify([th, thd], lm.forcing, cse=True)
    energy = sp.lambdify([th, thd], kinetic + potential, cse=True)
    build_s = time.perf_counter() - start

    def rhs(_t: float, s: np.ndarray) -> np.ndarray:
        q, qd = s[:n], s[n:]
        qdd = np.linalg.solve(mass(q, qd), np.asarray(forcing(q, qd), dtype=float).ravel())
        return np.concatenate([qd, qdd])

    start = time.perf_counter()
    sol = solve_ivp(rhs, (0.0, T_END), np.r_[np.full(n, ANGLE), np.zeros(n)],
                    method="DOP853", rtol=RTOL, atol=ATOL)
    simulate_s = time.perf_counter() - start
    e = np.array([energy(s[:n], s[n:]) for s in sol.y.T])
    return {
        "tool": "sympy-lagrange-minimal", "n": n, "build_s": build_s,
        "simulate_s": simulate_s, "evaluations": int(sol.nfev),
        "energy_error": float(np.abs(e - e[0]).max() / np.abs(e).max()), "residual": 0.0,
    }


def machine() -> dict:
    return {"python": platform.python_version(), "platform": platform.platform(),
            "cpus": os.cpu_count(), "dalembert": dalembert.__version__,
            "sympy": sp.__version__, "numpy": np.__version__, "scipy": scipy.__version__}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="small sizes only")
    parser.add_argument("--out", default=str(Path(__file__).parent / "results"))
    args = parser.parse_args()
    sizes = [1, 2, 4] if args.quick else [1, 2, 4, 8]
    records = []
    for n in sizes:
        for run in (dalembert_chain, sympy_chain):
            record = run(n)
            records.append(record)
            print(json.dumps(record))
    for n in sizes:
        ours, theirs = (next(r for r in records if r["n"] == n and r["tool"] == tool)
                        for tool in ("dalembert", "sympy-lagrange-minimal"))
        total = (theirs["build_s"] + theirs["simulate_s"]) / (ours["build_s"] + ours["simulate_s"])
        print(f"n={n}: sympy/dalembert end-to-end time ratio {total:.2f}")
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    path = out / "planar_chain.json"
    path.write_text(json.dumps({"machine": machine(), "records": records}, indent=2))
    print(f"wrote {path}")


if __name__ == "__main__":
    main()
