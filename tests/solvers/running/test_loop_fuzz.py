"""Fuzz: the C loop against the Python loop on random chains, tolerances and options.

Hypothesis draws a chain (``dalembert.multibody.chain``: planar or 3D, 1 to 4
links) with random link angles and spins, a tolerance, a method (DOP853, RK45,
RK23), a step-size controller, output times or not, and projection or Baumgarte,
and runs the simulation with ``backend="c"`` and ``backend="python"``. The two
loops take the same method and step-size control, but their right-hand sides come
from different KKT solves that differ in the last bits, and at tight tolerances
the error estimate of a step is near rounding level, so their steps part (README);
what they must share is the motion: end states within a small multiple of the
tolerance (measured against the motion's own scale). Where whole stretches run in C,
the step-by-step loop with the same C steps must take the very same steps (equal to
the bit at step ends). Every run is under a time bound: no crash, no hang.

Bounded for CI: a fixed number of examples, derandomized, a few seconds in all.
"""

from __future__ import annotations

import dataclasses
import warnings
from functools import cache

import numpy as np
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from dalembert import InitialConditionsAdjusted
from dalembert.multibody import chain

T_END = 0.5
#: End states of the two loops agree within this many times rtol, times the motion's
#: scale (measured over 300 random cases like these, rtol 1e-12 to 1e-6: 0.06 at most).
AGREEMENT = 1.0
EXAMPLES = 25


@cache
def chain_system(links: int, planar: bool):
    return chain(links, 1.0, 1.0, 0.05, joint="revolute" if planar else "spherical",
                 planar=planar)


def rot_y(a: float) -> np.ndarray:
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])


def start(mb, planar: bool, angles: list[float], spins: list[float]):
    """Links at the given angles from the vertical, joined end to end, each spinning."""
    names = [b.name for b in mb.bodies]
    top, positions, orientations = np.zeros(3), {}, {}
    for name, a in zip(names, angles):
        down = rot_y(a) @ [0, 0, -1.0] if not planar else np.array([np.sin(a), -np.cos(a), 0])
        positions[name] = top + 0.5 * down if not planar else (top + 0.5 * down)[:2]
        orientations[name] = rot_y(a) if not planar else a
        top = top + down
    spin = {n: (w if planar else np.array([0.3 * w, w, 0.0])) for n, w in zip(names, spins)}
    return mb.initial_state(positions=positions, orientations=orientations,
                            angular_velocities=spin)


cases = st.fixed_dictionaries({
    "links": st.integers(1, 4),
    "planar": st.booleans(),
    "angles": st.lists(st.floats(-1.2, 1.2), min_size=4, max_size=4),
    "spins": st.lists(st.floats(-2.0, 2.0), min_size=4, max_size=4),
    "rtol": st.sampled_from([1e-11, 1e-10, 1e-9, 1e-8, 1e-7, 1e-6]),
    "atol_ratio": st.sampled_from([1e-2, 1e-4]),
    "method": st.sampled_from(["DOP853", "RK45", "RK23"]),
    "step_control": st.sampled_from(["PI", "scipy"]),
    "t_eval": st.booleans(),
    "stabilization": st.sampled_from(["projection", "baumgarte"]),
})


def states(traj) -> np.ndarray:
    return np.hstack([traj.q, traj.qd])


@settings(max_examples=EXAMPLES, deadline=None, derandomize=True, database=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])
@given(case=cases)
def test_c_loop_against_python_loop(time_bound, case):
    mb = chain_system(case["links"], case["planar"])
    k = case["links"]
    q0, qd0 = start(mb, case["planar"], case["angles"][:k], case["spins"][:k])
    # RK23 at tight tolerances takes thousands of steps: not what CI's seconds are for
    rtol = max(case["rtol"], 1e-8) if case["method"] == "RK23" else case["rtol"]
    options = {"t_span": (0.0, T_END), "rtol": rtol, "atol": rtol * case["atol_ratio"],
               "method": case["method"], "step_control": case["step_control"],
               "stabilization": case["stabilization"],
               "t_eval": np.linspace(0.0, T_END, 11) if case["t_eval"] else None}
    system = mb.system
    with time_bound(60), warnings.catch_warnings():
        warnings.simplefilter("ignore", InitialConditionsAdjusted)
        c_plan = system.plan(q0=q0, qd0=qd0, backend="c", **options)
        runs = {"c": system.run(c_plan),
                "python": system.simulate(q0=q0, qd0=qd0, backend="python", **options)}
        if c_plan.stretches:
            runs["c, step by step"] = system.run(dataclasses.replace(c_plan, stretches=False))
    for traj in runs.values():
        assert traj.status == "finished" and traj.t[-1] == T_END
        assert np.all(np.isfinite(states(traj)))
    c, py = runs["c"], runs["python"]
    if case["t_eval"]:
        assert np.array_equal(c.t, py.t)
    scale = max(1.0, np.abs(states(py)).max())
    gap = np.abs(states(c)[-1] - states(py)[-1]).max()
    assert gap <= AGREEMENT * rtol * scale, f"end states {gap:.2e} apart at rtol {rtol:g}"
    if "c, step by step" in runs:
        same = runs["c, step by step"]
        assert same.stats == c.stats and np.array_equal(same.t, c.t)
        tol = 0.0 if not case["t_eval"] else 1e-12  # interpolated outputs: to rounding
        assert np.abs(states(same) - states(c)).max() <= tol * scale
