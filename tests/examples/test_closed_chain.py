"""The closed loop of six rods on spherical joints over 20 s: energy and constraints.

Independent answers: ``T + V`` evaluated from the bodies' states
(:func:`dalembert.multibody.energy`, not the model's energy expression) must stay
constant, both pins must hold, and the degrees of freedom counted by hand (6
links x 6 - 7 joints x 3 = 15) must match ``n - rank(A)``.
"""

from __future__ import annotations

import numpy as np
import pytest

from dalembert.examples import closed_chain as example
from dalembert.multibody import energy, point_positions

pytestmark = pytest.mark.filterwarnings("error::dalembert.errors.InitialConditionsAdjusted")

TIMES = np.linspace(0.0, example.T_END, 401)


@pytest.fixture(scope="module")
def mb():
    return example.build_multibody()  # derived once for the module


@pytest.fixture(scope="module")
def loop(mb):
    traj = mb.simulate((0.0, example.T_END), **example.INITIAL, t_eval=TIMES)
    return mb, traj


def test_degrees_of_freedom_counted_by_hand(mb):
    report = mb.system.consistent_initial_state(**example.INITIAL)
    assert not report.changed and report.dependent_constraints == []
    assert report.degrees_of_freedom == 6 * 6 - 7 * 3


@pytest.mark.validation
def test_energy_is_conserved_over_20_seconds(loop):
    mb, traj = loop
    assert traj.success and traj.t[-1] == example.T_END
    e = energy(mb, traj)
    assert np.abs(e - e[0]).max() / abs(e[0]) <= 1e-8  # measured 3.4e-13


@pytest.mark.validation
def test_the_loop_stays_closed(loop):
    mb, traj = loop
    assert traj.position_residual.max() <= 1e-12  # measured 1.0e-14
    end = point_positions(mb, traj, "link6", (0.0, 0.0, example.LENGTH / 2))
    assert np.abs(end - [example.SPAN, 0.0, 0.0]).max() <= 1e-12
    assert np.abs(traj["link3_y"]).max() > 0.1  # it did leave the plane


def test_checks_contract(loop):
    mb, traj = loop
    assert max(example.checks(mb.system, traj).values()) < 1e-8
