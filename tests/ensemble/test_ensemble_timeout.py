"""A case whose function of the user's never returns ends as that case's ``"timeout"``
(``timeout=``), the others complete: a controller (``case_inputs``) spinning inside the
run keeps the steps before; ``initial_state`` or an output function spinning outside it
are stopped too (each such function has the case's limit). Before, such a case held its
worker, and the ensemble, forever. On threads and on Dask's processes alike.

Checked against the bead's closed form: on the line ``x = y`` pushed by ``u`` along x
and braked by ``v = -c y'``, ``2 m x'' = u - c x'``, so
``x'(t) = u / c + (x'(0) - u / c) exp(-c t / (2 m))``; and against the pendulum's
height, the output function's value.
"""

from __future__ import annotations

import contextlib
import logging
import signal

import numpy as np
import pytest
from ensemble_models import (
    pendulum,
    pushed_bead,
    released,
    spinning_crossing,
    spinning_damper,
    spinning_initial_state,
    spinning_output,
)

from dalembert import EnsembleWarning
from dalembert.ensemble import grid

T_EVAL = np.linspace(0.0, 1.5, 16)
M = 2.0  # the bead's mass


def bead_velocity(u: float, c: float, t: np.ndarray) -> np.ndarray:
    return u / c + (1.0 - u / c) * np.exp(-c * t / (2 * M))


def check_bead(result, cases, timed_out: int) -> None:
    """Every case's x' against the closed form; the one that timed out up to t = 0.5."""
    summary = result.summary
    assert result.failed == [timed_out]
    assert summary.loc[timed_out, "status"] == "timeout"
    assert "while a function of yours, spin (ensemble_models.py:" in \
        summary.loc[timed_out, "message"]
    qd = result.dataset["qd"].values[:, :, 0]
    for i, (u, c) in enumerate(zip(cases["u"], cases["c"])):
        reached = ~np.isnan(qd[i])
        if i == timed_out:
            assert reached.sum() >= 3 and T_EVAL[reached].max() <= 0.5
        else:
            assert summary.loc[i, "status"] == "finished" and reached.all()
        np.testing.assert_allclose(qd[i, reached], bead_velocity(u, c, T_EVAL[reached]),
                                   rtol=1e-8, atol=1e-10)


@pytest.mark.parametrize("scheduler", ["serial", "threads"])
def test_a_controller_that_never_returns_times_its_case_out(scheduler):
    cases = grid(u=[1.0], c=[0.5, 2.0, 1.0], victim=[0.0])
    cases.loc[1, "victim"] = 1.0
    with pytest.warns(EnsembleWarning, match=r"1 of 3 cases did not succeed \(1 timeout\)"):
        result = pushed_bead().simulate_many(
            (0.0, 1.5), cases, q0=[0.5, 0.5], qd0=[1.0, 1.0], case_inputs=spinning_damper,
            t_eval=T_EVAL, keep=("q", "qd"), timeout=0.5, scheduler=scheduler, workers=2,
            progress=False)
    check_bead(result, cases, 1)


@pytest.mark.parametrize("scheduler", ["serial", "threads"])
def test_an_event_that_never_returns_times_its_case_out(scheduler):
    """In the Python loop (events), which keeps its thread's turn throughout."""
    cases = grid(l=[1.0, 1.5, 0.8])
    with pytest.warns(EnsembleWarning, match=r"1 of 3 cases did not succeed \(1 timeout\)"):
        result = pendulum().simulate_many(
            (0.0, 1.5), cases, initial_state=released, t_eval=T_EVAL,
            events=[spinning_crossing], timeout=0.5, scheduler=scheduler, workers=2,
            progress=False)
    summary = result.summary
    assert summary["status"].tolist() == ["finished", "timeout", "finished"]
    assert "while a function of yours, spin (ensemble_models.py:" in summary.loc[1, "message"]
    q = result.dataset["q"].values
    reached = ~np.isnan(q[1, :, 0])
    assert reached.sum() >= 3 and T_EVAL[reached].max() <= 0.3
    for i in range(3):  # the rod's length holds where each case reached
        ok = ~np.isnan(q[i, :, 0])
        np.testing.assert_allclose(np.hypot(q[i, ok, 0], q[i, ok, 1]), cases["l"][i],
                                   rtol=1e-10)
    # the others cross under the pivot at the quarter period (small-swing law, loosely)
    quarter = np.pi / 2 * np.sqrt(cases["l"][[0, 2]].to_numpy() / 9.81)
    np.testing.assert_allclose(summary.loc[[0, 2], "t_event_spinning_crossing"], quarter,
                               rtol=0.05)


@pytest.mark.parametrize("scheduler", ["serial", "threads"])
def test_an_initial_state_that_never_returns_times_its_case_out(scheduler):
    cases = grid(l=[0.8, 1.0, 1.2], victim=[0.0])
    cases.loc[0, "victim"] = 1.0
    with pytest.warns(EnsembleWarning, match=r"1 of 3 cases did not succeed \(1 timeout\)"):
        result = pendulum().simulate_many(
            (0.0, 1.5), cases, initial_state=spinning_initial_state, t_eval=T_EVAL,
            timeout=0.5, scheduler=scheduler, workers=2, progress=False)
    summary = result.summary
    assert summary["status"].tolist() == ["timeout", "finished", "finished"]
    assert summary.loc[0, "message"].startswith(
        "initial_state did not return within the case's time limit (timeout=0.5 s): "
        "stopped in spin (ensemble_models.py:")
    assert np.isnan(result.dataset["q"].values[0]).all()
    for i in (1, 2):  # the rod's length holds: x^2 + y^2 = l^2
        q = result.dataset["q"].values[i]
        np.testing.assert_allclose(np.hypot(q[:, 0], q[:, 1]), cases["l"][i], rtol=1e-10)


@pytest.mark.parametrize("scheduler", ["serial", "threads"])
def test_an_output_that_never_returns_keeps_its_cases_trajectory(scheduler):
    cases = grid(l=[1.0, 1.5, 0.8])
    with pytest.warns(EnsembleWarning, match=r"1 of 3 cases did not succeed \(1 timeout\)"):
        result = pendulum().simulate_many(
            (0.0, 1.5), cases, initial_state=released, t_eval=T_EVAL,
            outputs={"height": spinning_output}, timeout=0.5, scheduler=scheduler,
            workers=2, progress=False)
    summary, data = result.summary, result.dataset
    assert summary["status"].tolist() == ["finished", "timeout", "finished"]
    assert summary.loc[1, "message"].startswith(
        "the output 'height' did not return within the case's time limit (timeout=0.5 s)")
    assert np.isnan(data["height"].values[1]).all()
    q = data["q"].values
    np.testing.assert_allclose(np.hypot(q[1, :, 0], q[1, :, 1]), 1.5, rtol=1e-10)
    for i in (0, 2):
        np.testing.assert_array_equal(data["height"].values[i], q[i, :, 1])
    initial = released({"l": 1.5})[0]
    np.testing.assert_allclose(q[1, 0], [initial["x"], initial["y"]], rtol=1e-12)


@contextlib.contextmanager
def bounded(seconds: float):
    """Fail, not hang, if the block runs longer (the code before the watchdog hung)."""
    def alarm(signum, frame):
        raise TimeoutError("the time bound of the test was exceeded")

    previous = signal.signal(signal.SIGALRM, alarm)
    signal.setitimer(signal.ITIMER_REAL, seconds)
    try:
        yield
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, previous)


def test_a_controller_that_never_returns_times_its_case_out_on_processes():
    """On a Dask worker process (two threads): the case ends there as its timeout, the
    others complete, the worker goes on."""
    from distributed import Client, LocalCluster

    cases = grid(u=[1.0], c=[0.5, 2.0, 1.0, 1.5], victim=[0.0])
    cases.loc[2, "victim"] = 1.0
    with LocalCluster(n_workers=1, threads_per_worker=2, processes=True,
                      dashboard_address=None, silence_logs=logging.CRITICAL) as local, \
            Client(local) as client, bounded(120.0), \
            pytest.warns(EnsembleWarning, match=r"1 of 4 cases did not succeed \(1 timeout\)"):
        result = pushed_bead().simulate_many(
            (0.0, 1.5), cases, q0=[0.5, 0.5], qd0=[1.0, 1.0], case_inputs=spinning_damper,
            t_eval=T_EVAL, keep=("q", "qd"), timeout=0.5, client=client, batch_size=1,
            progress=False)
    check_bead(result, cases, 2)
