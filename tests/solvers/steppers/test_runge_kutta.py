"""The explicit Runge-Kutta stepper on its contract, against SciPy's own solvers: the
same steps bit for bit under SciPy's controller, the same interpolants, the state of
the controller passed in and out."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import DOP853, RK23, RK45

from dalembert.solvers.steppers.controller import PIController
from dalembert.solvers.steppers.runge_kutta import ExplicitRungeKutta, controlled_step
from dalembert.solvers.steppers.scipy_ivp import tableau_of

METHODS = [DOP853, RK45, RK23]


def kepler(t, y):
    """A planar orbit of eccentricity 0.6: the step varies tenfold along it."""
    r3 = np.hypot(y[0], y[1]) ** 3
    return np.array([y[2], y[3], -y[0] / r3, -y[1] / r3])


Y0 = np.array([0.4, 0.0, 0.0, 2.0])  # perihelion of a = 1, e = 0.6


def our_steps(cls, t_end, rtol, atol, step_control="scipy"):
    """Every step of our stepper under the controller, from SciPy's first step."""
    reference = cls(kepler, 0.0, Y0, t_end, rtol=rtol, atol=atol)
    stepper = ExplicitRungeKutta(tableau_of(cls))
    controller = PIController.for_method(step_control, cls.error_estimator_order)
    state = controller.initial_state()
    t, y, f, h_abs = 0.0, Y0.copy(), kepler(0.0, Y0), reference.h_abs
    steps = []
    while t < t_end:
        out = controlled_step(stepper, controller, state, kepler, t, y, f, h_abs,
                              direction=1.0, t_bound=t_end, rtol=rtol, atol=atol)
        assert out.step is not None
        state, h_abs, step = out.state, out.h_abs, out.step
        steps.append(step)
        t, y, f = step.t_new, step.y_new, step.f_new
    return steps


@pytest.mark.parametrize("cls", METHODS)
def test_scipy_controller_takes_scipys_steps_bit_for_bit(cls):
    rtol, atol = 1e-7, 1e-10
    steps = our_steps(cls, 6.3, rtol, atol)  # one revolution
    solver = cls(kepler, 0.0, Y0, 6.3, rtol=rtol, atol=atol)
    ts, ys = [], []
    while solver.status == "running":
        solver.step()
        ts.append(solver.t)
        ys.append(solver.y)
    assert len(steps) == len(ts) > 10
    assert np.array_equal([s.t_new for s in steps], ts)
    assert np.array_equal(np.array([s.y_new for s in steps]), np.array(ys))


@pytest.mark.parametrize("cls", METHODS)
def test_interpolant_is_scipys_dense_output(cls):
    """Each step's interpolant against SciPy's dense output of the same step, inside
    the step and at its ends (where it must give the step's own states)."""
    solver = cls(kepler, 0.0, Y0, 1.0, rtol=1e-8, atol=1e-11)
    stepper = ExplicitRungeKutta(tableau_of(cls))
    for _ in range(5):
        t, y, f, h = solver.t, solver.y.copy(), solver.f.copy(), solver.h_abs
        solver.step()
        h = solver.t - t
        step = stepper.attempt(kepler, t, y, f, h, rtol=1e-8, atol=1e-11)
        assert np.array_equal(step.y_new, solver.y)
        ours, theirs = stepper.interpolant(kepler, step), solver.dense_output()
        for x in (0.0, 0.25, 0.5, 0.9, 1.0):
            s = t + x * h
            assert np.allclose(ours(s), theirs(s), rtol=0, atol=1e-15)
        assert np.allclose(ours(t + h), solver.y, rtol=0, atol=1e-14)


@pytest.mark.parametrize(("cls", "n"), [(DOP853, 5), (RK45, 80), (RK23, 40)])
def test_order_of_accuracy(cls, n):
    """Halving a fixed step divides the error of the orbit after one revolution's part
    by about 2^order: the tableau read is the method it names."""
    stepper = ExplicitRungeKutta(tableau_of(cls))
    exact = DOP853(kepler, 0.0, Y0, 0.5, rtol=1e-13, atol=1e-15)
    while exact.status == "running":
        exact.step()
    errors = []
    for steps in (n, 2 * n):  # coarse enough to stay above the reference's error
        y, h = Y0.copy(), 0.5 / steps
        for k in range(steps):
            y = stepper.attempt(kepler, k * h, y, kepler(k * h, y), h, rtol=1, atol=1).y_new
        errors.append(np.abs(y - exact.y).max())
    observed = np.log2(errors[0] / errors[1])
    assert abs(observed - cls.order) < 0.6


def test_controller_state_is_passed_in_and_out():
    """The same step from the same state gives the same answer (no hidden memory), and
    the PI controller's answer depends on the state it is given."""
    cls = RK45
    stepper = ExplicitRungeKutta(tableau_of(cls))
    pi = PIController.for_method("PI", cls.error_estimator_order)
    args = (kepler, 0.0, Y0, kepler(0.0, Y0), 0.05)
    options = dict(direction=1.0, t_bound=1.0, rtol=1e-8, atol=1e-10)
    first = controlled_step(stepper, pi, pi.initial_state(), *args, **options)
    again = controlled_step(stepper, pi, pi.initial_state(), *args, **options)
    assert first.h_abs == again.h_abs and first.state == again.state
    other = controlled_step(stepper, pi, type(first.state)(0.5), *args, **options)
    assert other.h_abs != first.h_abs


def test_too_small_step_is_reported():
    stepper = ExplicitRungeKutta(tableau_of(RK45))
    pi = PIController.for_method("PI", 4)
    broken = lambda t, y: np.full(1, np.nan)  # noqa: E731  (every stage after the first)
    out = controlled_step(stepper, pi, pi.initial_state(), broken, 0.0, np.ones(1),
                          -np.ones(1), 1.0, direction=1.0, t_bound=1.0, rtol=1e-8, atol=1e-10)
    assert out.step is None and out.h_abs < 1e-14  # shrunk by min_factor until too small
