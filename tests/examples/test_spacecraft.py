"""The spacecraft slew: a PD controller given as a Python function (a callback from the
C loop at every evaluation). References: the closed loop's Lyapunov function and the
angular momentum balance (quadratures of the recorded rates and torques, see the
example), and the same law written in SymPy inside the model."""

from __future__ import annotations

import numpy as np
import pytest
import sympy as sp

from dalembert import report
from dalembert.examples import spacecraft as example
from dalembert.multibody import Multibody, RigidBody, Torque
from dalembert.multibody.rotations import E_matrix


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    return report.run_example("spacecraft", tmp_path_factory.mktemp("craft"), points=2001,
                              animation=False)


def test_lyapunov_and_momentum_balances(run):
    checks = run.checks
    assert checks["Lyapunov decrease relative error (dW = -KD int |w|^2)"] < 1e-8
    assert checks["angular momentum change relative error (int tau dt)"] < 1e-8
    assert checks["final attitude error (rad)"] < 5e-3  # from 90 degrees
    assert "attitude.png" in [p.name for p in run.files]


def test_the_python_controller_equals_the_law_in_sympy(run):
    craft = RigidBody("craft", example.MASS, example.INERTIA)
    b = craft.quaternion
    omega = 2 * E_matrix(b) * b.diff()
    law = [-example.KP * sp.sign(b[0]) * b[k + 1] - example.KD * omega[k] for k in range(3)]
    same = Multibody([craft], torques=[Torque(craft, law, frame="body")], gravity=(0, 0, 0))
    reference = same.simulate((0, example.T_END), example.INITIAL["q0"],
                              example.INITIAL["qd0"], t_eval=run.trajectory.t)
    assert np.abs(run.trajectory.q - reference.q).max() < 1e-10
    # the torques the trajectory records are the law's
    torque = np.array([example.controller(t, q, qd) for t, q, qd in
                       zip(reference.t, reference.q, reference.qd)])
    np.testing.assert_allclose(run.trajectory.inputs, torque, atol=1e-9)
