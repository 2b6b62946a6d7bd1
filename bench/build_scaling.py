"""Benchmark: how the build time (derive + generate code) grows with mechanism size.

Workload: ``dalembert.multibody.chain(n, 1.0, 1.0, 0.05)``, ``n`` quaternion rigid
links joined by spherical joints (``7 n`` coordinates, ``4 n`` constraints).
For each ``n`` a fresh Python process (so SymPy's cache starts cold) times

- ``model``: the multibody description turned into a checked ``Model``,
- ``derive``: :func:`dalembert.equations.lagrange.derive_equations`,
- ``compile``: :func:`dalembert.codegen.compiled.compile_equations`,

and the JSON records the seconds, ``build = derive + compile``, the sizes and
the ratio of each build time to the previous ``n`` (2.0 for linear growth when
``n`` doubles). Ratios, not absolute times, are what to compare on a shared
machine. ``baseline`` holds the times measured before the sparse derivation
(commit af91e82, same machine) for reference.

Usage: ``python bench/build_scaling.py [--sizes 2 4 8 16 32 64] [--out bench/results]``.
"""

from __future__ import annotations

import argparse
import json
import platform
import subprocess
import sys
import time
from pathlib import Path

#: Seconds measured at commit af91e82 (dense jacobians, one global cse).
BASELINE = {
    2: {"model": 0.39, "derive": 0.89, "compile": 0.65},
    4: {"model": 1.22, "derive": 3.03, "compile": 1.58},
    8: {"model": 2.16, "derive": 5.62, "compile": 3.88},
    16: {"model": 14.47, "derive": 51.73, "compile": 34.56},
}


def measure(n: int) -> dict[str, float]:
    """Time one chain of ``n`` links in this process (call in a fresh process)."""
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
    return {
        "n": n, "coordinates": model.coords.n, "constraints": model.constraints.m,
        "model": built - start, "derive": derived - built, "compile": done - derived,
        "build": done - built,
    }


def run(sizes: list[int]) -> list[dict[str, float]]:
    rows = []
    for n in sizes:
        out = subprocess.run([sys.executable, __file__, "--one", str(n)],
                             check=True, capture_output=True, text=True)
        row = json.loads(out.stdout.strip().splitlines()[-1])
        if rows:
            row["ratio_to_previous"] = row["build"] / rows[-1]["build"]
        rows.append(row)
        print(f"n={n:3d} ({row['coordinates']} coordinates): model {row['model']:.2f} s, "
              f"derive {row['derive']:.2f} s, compile {row['compile']:.2f} s", flush=True)
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=[2, 4, 8, 16, 32, 64])
    parser.add_argument("--out", default=str(Path(__file__).parent / "results"))
    parser.add_argument("--one", type=int, help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.one is not None:
        print(json.dumps(measure(args.one)))
        return
    import sympy

    rows = run(args.sizes)
    result = {
        "workload": "multibody.chain(n, 1.0, 1.0, 0.05), spherical joints",
        "rows": rows, "baseline": BASELINE, "python": platform.python_version(),
        "sympy": sympy.__version__, "machine": platform.machine(),
    }
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    (out / "build_scaling.json").write_text(json.dumps(result, indent=2) + "\n")
    print(f"wrote {out / 'build_scaling.json'}")


if __name__ == "__main__":
    main()
