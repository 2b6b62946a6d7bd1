"""Radau IIA stepping in C on the KKT structure (``solvers/native/radau.c``).

References: SciPy's own Radau step (``LinearizedRadau``: SciPy's Newton iteration, error
estimate and step control, on the Python solve of the same reduced systems, itself
checked against central differences in ``test_newton.py``) taking the same steps from
the same state, on a quaternion body, Pfaffian rows, dependent rows, a stiff damped
spring and a chain; whole runs against tight DOP853 references; the choice of the C
stepper where its exact Jacobian applies and of the Python one where it does not.
"""

from __future__ import annotations

import numpy as np
import pytest
from test_jacobian import stiff_double_pendulum
from test_newton import cases, hanging, swinging_chain

from dalembert.solvers.native import NativeRadau, NativeSolver
from dalembert.solvers.native.radau import newton_tables
from dalembert.solvers.newton import kkt_linearization
from dalembert.solvers.running.run_data import start_run
from dalembert.solvers.steppers.scipy_ivp import LinearizedRadau


def both_solvers(system, y0, t0, kept, t_bound, **options):
    """The C stepper and SciPy's Radau on the same reduced systems, from ``(t0, y0)``,
    both evaluating the C loop's right-hand side."""
    num = system.numeric()
    num.compiled.functions["residual_jacobians"]  # generated before the C model
    native = NativeSolver(num, 0.0, kept)
    c_radau = NativeRadau(native.rhs, t0, y0, t_bound, native=native, **options)
    scipy_radau = LinearizedRadau(native.rhs, t0, y0, t_bound,
                                  linearize=kkt_linearization(num, kept), **options)
    return c_radau, scipy_radau


@pytest.mark.parametrize("rtol", [1e-4, 1e-8])
def test_the_c_steps_are_scipys(rtol):
    """From the same state, the C stepper takes SciPy's steps (sizes, rejections,
    Jacobians and factorizations: the same counts) to rounding, and the two solutions
    agree far below the tolerance.

    To rounding: the two solve the same linear systems by different factorizations,
    and Radau's error estimate cancels (``f + Z E / h``, ``Z E / h`` close to ``-f``), so
    their error norms differ by about 1e-13 relative (1e-8 at ``rtol = 1e-8``), and the
    step-size controller, fed its own past steps, carries that on: after 25 steps the
    step ends are up to 2e-7 relative apart. The solutions are compared at one time
    inside both last steps (measured: within 1.2e-5 of the tolerance; asserted 1e-3)."""
    for name, system, traj, kept in cases():
        y0 = np.concatenate([traj.q[-1], traj.qd[-1]])
        t0 = float(traj.t[-1])
        c_radau, scipy_radau = both_solvers(system, y0, t0, kept, t0 + 0.5, rtol=rtol,
                                            atol=rtol / 100)
        for _ in range(25):
            if c_radau.status != "running":
                break
            c_radau.step()
            scipy_radau.step()
            assert c_radau.t == pytest.approx(scipy_radau.t, rel=1e-6), name
        assert (c_radau.nlu, c_radau.njev, c_radau.nfev) == \
            (scipy_radau.nlu, scipy_radau.njev, scipy_radau.nfev), name
        # the dense output is SciPy's, made from the C step's stages
        t = 0.5 * (max(c_radau.t_old, scipy_radau.t_old) + min(c_radau.t, scipy_radau.t))
        tolerance = rtol / 100 + rtol * np.abs(scipy_radau.y)
        difference = c_radau.dense_output()(t) - scipy_radau.dense_output()(t)
        assert np.max(np.abs(difference) / tolerance) < 1e-3, name


def test_the_band_holds_a_chain_in_a_narrow_band():
    """The reduced matrix of a chain, in reverse Cuthill-McKee order, has a band whose
    width does not grow with the chain: a step costs time linear in the links."""
    widths = []
    for links in (4, 16, 64):
        num = swinging_chain(links).system.numeric()
        num.compiled.functions["residual_jacobians"]
        band = newton_tables(NativeSolver(num)).struct
        size = band.N
        assert size == 5 * links  # three coordinates and two joint rows a link
        widths.append((band.kl, band.ku))
    assert widths[0] <= widths[1] == widths[2]


def test_a_stiff_spring_meets_the_reference_in_c():
    """A stiff damped spring (k = 1e6) in the C loop: the C stepper is the one chosen
    (whole stretches of its steps in C),
    and the run meets a tight DOP853 reference."""
    system, q0 = stiff_double_pendulum()
    plan = system.plan((0, 1), q0, method="Radau", backend="c")
    assert plan.stepper is NativeRadau and plan.stretches
    reference = system.simulate((0, 1), q0, rtol=1e-12, atol=1e-14, t_eval=[1.0])
    traj = system.simulate((0, 1), q0, method="Radau", rtol=1e-8, atol=1e-10, t_eval=[1.0],
                           backend="c")
    assert traj.status == "finished"
    assert np.abs(traj.q[-1] - reference.q[-1]).max() < 1e-9
    assert traj.stats["njev"] > 0 and traj.stats["nlu"] > 0


def test_a_long_chain_meets_the_reference_in_c():
    """24 planar links in the C loop against a tight DOP853 reference."""
    mb = swinging_chain(24)
    traj = mb.simulate((0, 0.4), hanging(24), method="Radau", rtol=1e-8, atol=1e-10,
                       t_eval=[0.4], backend="c")
    reference = mb.simulate((0, 0.4), hanging(24), rtol=1e-12, atol=1e-14, t_eval=[0.4])
    assert np.abs(traj.q[-1] - reference.q[-1]).max() < 1e-7


def test_the_python_stepper_where_the_exact_jacobian_does_not_apply():
    """Baumgarte's terms have no exact Jacobian here: Radau then takes SciPy's steps
    on the forward-difference Jacobian, in the Python solver (the C loop's rhs)."""
    system, q0 = stiff_double_pendulum()
    plan = system.plan((0, 1), q0, method="Radau", backend="c", stabilization="baumgarte")
    assert plan.stepper is None and plan.solver is LinearizedRadau


def test_a_run_state_is_per_run():
    """Two runs of one model share the band tables, not their state."""
    system, q0 = stiff_double_pendulum()
    plan = system.plan((0, 0.1), q0, method="Radau", backend="c")
    first, second = start_run(plan), start_run(plan)
    assert newton_tables(first.native) is newton_tables(second.native)
    a = first.integrate((0.0, 0.1), plan.y0, None, False)
    b = second.integrate((0.0, 0.1), plan.y0, None, False)
    assert np.array_equal(a.y[-1], b.y[-1])


@pytest.mark.parametrize("t_eval", [None, np.linspace(0.0, 1.0, 11)])
def test_stretches_in_c_take_the_steps_of_the_step_by_step_loop(t_eval):
    """Whole stretches of Radau steps in C (step, projection, outputs from the step's
    interpolant, restart from ``f`` at the projected end) give the steps and outputs of
    the loop that sees every step in Python (dense output asked for: no stretches)."""
    system, q0 = stiff_double_pendulum()
    options = dict(method="Radau", rtol=1e-8, atol=1e-10, t_eval=t_eval, backend="c")
    assert system.plan((0, 1), q0, **options).stretches
    assert not system.plan((0, 1), q0, **options, dense_output=True).stretches
    stretches = system.simulate((0, 1), q0, **options)
    stepwise = system.simulate((0, 1), q0, **options, dense_output=True)
    assert stretches.stats == stepwise.stats
    assert np.array_equal(stretches.t, stepwise.t)
    assert np.abs(stretches.q - stepwise.q).max() < 1e-13
    assert np.abs(stretches.qd - stepwise.qd).max() < 1e-11
