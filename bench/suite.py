"""Benchmark suite: dalembert against the tools users would otherwise pick.

Workload (see ``bench/peers/common.py``): an ``n``-link chain of uniform solid
cylinders (1 kg, 1 m, 5 cm radius) hung from a fixed point, 3D with spherical
joints and planar with revolute joints, tilted 30 degrees (the 3D chain also
turning at 0.2 rad/s out of the plane), simulated for 10 s. Tools (one module each
in ``bench/peers/``): dalembert, SymPy mechanics (minimal coordinates), MuJoCo
(RK4) and Exudyn (generalized-alpha, sparse solver). Each tool runs at its coarsest
tolerance or step (bisected to within 5%) at which the energy error at 10 s is <=
1e-6 and the constraint residual <= 1e-10 (Exudyn: the residual; its energy error is
reported). Times are wall and CPU seconds of the kept setting's fastest timing round;
the tools' rounds are interleaved.

Every (tool, workload, n) runs in a fresh process: it builds the model and bisects
its setting under a time cap (``bench/peers/ladder.py``), the tools one after the
other; then the kept settings are timed in rounds interleaved across the tools (A,
B, C, then B, C, A, ...: a slow spell of a shared machine falls on all of them),
each process kept alive between its rounds. A tool that does not finish is recorded
as ``did not finish in X s`` and larger ``n`` of that tool and workload are skipped.
Peak memory is that process's (``VmHWM``) at the end of its bisection.
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
import queue
import subprocess
import sys
import tempfile
import threading
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
TIME_MARK = "@@time "
#: Timing rounds of each tool's kept setting, by how long its run took: short runs
#: move most with the machine's load, so they are timed most often.
ROUND_COUNTS = ((1.0, 5), (10.0, 3), (30.0, 2), (float("inf"), 1))


def rounds_for(seconds: float) -> int:
    """How many timing rounds a run of ``seconds`` gets (:data:`ROUND_COUNTS`)."""
    return next(count for limit, count in ROUND_COUNTS if seconds < limit)


def serve(tool: str, workload: str, n: int) -> None:
    """The child's side: build, bisect the setting, print the record; then, for each
    ``time`` line read, run the kept setting once more and print its wall and CPU
    seconds (the suite interleaves these rounds across the tools)."""
    from bench.peers.common import peak_memory_mb
    from bench.peers.ladder import bisect, timed

    module = importlib.import_module(f"bench.peers.{tool}")
    record = {"tool": tool, "workload": workload, "n": n, "versions": module.versions()}
    with tempfile.TemporaryDirectory(prefix="dalembert-bench-") as cache:
        os.environ["DALEMBERT_CACHE_DIR"] = cache  # dalembert's first build is cold
        start = time.perf_counter()
        prepared = module.prepare(workload, n)
        record.update(bisect(prepared))
        record.update(prepared.info)
        record["wall_s"] = time.perf_counter() - start
        record["peak_memory_mb"] = peak_memory_mb()
        record["status"] = "ok" if record["met_target"] else (
            "accepted: residual target met, energy target not" if record["accepted"]
            else "finished without meeting the accuracy target")
        print(MARK + json.dumps(record), flush=True)
        for line in sys.stdin:
            if line.strip() != "time" or not record["accepted"]:
                break
            print(TIME_MARK + json.dumps(timed(prepared, record)), flush=True)


class Child:
    """One (tool, workload, n) in a fresh process, kept alive between its rounds."""

    def __init__(self, tool: str, workload: str, n: int, cap: float) -> None:
        cmd = [sys.executable, str(Path(__file__).resolve()), "--one", tool, workload, str(n)]
        env = {**os.environ, "BENCH_CAP": str(cap), "PYTHONWARNINGS": "ignore",
               **SINGLE_THREAD}
        self.stderr = tempfile.TemporaryFile(mode="w+")  # noqa: SIM115 (closed in close())
        self.proc = subprocess.Popen(cmd, stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                                     stderr=self.stderr, text=True, env=env)
        self.lines: queue.Queue[str | None] = queue.Queue()
        threading.Thread(target=self._read, daemon=True).start()

    def _read(self) -> None:
        assert self.proc.stdout is not None
        for line in self.proc.stdout:
            self.lines.put(line)
        self.lines.put(None)

    def wait_for(self, mark: str, timeout: float) -> dict | str:
        """The next line marked ``mark``, parsed; or why there is none (a string)."""
        deadline = time.perf_counter() + timeout
        while True:
            try:
                line = self.lines.get(timeout=max(deadline - time.perf_counter(), 0.0))
            except queue.Empty:
                self.proc.kill()
                self.close()
                return f"did not finish in {timeout:g} s"
            if line is None:
                self.proc.wait()
                self.stderr.seek(0)
                tail = (self.stderr.read().strip().splitlines() or ["no output"])[-1]
                return f"error: {tail[:300]}"
            if line.startswith(mark):
                return json.loads(line[len(mark):])

    def time_once(self, timeout: float) -> dict | str:
        assert self.proc.stdin is not None
        self.proc.stdin.write("time\n")
        self.proc.stdin.flush()
        return self.wait_for(TIME_MARK, timeout)

    def close(self) -> None:
        if self.proc.poll() is None:
            with contextlib.suppress(OSError):
                assert self.proc.stdin is not None
                self.proc.stdin.close()
            try:
                self.proc.wait(timeout=10)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()
        self.stderr.close()


def measure(tools: list[str], workload: str, n: int, cap: float) -> list[dict]:
    """Each tool bisects its setting in its own process (one after the other, so that
    they do not share the cores), then the kept settings are timed in interleaved
    rounds: tool A, B, C, then B, C, A, ... (the order turned each round), so that a
    slow spell of the machine falls on every tool alike. ``simulate_s`` and ``cpu_s``
    are the fastest round's wall and CPU seconds (as ``timeit`` takes the minimum),
    ``rounds`` every round's."""
    records: dict[str, dict] = {}
    children: dict[str, Child] = {}
    base = {"workload": workload, "n": n, "cap_s": cap}
    for tool in tools:
        child = Child(tool, workload, n, cap)
        start = time.perf_counter()
        got = child.wait_for(MARK, cap)
        if isinstance(got, str):
            records[tool] = {"tool": tool, **base, "status": got,
                             "elapsed_s": time.perf_counter() - start}
            child.close()
            continue
        records[tool] = {**base, **got}
        if got["accepted"]:
            records[tool]["rounds"] = []
            children[tool] = child
        else:
            child.close()
    wanted = {tool: rounds_for(records[tool]["simulate_s"]) for tool in children}
    for r in range(max(wanted.values(), default=0)):
        order = list(children)
        for tool in order[r % len(order):] + order[:r % len(order)]:
            if len(records[tool]["rounds"]) >= wanted[tool]:
                continue
            got = children[tool].time_once(cap)
            if isinstance(got, str):
                records[tool]["rounds_note"] = f"round {r + 1}: {got}"
                wanted[tool] = len(records[tool]["rounds"])
                continue
            records[tool]["rounds"].append(got)
    for tool, child in children.items():
        child.close()
        rec = records[tool]
        rec["bisection_simulate_s"], rec["bisection_cpu_s"] = rec["simulate_s"], rec["cpu_s"]
        if rec["rounds"]:
            rec["simulate_s"] = min(x["simulate_s"] for x in rec["rounds"])
            rec["cpu_s"] = min(x["cpu_s"] for x in rec["rounds"])
            differs = sorted({k for x in rec["rounds"] for k in x["differs"]})
            if differs:
                rec["repeat_differs"] = differs
        if "steps" in rec and rec.get("eval_s", 0) is None:  # Exudyn: one implicit step
            rec["step_s"] = rec["simulate_s"] / rec["steps"]
    return [records[tool] for tool in tools]


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
    """Peer time / dalembert time per workload and n: simulation wall and CPU seconds,
    build, and build + simulate (wall)."""
    ours = {(r["workload"], r["n"]): r for r in records
            if r["tool"] == "dalembert" and "simulate_s" in r}
    rows = []
    for r in records:
        base = ours.get((r["workload"], r["n"]))
        if r["tool"] == "dalembert" or base is None or "simulate_s" not in r:
            continue
        rows.append({"tool": r["tool"], "workload": r["workload"], "n": r["n"],
                     "simulate": r["simulate_s"] / base["simulate_s"],
                     "simulate_cpu": r["cpu_s"] / base["cpu_s"],
                     "build": r["build_s"] / base["build_s"],
                     "total": total_s(r) / total_s(base)})
    return rows


def setting_text(r: dict) -> str:
    """The kept setting in a few characters: rtol or step."""
    setting = r.get("setting", {})
    for key, label in (("rtol", "rtol"), ("timestep", "h"), ("step", "h")):
        if key in setting:
            return f"{label} {setting[key]:.3g}"
    return "-"


def table(records: list[dict]) -> str:
    head = (f"{'workload':9} {'tool':9} {'n':>5} {'build s':>9} {'warm s':>8} {'sim s':>9} "
            f"{'cpu s':>9} {'setting':>13} {'evals':>8} {'E err':>8} {'resid':>8} {'MB':>6}"
            "  status")
    lines = [head, "-" * len(head)]
    for r in records:
        if "simulate_s" not in r:
            lines.append(f"{r['workload']:9} {r['tool']:9} {r['n']:>5}  {r['status']}")
            continue
        warm = "-" if r.get("build_warm_s") is None else f"{r['build_warm_s']:.3g}"
        lines.append(
            f"{r['workload']:9} {r['tool']:9} {r['n']:>5} {r['build_s']:9.3g} {warm:>8} "
            f"{r['simulate_s']:9.3g} {r['cpu_s']:9.3g} {setting_text(r):>13} "
            f"{r['evaluations']:>8} {r['energy_error']:8.1e} "
            f"{r['residual']:8.1e} {r['peak_memory_mb']:6.0f}  {r['status']}")
    return "\n".join(lines)


def suite(tools, sizes, cap: float, budget: float | None,
          workloads: tuple[str, ...] = WORKLOADS) -> list[dict]:
    """Smallest ``n`` first, so a budget cut keeps every tool's small n; at each n and
    workload the tools are measured together (:func:`measure`)."""
    records, start = [], time.perf_counter()
    missing = {tool: available(tool) for tool in tools}
    stopped: dict[tuple[str, str], str] = {}
    for n in sizes:
        for workload in workloads:
            going = []
            for tool in tools:
                why = missing[tool] or stopped.get((tool, workload))
                if why is None and budget is not None and time.perf_counter() - start > budget:
                    why = f"skipped: the suite's {budget:g} s budget was spent"
                if why:
                    records.append({"tool": tool, "workload": workload, "n": n, "status": why})
                else:
                    going.append(tool)
            for record in measure(going, workload, n, cap) if going else []:
                records.append(record)
                print(f"{workload:9} {record['tool']:9} n={n:<5} {record['status']}"
                      + (f"  build {record['build_s']:.3g} s, simulate "
                         f"{record['simulate_s']:.3g} s (CPU {record['cpu_s']:.3g} s), "
                         f"{setting_text(record)}, {len(record['attempts'])} attempts, "
                         f"{len(record.get('rounds', []))} rounds"
                         if "simulate_s" in record else ""), flush=True)
                if "simulate_s" not in record:
                    stopped[record["tool"], workload] = f"skipped: n={n} {record['status']}"
    return sorted(records, key=lambda r: (r["workload"], r["tool"], r["n"]))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true",
                        help=f"n in {QUICK_SIZES}, 30 s cap, 240 s budget (under 5 minutes)")
    parser.add_argument("--sizes", type=int, nargs="+")
    parser.add_argument("--tools", nargs="+", choices=TOOLS, default=list(TOOLS))
    parser.add_argument("--workloads", nargs="+", choices=WORKLOADS, default=list(WORKLOADS))
    parser.add_argument("--cap", type=float, help="seconds per tool's bisection, and "
                        "per timing round (default 600; quick 30)")
    parser.add_argument("--budget", type=float, help="seconds for the whole suite")
    parser.add_argument("--out", default=str(HERE / "results" / "suite.json"))
    parser.add_argument("--one", nargs=3, metavar=("TOOL", "WORKLOAD", "N"),
                        help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.one:
        tool, workload, n = args.one
        serve(tool, workload, int(n))
        return
    sizes = args.sizes or (QUICK_SIZES if args.quick else SIZES)
    cap = args.cap or (30.0 if args.quick else 600.0)
    budget = args.budget or (240.0 if args.quick else None)
    started = time.time()
    records = suite(args.tools, sizes, cap, budget, tuple(args.workloads))
    result = {"workload": __doc__.split("\n\n")[1].replace("\n", " "),
              "mode": "quick" if args.quick else "full", "cap_s": cap, "sizes": list(sizes),
              "workloads": list(args.workloads), "tools": list(args.tools),
              "started": time.strftime("%Y-%m-%d %H:%M:%S", time.localtime(started)),
              "elapsed_s": time.time() - started, "machine": machine(),
              "ratios_peer_over_dalembert": ratios(records), "records": records}
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(json.dumps(result, indent=1) + "\n")
    print(table(records))
    print("\nratios peer / dalembert (simulate wall, simulate CPU, build + simulate):")
    for r in result["ratios_peer_over_dalembert"]:
        print(f"  {r['workload']:9} {r['tool']:7} n={r['n']:<5} simulate {r['simulate']:8.3g}"
              f"  CPU {r['simulate_cpu']:8.3g}  total {r['total']:8.3g}")
    print(f"wrote {out}")


if __name__ == "__main__":
    main()
