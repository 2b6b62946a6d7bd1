"""Log-log scaling plot of ``bench/results/suite.json``: time against chain length.

One panel per workload (3D spherical, planar revolute); per tool, the simulation
time (solid) and the build time (dashed) against ``n``. Runs that did not finish
are left out (their status is in the JSON).

Usage: ``python bench/plot.py [suite.json] [--out suite.png]``.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt

HERE = Path(__file__).resolve().parent
COLORS = {"dalembert": "C0", "sympy": "C1", "mujoco": "C2", "exudyn": "C3"}

#: Panel titles by workload.
TITLES = {"spherical": "3D chain (spherical joints)",
          "revolute": "planar chain (revolute joints)"}


def plot(result: dict, out: Path) -> Path:
    """Draw the two panels and save them to ``out``."""
    workloads = ("spherical", "revolute")
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.5), sharey=True)
    for ax, workload in zip(axes, workloads):
        rows = [r for r in result["records"] if r["workload"] == workload and "simulate_s" in r]
        for tool in dict.fromkeys(r["tool"] for r in rows):
            mine = sorted((r for r in rows if r["tool"] == tool), key=lambda r: r["n"])
            ns = [r["n"] for r in mine]
            color = COLORS.get(tool)
            ax.loglog(ns, [r["simulate_s"] for r in mine], "o-", color=color,
                      label=f"{tool} simulate")
            ax.loglog(ns, [r["build_s"] for r in mine], "s--", color=color, alpha=0.6,
                      label=f"{tool} build")
        ax.set_title(f"{TITLES.get(workload, workload)}, 10 s at energy error <= 1e-6")
        ax.set_xlabel("links n")
        ax.grid(True, which="both", alpha=0.3)
    axes[0].set_ylabel("seconds (cold build, simulation)")
    axes[1].legend(fontsize=8, loc="upper left")
    fig.suptitle(f"{result['machine']['cpu']}, {result['machine']['cpus']} cores "
                 f"({result['mode']} run, cap {result['cap_s']:g} s per run)", fontsize=9)
    fig.tight_layout()
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, dpi=110)
    plt.close(fig)
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("json", nargs="?", default=str(HERE / "results" / "suite.json"))
    parser.add_argument("--out")
    args = parser.parse_args()
    src = Path(args.json)
    out = Path(args.out) if args.out else src.with_suffix(".png")
    print(f"wrote {plot(json.loads(src.read_text()), out)}")


if __name__ == "__main__":
    main()
