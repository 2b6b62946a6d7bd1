"""The step-size controller as a value: PI.3.4's exponents, SciPy's as the special case,
the limits of one change, and the C steps reading the same values."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import RK23, RK45

from dalembert.solvers.steppers.controller import ControllerState, PIController


def test_exponents():
    # PI.3.4 (Gustafsson; Soderlind): alpha = 0.7 / k, beta = 0.4 / k, k = estimator order + 1.
    pi = PIController.for_method("PI", RK45.error_estimator_order)
    assert (pi.alpha, pi.beta) == pytest.approx((0.14, 0.08))
    scipy_like = PIController.for_method("scipy", RK23.error_estimator_order)
    assert (scipy_like.alpha, scipy_like.beta) == (1 / 3, 0.0)


def test_factors_follow_the_formula_within_limits():
    pi = PIController(alpha=0.14, beta=0.08)
    state = ControllerState(0.3)
    factor, new = pi.accepted(state, 0.5, rejected=False)
    assert factor == pytest.approx(0.9 * 0.5 ** -0.14 * 0.3 ** 0.08, rel=1e-15)
    assert new.err_old == 0.5 and state.err_old == 0.3  # the old state is not changed
    assert pi.accepted(state, 0.0, rejected=False)[0] == pi.max_factor
    assert pi.accepted(state, 1e-12, rejected=True)[0] == 1.0  # no growth after a rejection
    assert pi.accepted(state, 1e-12, rejected=False)[1].err_old == pi.error_floor
    assert pi.rejected(1e6) == pi.min_factor
    assert pi.rejected(np.nan) == pi.min_factor  # a stage that is not finite
    assert pi.rejected(2.0) == pytest.approx(0.9 * 2.0 ** -0.14)


def test_c_steps_read_the_controllers_values():
    """A controller with other constants changes the C steps as it changes the Python
    ones (C holds no constants of its own): both take the same steps under it, and
    other steps than under the default controller."""
    from dalembert.examples import load

    system = load("pendulum").build()
    plan = system.plan((0.0, 2.0), {"x": 1.0, "y": 0.0}, rtol=1e-6, atol=1e-9)
    if plan.loop != "c":
        pytest.fail(f"the C loop must run here: {plan.why_python}")
    python = system.plan((0.0, 2.0), {"x": 1.0, "y": 0.0}, rtol=1e-6, atol=1e-9,
                         backend="python")
    custom = PIController(alpha=0.0875, beta=0.05, safety=0.8, max_factor=1.5)

    def steps(p, controller):
        data = p.start()
        solver = p.solver(data.rhs, 0.0, p.y0, 2.0, controller=controller,
                          **data.solver_options)
        times = []
        while solver.status == "running":
            solver.step()
            times.append(solver.t)
        return np.array(times)

    c_custom, py_custom = steps(plan, custom), steps(python, custom)
    assert plan.solver.__name__.startswith("Native")
    assert len(c_custom) == len(py_custom)
    assert np.allclose(c_custom, py_custom, rtol=1e-7, atol=0)  # rounding, grown over the steps
    default = steps(plan, None)
    assert len(default) != len(c_custom)
