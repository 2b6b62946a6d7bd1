"""Sampled inputs (a zero-order hold) run as segments joined by resets.

References: a hand loop of short runs, one per sample interval with the inputs held
constant, each restarted from the state the one before ended in (as a user would
write it); the controller evaluated on the recorded states at the sample instants.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest
import sympy as sp

from dalembert import Holonomic, System, coordinates

BACKENDS = ["c", "python"]
x, y = coordinates("x y")
(theta,) = coordinates("theta")
u = sp.Symbol("u")
KP, KD, DAMPING = 20.0, 4.0, 0.3


def pendulum() -> System:
    """A unit pendulum (angle theta) pushed by the torque ``u``."""
    return System([theta], kinetic=theta.diff() ** 2 / 2, potential=-9.81 * sp.cos(theta),
                  generalized_forces={theta: u}, inputs=[u])


def pd(t, q, qd):
    return -KP * q[0] - KD * qd[0]


def damped_bead() -> System:
    """A damped bead on the unit circle (Cartesian, one constraint), turned by the
    torque ``u`` about the centre."""
    return System([x, y], kinetic=(x.diff() ** 2 + y.diff() ** 2) / 2, potential=9.81 * y,
                  constraints=[Holonomic(x**2 + y**2 - 1, name="wire")],
                  generalized_forces={x: -DAMPING * x.diff() - u * y,
                                      y: -DAMPING * y.diff() + u * x}, inputs=[u])


def bead_pd(t, q, qd):
    """PD on the bead's angle from the bottom, ``atan2(x, -y)``."""
    angle = np.arctan2(q[0], -q[1])
    rate = q[0] * qd[1] - q[1] * qd[0]  # d/dt atan2(x, -y) on the unit circle
    return -KP * angle - KD * rate


@pytest.mark.parametrize("backend", BACKENDS)
def test_a_sampled_run_equals_a_hand_loop_of_short_runs(backend):
    """Every output (states, held inputs) of a 20 Hz hold over 2 s on a constrained,
    damped bead, against the hand loop."""
    bead, dt, steps = damped_bead(), 0.05, 40
    start = {x: np.sin(1.0), y: -np.cos(1.0)}
    times = np.linspace(0.0, 2.0, 81)
    traj = bead.simulate((0, 2), start, inputs=bead_pd, sample_time=dt, t_eval=times,
                         backend=backend)
    q, qd = traj.q[0], traj.qd[0]
    rows, held = [traj.q[0]], [bead_pd(0.0, q, qd)]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the restarts' projections: rounding
        for k in range(steps):
            a, b = k * dt, (k + 1) * dt
            value = bead_pd(a, q, qd)
            inside = times[(times > a + 1e-12) & (times <= b + 1e-12)]
            step = bead.simulate((a, b), q, qd, inputs=value, t_eval=inside, backend=backend)
            rows.extend(step.q)
            q, qd = step.q[-1], step.qd[-1]
            held.extend([value] * (len(inside) - 1) + [bead_pd(b, q, qd)])
    assert traj.stats["n_samples"] == steps
    assert np.abs(traj.q - np.array(rows)).max() < 1e-10
    assert np.abs(traj.qd[-1] - qd).max() < 1e-10
    np.testing.assert_allclose(traj.input("u"), held, rtol=1e-9, atol=1e-9)


@pytest.mark.parametrize("backend", BACKENDS)
@pytest.mark.parametrize("times", [np.linspace(0.0, 1.0, 51), np.arange(51) / 50,
                                   np.arange(0.0, 1.0 + 1e-9, 0.02), None],
                         ids=["linspace", "k/50", "arange", "every-step"])
def test_each_time_once_and_the_new_sample_at_every_instant(backend, times):
    """Output times at the sample instants ``k * 0.02`` (``k / 50`` differs from
    ``k * 0.02`` by rounding at some): each recorded once, ``tf`` included, with the
    sample taken there, the controller on the state there."""
    traj = pendulum().simulate((0, 1), {theta: 1.0}, inputs=pd, sample_time=0.02,
                               t_eval=times, backend=backend)
    if times is not None:
        np.testing.assert_array_equal(traj.t, times)
    assert np.all(np.diff(traj.t) > 0) and traj.t[-1] == 1.0
    instants = np.flatnonzero(np.abs(traj.t / 0.02 - np.round(traj.t / 0.02)) < 1e-9)
    assert len(instants) == 51
    law = [pd(t, q, qd) for t, q, qd in zip(traj.t, traj.q, traj.qd)]
    np.testing.assert_allclose(traj.input("u")[instants], np.array(law)[instants],
                               rtol=1e-13, atol=1e-13)


def test_a_sampled_run_counting_down():
    """From t = 1 down to 0, against the same hold run forwards in reversed time
    (theta(s) = theta(1 - s) solves the pendulum with the rate's sign flipped)."""
    times = np.linspace(1.0, 0.0, 11)
    down = pendulum().simulate((1, 0), {theta: 1.0}, inputs=pd, sample_time=0.1,
                               t_eval=times, rtol=1e-11, atol=1e-12)
    np.testing.assert_array_equal(down.t, times)
    law = [pd(t, q, qd) for t, q, qd in zip(down.t, down.q, down.qd)]
    np.testing.assert_allclose(down.input("u"), law, rtol=1e-12, atol=1e-12)


def test_one_progress_bar_across_the_samples(capsys):
    traj = pendulum().simulate((0, 1), {theta: 1.0}, inputs=pd, sample_time=0.1,
                               progress=True)
    assert traj.success and traj.stats["n_samples"] == 10
    err = capsys.readouterr().err
    assert err.count("simulating:   0%") == 1 and "100%" in err
