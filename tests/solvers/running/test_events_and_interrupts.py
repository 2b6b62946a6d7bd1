"""Event functions that fail, and Ctrl-C at any moment of a step.

An event function returning NaN used to never fire, silently; one that raised lost
the trajectory. Both now end the run ("failed", naming the event and the time) and
return the steps before, the exception chained to the warning. A Ctrl-C that lands
between recording a step's output and its dense-output interpolant used to leave a
last point outside ``traj.sol``'s range: every moment of a step is tried here.
What is checked against: the pendulum's closed-form crossing times (the events
that did fire before the failure) and the uninterrupted run (the steps kept).
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import textwrap
import time

import numpy as np
import pytest
from pendulum_case import PERIOD, Q0

from dalembert import IntegrationWarning
from dalembert.solvers.running import loop as loop_module
from dalembert.solvers.running.integrate import integrate
from dalembert.solvers.steppers.dense_output import DenseRecorder

BACKENDS = ["c", "python"]


def crossing(t, q, qd):
    """x = 0: the bob passes under the pivot, at PERIOD / 4, 3 PERIOD / 4..."""
    return q[0]


def failing_after(t_fail: float, failure):
    def event(t, q, qd):
        return failure() if t > t_fail else q[0]

    return event


def nan():
    return float("nan")


def division():
    return 1 / 0


@pytest.mark.parametrize("backend", BACKENDS)
def test_an_event_that_changes_its_arguments_changes_only_its_own_copy(pendulum, backend):
    """An event that writes into the q and qd it is given (q[0] = 5, qd[0] = 0) finds the
    crossings at PERIOD / 4 and 3 PERIOD / 4 and leaves the motion as it is without it
    (it pinned or froze the run)."""
    def meddling(t, q, qd, lam):
        value = q[0]
        q[0], qd[0], lam[0] = 5.0, 0.0, 0.0
        return value

    times = np.linspace(0, PERIOD, 9)
    plain = pendulum.simulate((0, PERIOD), Q0, t_eval=times, backend=backend)
    traj = pendulum.simulate((0, PERIOD), Q0, t_eval=times, backend=backend,
                             events=[meddling])
    assert traj.success
    np.testing.assert_allclose(traj.t_events[0], [PERIOD / 4, 3 * PERIOD / 4], atol=1e-10)
    assert np.abs(traj.q - plain.q).max() < 1e-12
    assert np.abs(traj.qd - plain.qd).max() < 1e-12


@pytest.mark.parametrize("backend", BACKENDS)
@pytest.mark.parametrize(("failure", "said"), [
    (nan, "returned nan at t="), (division, "raised ZeroDivisionError at t=")])
def test_a_failing_event_ends_the_run_with_the_steps_before(pendulum, backend, failure, said):
    t_fail = 0.9 * PERIOD
    events = [crossing, failing_after(t_fail, failure)]
    with pytest.warns(IntegrationWarning) as record:
        traj = pendulum.simulate((0, 2 * PERIOD), Q0, events=events, backend=backend,
                                 dense_output=True)
    assert traj.status == "failed"
    assert traj.message.startswith(f"event 1 (event) {said}")
    t_stop = traj.t[-1]
    # the failing call is the first at a step end past t_fail: the last kept step ends
    # before it, and the message gives the time of that call
    assert t_stop <= t_fail < float(traj.message.split("t=")[1].split(":")[0])
    # the events before: the crossings at PERIOD / 4 and 3 PERIOD / 4, both events
    np.testing.assert_allclose(traj.t_events[0], [PERIOD / 4, 3 * PERIOD / 4], atol=1e-10)
    np.testing.assert_allclose(traj.t_events[1], [PERIOD / 4, 3 * PERIOD / 4], atol=1e-10)
    assert traj.sol.t_max == t_stop
    np.testing.assert_array_equal(traj.sol(t_stop), np.concatenate([traj.q[-1], traj.qd[-1]]))
    cause = record[0].message.__cause__
    assert isinstance(cause, ZeroDivisionError) if failure is division else cause is None


def test_an_event_failing_at_the_start(pendulum):
    with pytest.warns(IntegrationWarning):
        traj = pendulum.simulate((0, 1), Q0, events=[failing_after(-1.0, nan)])
    assert traj.status == "failed" and traj.t.tolist() == [0.0]
    assert traj.message.startswith("event 0 (event) returned nan at t=0:")


def test_an_event_failing_while_its_root_is_sought(pendulum):
    """The crossing is bracketed at a step end, then the function raises inside it."""
    def event(t, q, qd):
        if 0.2 * PERIOD < t < 0.25 * PERIOD:
            raise ValueError("no value here")
        return q[0]

    with pytest.warns(IntegrationWarning) as record:
        traj = pendulum.simulate((0, PERIOD), Q0, events=[event])
    assert traj.message.startswith("event 0 (event) raised ValueError at t=")
    assert traj.t[-1] < PERIOD / 4 and len(traj.t_events[0]) == 0
    assert isinstance(record[0].message.__cause__, ValueError)


# ---- Ctrl-C ---------------------------------------------------------------------------
#: Every function a step of the Python loop calls between its first record and the end
#: of the step (the places a Ctrl-C may land while a step is half recorded).
INSIDE_A_STEP = [
    (loop_module.PythonLoop, "_record"), (loop_module._StepState, "__call__"),
    (loop_module._StepState, "interpolant"), (DenseRecorder, "add"),
    (loop_module, "restart_second_order"), (loop_module.PythonLoop, "_commit"),
]


@pytest.mark.parametrize(("owner", "name"), INSIDE_A_STEP)
@pytest.mark.parametrize("t_eval", [None, np.linspace(0, 2, 81)])
def test_ctrl_c_anywhere_in_a_step_keeps_a_consistent_trajectory(
        pendulum, monkeypatch, owner, name, t_eval):
    options = {"t_span": (0, 2), "q0": Q0, "dense_output": True, "events": [crossing],
               "t_eval": t_eval, "rtol": 1e-8, "atol": 1e-10}
    whole = pendulum.simulate(**options)
    real = getattr(owner, name)
    for nth in (2, 3, 6):  # the second call may be in the first step, the sixth later
        calls = {"n": 0}

        def interrupted(*args, real=real, calls=calls, nth=nth, **kwargs):
            calls["n"] += 1
            if calls["n"] == nth:
                raise KeyboardInterrupt
            return real(*args, **kwargs)

        monkeypatch.setattr(owner, name, interrupted)
        with pytest.warns(IntegrationWarning):
            traj = pendulum.simulate(**options)
        monkeypatch.setattr(owner, name, real)
        assert calls["n"] >= nth and traj.status == "interrupted"
        assert f"at t={traj.sol.t_max:.6g}" in traj.message
        k = len(traj)
        assert k and np.array_equal(traj.t, whole.t[:k])
        np.testing.assert_array_equal(traj.q, whole.q[:k])
        # the last point inside the dense output, which gives it exactly at a step end
        assert traj.sol.t_min == 0 and traj.t[-1] <= traj.sol.t_max
        if t_eval is None:
            assert traj.t[-1] == traj.sol.t_max
            np.testing.assert_array_equal(traj.sol(traj.t[-1]),
                                          np.concatenate([traj.q[-1], traj.qd[-1]]))
        steps = traj.stats["n_steps"]  # the steps kept are those of the dense output
        assert np.array_equal(traj.sol.t_new, whole.sol.t_new[:steps] if steps else [0.0])
        assert [len(e) for e in traj.t_events] == [np.sum(whole.t_events[0] <= traj.sol.t_max)]


def test_ctrl_c_before_the_first_step():
    """A Ctrl-C while the solver starts (it evaluates the model) or while the output
    times are read: an interrupted run with the start, not a traceback."""
    from scipy.integrate import RK45

    def fun(t, y):
        raise KeyboardInterrupt

    result = integrate(fun, (0.0, 1.0), np.ones(2), method=RK45)
    assert result.status == "interrupted" and result.t.tolist() == [0.0]
    assert result.message == "interrupted by the user at t=0, before the first step"

    class Times:
        def __array__(self, dtype=None, copy=None):
            raise KeyboardInterrupt

    result = integrate(lambda t, y: -y, (0.0, 1.0), np.ones(2), method=RK45, t_eval=Times())
    assert result.status == "interrupted"


CHILD = textwrap.dedent("""
    import json, sys, time, warnings
    import numpy as np
    from dalembert.examples import load
    warnings.simplefilter("ignore")
    pendulum = load("pendulum").build()
    runs = {"c": {"backend": "c"},
            "python-dense": {"backend": "python", "dense_output": True}}
    for name, options in runs.items():
        pendulum.simulate((0, 0.1), {"x": 1.0, "y": 0.0}, **options)  # warm
        print("go", name, flush=True)
        traj = pendulum.simulate((0, 1e7), {"x": 1.0, "y": 0.0}, **options)
        end = time.monotonic()
        in_range = options.get("dense_output") is None or traj.t[-1] <= traj.sol.t_max
        print(json.dumps({"name": name, "status": traj.status, "end": end,
                          "steps": traj.stats["n_steps"], "in_range": bool(in_range)}),
              flush=True)
""")


@pytest.mark.skipif(not hasattr(signal, "SIGINT") or os.name != "posix",
                    reason="sends SIGINT to a child process")
def test_sigint_stops_a_long_run_within_a_second(time_bound):
    """A real Ctrl-C (SIGINT) to a process running a long simulation, in the C loop and
    in the Python loop with dense output: each returns "interrupted" at once."""
    child = subprocess.Popen([sys.executable, "-c", CHILD], stdout=subprocess.PIPE, text=True)
    try:
        with time_bound(120):
            for name in ("c", "python-dense"):
                assert child.stdout.readline().split() == ["go", name]
                time.sleep(0.5)
                child.send_signal(signal.SIGINT)
                sent = time.monotonic()
                result = json.loads(child.stdout.readline())
                assert result["name"] == name and result["status"] == "interrupted"
                assert result["end"] - sent < 1.0 and result["steps"] > 0
                assert result["in_range"]
    finally:
        child.kill()
        child.wait()


def test_outputs_in_chunks_are_those_of_one_call(pendulum, monkeypatch):
    """The C outputs of a long trajectory are computed in chunks (a Ctrl-C is served
    between them): chunks of 3 give the same arrays as one call."""
    from dalembert.solvers.native import solver as native_solver

    plan = pendulum.plan((0, 1), Q0, backend="c", t_eval=np.linspace(0, 1, 11))
    traj = pendulum.run(plan)
    y = np.hstack([traj.q, traj.qd])
    outputs = plan.start().outputs
    whole = outputs(traj.t, y)
    monkeypatch.setattr(native_solver, "OUTPUT_CHUNK", 3)
    chunked = outputs(traj.t, y)
    for key, value in whole.items():
        assert np.array_equal(chunked[key], value), key


def test_an_event_whose_root_cannot_be_located(pendulum):
    """A function whose sign change at a step end is not there when the step is searched
    (it depends on how often it is called): a failed run naming it, not a traceback."""
    calls = {"n": 0}

    def fickle(t, q, qd):
        calls["n"] += 1
        return -1.0 if calls["n"] <= 3 else 1.0  # the 4th call (a step end) flips it

    with pytest.warns(IntegrationWarning):
        traj = pendulum.simulate((0, 1), Q0, events=[fickle])
    assert traj.status == "failed" and len(traj) == 3
    assert traj.message.startswith("event 0 (fickle) changed sign between t=")


@pytest.mark.parametrize("backend", BACKENDS)
def test_ctrl_c_while_the_outputs_are_computed_keeps_the_states(pendulum, backend,
                                                                 monkeypatch):
    """A Ctrl-C in the outputs (after a long run) returns the trajectory, interrupted, with
    every state as the run computed it and the derived quantities NaN (it raised a raw
    KeyboardInterrupt and lost the run)."""
    import dalembert.solvers.running.execute as execute_module

    times = np.linspace(0, PERIOD, 21)
    plain = pendulum.simulate((0, PERIOD), Q0, t_eval=times, backend=backend)
    real = execute_module._outputs

    def pressed(segment, t, y, dynamics=True):
        if len(t):
            raise KeyboardInterrupt
        return real(segment, t, y, dynamics=dynamics)

    monkeypatch.setattr(execute_module, "_outputs", pressed)
    with pytest.warns(IntegrationWarning, match="while the outputs were computed"):
        traj = pendulum.simulate((0, PERIOD), Q0, t_eval=times, backend=backend)
    assert traj.status == "interrupted"
    np.testing.assert_array_equal(traj.t, plain.t)
    np.testing.assert_array_equal(traj.q, plain.q)
    np.testing.assert_array_equal(traj.qd, plain.qd)
    assert np.isnan(traj.energy).all() and np.isnan(traj.multipliers).all()
