"""The arm imported from MJCF: degrees of freedom counted by hand, the energy balance
with the motor's work, the parallelogram's loop closed to rounding, its geometry in the
viewer."""

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
    # 4 hinges + ball 3 - connect 3: turret, shoulder, parallelogram, the rod's spin
    report = example.build().consistent_initial_state(example.INITIAL["q0"],
                                                      example.INITIAL["qd0"])
    assert not report.changed and report.dependent_constraints == []
    assert report.degrees_of_freedom == 4


def test_motor_work_balances_energy_and_the_loop_holds(run):
    system, traj = run
    measured = example.checks(system, traj)
    assert measured["relative energy balance error"] < 1e-8
    assert measured["max loop opening (m)"] < 1e-12
    # the motor turns the turret (not a run that stays at rest)
    assert np.ptp(example._turret_angle(traj)) > 0.5  # 0.8 rad in the 2 s run


def test_the_viewer_draws_the_model_geoms(run):
    """Every geom of the file is in the scene: 4 capsules (a cylinder and two balls
    each), 2 more capsules on the forearm, 2 cylinders and 2 boxes on bodies, and the
    base cylinder on the ground."""
    from dalembert.plotting.viewer import scene_of

    system, traj = run
    shapes = scene_of(traj, system).shapes
    moving = [s["kind"] for s in shapes if s["body"] >= 0]
    assert sorted(moving) == sorted(["cylinder"] * 7 + ["sphere"] * 10 + ["box"] * 2)
    assert [s["kind"] for s in shapes if s["body"] < 0 and s["kind"] == "cylinder"] == \
        ["cylinder"]
