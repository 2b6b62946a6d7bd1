"""Ctrl-C before a run starts (a t_eval of 1e7 times takes a second or more to check):
a KeyboardInterrupt saying that nothing ran and nothing is lost, not one raised from
deep inside NumPy's conversion with its traceback."""

from __future__ import annotations

import numpy as np
import pytest

from dalembert.examples import load


class InterruptedTimes:
    """A sequence of times whose conversion a Ctrl-C interrupts (at element ``at``)."""

    def __init__(self, size: int, at: int) -> None:
        self.size, self.at = size, at

    def __len__(self) -> int:
        return self.size

    def __getitem__(self, k: int) -> float:
        if k < 0 or k >= self.size:
            raise IndexError(k)
        if k == self.at:
            raise KeyboardInterrupt
        return k / self.size


@pytest.fixture(scope="module")
def pendulum():
    return load("pendulum").build()


def test_ctrl_c_while_t_eval_is_checked_says_nothing_ran(pendulum):
    with pytest.raises(KeyboardInterrupt) as info:
        pendulum.simulate((0.0, 1.0), {"x": 1.0, "y": 0.0}, t_eval=InterruptedTimes(1000, 500))
    assert str(info.value) == ("simulate was interrupted while its arguments were checked, "
                               "before it ran: nothing was lost")
    assert info.value.__suppress_context__


def test_ctrl_c_while_the_initial_state_is_made_consistent_says_nothing_ran(pendulum,
                                                                          monkeypatch):
    from dalembert import system as system_module

    def interrupted(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(system_module, "consistent_state", interrupted)
    with pytest.raises(KeyboardInterrupt, match=r"^simulate was interrupted while its "
                                                r"arguments were checked and its initial "
                                                r"state made consistent, before it ran"):
        pendulum.simulate((0.0, 1.0), {"x": 1.0, "y": 0.0}, t_eval=np.linspace(0, 1, 3))
