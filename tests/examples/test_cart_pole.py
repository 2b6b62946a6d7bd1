"""The cart-pole balanced by a digital LQR designed from ``linearize_joints``.

References: the discrete closed loop's eigenvalues (inside the unit circle); the pole's
return to upright from the example's 0.2 rad tilt; and, from a small tilt, the simulated
samples against the linear discrete model's prediction ``x_k = (Ad - Bd K)^k x_0``,
which the nonlinear motion must follow to second order in the tilt. (``A`` and ``B``
themselves are checked against the textbook cart-pole in
``tests/multibody/test_mb_joint_control.py``.)
"""

from __future__ import annotations

import numpy as np
import pytest

from dalembert.examples import cart_pole as example
from dalembert.multibody import joint_positions, joint_velocities


@pytest.fixture(scope="module")
def mb():
    return example.build_multibody()


def test_the_closed_loop_is_stable(mb):
    d = example.design(mb)
    radius = np.abs(np.linalg.eigvals(d.closed_loop)).max()
    assert radius < 1  # measured 0.980
    assert np.abs(np.linalg.eigvals(d.A)).max() > 3  # the open loop is not: upright falls


def test_the_pole_returns_upright_from_a_tilt(mb):
    traj = mb.simulate((0.0, example.T_END), **example.INITIAL,
                       t_eval=np.linspace(0.0, example.T_END, 61))
    assert traj.success and traj.stats["n_samples"] >= example.T_END / example.SAMPLE_TIME
    checks = example.checks(mb.system, traj)
    assert checks["final pole tilt (rad)"] < 2e-3  # measured 3.0e-4 after 6 s, from 0.2
    assert checks["final cart position (m)"] < 2e-2  # measured 4.2e-3
    # the force is held between samples: one value per sample
    held = traj.inputs[:, 0]
    assert np.abs(held[0] - example.controller(0.0, traj.q[0], traj.qd[0])) < 1e-12


def test_the_response_near_upright_follows_the_linear_model(mb):
    tilt, samples = 0.01, 100
    d = example.design(mb)
    times = np.arange(samples + 1) * example.SAMPLE_TIME
    traj = mb.simulate((0.0, times[-1]), example.tilted(tilt), {},
                       inputs=example.controller, sample_time=example.SAMPLE_TIME,
                       t_eval=times)
    joints = list(example.JOINTS)
    simulated = np.hstack([joint_positions(mb, traj, joints=joints).array,
                           joint_velocities(mb, traj, joints=joints).array])
    x = np.array([0.0, tilt, 0.0, 0.0])
    predicted = [x]
    for _ in range(samples):
        x = d.closed_loop @ x
        predicted.append(x)
    error = np.abs(simulated - np.array(predicted)).max(axis=0) / np.abs(simulated).max(axis=0)
    # what the linear model leaves out is of second order in the tilt
    assert error.max() < 1e-3  # measured 6.1e-5 (relative to each state's range)
