"""The contact events screened in C (``solvers/native/screens.py``): the segments of a
contact run take their steps in C stretches, and the steps where an event may fire are
handed to the Python loop, which locates it.

Reference: the same run with a user event that never fires added. A user event has no
screen, so every segment of that run takes its steps one by one in the Python loop,
evaluating each contact event at each step's end. Both runs must switch at the same
instants and give the same states: with DOP853 both loops take the same steps (the
same computation, so equal to rounding); with Radau the stretches hold the Newton
matrices differently, so they agree to the run's tolerance.
"""

from __future__ import annotations

import numpy as np
import pytest
import sympy as sp

from dalembert import System, Unilateral, coordinates
from dalembert.examples import slack_string
from dalembert.solvers.native import run as native_run

g = 9.81
X, Y, Z, TH = coordinates("x y z theta")


def never(t, q, qd):
    """A user event that never fires: its run steps in the Python loop."""
    return 1.0


@pytest.fixture
def both(monkeypatch):
    """``both(system, *args, **options)``: the run screened in C, and the run stepped
    in Python; the first must have run stretches of C with screens (the premise of
    the comparison), the second none."""
    stretches = []
    run = native_run._Stretches.run

    def counted(self, *args, **kwargs):
        stretches.append(self._screens is not None)
        return run(self, *args, **kwargs)

    monkeypatch.setattr(native_run._Stretches, "run", counted)

    def simulate_both(system: System, *args, **options):
        screened = system.simulate(*args, **options)
        assert any(stretches), "no stretch in C with screens"
        stretches.clear()
        stepped = system.simulate(*args, events=[never], **options)
        assert not stretches
        assert screened.success and stepped.success, (screened.message, stepped.message)
        return screened, stepped

    return simulate_both


def switches(traj) -> np.ndarray:
    return np.array([s.t for s in traj.contacts.switches])


def assert_same(screened, stepped, tol: float = 0.0) -> None:
    """The same switches and states (``tol``: relative, 0 for the same computation)."""
    assert [s.closed for s in screened.contacts.switches] == \
        [s.closed for s in stepped.contacts.switches]
    assert np.abs(switches(screened) - switches(stepped)).max() <= tol * (1.0 + stepped.t[-1])
    if tol == 0.0:
        assert screened.stats == stepped.stats
        assert np.array_equal(screened.t, stepped.t)
    scale = 1.0 + np.abs(stepped.q).max()
    assert np.abs(screened.q[-1] - stepped.q[-1]).max() <= max(tol, 1e-15) * scale


@pytest.mark.parametrize("method, tol", [("DOP853", 0.0), ("Radau", 1e-8)])
def test_a_slack_string_goes_slack_and_catches_as_in_the_python_loop(method, tol, both):
    """Separation on the tension (a multiplier) and catching on the gap (a position)."""
    system = slack_string.build()
    screened, stepped = both(system, (0.0, 6.0), method=method, **slack_string.INITIAL)
    assert len(screened.contacts.impacts) >= 1
    assert_same(screened, stepped, tol)


def test_a_bouncing_ball_hits_the_floor_at_the_same_instants(both):
    ball = System([Y], kinetic=Y.diff() ** 2 / 2, potential=g * Y,
                  constraints=[Unilateral(Y, name="floor", restitution=0.8)])
    screened, stepped = both(ball, (0.0, 3.0), {"y": 1.0}, t_eval=np.linspace(0, 3, 61))
    assert len(screened.contacts.impacts) > 5
    assert_same(screened, stepped)


def test_sliding_stops_where_the_rate_screen_and_the_python_loop_say(both):
    """A puck pushed sideways: its sliding velocity along its start direction (a rate
    of the model's rows) reaches 0, then it sticks; the cone screen watches it."""
    push = 0.15 * g
    puck = System([X, Y, Z], kinetic=(X.diff() ** 2 + Y.diff() ** 2 + Z.diff() ** 2) / 2,
                  potential=g * Y - push * Z,
                  constraints=[Unilateral(Y, name="floor", friction=0.3,
                                          tangents=[X.diff(), Z.diff()])])
    screened, stepped = both(puck, (0.0, 1.5), {"x": 0.0, "y": 0.0, "z": 0.0}, {"x": 2.0})
    assert len(screened.contacts.switches) == 2
    assert_same(screened, stepped)


def test_a_sticking_block_slips_where_its_force_leaves_the_cone(both):
    """A block pushed by ``k t``: the cone screen flags the step where ``k t`` passes
    ``mu m g``."""
    u = sp.Symbol("u")
    block = System([X, Y], kinetic=(X.diff() ** 2 + Y.diff() ** 2) / 2, potential=g * Y,
                   constraints=[Unilateral(Y, name="floor", friction=0.3,
                                           tangents=[X.diff()])],
                   inputs=[u], generalized_forces=[u, 0])
    screened, stepped = both(block, (0.0, 1.0), {"x": 0.0, "y": 0.0},
                             inputs={"u": lambda t: 5.0 * t})
    assert len(screened.contacts.switches) == 2
    assert_same(screened, stepped)


def test_a_rocking_block_with_dependent_corners_runs_as_in_the_python_loop(both):
    """Rocking and sliding (``mu = 0.1``) until it rests flat: on both corners its rows
    are dependent (a set whose multipliers are not the run's: C's screens make them the
    minimum-norm ones, ``test_screens_dependent.py``)."""
    from test_rough import block, tilted

    screened, stepped = both(block(0.1), (0.0, 2.5), tilted(-0.1))
    assert len(screened.contacts.impacts) >= 10
    assert screened.contacts.closed_at(screened.t[-1:]).all()
    assert_same(screened, stepped)
