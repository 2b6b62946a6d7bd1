"""Whole stretches of the simulation loop in C (``dl_rk_run``) against the step-by-step loop.

Reference: the same simulation with the plan's ``stretches`` switched off, where
Python takes every step (the native step, the projection, the outputs, the
restart). Both must take the same steps with the same evaluations; the states at
step ends are the same computation, the interpolated outputs agree to rounding.
"""

from __future__ import annotations

import dataclasses
import signal
import warnings

import numpy as np
import pytest

from dalembert.examples import load
from dalembert.multibody import chain
from dalembert.solvers.native import NativeSolver, run
from dalembert.solvers.native.run import StretchRunner
from dalembert.solvers.projection import StepProjector

T_END = 3.0
#: As defined (the tests wrap them).
RUN, PROJECT, ARGUMENTS = StretchRunner.run, StepProjector.__call__, \
    NativeSolver.projection_arguments


def hanging(n: int, joint: str):
    """A chain tilted from the vertical, spinning about the horizontal."""
    mb = chain(n, 1.0, 1.0, 0.05, joint=joint)
    names = [b.name for b in mb.bodies]
    c, s = np.cos(np.pi / 6), np.sin(np.pi / 6)
    tilt = np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])
    centers = np.outer(np.arange(n) + 0.5, tilt @ [0, 0, -1.0])
    w = np.array([0.0, 0.2, 0.0]) if joint == "revolute" else np.array([0.2, 0.0, 0.0])
    q0, qd0 = mb.initial_state(
        positions=dict(zip(names, centers)), orientations=dict.fromkeys(names, tilt),
        velocities={k: np.cross(w, ck) for k, ck in zip(names, centers)},
        angular_velocities=dict.fromkeys(names, w))
    return mb.system, {"q0": q0, "qd0": qd0}


@pytest.fixture(scope="module")
def chains():
    return {"spherical": hanging(4, "spherical"), "revolute": hanging(5, "revolute")}


def simulate(system, initial, *, stretches: bool, **options):
    options = {"t_span": (0.0, T_END), "rtol": 1e-6, "atol": 1e-8, **options}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        plan = system.plan(**initial, **options)
        assert plan.stretches or plan.options.output.events or plan.options.output.dense_output
        return system.run(dataclasses.replace(plan, stretches=plan.stretches and stretches))


def states(traj) -> np.ndarray:
    return np.hstack([traj.q, traj.qd])


def assert_same(fast, slow, tol=1e-12):
    assert fast.stats == slow.stats
    assert (fast.status, fast.message) == (slow.status, slow.message)
    assert np.array_equal(fast.t, slow.t)
    reference = states(slow)
    assert np.abs(states(fast) - reference).max() <= tol * np.abs(reference).max()


def both(system, initial, **options):
    return [simulate(system, initial, stretches=s, **options) for s in (True, False)]


@pytest.mark.parametrize("joint", ["spherical", "revolute"])
@pytest.mark.parametrize("method", ["DOP853", "RK45", "RK23"])
def test_same_as_step_by_step(chains, joint, method):
    system, initial = chains[joint]
    ends_fast, ends_slow = both(system, initial, method=method)
    assert ends_fast.stats["n_steps"] > 10
    # Step ends are the same computation in both loops: equal to the last bit.
    assert_same(ends_fast, ends_slow, tol=0.0)
    # Outputs at t_eval: the same evaluations (DOP853's interpolant costs three per step
    # with an output time inside), the interpolated states to rounding.
    fast, slow = both(system, initial, method=method, t_eval=np.linspace(0.0, T_END, 31))
    assert_same(fast, slow)
    assert fast.stats["n_steps"] == ends_fast.stats["n_steps"]


@pytest.mark.parametrize("method", ["DOP853", "RK45"])
def test_outputs_on_step_ends_are_the_projected_ends(chains, method):
    system, initial = chains["spherical"]
    ends = simulate(system, initial, stretches=True, method=method)
    picked = ends.t[[0, 3, 4, 9, -1]]  # t0, two adjacent step ends, the last (T_END)
    inside = [0.5 * (ends.t[5] + ends.t[6]), 0.123]
    t_eval = np.sort(np.concatenate([picked, inside]))
    fast, slow = both(system, initial, method=method, t_eval=t_eval)
    assert_same(fast, slow)
    on_ends = np.isin(fast.t, picked)
    assert on_ends.sum() == len(picked)
    assert np.array_equal(states(fast)[on_ends], states(ends)[np.isin(ends.t, picked)])
    # Only steps with an output time strictly inside make DOP853's interpolant.
    steps_with_inside = len(np.unique(np.searchsorted(ends.t, inside)))
    extra = 3 if method == "DOP853" else 0
    assert fast.stats["nfev"] == ends.stats["nfev"] + extra * steps_with_inside


def test_backward_in_time(chains):
    system, initial = chains["revolute"]
    t_eval = np.linspace(T_END, 0.0, 13)
    fast, slow = both(system, initial, t_span=(T_END, 0.0), t_eval=t_eval)
    assert fast.success and np.array_equal(fast.t, t_eval)
    assert_same(fast, slow)
    fast, slow = both(system, initial, t_span=(T_END, 0.0))
    assert fast.t[-1] == 0.0
    assert_same(fast, slow, tol=0.0)


def counting(real, counts: dict, result=None):
    """``real`` counting its calls (those returning ``result``, if given) in ``counts``."""

    def wrapped(*args):
        value = real(*args)
        counts[real] = counts.get(real, 0) + (result is None or value == result)
        return value

    return wrapped


def test_short_calls_and_full_buffers_change_nothing(chains, monkeypatch):
    system, initial = chains["spherical"]
    t_eval = np.linspace(0.0, T_END, 301)  # several outputs in most steps
    whole = simulate(system, initial, stretches=True, t_eval=t_eval)
    counts: dict = {}
    monkeypatch.setattr(StretchRunner, "run", counting(RUN, counts))
    monkeypatch.setattr(run, "MAX_STEPS", 2)
    piecewise = simulate(system, initial, stretches=True, t_eval=t_eval)
    assert counts[RUN] >= whole.stats["n_steps"] / 2
    assert_same(piecewise, whole, tol=0.0)
    # A buffer of 4 rows: calls end when it is full, and a step with more outputs
    # than that is taken by the step-by-step loop.
    counts.clear()
    monkeypatch.setattr(StretchRunner, "run", counting(RUN, counts, False))
    monkeypatch.setattr(run, "MAX_STEPS", 1 << 62)
    monkeypatch.setattr(run, "ROWS", (4, 4))
    tight = simulate(system, initial, stretches=True, t_eval=t_eval)
    assert 0 < counts[RUN] < whole.stats["n_steps"]
    assert_same(tight, whole)


@pytest.mark.parametrize("name", ["rolling-disk", "closed-chain"])
def test_gallery_examples(name):
    module = load(name)
    system = module.build()
    t_eval = np.linspace(0.0, module.T_END, 41)
    fast, slow = both(system, module.INITIAL, t_span=(0.0, module.T_END), t_eval=t_eval,
                      rtol=1e-9, atol=1e-11)
    assert fast.success
    assert_same(fast, slow)
    assert fast.position_residual.max() < 1e-12


@pytest.mark.parametrize("t_eval", [None, np.linspace(0.0, T_END, 31)])
def test_projection_failure_falls_back_to_python(chains, monkeypatch, t_eval):
    """C projections allowed one Newton iteration and a rounding-level residual fail
    now and then (at step ends, at outputs); those steps must go to the step-by-step
    loop, where the Python projector takes over, exactly as without stretches."""
    system, initial = chains["spherical"]

    def strict(self):
        mask, _, _, position_tol, _ = ARGUMENTS(self)
        return mask, 1, 0, position_tol, 1e-15

    monkeypatch.setattr(NativeSolver, "projection_arguments", strict)
    counts: dict = {}
    monkeypatch.setattr(StepProjector, "__call__", counting(PROJECT, counts))
    monkeypatch.setattr(StretchRunner, "run", counting(RUN, counts, False))
    options = {"rtol": 1e-4, "atol": 1e-6, "t_eval": t_eval}
    fast = simulate(system, initial, stretches=True, **options)
    handed_back, fallbacks = counts[RUN], counts[PROJECT]
    assert 0 < handed_back < fast.stats["n_steps"]
    counts.clear()
    slow = simulate(system, initial, stretches=False, **options)
    assert counts[PROJECT] == fallbacks
    assert_same(fast, slow)


def test_interrupt_keeps_the_stretches_done(chains, monkeypatch):
    """Ctrl-C lands after a call to C returns: the steps of that call are kept."""
    system, initial = chains["spherical"]
    whole = simulate(system, initial, stretches=True)
    calls = {"n": 0}

    def impatient(self, *budget):
        done = RUN(self, *budget)
        calls["n"] += 1
        if calls["n"] == 3:
            raise KeyboardInterrupt
        return done

    monkeypatch.setattr(run, "MAX_STEPS", 4)
    monkeypatch.setattr(StretchRunner, "run", impatient)
    traj = simulate(system, initial, stretches=True)
    assert traj.status == "interrupted"
    assert traj.stats["n_steps"] == 12 and len(traj) == 13
    assert f"t={traj.t[-1]:.6g}" in traj.message
    assert np.array_equal(states(traj), states(whole)[:13])


@pytest.mark.skipif(not hasattr(signal, "setitimer"), reason="needs POSIX interval timers")
def test_a_signal_during_a_call_interrupts(chains, monkeypatch):
    """A real signal (standing in for Ctrl-C) that arrives while C runs: Python raises
    KeyboardInterrupt when the call returns, and every step done is kept."""
    system, initial = chains["spherical"]

    def ctrl_c(signum, frame):
        raise KeyboardInterrupt

    def arm_then_run(self, *budget):  # the timer starts with the first call to C
        if not signal.getitimer(signal.ITIMER_REAL)[0]:
            signal.setitimer(signal.ITIMER_REAL, 0.02)
        return RUN(self, *budget)

    monkeypatch.setattr(StretchRunner, "run", arm_then_run)
    previous = signal.signal(signal.SIGALRM, ctrl_c)
    try:
        traj = simulate(system, initial, stretches=True, t_span=(0.0, 1e4))
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, previous)
    assert traj.status == "interrupted"
    assert 0 < traj.t[-1] < 1e4 and traj.stats["n_steps"] == len(traj) - 1 > 0
    assert traj.position_residual.max() < 1e-12
