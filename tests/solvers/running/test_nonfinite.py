"""NaN and infinity in a simulation: every run ends, says what is not finite and where,
and returns the steps before.

These inputs used to loop forever (a NaN step size never falls below the smallest
step; in C even Ctrl-C could not stop it), or stopped with a traceback from the
KKT solve. Each run here is under a time bound, so a regression fails instead of
hanging the suite. What is checked against: the culprit the test put in (the force
that is NaN, the gain, the velocity that overflows), the time it was put at, and
for a force undefined past ``x = 1.5`` the closed-form time the particle gets there.
"""

from __future__ import annotations

import dataclasses
import warnings

import numpy as np
import pytest
import sympy as sp

from dalembert import Holonomic, InitialConditionError, IntegrationWarning, System, coordinates
from dalembert import t as time_symbol
from dalembert.options import Baumgarte, simulation_options
from dalembert.solvers.native import run as native_run
from dalembert.solvers.running.plan import plan_simulation

x, y = coordinates("x y")
BACKENDS = ["c", "python"]
#: Seconds a run here may take (they take milliseconds).
BOUND = 20.0


def on_a_line(force) -> System:
    """A unit mass on the line y = 2x under a force along x: M and A are constant, so a
    NaN force reaches the accelerations without the KKT solve noticing."""
    return System([x, y], kinetic=(x.diff() ** 2 + y.diff() ** 2) / 2,
                  generalized_forces={x: force}, constraints=[Holonomic(y - 2 * x, name="line")])


@pytest.fixture(scope="module")
def pendulum() -> System:
    return System([x, y], kinetic=(x.diff() ** 2 + y.diff() ** 2) / 2, potential=9.81 * y,
                  constraints=[Holonomic(x**2 + y**2 - 1, name="rod")])


def failed(run) -> object:
    with pytest.warns(IntegrationWarning) as record:
        traj = run()
    assert traj.status == "failed" and not traj.success
    assert str(record[0].message).startswith(traj.message)
    assert np.all(np.isfinite(traj.q)) and np.all(np.isfinite(traj.qd))
    return traj


@pytest.mark.parametrize("backend", BACKENDS)
@pytest.mark.parametrize("method", ["DOP853", "RK45", "Radau"])
def test_a_force_nan_at_the_start(time_bound, backend, method):
    """Not finite at the start: refused at the door, naming the force (no loop runs)."""
    system = on_a_line(sp.sqrt(x - 2))  # NaN for x < 2
    with time_bound(BOUND), pytest.raises(InitialConditionError,
                                          match="the generalized force on 'x' is nan"):
        system.simulate((0, 1), [0.5, 1.0], backend=backend, method=method)


@pytest.mark.parametrize("backend", BACKENDS)
@pytest.mark.parametrize("stretches", [True, False])
def test_a_nan_first_step(time_bound, pendulum, backend, stretches):
    # the door refuses first_step=nan; the loops must not depend on it
    plan = pendulum.plan((0, 1), [1, 0], backend=backend)
    plan = dataclasses.replace(plan, solver_options={**plan.solver_options,
                                                     "first_step": float("nan")},
                               stretches=plan.stretches and stretches)
    with time_bound(BOUND):
        traj = failed(lambda: pendulum.run(plan))
    assert traj.message == ("integration stopped at t=0: the step size is not finite "
                            "(first_step is NaN, or the derivative at the start is not finite)")
    assert len(traj) == 1


@pytest.mark.parametrize("backend", BACKENDS)
def test_a_nan_baumgarte_gain(time_bound, pendulum, backend):
    options = simulation_options((0, 1), stabilization="baumgarte", backend=backend)
    options = dataclasses.replace(options, stabilization=Baumgarte(float("nan")))
    plan = plan_simulation(pendulum.numeric(), pendulum.consistent_initial_state([1, 0]),
                           options)
    with time_bound(BOUND):
        traj = failed(lambda: pendulum.run(plan))
    assert traj.message.startswith("integration stopped at t=0: the Baumgarte gain is nan")


@pytest.mark.parametrize("backend", BACKENDS)
def test_velocities_that_overflow(time_bound, pendulum, backend):
    """c = -qd^T (d2 psi / dq2) qd = -2 |qd|^2 = -inf at the start: refused at the door,
    naming the constraint and the velocity."""
    with time_bound(BOUND), pytest.raises(
            InitialConditionError, match=r"the acceleration term c of constraint 'rod' is "
            r"-inf.*largest \|qd\|: 1e\+200 for y_dot"):
        pendulum.simulate((0, 1), [1, 0], [0, 1e200], backend=backend)


@pytest.mark.parametrize("backend", BACKENDS)
@pytest.mark.parametrize("method", ["DOP853", "RK23"])
def test_a_force_undefined_ahead(time_bound, backend, method):
    """The force sqrt(1.5 - x) is NaN past x = 1.5: steps that cross it are rejected and
    shrink until they cannot, then the run stops at x = 1.5 with the steps before."""
    system = on_a_line(sp.sqrt(sp.Rational(3, 2) - x))
    with time_bound(BOUND):
        traj = failed(lambda: system.simulate((0, 10), [0, 0], [1, 2], backend=backend,
                                              method=method, rtol=1e-8, atol=1e-10))
    assert "the derivative was not finite within the step at every step size tried" \
        in traj.message
    # Along the line (y = 2x: T = 5/2 x'^2) 5 x'' = sqrt(1.5 - x), so from x' = 1 at x = 0
    # 5/2 (x'^2 - 1) = 2/3 (1.5^1.5 - (1.5 - x)^1.5): x reaches 1.5 at t* = int dx / x'
    from scipy.integrate import quad

    t_star = quad(lambda s: 1 / np.sqrt(1 + 4 / 15 * (1.5**1.5 - (1.5 - s) ** 1.5)), 0, 1.5)[0]
    assert abs(traj.t[-1] - t_star) < 1e-5 and abs(traj["x"][-1] - 1.5) < 1e-5
    assert f"t={traj.t[-1]:.6g}" in traj.message


def test_the_c_step_refuses_what_is_not_finite(time_bound, pendulum):
    """dl_rk_step and dl_rk_run hand a NaN step size or derivative back to Python at
    once: before, a NaN step size was retried forever inside one call to C."""
    plan = pendulum.plan((0, 1), [1, 0], backend="c")
    data = plan.start()
    solver = plan.solver(data.rhs, 0.0, plan.y0, 1.0, **data.solver_options)
    runner = native_run.StretchRunner(solver, None)
    with time_bound(BOUND):
        for name, value in [("h_abs", float("nan")), ("f", np.full(4, np.nan))]:
            good = getattr(solver, name)
            setattr(solver, name, value)
            assert runner.run() is False and runner.take()[0] == 0
            assert solver._step_impl() == (False, "the step would start from values that "
                                           "are not finite")
            setattr(solver, name, good)
    assert runner.run() is True


def test_model_nan_inside_a_step_does_not_end_a_healthy_run(time_bound):
    """A step whose trial stages leave the model's domain is rejected and retried
    smaller, as SciPy does; the run goes on when a smaller step stays inside."""
    # force -x / sqrt(1 - x^2): oscillates inside |x| < 1, NaN outside; a first step
    # that overshoots |x| = 1 is cut back
    system = on_a_line(-x / sp.sqrt(1 - x**2 / 4))
    with time_bound(BOUND), warnings.catch_warnings():
        warnings.simplefilter("error", IntegrationWarning)
        traj = system.simulate((0, 5), [0, 0], [1, 2], first_step=3.0, rtol=1e-9, atol=1e-11)
    assert traj.success and np.abs(traj["x"]).max() < 2


@pytest.mark.parametrize("backend", BACKENDS)
def test_a_force_turning_nan_mid_run_on_a_pendulum_is_named_in_both_loops(time_bound,
                                                                         backend):
    """sqrt(1.5 - t) on a pendulum, whose rod row depends on the state: the stages past
    t = 1.5 go NaN and so does A there. The C loop called that a singular KKT matrix; both
    loops now say the derivative was not finite, and stop at t = 1.5."""
    system = System([x, y], kinetic=(x.diff() ** 2 + y.diff() ** 2) / 2, potential=9.81 * y,
                    generalized_forces={x: sp.sqrt(sp.Rational(3, 2) - time_symbol)},
                    constraints=[Holonomic(x**2 + y**2 - 1, name="rod")])
    with time_bound(BOUND):
        traj = failed(lambda: system.simulate((0, 3), {x: 1.0, y: 0.0}, backend=backend))
    assert "the derivative was not finite within the step" in traj.message
    assert "singular" not in traj.message.split("or the motion")[0]
    assert abs(traj.t[-1] - 1.5) < 1e-6


@pytest.mark.parametrize("backend", BACKENDS)
def test_a_time_span_near_the_largest_float_is_named(time_bound, pendulum, backend):
    with time_bound(BOUND):
        traj = failed(lambda: pendulum.simulate((1e300, 1.5e300), {x: 1.0, y: 0.0},
                                                backend=backend))
    assert "the derivative was not finite within the step" in traj.message
    assert "KKT matrix" not in traj.message
