"""Contact segments in C: the same runs with their contact events screened in C
(``solvers/native/screens.py``: the steps run in stretches of C between switches) and
held in the Python loop (a user event that never fires has no screen, so every step is
taken one by one in Python, as every contact run's steps were before the screens).

Cases: the bouncing ball (e = 0.8, 3.8 s, a few steps a flight), the slack string of
the gallery over 20 s (one long pendulum segment), the gallery's rolling sphere
(sliding, then rolling), Housner's block rocking on rough corners and on corners with
``mu = 0.1`` (rocking and sliding until it rests flat: its sets with both corners closed
have dependent rows and keep the Python loop). Both runs of a case take the same steps
(tests/solvers/contact/test_screens.py checks the switches and states).

CPU time (``time.process_time``) beside wall time, the best of interleaved rounds.
Writes ``bench/results/contact_screens.json``. Usage:
``python bench/contact_screens.py [--rounds 7]``.
"""

from __future__ import annotations

import argparse
import json
import platform
import sys
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
OUT = HERE / "results" / "contact_screens.json"


def never(t, q, qd):
    """A user event that never fires: its run steps in the Python loop."""
    return 1.0


def cases() -> dict[str, Callable]:
    sys.path.insert(0, str(HERE.parent / "tests" / "solvers" / "contact"))
    from test_rough import block, tilted

    from dalembert import System, Unilateral, coordinates
    from dalembert.examples import rolling_sphere, slack_string

    (y,) = coordinates("y")
    ball = System([y], kinetic=y.diff() ** 2 / 2, potential=9.81 * y,
                  constraints=[Unilateral(y, name="floor", restitution=0.8)])
    string, sphere = slack_string.build(), rolling_sphere.build()
    rough, sliding = block(float("inf")), block(0.1)
    return {
        "bouncing ball, 3.8 s, rtol 1e-6": lambda ev: ball.simulate(
            (0.0, 3.8), {"y": 1.0}, rtol=1e-6, atol=1e-8, events=ev),
        "slack string, 20 s": lambda ev: string.simulate(
            (0.0, 20.0), events=ev, **slack_string.INITIAL),
        "rolling sphere (gallery)": lambda ev: sphere.simulate(
            (0.0, rolling_sphere.T_END), events=ev, **rolling_sphere.INITIAL),
        "rocking block, rough, 2.5 s": lambda ev: rough.simulate(
            (0.0, 2.5), tilted(-0.1), events=ev),
        "rocking block, mu = 0.1, 2.5 s": lambda ev: sliding.simulate(
            (0.0, 2.5), tilted(-0.1), events=ev),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=7)
    args = parser.parse_args()
    runs = cases()
    loops = {"screened in C": [], "Python loop": [never]}
    best = {name: {loop: [np.inf, np.inf] for loop in loops} for name in runs}
    stats: dict[str, dict] = {}
    for run in runs.values():  # generated and compiled: not timed
        for events in loops.values():
            run(events)
    for _ in range(args.rounds):
        for name, run in runs.items():
            for loop, events in loops.items():
                wall, cpu = time.perf_counter(), time.process_time()
                traj = run(events)
                cpu, wall = time.process_time() - cpu, time.perf_counter() - wall
                kept = best[name][loop]
                kept[0], kept[1] = min(kept[0], cpu), min(kept[1], wall)
                stats[name] = {k: int(v) for k, v in traj.stats.items()}
    rows = []
    for name in runs:
        (c_cpu, c_wall), (p_cpu, p_wall) = best[name]["screened in C"], best[name]["Python loop"]
        rows.append({"case": name, **stats[name], "cpu_s": {"screened": c_cpu, "python": p_cpu},
                     "wall_s": {"screened": c_wall, "python": p_wall},
                     "cpu_ratio": p_cpu / c_cpu})
        print(f"| {name} | {stats[name]['n_steps']} | {stats[name]['n_segments']} | "
              f"{p_cpu:.4f} | {c_cpu:.4f} | {p_cpu / c_cpu:.1f} |")
    OUT.write_text(json.dumps({"machine": platform.platform(), "rounds": args.rounds,
                               "cases": rows}, indent=2) + "\n")


if __name__ == "__main__":
    main()
