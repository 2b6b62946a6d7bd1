"""Threads taking turns for their Python (dalembert.solvers.native.turns)."""

from __future__ import annotations

import threading
import time

import numpy as np
import pytest

from dalembert.examples import load
from dalembert.solvers.native.turns import outside_python, python_turn


def test_the_c_loop_lets_the_turn_go_while_it_runs():
    """A simulation in a thread holding the turn: another thread waiting for the turn
    gets it while the first one's C loop runs, and the first takes it back after."""
    pendulum = load("pendulum").build()
    pendulum.simulate((0, 0.1), {"x": 1.0, "y": 0.0})  # code loaded before the timing
    turns = threading.Lock()
    waiting, got = threading.Event(), []

    def other():
        waiting.set()
        with python_turn(turns):
            got.append(time.perf_counter())

    with python_turn(turns):
        thread = threading.Thread(target=other)
        thread.start()
        waiting.wait()
        traj = pendulum.simulate((0, 200.0), {"x": 1.0, "y": 0.0}, t_eval=[200.0],
                                 rtol=1e-12, atol=1e-14)
        finished = time.perf_counter()
        assert turns.locked()  # taken back
        assert traj.status == "finished"
    thread.join()
    assert got and got[0] < finished  # the other thread ran while this one was in C


def test_a_turn_is_let_go_when_the_block_raises():
    turns = threading.Lock()
    with pytest.raises(ValueError), python_turn(turns):
        with outside_python():
            assert not turns.locked()
        raise ValueError("inside")
    assert not turns.locked()


def test_results_on_threads_taking_turns_equal_those_alone():
    """Two threads taking turns give each simulation as it runs alone, to the bit."""
    pendulum = load("pendulum").build()
    starts = [{"x": np.sin(a), "y": -np.cos(a)} for a in np.linspace(0.2, 1.4, 6)]
    alone = [pendulum.simulate((0, 5.0), q0, t_eval=np.linspace(0, 5, 11)).q for q0 in starts]
    turns = threading.Lock()
    together: list[np.ndarray | None] = [None] * len(starts)

    def run(k: int) -> None:
        with python_turn(turns):
            together[k] = pendulum.simulate((0, 5.0), starts[k],
                                            t_eval=np.linspace(0, 5, 11)).q

    threads = [threading.Thread(target=run, args=(k,)) for k in range(len(starts))]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()
    for a, b in zip(alone, together):
        assert b is not None and np.array_equal(a, b)
