"""Benchmark: what an open model costs: new parameter values, inputs from Python.

Workload: the 16-link 3D chain of ``bench/suite.py`` (``chain(16, l, m, r)``, here with
symbolic length, mass and radius), 10 s simulated at rtol 3e-4 (the suite's accepted
tolerance for it), 101 outputs, the C loop. Measured, best of ``--repeats``:

- ``parameters``: a simulation with new parameter values against one with the values
  of the run before; the difference is what binding new values costs (deriving the
  links' inertias, checking the bound mechanism). The target: at most 10 ms, and no
  code generated or compiled (counted).
- ``inputs``: a motor torque ``u`` about x on the top link (a ``Torque``) from a Python
  function of the state, called by C at every evaluation, against the same law written
  in SymPy inside the model; the difference per evaluation is the callback's cost.
- ``sampled``: the same controller held at 100 Hz (``sample_time=0.01``): 1000
  restarts in 10 s.

Usage: ``python bench/open_model.py [--repeats 5] [--out bench/results]``.
"""

from __future__ import annotations

import argparse
import json
import platform
import time
import warnings
from pathlib import Path

import numpy as np
import sympy as sp

from dalembert.codegen import c_backend
from dalembert.multibody import Multibody, Torque, chain

N, T_END, RTOL = 16, 10.0, 3e-4
m, l, r, u = sp.symbols("m l r u")
GAIN, DAMPING = 5.0, 1.0


def best(run, repeats: int) -> tuple[float, object]:
    seconds, out = [], None
    for _ in range(repeats):
        start = time.perf_counter()
        out = run()
        seconds.append(time.perf_counter() - start)
    return min(seconds), out


def initial(mb: Multibody, length: float):
    """The suite's start: every link tilted 30 degrees about y, the chain turning about x."""
    c, s = np.cos(np.pi / 6), np.sin(np.pi / 6)
    R = np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])
    omega = np.array([0.2, 0.0, 0.0])
    down = R @ np.array([0.0, 0.0, -length])
    positions = {f"link{k + 1}": (k + 0.5) * down for k in range(N)}
    return mb.initial_state(positions=positions, orientations=dict.fromkeys(positions, R),
                            velocities={k: np.cross(omega, x) for k, x in positions.items()},
                            angular_velocities=dict.fromkeys(positions, omega))


def parameters(repeats: int) -> dict[str, float]:
    mb = chain(N, l, m, r)
    q0, qd0 = initial(mb, 1.0)
    options = dict(t_eval=np.linspace(0, T_END, 101), rtol=RTOL, atol=RTOL / 100)
    values = [{l: 1.0, m: 1.0 + k * 1e-3, r: 0.05} for k in range(repeats + 1)]
    mb.simulate((0, T_END), q0, qd0, parameters=values[0], **options)  # build, compile
    runs: list[object] = []
    original = c_backend._compile
    c_backend._compile = lambda *a, **k: runs.append(a) or original(*a, **k)
    try:
        same, _ = best(lambda: mb.simulate((0, T_END), q0, qd0, parameters=values[0],
                                           **options), repeats)
        changed = []
        for v in values[1:]:
            start = time.perf_counter()
            mb.simulate((0, T_END), q0, qd0, parameters=v, **options)
            changed.append(time.perf_counter() - start)
        start = time.perf_counter()
        for v in values[1:]:
            mb.system.numeric(v)  # binding alone
        bind = (time.perf_counter() - start) / repeats
    finally:
        c_backend._compile = original
    return {"same_values_s": same, "new_values_s": min(changed),
            "overhead_s": min(changed) - same, "bind_s": bind, "compiler_runs": len(runs)}


def controlled(repeats: int) -> dict[str, float]:
    def build(torque):
        base = chain(N, 1.0, 1.0, 0.05)
        motor = Torque(base.body("link1"), (torque, 0, 0), name="motor")
        return Multibody(base.bodies, base.joints, gravity=base.gravity, torques=[motor],
                         inputs=[u] if torque == u else [])

    with_input, with_law = build(u), None
    q0, qd0 = initial(with_input, 1.0)
    # the same law in SymPy: a torque about x on the top link against its Euler
    # parameter b1 (half the tilt about x, for small angles) and its rate
    options = dict(t_eval=np.linspace(0, T_END, 101), rtol=RTOL, atol=RTOL / 100)
    index = with_input.system.coordinate_names.index("link1_b1")

    def controller(t, q, qd):
        return -GAIN * q[index] - DAMPING * qd[index]

    b1 = with_input.body("link1").coordinates[4]
    with_law = build(-GAIN * b1 - DAMPING * b1.diff())
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        with_input.simulate((0, 1), q0, qd0, inputs=controller)
        with_law.simulate((0, 1), q0, qd0)
        law_s, law = best(lambda: with_law.simulate((0, T_END), q0, qd0, **options), repeats)
        input_s, run = best(lambda: with_input.simulate((0, T_END), q0, qd0,
                                                        inputs=controller, **options), repeats)
        sampled_s, held = best(lambda: with_input.simulate(
            (0, T_END), q0, qd0, inputs=controller, sample_time=0.01, **options), repeats)
    return {"law_in_sympy_s": law_s, "python_callback_s": input_s,
            "callback_per_evaluation_us": (input_s - law_s) / run.stats["nfev"] * 1e6,
            "nfev": run.stats["nfev"], "nfev_law": law.stats["nfev"],
            "max_difference_q": float(np.abs(run.q - law.q).max()),
            "sampled_100hz_s": sampled_s, "sampled_nfev": held.stats["nfev"],
            "sampled_samples": held.stats["n_samples"]}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--out", type=Path, default=Path(__file__).parent / "results")
    args = parser.parse_args()
    out = {"machine": platform.platform(), "python": platform.python_version(),
           "workload": {"links": N, "t_end": T_END, "rtol": RTOL},
           "parameters": parameters(args.repeats), "inputs": controlled(args.repeats)}
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "open_model.json").write_text(json.dumps(out, indent=2))
    print(json.dumps(out, indent=2))


if __name__ == "__main__":
    main()
