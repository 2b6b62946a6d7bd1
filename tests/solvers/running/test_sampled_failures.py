"""A sampled input (``sample_time=``) that fails or never returns between segments ends
the run there, keeping the points before, as one inside a segment does.

The kept part is checked against the same digital controller run without the fault
(the reference), over the same output times.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest
import sympy as sp

from dalembert import InputError, IntegrationWarning, System, coordinates

(theta,) = coordinates("theta")
u = sp.Symbol("u")
TIMES = np.linspace(0.0, 2.0, 21)
T_FAULT = 0.5


def pendulum() -> System:
    return System([theta], kinetic=theta.diff() ** 2 / 2, potential=-9.81 * sp.cos(theta),
                  generalized_forces={theta: u}, inputs=[u])


def law(t, q, qd):
    return -20.0 * q[0] - 4.0 * qd[0]


@pytest.fixture(scope="module")
def reference():
    return pendulum().simulate((0, 2), {theta: 1.0}, t_eval=TIMES, inputs=law,
                               sample_time=0.1)


@pytest.mark.parametrize("backend", ["c", "python"])
def test_a_sampled_input_that_raises_keeps_the_run_so_far(reference, backend):
    def faulty(t, q, qd):
        if t > T_FAULT:
            raise RuntimeError("sensor lost")
        return law(t, q, qd)

    with pytest.warns(IntegrationWarning, match="sensor lost"):
        traj = pendulum().simulate((0, 2), {theta: 1.0}, t_eval=TIMES, inputs=faulty,
                                   sample_time=0.1, backend=backend)
    assert traj.status == "failed" and "t=0.6" in traj.message
    kept = len(traj.t)
    assert 6 <= kept < len(TIMES)
    assert np.abs(traj.q - reference.q[:kept]).max() < 1e-12


@pytest.mark.parametrize("backend", ["c", "python"])
def test_a_sampled_input_that_never_returns_is_stopped_by_the_time_limit(reference,
                                                                          backend):
    def hanging(t, q, qd):
        if t > T_FAULT:
            while True:
                pass
        return law(t, q, qd)

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", IntegrationWarning)
        traj = pendulum().simulate((0, 2), {theta: 1.0}, t_eval=TIMES, inputs=hanging,
                                   sample_time=0.1, backend=backend, timeout=1.0)
    assert traj.status == "timeout" and "sampled" in traj.message
    kept = len(traj.t)
    assert 6 <= kept < len(TIMES)
    assert np.abs(traj.q - reference.q[:kept]).max() < 1e-12


def test_input_error_is_still_the_error_of_a_first_sample():
    def broken(t, q, qd):
        raise RuntimeError("no sensor")

    with pytest.raises(InputError, match="no sensor"):
        pendulum().simulate((0, 1), {theta: 1.0}, inputs=broken, sample_time=0.1)
