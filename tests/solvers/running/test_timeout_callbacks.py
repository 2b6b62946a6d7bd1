"""``simulate(timeout=)`` inside a function of the user's that never returns: an input
(a controller) or an event function spinning forever is stopped by the run's watchdog
(:mod:`dalembert.solvers.running.watchdog`), in the main thread and in any other, on
both loops; the run ends with status ``"timeout"`` and keeps the steps before.

A real Ctrl-C in such a function is served at once too, on both loops.

Before, such a run never returned (the limit was checked only between steps). What
the kept part is checked against: the same control law written in SymPy inside the
model (no input, no callback), run over the same output times.
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import textwrap
import threading
import time

import numpy as np
import pytest
import sympy as sp

from dalembert import IntegrationWarning, System, coordinates

BACKENDS = ["c", "python"]
(theta,) = coordinates("theta")
u = sp.Symbol("u")
KP, KD = 20.0, 4.0
TIMES = np.linspace(0.0, 2.0, 21)
#: The time from which the functions below never return.
T_HANG = 0.5


def pendulum(law=None) -> System:
    """A unit pendulum pushed by the torque ``u``, or by ``law`` itself."""
    return System([theta], kinetic=theta.diff() ** 2 / 2, potential=-9.81 * sp.cos(theta),
                  generalized_forces={theta: u if law is None else law},
                  inputs=[u] if law is None else [])


@pytest.fixture(scope="module")
def system() -> System:
    return pendulum()


@pytest.fixture(scope="module")
def reference():
    """The PD law inside the model (no callback), at every output time."""
    return pendulum(-KP * theta - KD * theta.diff()).simulate((0, 2), {theta: 1.0},
                                                              t_eval=TIMES)


def spin() -> None:
    while True:
        pass


def controller(t, q, qd):
    """The PD law, which never returns from ``T_HANG`` on."""
    if t > T_HANG:
        spin()
    return -KP * q[0] - KD * qd[0]


def stubborn(t, q, qd):
    """The PD law, which swallows the first stop from ``T_HANG`` on and spins again."""
    if t > T_HANG:
        try:
            spin()
        except BaseException:  # what a careless controller does
            spin()
    return -KP * q[0] - KD * qd[0]


def crossing(t, q, qd):
    """An event function that never returns from ``T_HANG`` on."""
    if t > T_HANG:
        spin()
    return q[0]


def _check_kept(traj, reference, function: str) -> None:
    """Status timeout, the function named, the steps before kept and right."""
    assert traj.status == "timeout" and not traj.success
    assert f"while a function of yours, {function} (test_timeout_callbacks.py:" in \
        traj.message
    k = len(traj.t)
    assert k >= 4 and traj.t[-1] <= T_HANG
    assert np.array_equal(traj.t, TIMES[:k])
    assert np.abs(traj.q - reference.q[:k]).max() < 1e-9
    assert np.abs(traj.qd - reference.qd[:k]).max() < 1e-9


@pytest.mark.parametrize("backend", BACKENDS)
def test_an_input_that_never_returns_ends_the_run_as_a_timeout(system, reference, backend,
                                                              time_bound):
    with time_bound(30.0), pytest.warns(IntegrationWarning, match=(
            r"the run's time limit \(timeout=\) passed while a function of yours")):
        traj = system.simulate((0, 2), {theta: 1.0}, inputs=controller, t_eval=TIMES,
                               backend=backend, timeout=0.5)
    _check_kept(traj, reference, "spin")
    np.testing.assert_allclose(traj.input("u"), -KP * traj.q[:, 0] - KD * traj.qd[:, 0],
                               rtol=1e-13, atol=1e-13)


@pytest.mark.parametrize("backend", BACKENDS)
def test_an_event_that_never_returns_ends_the_run_as_a_timeout(system, reference, backend,
                                                              time_bound):
    with time_bound(30.0), pytest.warns(IntegrationWarning, match="timeout="):
        traj = system.simulate((0, 2), {theta: 1.0}, inputs=lambda t, q, qd: -KP * q[0] -
                               KD * qd[0], events=[crossing], t_eval=TIMES,
                               backend=backend, timeout=0.5)
    _check_kept(traj, reference, "spin")


@pytest.mark.parametrize("backend", BACKENDS)
def test_a_function_that_catches_the_stop_is_stopped_again(system, reference, backend,
                                                          time_bound):
    with time_bound(30.0), pytest.warns(IntegrationWarning, match="timeout="):
        traj = system.simulate((0, 2), {theta: 1.0}, inputs=stubborn, t_eval=TIMES,
                               backend=backend, timeout=0.3)
    _check_kept(traj, reference, "spin")


@pytest.mark.parametrize("backend", BACKENDS)
def test_a_run_in_another_thread_is_stopped_too(system, reference, backend, time_bound):
    """Signals reach only the main thread; the watchdog reaches any."""
    got = {}

    def run() -> None:
        import warnings
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", IntegrationWarning)
            got["traj"] = system.simulate((0, 2), {theta: 1.0}, inputs=controller,
                                          t_eval=TIMES, backend=backend, timeout=0.5)

    worker = threading.Thread(target=run, daemon=True)
    with time_bound(30.0):
        worker.start()
        worker.join(25.0)
    assert not worker.is_alive()
    _check_kept(got["traj"], reference, "spin")


def test_a_run_that_returns_in_time_leaves_nothing_armed(system, reference):
    """After a run within its limit nothing is raised later in the thread (a pending
    stop is withdrawn with the run)."""
    from dalembert.solvers.running import watchdog

    traj = system.simulate((0, 2), {theta: 1.0}, inputs=lambda t, q, qd: -KP * q[0] -
                           KD * qd[0], t_eval=TIMES, timeout=0.05 + 1e-3)
    assert traj.status in ("finished", "timeout")
    end = time.monotonic() + 3 * watchdog.GRACE
    while time.monotonic() < end:  # Python instructions, where a stray stop would land
        pass
    assert not watchdog._monitor()._armed


CHILD = textwrap.dedent("""
    import json, sys, time, warnings
    import numpy as np
    import sympy as sp
    from dalembert import System, coordinates
    warnings.simplefilter("ignore")
    (theta,) = coordinates("theta")
    u = sp.Symbol("u")
    system = System([theta], kinetic=theta.diff() ** 2 / 2,
                    potential=-9.81 * sp.cos(theta), generalized_forces={theta: u},
                    inputs=[u])

    def hanging(name):
        def function(t, q, qd):
            if t > 0.5:
                print("go", name, flush=True)
                while True:
                    pass
            return -q[0] if name.endswith("input") else q[0]
        return function

    for name in ("c-input", "python-input", "c-event", "python-event"):
        backend, kind = name.split("-")
        options = {"inputs": hanging(name)} if kind == "input" else \\
            {"inputs": 0.0, "events": [hanging(name)]}
        system.simulate((0, 0.1), {theta: 1.0}, backend=backend, inputs=0.0)  # warm
        traj = system.simulate((0, 2), {theta: 1.0}, backend=backend,
                               t_eval=np.linspace(0, 2, 21), **options)
        end = time.monotonic()
        print(json.dumps({"name": name, "status": traj.status, "end": end,
                          "last": float(traj.t[-1])}), flush=True)
""")


@pytest.mark.skipif(not hasattr(signal, "SIGINT") or os.name != "posix",
                    reason="sends SIGINT to a child process")
def test_ctrl_c_in_a_function_that_never_returns_is_served_at_once(time_bound):
    """A real Ctrl-C (SIGINT) while an input or an event function spins forever, in the C
    loop and in the Python loop: each run returns "interrupted" with the steps before,
    within a second."""
    child = subprocess.Popen([sys.executable, "-c", CHILD], stdout=subprocess.PIPE,
                             text=True)
    try:
        with time_bound(120):
            for name in ("c-input", "python-input", "c-event", "python-event"):
                assert child.stdout.readline().split() == ["go", name]
                time.sleep(0.3)
                child.send_signal(signal.SIGINT)
                sent = time.monotonic()
                result = json.loads(child.stdout.readline())
                assert result["name"] == name and result["status"] == "interrupted"
                assert result["end"] - sent < 1.0 and 0.3 <= result["last"] <= 0.5
    finally:
        child.kill()
        child.wait()
