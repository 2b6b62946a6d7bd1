"""Benchmark: how the build time (derive + generate code) grows with mechanism size.

Workload: ``dalembert.multibody.chain(n, 1.0, 1.0, 0.05)``, ``n`` quaternion rigid
links joined by spherical joints (``7 n`` coordinates, ``4 n`` constraints).
For each ``n`` a fresh Python process (SymPy's cache cold, an empty code cache)
times both routes:

- ``parts`` (what ``Multibody.system`` uses): ``chain(...)`` (``bodies``), then
  :func:`dalembert.multibody.parts.multibody_parts` (``derive``: one link and two
  joint kinds) and :func:`dalembert.codegen.assembly.compile_parts` (``compile``);
- ``global`` (what a hand-written ``System`` uses, and the reference the parts are
  tested against): the whole model (``model``),
  :func:`~dalembert.equations.lagrange.derive_equations` and
  :func:`~dalembert.codegen.compiled.compile_equations`, up to ``--global-max``.

The JSON records the seconds per stage, ``build`` (all stages) and the ratio of
each build time to the previous ``n`` (2.0 for linear growth when ``n`` doubles).
``baseline`` holds the global route's times before the sparse derivation
(commit af91e82, same machine) for reference.

Usage: ``python bench/build_scaling.py [--sizes 2 4 ... 1024] [--global-max 32] [--out DIR]``.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import subprocess
import sys
import tempfile
import time
from pathlib import Path

#: Seconds measured at commit af91e82 (dense jacobians, one global cse).
BASELINE = {
    2: {"model": 0.39, "derive": 0.89, "compile": 0.65},
    4: {"model": 1.22, "derive": 3.03, "compile": 1.58},
    8: {"model": 2.16, "derive": 5.62, "compile": 3.88},
    16: {"model": 14.47, "derive": 51.73, "compile": 34.56},
}


def measure(n: int, route: str) -> dict[str, float]:
    """Time one chain of ``n`` links in this process (call in a fresh process)."""
    with tempfile.TemporaryDirectory() as cache:
        os.environ["DALEMBERT_CACHE_DIR"] = cache
        return (_parts if route == "parts" else _global)(n)


def _parts(n: int) -> dict[str, float]:
    from dalembert.codegen.assembly import compile_parts
    from dalembert.multibody import chain
    from dalembert.multibody.parts import multibody_parts

    start = time.perf_counter()
    mb = chain(n, 1.0, 1.0, 0.05)
    system = mb.system
    built = time.perf_counter()
    parts = multibody_parts(mb)
    derived = time.perf_counter()
    compile_parts(parts, len(system.coordinate_names), len(system.constraint_names))
    done = time.perf_counter()
    return {"n": n, "route": "parts", "coordinates": len(system.coordinate_names),
            "constraints": len(system.constraint_names), "bodies": built - start,
            "derive": derived - built, "compile": done - derived, "build": done - start}


def _global(n: int) -> dict[str, float]:
    from dalembert.codegen.compiled import compile_equations
    from dalembert.equations.lagrange import derive_equations
    from dalembert.multibody import chain

    start = time.perf_counter()
    model = chain(n, 1.0, 1.0, 0.05).system.model
    built = time.perf_counter()
    eqs = derive_equations(model)
    derived = time.perf_counter()
    compile_equations(eqs)
    done = time.perf_counter()
    return {"n": n, "route": "global", "coordinates": model.coords.n,
            "constraints": model.constraints.m, "model": built - start,
            "derive": derived - built, "compile": done - derived, "build": done - start}


def run(sizes: list[int], route: str) -> list[dict[str, float]]:
    rows = []
    for n in sizes:
        out = subprocess.run([sys.executable, __file__, "--one", route, str(n)],
                             check=True, capture_output=True, text=True)
        row = json.loads(out.stdout.strip().splitlines()[-1])
        if rows:
            row["ratio_to_previous"] = row["build"] / rows[-1]["build"]
        rows.append(row)
        stages = ", ".join(f"{k} {row[k]:.2f} s" for k in ("bodies", "model", "derive", "compile")
                           if k in row)
        print(f"{route:6} n={n:4d} ({row['coordinates']} coordinates): {stages}", flush=True)
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", type=int, nargs="+",
                        default=[2, 4, 8, 16, 32, 64, 128, 256, 1024])
    parser.add_argument("--global-max", type=int, default=32,
                        help="largest n for the global route (default 32)")
    parser.add_argument("--out", default=str(Path(__file__).parent / "results"))
    parser.add_argument("--one", nargs=2, metavar=("ROUTE", "N"), help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.one is not None:
        print(json.dumps(measure(int(args.one[1]), args.one[0])))
        return
    import sympy

    result = {
        "workload": "multibody.chain(n, 1.0, 1.0, 0.05), spherical joints",
        "parts": run(args.sizes, "parts"),
        "global": run([n for n in args.sizes if n <= args.global_max], "global"),
        "baseline": BASELINE, "python": platform.python_version(),
        "sympy": sympy.__version__, "machine": platform.machine(),
    }
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    (out / "build_scaling.json").write_text(json.dumps(result, indent=2) + "\n")
    print(f"wrote {out / 'build_scaling.json'}")


if __name__ == "__main__":
    main()
