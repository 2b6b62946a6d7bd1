"""The linkage imported from MJCF: degrees of freedom counted by hand, the energy
balance with the motor's work, the loop closed to rounding."""

from __future__ import annotations

import numpy as np
import pytest

from dalembert.examples import imported_linkage as example

pytestmark = pytest.mark.filterwarnings("error::dalembert.errors.InitialConditionsAdjusted")


@pytest.fixture(scope="module")
def run():
    system = example.build()
    traj = system.simulate((0.0, 2.0), **example.INITIAL, t_eval=np.linspace(0.0, 2.0, 201))
    return system, traj


def test_degrees_of_freedom_counted_by_hand():
    # hinge 1 + ball 3 + hinge 1 - connect 3: the linkage's one, the coupler's spin
    report = example.build().consistent_initial_state(example.INITIAL["q0"],
                                                      example.INITIAL["qd0"])
    assert not report.changed and report.dependent_constraints == []
    assert report.degrees_of_freedom == 2


def test_motor_work_balances_energy_and_the_loop_holds(run):
    system, traj = run
    measured = example.checks(system, traj)
    assert measured["relative energy balance error"] < 1e-8
    assert measured["max loop opening (m)"] < 1e-12
    # the motor turns the crank (not a run that stays at rest)
    assert np.ptp(example._crank_angle(traj)) > 1.0
