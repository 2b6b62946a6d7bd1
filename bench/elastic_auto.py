"""The elastic pendulum: ``method="auto"`` against DOP853 and Radau, k = 1e3 ... 1e8.

Workload: the stiff elastic pendulum of ``tests/solvers/test_elastic_pendulum.py`` (a
bob on a spring of stiffness ``k`` from a fixed point, held on an inclined plane: three
Cartesian coordinates and one constraint; it starts on the spring's static length, so
the fast radial mode is only excited by the swing), 2 s, each method at the same
``rtol = 1e-8`` (``atol = 1e-10``), the end position's error against its
polar-coordinate model integrated by SciPy's DOP853 at rtol 1e-11 (k <= 1e6; at
k >= 1e7 that takes minutes, and DOP853 in C at rtol 1e-12 is the reference). The runs
are timed in interleaved rounds, every method once per round, and the fastest round's
CPU seconds (``time.process_time``) kept with the run's steps, evaluations and switches.

Usage: ``python bench/elastic_auto.py [--rounds R]``. Writes
``bench/results/elastic_auto.json``.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))
sys.path.insert(0, str(HERE.parent / "tests" / "solvers"))

from test_elastic_pendulum import T_END, TH0, build, cartesian, polar, r0  # noqa: E402

from bench.suite import machine  # noqa: E402

STIFFNESSES = (1e3, 1e4, 1e5, 1e6, 1e7, 1e8)
METHODS = ("DOP853", "Radau", "auto")
OPTIONS = {"rtol": 1e-8, "atol": 1e-10, "t_eval": [T_END]}


def end_of(traj) -> np.ndarray:
    return np.array([traj[c][-1] for c in ("x", "y", "z")])


def exact_end(system, q0: dict, t_end: float = T_END) -> np.ndarray:
    """The end position by DOP853 in C at rtol 1e-12 (where the polar model is slow)."""
    return end_of(system.simulate((0.0, t_end), q0, method="DOP853", rtol=1e-12,
                                  atol=1e-14, t_eval=[t_end]))


def reference_end(k: float, system, q0: dict) -> np.ndarray:
    """The end position at ``T_END`` to measure against (see the module)."""
    return cartesian(*polar(k)) if k <= 1e6 else exact_end(system, q0)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=9)
    args = parser.parse_args()
    results: dict[str, object] = {"machine": machine(), "rounds": args.rounds,
                                  "options": {"rtol": 1e-8, "atol": 1e-10}, "rows": {}}
    for k in STIFFNESSES:
        system = build(k)
        q0 = dict(zip(("x", "y", "z"), cartesian(r0(k), TH0)))
        reference = reference_end(k, system, q0)
        best = dict.fromkeys(METHODS, float("inf"))
        row: dict[str, dict[str, float]] = {}
        for method in METHODS:  # compiled and warmed up
            system.simulate((0.0, T_END), q0, method=method, **OPTIONS)
        for _ in range(args.rounds):
            for method in METHODS:
                start = time.process_time()
                traj = system.simulate((0.0, T_END), q0, method=method, **OPTIONS)
                best[method] = min(best[method], time.process_time() - start)
                row[method] = {"error": float(np.abs(end_of(traj) - reference).max()),
                               "steps": traj.stats["n_steps"], "nfev": traj.stats["nfev"],
                               "switches": traj.stats.get("n_switches", 0)}
        for method in METHODS:
            row[method]["cpu_s"] = best[method]
        better = min(best["DOP853"], best["Radau"])
        row["auto_over_better"] = {"ratio": best["auto"] / better}
        results["rows"][f"{k:g}"] = row  # type: ignore[index]
        print(f"k={k:g}: " + ", ".join(
            f"{m} {best[m]:.4f} s ({row[m]['steps']} steps, err {row[m]['error']:.1e})"
            for m in METHODS) + f"; auto / better {best['auto'] / better:.2f}", flush=True)
    out = HERE / "results" / "elastic_auto.json"
    out.write_text(json.dumps(results, indent=1))
    print(f"wrote {out}")


if __name__ == "__main__":
    main()
