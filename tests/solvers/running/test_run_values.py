"""A run's values are its own: the inputs a run writes never reach the bound model it
was planned from, so plans of one model may run side by side (threads)."""

from __future__ import annotations

from concurrent.futures import ThreadPoolExecutor

import numpy as np
import pytest
import sympy as sp

from dalembert import System, coordinates
from dalembert.solvers.running.plan import plan_simulation

(theta,) = coordinates("theta")
u = sp.Symbol("u")


@pytest.fixture(scope="module")
def pushed():
    """A unit pendulum pushed by the torque ``u``."""
    return System([theta], kinetic=theta.diff() ** 2 / 2, potential=-9.81 * sp.cos(theta),
                  generalized_forces={theta: u}, inputs=[u])


@pytest.mark.parametrize("backend", ["c", "python"])
def test_a_run_leaves_the_bound_model_unchanged(pushed, backend):
    num = pushed.numeric()
    before = num.p.copy()
    state = pushed.consistent_initial_state({theta: 1.0})
    options = pushed.check_options((0.0, 1.0), inputs=lambda t, q, qd: 5.0,
                                   backend=backend)
    plan_simulation(num, state, options).run()
    assert np.array_equal(num.p, before) and not num.p.flags.writeable
    with pytest.raises(ValueError):
        num.set_inputs([1.0])  # the bound model's values are read-only


def test_plans_of_one_model_run_side_by_side(pushed):
    """Two constant torques, each run alone and both at once in threads: the same
    trajectories (each run reads its own inputs)."""
    num = pushed.numeric()
    state = pushed.consistent_initial_state({theta: 1.0})
    times = np.linspace(0.0, 1.0, 11)

    def run(torque: float) -> np.ndarray:
        options = pushed.check_options((0.0, 1.0), t_eval=times, backend="python",
                                       inputs=lambda t, q, qd: torque)
        return plan_simulation(num, state, options).run().y

    alone = [run(2.0), run(-2.0)]
    with ThreadPoolExecutor(2) as pool:
        together = list(pool.map(run, [2.0, -2.0]))
    assert not np.allclose(alone[0], alone[1])
    for a, b in zip(alone, together):
        assert np.array_equal(a, b)
