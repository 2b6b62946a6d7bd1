"""Dense output kept compactly: SciPy's interpolants from numbers in one array.

Checked against SciPy's own ``DenseOutput`` objects of the same steps (DOP853's
evaluation repeats its operations, so it is equal to the bit; RK45's and RK23's sum
the powers in another order, so to rounding), and the memory a step keeps against
the count of numbers its interpolant needs (``2 + 8 n_state`` doubles for DOP853,
``2 + 5 n_state`` for RK45): it was about a kilobyte of objects per step.
"""

from __future__ import annotations

import gc
import tracemalloc

import numpy as np
import pytest
from pendulum_case import Q0
from scipy.integrate import DOP853, RK23, RK45, Radau

from dalembert.solvers.steppers.dense_output import DenseRecorder


def oscillator(t, y):
    return np.array([y[1], -4.0 * y[0] + 0.1 * np.sin(t), y[3], -y[2] * abs(y[0])])


@pytest.mark.parametrize(("cls", "exact"), [(DOP853, True), (RK45, False), (RK23, False),
                                            (Radau, True)])
@pytest.mark.parametrize("t_bound", [3.0, -3.0])
def test_same_values_as_scipys_interpolants(cls, exact, t_bound):
    solver = cls(oscillator, 0.0, np.array([1.0, 0.0, 0.5, 0.2]), t_bound, rtol=1e-6,
                 atol=1e-9)
    recorder = DenseRecorder(0.0, solver.y.copy(), solver.direction, None)
    theirs = []
    while solver.status == "running":
        solver.step()
        dense = solver.dense_output()
        theirs.append(dense)
        recorder.add(solver.t_old, solver.t, dense, solver.y.copy())
    sol = recorder.solution()
    assert (sol.t_min, sol.t_max) == (min(0.0, t_bound), max(0.0, t_bound))
    rng = np.random.default_rng(0)
    times = t_bound * np.sort(rng.uniform(0.0, 1.0, 200))
    ours = sol(times)
    assert ours.shape == (4, 200)
    for s, y in zip(times, ours.T):
        step = next(d for d in theirs if min(d.t_old, d.t) <= s <= max(d.t_old, d.t))
        if exact:
            assert np.array_equal(y, step(s))
        else:
            np.testing.assert_allclose(y, step(s), rtol=1e-14, atol=1e-15)
    # a step's end is the state recorded there; a scalar time gives one state
    assert np.array_equal(sol(t_bound), solver.y) and sol(t_bound).shape == (4,)
    assert np.array_equal(sol(theirs[2].t), theirs[3].y_old)
    with pytest.raises(ValueError, match="outside the integrated interval"):
        sol(1.5 * t_bound)


def test_before_the_first_step_only_the_start():
    recorder = DenseRecorder(1.0, np.array([2.0, 3.0]), 1.0, None)
    sol = recorder.solution()
    assert sol(1.0).tolist() == [2.0, 3.0]
    with pytest.raises(ValueError, match="outside"):
        sol(1.1)


def kept_bytes(system, **options) -> tuple[float, int]:
    """Bytes the dense output keeps per step (dense output on minus off)."""
    for dense in (False, True):  # what is made once (code, caches) is made now
        system.simulate(**options, dense_output=dense)
    sizes = []
    for dense in (False, True):
        gc.collect()
        tracemalloc.start()
        traj = system.simulate(**options, dense_output=dense)
        gc.collect()
        sizes.append(tracemalloc.get_traced_memory()[0])
        tracemalloc.stop()
        del traj
    steps = system.simulate(**options).stats["n_steps"]
    return (sizes[1] - sizes[0]) / steps, steps


@pytest.mark.parametrize(("method", "rows", "t_end"), [("DOP853", 7, 150.0), ("RK45", 4, 25.0)])
def test_memory_per_step(pendulum, method, rows, t_end):
    n_state = 4
    per_step, steps = kept_bytes(pendulum, t_span=(0, t_end), q0=Q0, t_eval=[t_end],
                                 method=method, rtol=1e-9, atol=1e-11)
    assert steps > 2000
    numbers = 8 * (2 + n_state * (1 + rows))  # t_old, t_new, y_old, the rows
    # beside them only what a run keeps anyway (a few kB over the run)
    assert numbers <= per_step < 1.2 * numbers
