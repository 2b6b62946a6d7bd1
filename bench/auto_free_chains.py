"""``method="auto"`` on the suite's free chains: DOP853, Radau and ``auto`` side by side.

``auto``'s target (``dalembert/solvers/running/switching.py``) is to stay within 1.3x of
the better of DOP853 and Radau; on the stiff spring chain (``bench/stiff.py``) it is
measured, here on the suite's non-stiff chains: the planar chain (revolute joints) of
16 and 256 links and the 3D chain (spherical joints) of 16 links, 10 s falling under
gravity from 30 degrees (``bench/peers/common.py``; model and initial state from
``bench/peers/dalembert.py``).

Each method's coarsest rtol (atol = rtol / 100) meeting the suite's target (energy
error <= 1e-6 and constraint residual <= 1e-10 at 10 s) is bisected on a log scale to
within 5% (``bench/peers/ladder.py``), then the kept settings are timed in interleaved
rounds (DOP853, Radau, auto; then Radau, auto, DOP853; ...), the fastest round's CPU
time (``time.process_time``) kept with its wall time beside it. Every run records its
steps, evaluations, LU factorizations and how many times ``auto`` switched; one more
``auto`` run is watched for the switches' times and, at each trial's judgement, the
step Radau had grown to over the explicit one (``watched``). ``same_rtol`` splits
``auto``'s cost at DOP853's setting: DOP853, ``auto``, and ``auto`` with a detector
that cannot fire (the test's own cost, no switch).

``python bench/auto_free_chains.py`` writes ``bench/results/auto_free_chains.json``
(``--chains planar16 planar256 spatial16``, ``--rounds``).
"""

from __future__ import annotations

import argparse
import json
import sys
import time
import warnings
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from bench.peers import dalembert as peer
from bench.peers.common import T_END, energy_error, meets
from bench.peers.ladder import Prepared, bisect

METHODS = ("DOP853", "Radau", "auto")
CHAINS = {"planar16": ("revolute", 16), "planar256": ("revolute", 256),
          "spatial16": ("spherical", 16)}
#: The suite's rtol ladder (coarse to fine) brackets each method's setting.
RTOLS = peer.RTOLS


def simulate(mb, q0, qd0, method: str, rtol: float):
    """One run of 10 s at ``rtol`` (atol = rtol / 100), output at 101 times as the suite's."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # rounding-level projection of q0
        return mb.simulate((0.0, T_END), q0, qd0, method=method, rtol=rtol, atol=rtol / 100,
                           t_eval=np.linspace(0.0, T_END, 101))


def record(traj, n: int) -> dict:
    """Accuracy and work of one run."""
    stats = {k: int(v) for k, v in traj.stats.items()}
    return {"energy_error": energy_error(traj.energy[0], traj.energy[-1], n),
            "residual": float(traj.position_residual.max()),
            "finished": traj.status == "finished" if isinstance(traj.status, str)
            else bool(traj.status == 0),
            "evaluations": stats.get("nfev"), "steps": stats.get("n_steps"),
            "lu": stats.get("nlu"), "switches": stats.get("n_switches"), "stats": stats}


def timed(mb, q0, qd0, method: str, rtol: float, n: int) -> dict:
    """One run at ``rtol``: its record with its wall and CPU seconds."""
    start, cpu = time.perf_counter(), time.process_time()
    traj = simulate(mb, q0, qd0, method, rtol)
    wall, cpu = time.perf_counter() - start, time.process_time() - cpu
    return {"setting": {"method": method, "rtol": rtol}, "simulate_s": wall, "cpu_s": cpu,
            **record(traj, n)}


def switch_times(mb, q0, qd0, rtol: float) -> dict:
    """An ``auto`` run at ``rtol`` watched: ``(t, method)`` of each switch (the policy's
    record) and, at each judgement of a trial, ``(t, h_implicit / h_explicit)`` (the
    trial pays at ``COST_RATIO``, 2)."""
    from dalembert.solvers.running import switching
    from dalembert.solvers.steppers.scipy_ivp import step_size

    seen: list = []
    judged: list = []
    after = switching.StiffSwitch.after

    def watched(self, solver, n_steps):
        if not any(s is self for s in seen):
            seen.append(self)
        trial = self._trial
        if trial is not None and n_steps - trial[1] >= switching.TRIAL_STEPS:
            judged.append([float(solver.t), float(step_size(solver) / trial[2])])
        return after(self, solver, n_steps)

    switching.StiffSwitch.after = watched  # type: ignore[method-assign]
    try:
        simulate(mb, q0, qd0, "auto", rtol)
    finally:
        switching.StiffSwitch.after = after  # type: ignore[method-assign]
    return {"switches": [[float(t), m] for s in seen for t, m in s.switches],
            "judgements": judged}


def same_rtol(mb, q0, qd0, rtol: float, n: int, rounds: int) -> dict:
    """Where ``auto``'s time goes: DOP853, ``auto`` and ``auto`` with a detector that
    cannot fire (its limit out of reach: the test's cost alone, no switch) at one rtol
    (DOP853's kept one), interleaved rounds, the fastest CPU time of each."""
    from dalembert.solvers.running import run_data
    from dalembert.solvers.steppers.stiffness import StiffnessDetector

    real = run_data.DETECTOR
    variants = [("DOP853", "DOP853", real), ("auto", "auto", real),
                ("auto, detector never firing", "auto", StiffnessDetector(limit=1e300))]
    out: dict[str, dict] = {}
    try:
        for r in range(rounds):
            for label, method, detector in variants[r % 3:] + variants[:r % 3]:
                run_data.DETECTOR = detector
                one = timed(mb, q0, qd0, method, rtol, n)
                if label not in out or one["cpu_s"] < out[label]["cpu_s"]:
                    out[label] = one
    finally:
        run_data.DETECTOR = real
    return {"rtol": rtol, **{k: {f: v[f] for f in ("cpu_s", "simulate_s", "steps",
                                                   "evaluations", "lu", "switches",
                                                   "energy_error")}
                             for k, v in out.items()}}


def run_chain(name: str, rounds: int) -> dict:
    """One chain: each method bisected, then timed in interleaved rounds (0: the default
    count), ``auto`` watched and its cost split at DOP853's setting."""
    workload, n = CHAINS[name]
    mb, build_s = peer.build(workload, n)
    q0, qd0 = peer.initial_state(mb, workload, n)
    simulate(mb, q0, qd0, "DOP853", 1e-3)  # load the C loop before anything is timed
    kept: dict[str, dict] = {}
    for method in METHODS:
        def attempt(rtol: float, method: str = method) -> dict:
            return timed(mb, q0, qd0, method, rtol, n)

        rec = bisect(Prepared({}, attempt, RTOLS, meets))
        kept[method] = rec
        print(f"{name} {method}: rtol {rec['setting_value']:.3g} ({rec['bisection']}), "
              f"{rec['steps']} steps, {rec['evaluations']} evaluations, "
              f"switches {rec['switches']}, energy {rec['energy_error']:.2e}", flush=True)
    rounds = rounds or (31 if n <= 64 else 21)
    order = list(METHODS)
    times: dict[str, list] = {m: [] for m in METHODS}
    for r in range(rounds):
        for method in order[r % 3:] + order[:r % 3]:
            one = timed(mb, q0, qd0, method, kept[method]["setting_value"], n)
            times[method].append((one["cpu_s"], one["simulate_s"]))
    per_round = [a[0] / min(d[0], r[0]) for d, r, a in
                 zip(times["DOP853"], times["Radau"], times["auto"])]
    out = {"workload": workload, "n": n, "build_s": build_s, "rounds": rounds, "methods": {}}
    for method in METHODS:
        rec = kept[method]
        cpu, wall = min(times[method])
        out["methods"][method] = {
            **{k: v for k, v in rec.items() if k not in ("simulate_s", "cpu_s")},
            "cpu_s": cpu, "wall_s": wall, "rounds_cpu_s": [c for c, _ in times[method]],
            "rounds_wall_s": [w for _, w in times[method]],
            "bisection_cpu_s": rec["cpu_s"]}
    out["methods"]["auto"]["watched"] = switch_times(
        mb, q0, qd0, kept["auto"]["setting_value"])
    best = min(out["methods"][m]["cpu_s"] for m in ("DOP853", "Radau"))
    out["auto_over_best"] = out["methods"]["auto"]["cpu_s"] / best
    out["auto_over_best_median_round"] = float(np.median(per_round))
    out["same_rtol"] = same_rtol(mb, q0, qd0, kept["DOP853"]["setting_value"], n, rounds)
    for method in METHODS:
        m = out["methods"][method]
        print(f"{name} {method}: rtol {m['setting_value']:.3g}, CPU {m['cpu_s']:.4f} s "
              f"(wall {m['wall_s']:.4f}), {m['steps']} steps", flush=True)
    print(f"{name}: auto watched {out['methods']['auto']['watched']}", flush=True)
    print(f"{name}: auto / best = {out['auto_over_best']:.2f} (median round "
          f"{out['auto_over_best_median_round']:.2f})", flush=True)
    for label, v in out["same_rtol"].items():
        if isinstance(v, dict):
            print(f"  at rtol {out['same_rtol']['rtol']:.3g}, {label}: CPU {v['cpu_s']:.4f} s, "
                  f"{v['steps']} steps, {v['evaluations']} evaluations, LU {v['lu']}, "
                  f"switches {v['switches']}", flush=True)
    return out


def main() -> None:
    """Bisect and time every chain asked for; write the JSON."""
    parser = argparse.ArgumentParser(description=main.__doc__)
    parser.add_argument("--chains", nargs="+", default=list(CHAINS), choices=list(CHAINS))
    parser.add_argument("--rounds", type=int, default=0,
                        help="timing rounds (0: 31 for n <= 64, else 21)")
    parser.add_argument("--out", type=Path,
                        default=Path(__file__).parent / "results" / "auto_free_chains.json")
    args = parser.parse_args()
    out = json.loads(args.out.read_text()) if args.out.exists() else {}
    for name in args.chains:
        out[name] = run_chain(name, args.rounds)
        args.out.parent.mkdir(parents=True, exist_ok=True)
        args.out.write_text(json.dumps(out, indent=1) + "\n")


if __name__ == "__main__":
    main()
