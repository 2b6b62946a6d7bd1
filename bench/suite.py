"""Benchmark suite: dalembert against the tools users would otherwise pick.

Workload (see ``bench/peers/common.py``): an ``n``-link chain of uniform solid
cylinders (1 kg, 1 m, 5 cm radius) hung from a fixed point, 3D with spherical
joints and planar with revolute joints, tilted 30 degrees (the 3D chain also
turning at 0.2 rad/s out of the plane), simulated for 10 s. Tools (one module each
in ``bench/peers/``): dalembert, SymPy mechanics (minimal coordinates), MuJoCo
(RK4) and Exudyn (generalized-alpha, sparse solver). Each tool tightens its
tolerance or step until the energy error at 10 s is <= 1e-6 and the constraint
residual <= 1e-10 (Exudyn: the residual; its energy error is reported).

Every (tool, workload, n) runs in a fresh process under a time cap; a run that
does not finish is recorded as ``did not finish in X s`` and larger ``n`` of that
tool and workload are skipped. Peak memory is that process's ``ru_maxrss``.
Writes ``bench/results/suite.json`` (records, ratios peer/dalembert, machine) and
prints a table; ``bench/plot.py`` draws the scaling PNG.

Usage: ``python bench/suite.py [--quick] [--cap S] [--sizes N ...] [--tools T ...]``.
"""

from __future__ import annotations

import argparse
import contextlib
import importlib
import json
import os
import platform
import subprocess
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))

from bench.peers import TOOLS  # noqa: E402

WORKLOADS = ("spherical", "revolute")
#: Every tool runs on one thread (the machine's 2 cores are shared; BLAS threads
#: that spin between NumPy calls would take the other one).
SINGLE_THREAD = {k: "1" for k in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS",
                                  "MKL_NUM_THREADS")}
SIZES = (2, 4, 8, 16, 32, 64, 128, 256, 1024)
QUICK_SIZES = (2, 4, 8)
MARK = "@@record "
#: Records whose whole process took under this many seconds run a second time after
#: the first pass, every tool alike, and the faster round is kept: noise on shared
#: machines comes in spells of minutes, which best-of-five within one process cannot
#: leave.
SECOND_ROUND_WALL_S = 10.0


def run_one(tool: str, workload: str, n: int) -> dict:
    """Measure one record in this process (the suite calls it in a child)."""
    from bench.peers.common import peak_memory_mb

    module = importlib.import_module(f"bench.peers.{tool}")
    record = {"tool": tool, "workload": workload, "n": n, "versions": module.versions()}
    start = time.perf_counter()
    record.update(module.run(workload, n))
    record["wall_s"] = time.perf_counter() - start
    record["peak_memory_mb"] = peak_memory_mb()
    record["status"] = "ok" if record["met_target"] else (
        "accepted: residual target met, energy target not" if record.get("accepted")
        else "finished without meeting the accuracy target")
    return record


def spawn(tool: str, workload: str, n: int, cap: float) -> dict:
    """Run one record in a fresh process, killed after ``cap`` seconds."""
    base = {"tool": tool, "workload": workload, "n": n, "cap_s": cap}
    cmd = [sys.executable, str(Path(__file__).resolve()), "--one", tool, workload, str(n)]
    env = {**os.environ, "BENCH_CAP": str(cap), "PYTHONWARNINGS": "ignore", **SINGLE_THREAD}
    start = time.perf_counter()
    try:
        out = subprocess.run(cmd, capture_output=True, text=True, timeout=cap, env=env)
    except subprocess.TimeoutExpired:
        return {**base, "status": f"did not finish in {cap:g} s"}
    lines = [ln for ln in out.stdout.splitlines() if ln.startswith(MARK)]
    if out.returncode != 0 or not lines:
        tail = (out.stderr.strip().splitlines() or ["no output"])[-1]
        return {**base, "status": f"error: {tail[:300]}", "elapsed_s": time.perf_counter() - start}
    return {**base, **json.loads(lines[-1][len(MARK):])}


def available(tool: str) -> str | None:
    """``None`` if the tool imports here, else why not."""
    try:
        importlib.import_module(f"bench.peers.{tool}").versions()
    except ImportError as exc:
        return f"not installed: {exc} (pip install -e '.[bench]')"
    return None


def machine() -> dict:
    cpu = "unknown"
    with contextlib.suppress(OSError, StopIteration):
        cpu = next(ln.split(":", 1)[1].strip() for ln in Path("/proc/cpuinfo").read_text()
                   .splitlines() if ln.startswith("model name"))
    return {"python": platform.python_version(), "platform": platform.platform(),
            "cpu": cpu, "cpus": os.cpu_count(),
            "memory_gb": round(os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES") / 2**30,
                               1)}


def total_s(r: dict) -> float | None:
    return r["build_s"] + r["simulate_s"] if "simulate_s" in r else None


def ratios(records: list[dict]) -> list[dict]:
    """Peer time / dalembert time per workload and n (simulate and build + simulate)."""
    ours = {(r["workload"], r["n"]): r for r in records
            if r["tool"] == "dalembert" and "simulate_s" in r}
    rows = []
    for r in records:
        base = ours.get((r["workload"], r["n"]))
        if r["tool"] == "dalembert" or base is None or "simulate_s" not in r:
            continue
        rows.append({"tool": r["tool"], "workload": r["workload"], "n": r["n"],
                     "simulate": r["simulate_s"] / base["simulate_s"],
                     "build": r["build_s"] / base["build_s"],
                     "total": total_s(r) / total_s(base)})
    return rows


def table(records: list[dict]) -> str:
    head = (f"{'workload':9} {'tool':9} {'n':>5} {'build s':>9} {'warm s':>8} {'sim s':>9} "
            f"{'evals':>8} {'E err':>8} {'resid':>8} {'MB':>6}  status")
    lines = [head, "-" * len(head)]
    for r in records:
        if "simulate_s" not in r:
            lines.append(f"{r['workload']:9} {r['tool']:9} {r['n']:>5}  {r['status']}")
            continue
        warm = "-" if r.get("build_warm_s") is None else f"{r['build_warm_s']:.3g}"
        lines.append(
            f"{r['workload']:9} {r['tool']:9} {r['n']:>5} {r['build_s']:9.3g} {warm:>8} "
            f"{r['simulate_s']:9.3g} {r['evaluations']:>8} {r['energy_error']:8.1e} "
            f"{r['residual']:8.1e} {r['peak_memory_mb']:6.0f}  {r['status']}")
    return "\n".join(lines)


def suite(tools, sizes, cap: float, budget: float | None) -> list[dict]:
    """Smallest ``n`` first across all tools, so a budget cut keeps every tool's small n."""
    records, start = [], time.perf_counter()
    missing = {tool: available(tool) for tool in tools}
    stopped: dict[tuple[str, str], str] = {}
    for n in sizes:
        for workload in WORKLOADS:
            for tool in tools:
                base = {"tool": tool, "workload": workload, "n": n}
                why = missing[tool] or stopped.get((tool, workload))
                if why is None and budget is not None and time.perf_counter() - start > budget:
                    why = f"skipped: the suite's {budget:g} s budget was spent"
                if why:
                    records.append({**base, "status": why})
                    continue
                record = spawn(tool, workload, n, cap)
                records.append(record)
                print(f"{workload:9} {tool:9} n={n:<5} {record['status']}"
                      + (f"  build {record['build_s']:.3g} s, simulate "
                         f"{record['simulate_s']:.3g} s" if "simulate_s" in record else ""),
                      flush=True)
                if "simulate_s" not in record:
                    stopped[tool, workload] = f"skipped: n={n} {record['status']}"
    return sorted(records, key=lambda r: (r["workload"], r["tool"], r["n"]))


def second_round(records: list[dict], cap: float) -> list[dict]:
    """The short records measured again in fresh processes; per record the faster
    round is kept, ``simulate_rounds`` has both rounds' times."""
    kept = []
    for r in records:
        if "simulate_s" not in r or r.get("wall_s", float("inf")) > SECOND_ROUND_WALL_S:
            kept.append(r)
            continue
        again = spawn(r["tool"], r["workload"], r["n"], cap)
        rounds = [r["simulate_s"], again.get("simulate_s", float("nan"))]
        best = again if rounds[1] < rounds[0] else r
        kept.append({**best, "simulate_rounds": rounds})
    return kept


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true",
                        help=f"n in {QUICK_SIZES}, 20 s cap, 240 s budget (under 5 minutes)")
    parser.add_argument("--sizes", type=int, nargs="+")
    parser.add_argument("--tools", nargs="+", choices=TOOLS, default=list(TOOLS))
    parser.add_argument("--cap", type=float, help="seconds per run (default 300; quick 20)")
    parser.add_argument("--budget", type=float, help="seconds for the whole suite")
    parser.add_argument("--out", default=str(HERE / "results" / "suite.json"))
    parser.add_argument("--one", nargs=3, metavar=("TOOL", "WORKLOAD", "N"),
                        help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.one:
        tool, workload, n = args.one
        print(MARK + json.dumps(run_one(tool, workload, int(n))), flush=True)
        return
    sizes = args.sizes or (QUICK_SIZES if args.quick else SIZES)
    cap = args.cap or (20.0 if args.quick else 300.0)
    budget = args.budget or (240.0 if args.quick else None)
    started = time.time()
    records = second_round(suite(args.tools, sizes, cap, budget), cap)
    result = {"workload": __doc__.split("\n\n")[1].replace("\n", " "),
              "mode": "quick" if args.quick else "full", "cap_s": cap, "sizes": list(sizes),
              "started": time.strftime("%Y-%m-%d %H:%M:%S", time.localtime(started)),
              "elapsed_s": time.time() - started, "machine": machine(),
              "ratios_peer_over_dalembert": ratios(records), "records": records}
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(json.dumps(result, indent=1) + "\n")
    print(table(records))
    print("\nratios peer / dalembert (simulate, build + simulate):")
    for r in result["ratios_peer_over_dalembert"]:
        print(f"  {r['workload']:9} {r['tool']:7} n={r['n']:<5} simulate {r['simulate']:8.3g}"
              f"  total {r['total']:8.3g}")
    print(f"wrote {out}")


if __name__ == "__main__":
    main()
