"""The stiff chain's ``auto`` against DOP853 and Radau in interleaved timing rounds.

Workload: ``bench/stiff.py``'s 16-link spring chain (``bench/stiff_chain.py``), each
of dalembert's DOP853, Radau and ``auto`` at the coarsest ``rtol`` meeting 1e-3 and
1e-6 rad that ``bench/stiff.py`` found (read from its result files: DOP853 and Radau
from ``--settings``, ``auto`` from ``--auto``; no bisection here). For each ``k`` the
runs are timed in rounds, every method and target once per round, and the fastest
round's CPU seconds (``time.process_time``) kept with the run's counts (steps,
evaluations, Jacobians, LU factorizations, switches) and angle error. The rounds are
interleaved so that the load of a shared machine falls on all methods alike. DOP853
at k = 1e8 is left out (its run takes seconds; the result files hold it).

Usage: ``python bench/stiff_interleaved.py [--rounds R] [--k K ...]``. Writes
``bench/results/stiff_interleaved.json``.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))

from bench import stiff_chain as sc  # noqa: E402
from bench.stiff import TARGETS, prepare_dalembert, reference_angles  # noqa: E402
from bench.suite import machine  # noqa: E402

METHODS = ("DOP853", "Radau", "auto")


def settings(path: Path, method: str) -> dict[tuple[float, str], float]:
    """``(k, target) -> rtol`` of ``dalembert-<method>`` in a ``bench/stiff.py`` result."""
    found = {}
    for record in json.loads(path.read_text())["records"]:
        if record["tool"] != f"dalembert-{method}":
            continue
        for target, got in record.get("targets", {}).items():
            if got.get("setting"):
                found[(record["k"], target)] = got["setting"]["rtol"]
    return found


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--k", type=float, nargs="+", default=list(sc.STIFFNESSES))
    parser.add_argument("--rounds", type=int, default=7)
    parser.add_argument("--settings", type=Path, default=HERE / "results" / "stiff_c.json")
    parser.add_argument("--auto", type=Path, default=HERE / "results" / "stiff_auto_retry.json")
    parser.add_argument("--out", type=Path, default=HERE / "results" / "stiff_interleaved.json")
    args = parser.parse_args()
    chosen = {m: settings(args.auto if m == "auto" else args.settings, m) for m in METHODS}
    started, cells = time.time(), []
    for k in args.k:
        ref, c = reference_angles(k), sc.damping_for(k)["c"]
        runs = [(m, f"{t:g}", chosen[m][(k, f"{t:g}")]) for t in TARGETS for m in METHODS
                if (k, f"{t:g}") in chosen[m] and not (m == "DOP853" and k >= 1e8)]
        attempts = {m: prepare_dalembert(m, k, c, ref).attempt for m in {r[0] for r in runs}}
        best: dict[tuple[str, str], dict] = {}
        for _ in range(args.rounds):
            for method, target, rtol in runs:
                got = attempts[method](rtol)
                kept = best.get((method, target))
                if kept is None or got["cpu_s"] < kept["cpu_s"]:
                    best[(method, target)] = got
        for (method, target), got in best.items():
            cells.append({"k": k, "method": method, "target_rad": float(target),
                          **{key: got.get(key) for key in (
                              "cpu_s", "angle_error", "n_steps", "nfev", "njev", "nlu",
                              "n_switches")}, "rtol": got["setting"]["rtol"]})
            print(f"k={k:g} {method} {target}: {got['cpu_s']:.4f} s, rtol "
                  f"{got['setting']['rtol']:.3g}, steps {got.get('n_steps')}, nfev "
                  f"{got.get('nfev')}, nlu {got.get('nlu')}, switches "
                  f"{got.get('n_switches', '-')}", flush=True)
        args.out.write_text(json.dumps(
            {"workload": __doc__.split("\n\n")[1].replace("\n", " "), "rounds": args.rounds,
             "settings_from": {"DOP853, Radau": args.settings.name, "auto": args.auto.name},
             "machine": machine(),
             "started": time.strftime("%Y-%m-%d %H:%M:%S", time.localtime(started)),
             "elapsed_s": time.time() - started, "cells": cells}, indent=1) + "\n")


if __name__ == "__main__":
    main()
