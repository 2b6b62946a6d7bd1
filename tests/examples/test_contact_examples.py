"""The contact examples of the gallery against their closed forms.

Each example's ``checks`` compares with an independent answer written in the example
(the bouncing ball's impact times ``t_1 (1 + 2 sum e^j)`` and rest time
``t_1 (1 + e) / (1 - e)``; the slack string's angle ``cos(theta) = (2 g l - v0^2) /
(3 g l)`` and the parabola's catch; the cradle's impact times from the pendulum's
period ``4 sqrt(l / g) K(sin^2(theta0 / 2))``; the falling chain's horizontal
momentum, conserved on a frictionless table; the rolling sphere's ``5/7 v0`` from
``2 v0 / (7 mu g)`` and its angular momentum about the contact); here the same runs as a user makes
them, in both loops, and the simultaneous law on the cradle.
"""

from __future__ import annotations

import numpy as np
import pytest

from dalembert.examples import (
    bouncing_ball,
    falling_chain,
    newtons_cradle,
    rolling_sphere,
    slack_string,
)

LIMITS = {
    bouncing_ball: {"impact time error": 1e-10, "rest time error": 1e-5,
                    "energy lost per impact, error / first fall's energy": 1e-12,
                    "floor force at rest / weight - 1": 1e-12,
                    "deepest point below the floor": 1e-14},
    slack_string: {"slack angle error (rad)": 1e-10, "catch time error": 1e-10,
                   "energy lost at the catch, relative error": 1e-9,
                   "max position residual": 1e-12},
    newtons_cradle: {"velocities after the first impact, error": 1e-10,
                     "impact time error": 1e-9, "energy lost in the impacts": 1e-12,
                     "relative energy error": 1e-11},
    falling_chain: {"horizontal momentum, relative error": 1e-12,
                    "deepest point below the table": 1e-12,
                    "max rod length residual": 1e-12,
                    "height of the chain at the end": 1e-8},
    rolling_sphere: {"rolling speed / (5/7 v0) - 1": 1e-12,
                     "rolling starts, error (s)": 1e-12,
                     "angular momentum about the contact, relative error": 1e-12,
                     "deepest point below the floor": 1e-14},
}


@pytest.mark.parametrize("example", list(LIMITS), ids=lambda m: m.__name__.split(".")[-1])
@pytest.mark.parametrize("backend", ["c", "python"])
def test_checks_within_limits(example, backend):
    system = example.build()
    traj = system.simulate((0.0, example.T_END), **example.INITIAL, backend=backend)
    assert traj.success, traj.message
    measured = example.checks(system, traj)
    assert set(measured) == set(LIMITS[example])
    for name, limit in LIMITS[example].items():
        assert measured[name] < limit, (name, measured[name])


def test_cradle_simultaneous_shares_the_motion():
    system = newtons_cradle.build()
    traj = system.simulate((0.0, 1.0), **newtons_cradle.INITIAL, impact_law="simultaneous")
    after = traj.contacts.impacts[0].qd_after[:newtons_cradle.COUNT]
    v = traj.contacts.impacts[0].qd_before[0]  # the first ball, level at the bottom
    # the first ball against the four others as one body, e = 1
    assert np.abs(after - v * np.array([-0.6, 0.4, 0.4, 0.4, 0.4])).max() < 1e-10
