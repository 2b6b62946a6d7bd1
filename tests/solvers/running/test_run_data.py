"""One plan, many runs: each run writes only its own data (its parameter vector with the
inputs, the C loop's work arrays, the careful steps' state).

References: the same runs made one after the other; the model's functions evaluated
with the inputs written by hand.
"""

from __future__ import annotations

import threading

import numpy as np
import pytest
import sympy as sp

from dalembert import Holonomic, System, coordinates

BACKENDS = ["c", "python"]
x, y = coordinates("x y")
u = sp.Symbol("u")


def bead() -> System:
    """A bead on the unit circle turned by the torque ``u`` about the centre."""
    return System([x, y], kinetic=(x.diff() ** 2 + y.diff() ** 2) / 2, potential=9.81 * y,
                  constraints=[Holonomic(x**2 + y**2 - 1, name="wire")],
                  generalized_forces={x: -u * y, y: u * x}, inputs=[u])


def push(t, q, qd):
    return -20.0 * np.arctan2(q[0], -q[1]) - 2.0 * (q[0] * qd[1] - q[1] * qd[0])


START = {x: np.sin(1.0), y: -np.cos(1.0)}


@pytest.mark.parametrize("backend", BACKENDS)
def test_two_runs_of_one_plan_hold_their_own_inputs(backend):
    """Inputs written into one run's data do not reach another's (before, the plan held
    one parameter vector that every run of it wrote)."""
    plan = bead().plan((0, 1), START, inputs=push, sample_time=0.1, backend=backend)
    first, second = plan.start(), plan.start()
    y0 = plan.y0
    first.hold_inputs(np.array([3.0]))
    second.hold_inputs(np.array([-5.0]))
    for data, value in [(first, 3.0), (second, -5.0)]:
        # at rest at the angle 1 from the bottom: phi'' = u - g sin(phi), and
        # (x'', y'') = phi'' (cos(phi), sin(phi))
        phi_dd = value - 9.81 * np.sin(1.0)
        expected = [0.0, 0.0, phi_dd * np.cos(1.0), phi_dd * np.sin(1.0)]
        np.testing.assert_allclose(data.rhs(0.0, y0), expected, rtol=1e-13, atol=1e-13)
    assert plan.num.p.flags.writeable is False  # the plan's own values: never written


@pytest.mark.parametrize("backend", BACKENDS)
def test_one_plan_runs_in_several_threads_at_once(backend):
    """Four threads run one plan (a sampled controller: each of 200 segments holds its
    inputs in the run's data) at the same time; each gives, bit for bit, the run made
    alone."""
    system = bead()
    times = np.linspace(0, 2, 41)
    plan = system.plan((0, 2), START, inputs=push, sample_time=0.01, t_eval=times,
                       backend=backend)
    alone = system.run(plan)
    results: list[object] = [None] * 4

    def work(k: int) -> None:
        results[k] = system.run(plan)

    threads = [threading.Thread(target=work, args=(k,)) for k in range(4)]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()
    for traj in results:
        np.testing.assert_array_equal(traj.q, alone.q)
        np.testing.assert_array_equal(traj.inputs, alone.inputs)
        np.testing.assert_array_equal(traj.multipliers, alone.multipliers)
    assert alone.stats["n_segments"] == 200  # one per sample interval
