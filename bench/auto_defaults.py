"""``method="auto"`` at the default tolerances, against DOP853 and Radau at theirs.

``auto`` is the default method, so its runs without ``rtol`` are the ones most users
make: DOP853 at rtol 1e-11 until a switch, Radau at 1e-8 after it. Each method runs at
its own defaults (no ``rtol``, ``atol``), ``t_eval`` the end only, on:

- the **flyball governor** (IFToMM A05, the gallery's example), 10 s: error of the
  sleeve height ``s(10)`` against the benchmark's minimal-coordinate reference;
- the **elastic pendulum** of ``tests/solvers/test_elastic_pendulum.py``, k = 1e3 ...
  1e8, 2 s: the end position against its polar-coordinate model (SciPy DOP853, rtol
  1e-11; at k >= 1e7 dalembert's DOP853 in C at rtol 1e-12, as ``bench/elastic_auto.py``);
  and the same pendulum whose spring softens from 1e8 to 50 N/m around t = 1
  (``softening`` there), 10 s, against DOP853 in C at rtol 1e-12: stiff, then not;
- the **16-link spring chain** of ``bench/stiff.py``, k = 1e2 ... 1e8, 10 s: the links'
  angles against its minimal-coordinate reference (``bench/stiff_chain.py``);
- the gallery's **slider-crank over 100 s**, not stiff but long enough for a probe:
  ``auto``'s run against DOP853's, state for state (``same``).

The model's code is generated and each method run once before any timing. Runs are
timed in interleaved rounds (every method of a workload once a round), CPU seconds
(``time.process_time``) beside wall seconds, the fastest round kept; a run over
``--long`` seconds is not repeated. A run is stopped after ``--cap`` seconds (wall), and
reported as such.

Usage: ``python bench/auto_defaults.py [--rounds R] [--cap S] [--long S]``. Writes
``bench/results/auto_defaults.json``.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
import warnings
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))
sys.path.insert(0, str(HERE.parent / "tests" / "solvers"))

from test_elastic_pendulum import T_END as ELASTIC_END  # noqa: E402
from test_elastic_pendulum import TH0, cartesian, r0, softening  # noqa: E402
from test_elastic_pendulum import build as elastic_pendulum  # noqa: E402

from bench import stiff_chain as sc  # noqa: E402
from bench.elastic_auto import end_of, exact_end, reference_end  # noqa: E402
from bench.stiff import dalembert_chain, reference_angles  # noqa: E402
from bench.suite import machine  # noqa: E402

METHODS = ("auto", "DOP853", "Radau")
OUT = HERE / "results" / "auto_defaults.json"
SOFTENING_END = 10.0

#: ``(run, error)``: ``run(method, timeout)`` one run of a workload to its end,
#: ``error(traj)`` the error of one that got there.
Run = tuple[Callable[[str, float], Any], Callable[[Any], float]]


def flyball() -> Run:
    from dalembert.examples import flyball_governor as ex

    system = ex.build()

    def run(method: str, timeout: float):
        return system.simulate((0.0, ex.T_END), **ex.INITIAL, method=method,
                               t_eval=[ex.T_END], timeout=timeout)
    return run, lambda traj: float(abs(traj["sleeve_z"][-1] - ex.S_REFERENCE))


def elastic(k: float, let_go: bool = False) -> Run:
    system = softening(k) if let_go else elastic_pendulum(k)
    t_end = SOFTENING_END if let_go else ELASTIC_END
    q0 = dict(zip(("x", "y", "z"), cartesian(r0(k), TH0)))
    reference = exact_end(system, q0, t_end) if let_go else reference_end(k, system, q0)

    def run(method: str, timeout: float):
        return system.simulate((0.0, t_end), q0, method=method, t_eval=[t_end],
                               timeout=timeout)
    return run, lambda traj: float(np.abs(end_of(traj) - reference).max())


def spring_chain(k: float) -> Run:
    mb, q0, qd0, names = dalembert_chain(k, sc.damping_for(k)["c"])
    reference = reference_angles(k)

    def run(method: str, timeout: float):
        return mb.simulate((0.0, sc.T_END), q0, qd0, method=method, t_eval=[sc.T_END],
                           timeout=timeout)

    def error(traj) -> float:
        phi = -np.array([traj[f"{n}_theta"][-1] for n in names])
        return float(np.abs(phi - reference).max())
    return run, error


def slider_crank() -> Run:
    from dalembert.examples import slider_crank as ex

    system = ex.build()
    span = (0.0, 10 * ex.T_END)
    explicit = system.simulate(span, **ex.INITIAL, method="DOP853")

    def run(method: str, timeout: float):
        return system.simulate(span, **ex.INITIAL, method=method, timeout=timeout)

    def error(traj) -> float:  # 0 where the run is DOP853's, state for state
        same = traj.q.shape == explicit.q.shape and bool(np.array_equal(traj.q, explicit.q))
        return 0.0 if same else float("nan")
    return run, error


WORKLOADS: dict[str, Callable[[], Run]] = {
    "flyball governor": flyball,
    **{f"elastic pendulum k={k:g}": (lambda k=k: elastic(k))
       for k in (1e3, 1e4, 1e5, 1e6, 1e7, 1e8)},
    "softening pendulum k=1e8 to 50": lambda: elastic(1e8, let_go=True),
    **{f"16-link chain k={k:g}": (lambda k=k: spring_chain(k))
       for k in (1e2, 1e4, 1e6, 1e8)},
    "slider-crank 100 s": slider_crank,
}


def record(traj, error: float, cpu: float, wall: float) -> dict:
    stats = traj.stats
    return {"cpu_s": cpu, "wall_s": wall, "error": error, "finished": traj.status == "finished",
            "t_reached": float(traj.t[-1]) if len(traj.t) else 0.0,
            **{key: int(stats[key]) for key in ("n_steps", "nfev", "njev", "nlu",
                                                   "n_switches", "n_probes") if key in stats}}


def measure(workload: Run, rounds: int, cap: float, long: float) -> dict:
    run, error = workload
    rows: dict[str, dict] = {}
    for method in METHODS:  # the method's own code generated and compiled (the run cut short)
        run(method, 2.0)
    for _ in range(rounds):
        for method in METHODS:
            if method in rows and (rows[method]["cpu_s"] > long or not rows[method]["finished"]):
                continue
            cpu, wall = time.process_time(), time.perf_counter()
            traj = run(method, cap)
            cpu, wall = time.process_time() - cpu, time.perf_counter() - wall
            if method not in rows or cpu < rows[method]["cpu_s"]:
                ended = traj.status == "finished"  # (else stopped at the cap)
                rows[method] = record(traj, error(traj) if ended else float("nan"), cpu,
                                      wall)
    better = min(rows["DOP853"]["cpu_s"], rows["Radau"]["cpu_s"])
    rows["auto_over_better"] = {"ratio": rows["auto"]["cpu_s"] / better}
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--cap", type=float, default=120.0, help="seconds a run may take")
    parser.add_argument("--long", type=float, default=10.0,
                        help="CPU seconds above which a run is not repeated")
    parser.add_argument("--only", nargs="*", help="workloads whose name starts so")
    args = parser.parse_args()
    results: dict = {"machine": machine(), "rounds": args.rounds, "cap_s": args.cap,
                     "rows": json.loads(OUT.read_text())["rows"] if args.only and OUT.exists()
                     else {}}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for name, make in WORKLOADS.items():
            if args.only and not any(name.startswith(o) for o in args.only):
                continue
            rows = measure(make(), args.rounds, args.cap, args.long)
            results["rows"][name] = rows
            print(f"{name}: " + ", ".join(
                f"{m} {rows[m]['cpu_s']:.3f} s ({rows[m]['n_steps']} steps, "
                f"err {rows[m]['error']:.1e}{'' if rows[m]['finished'] else ', stopped'})"
                for m in METHODS) + f"; auto / better {rows['auto_over_better']['ratio']:.2f}",
                flush=True)
            OUT.write_text(json.dumps(results, indent=1))
    print(f"wrote {OUT}")


if __name__ == "__main__":
    main()
