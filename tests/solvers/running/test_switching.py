"""``method="auto"``: DOP853 under Hairer's stiffness detector, switching to Radau.

References: the elastic pendulum of ``test_elastic_pendulum.py`` (checked there against
its polar-coordinate model at k = 1e3 and 1e6) at k = 1e8, integrated by DOP853 at rtol
1e-12 (the polar model's own reference takes minutes at this stiffness), for runs that
switch; DOP853's own run for one that does not; the detector's estimate against
``h |lambda|`` of a linear problem; the switch back, forced, against the same reference.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest
from scipy.integrate import DOP853

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from test_elastic_pendulum import T_END, TH0, build, cartesian, r0

from dalembert.examples import cartesian_pendulum
from dalembert.solvers.running import switching
from dalembert.solvers.steppers.scipy_ivp import ControlledDOP853
from dalembert.solvers.steppers.stiffness import StiffnessDetector

K = 1e8


@pytest.fixture(scope="module")
def elastic():
    system = build(K)
    q0 = dict(zip(("x", "y", "z"), cartesian(r0(K), TH0)))
    reference = system.simulate((0.0, T_END), q0, rtol=1e-12, atol=1e-14, t_eval=[T_END])
    return system, q0, end_of(reference)


def end_of(traj) -> np.ndarray:
    return np.array([traj[c][-1] for c in ("x", "y", "z")])


@pytest.mark.parametrize("backend", ["c", "python"])
def test_a_stiff_run_switches_to_radau_and_meets_the_reference(elastic, backend):
    """The spring's radial mode (1e4 rad/s, undamped) holds DOP853's steps at ``h |lambda|``
    about 1.4: the detector says stiff, Radau takes over (once), and the end meets the
    reference; far fewer steps than DOP853's."""
    system, q0, expected = elastic
    options = dict(rtol=1e-8, atol=1e-10, t_eval=[T_END], backend=backend)
    auto = system.simulate((0.0, T_END), q0, method="auto", **options)
    assert auto.success and auto.stats["n_switches"] == 1
    assert auto.stats["njev"] > 0  # Radau's Jacobians
    assert np.abs(end_of(auto) - expected).max() < 1e-8
    explicit = system.simulate((0.0, T_END), q0, method="DOP853", **{**options,
                                                                    "backend": "c"})
    assert auto.stats["n_steps"] < explicit.stats["n_steps"] / 3


def test_a_non_stiff_run_is_dop853s():
    """Without stiffness the run is DOP853's, step for step (the detector only watches)."""
    system = cartesian_pendulum.build()
    q0 = {"x": 0.6, "y": -0.8}
    auto = system.simulate((0, 2), q0, method="auto", t_eval=[2.0])
    explicit = system.simulate((0, 2), q0, t_eval=[2.0])
    assert auto.stats["n_switches"] == 0
    assert auto.stats["n_steps"] == explicit.stats["n_steps"]
    assert np.array_equal(auto.q, explicit.q)


def test_going_back_when_radau_does_not_pay(elastic, monkeypatch):
    """Where Radau's steps are not ``COST_RATIO`` times DOP853's the run goes back to
    DOP853 after the trial steps (forced here by an unreachable ratio), for good, and
    still meets the reference."""
    system, q0, expected = elastic
    monkeypatch.setattr(switching, "COST_RATIO", 1e9)
    traj = system.simulate((0.0, T_END), q0, method="auto", rtol=1e-8, atol=1e-10,
                           t_eval=[T_END])
    assert traj.success and traj.stats["n_switches"] == 2
    assert np.abs(end_of(traj) - expected).max() < 1e-8


def test_the_detector_measures_h_lambda():
    """On ``y' = -lambda y`` the estimate is ``h lambda``; a long run at DOP853's
    stability limit is called stiff, a smooth one is not."""
    lam = 1e4
    solver = ControlledDOP853(lambda t, y: -lam * y + np.cos(t), 0.0, np.array([0.0]), 1.0,
                              rtol=1e-6, atol=1e-9, detector=StiffnessDetector())
    for _ in range(60):
        solver.step()
    assert solver.stiff
    assert 6.1 < lam * solver.h_previous < 6.6  # at the edge of the stability region
    smooth = ControlledDOP853(lambda t, y: np.cos(t), 0.0, np.array([0.0]), 10.0,
                              rtol=1e-6, atol=1e-9, detector=StiffnessDetector())
    while smooth.status == "running":
        smooth.step()
    assert not smooth.stiff
    assert issubclass(ControlledDOP853, DOP853)


def test_auto_needs_the_pi_controller(elastic):
    system, q0, _ = elastic
    with pytest.raises(ValueError, match="step_control='PI'"):
        system.simulate((0.0, 0.1), q0, method="auto", step_control="scipy")
