"""Step-size control: SciPy's controller reproduced exactly, PI control at the
stability boundary, the choice checked and carried through simulate."""

import numpy as np
import pytest
from scipy.integrate import DOP853, RK23, RK45, Radau

from dalembert.options import STEP_CONTROLS, simulation_options
from dalembert.solvers.running.integrate import integrate
from dalembert.solvers.steppers.scipy_ivp import CONTROLLED, controlled_class

METHODS = [DOP853, RK45, RK23]


def run(cls, fun, y0, t_end, **options):
    """Every step end of ``cls``; ``(t, y, rejected attempts, nfev)``."""
    solver = cls(fun, 0.0, np.asarray(y0, float), t_end, **options)
    start, ts, ys = solver.nfev, [0.0], [solver.y]
    while solver.status == "running":
        solver.step()
        ts.append(solver.t)
        ys.append(solver.y)
    attempts = (solver.nfev - start) // solver.n_stages  # each costs n_stages evaluations
    return np.array(ts), np.array(ys), attempts - (len(ts) - 1), solver.nfev


def van_der_pol(t, y):
    return np.array([y[1], 5.0 * (1 - y[0] ** 2) * y[1] - y[0]])


@pytest.mark.parametrize("cls", METHODS)
def test_scipy_control_takes_scipys_steps(cls):
    """The controlled step under step_control="scipy" is SciPy's, bit for bit."""
    options = dict(rtol=1e-6, atol=1e-9)
    ours = run(CONTROLLED[cls], van_der_pol, [2.0, 0.0], 20.0, step_control="scipy", **options)
    ref = run(cls, van_der_pol, [2.0, 0.0], 20.0, **options)
    assert ref[2] > 10  # the comparison covers rejected steps
    assert np.array_equal(ours[0], ref[0]) and np.array_equal(ours[1], ref[1])
    assert ours[2:] == ref[2:]


def fast_mode(t, y):
    """A slow oscillator (period 2 pi) and a fast one (200 rad/s) at an amplitude below
    the tolerance: accuracy asks nothing of the fast mode, stability bounds the step."""
    return np.array([y[1], -200.0**2 * y[0], y[3], -y[2]])


@pytest.mark.parametrize("cls", METHODS)
def test_pi_control_damps_rejections_at_the_stability_boundary(cls):
    options = dict(rtol=1e-4, atol=1e-7)
    y0 = [1e-9, 0.0, 0.0, 1.0]
    t, y, rejected, nfev = {}, {}, {}, {}
    for control in STEP_CONTROLS:
        t[control], y[control], rejected[control], nfev[control] = run(
            CONTROLLED[cls], fast_mode, y0, 20.0, step_control=control, **options)
    # Measured: 227 -> 29 (DOP853), 1088 -> 165 (RK45), 973 -> 334 (RK23) rejections.
    assert rejected["scipy"] > 100
    assert rejected["PI"] < 0.4 * rejected["scipy"]
    # The slow mode as accurate, the fast one kept at its size (stable steps).
    assert abs(y["PI"][-1, 2] - np.sin(20.0)) < 1e-6
    assert np.abs(y["PI"][:, 0]).max() < 1e-6


@pytest.mark.parametrize("cls", METHODS)
def test_pi_control_saves_evaluations_at_the_stability_boundary(cls):
    """Fewer evaluations in all over fast modes of several sizes. One size alone is a
    poor sample: where the fast mode sits against the tolerance decides how many
    steps either controller takes, and that shifts with the last bit of rounding
    (one amplitude took 25% more steps under PI on one processor, fewer on another)."""
    options = dict(rtol=1e-4, atol=1e-7)
    nfev = dict.fromkeys(STEP_CONTROLS, 0)
    for amplitude in np.geomspace(3e-10, 3e-9, 5):
        for control in STEP_CONTROLS:
            nfev[control] += run(CONTROLLED[cls], fast_mode, [amplitude, 0.0, 0.0, 1.0],
                                 20.0, step_control=control, **options)[3]
    # Measured: 0.84 (DOP853), 0.83 (RK45), 0.85 (RK23).
    assert nfev["PI"] < 0.9 * nfev["scipy"]


def test_unknown_step_control_names_the_choices():
    with pytest.raises(ValueError, match=r"'step_control' parameter of simulate must be one "
                                         r"of 'PI', 'scipy'; got 'PID'"):
        simulation_options((0.0, 1.0), step_control="PID")


def test_implicit_methods_keep_their_own_control():
    assert controlled_class(Radau, "PI") is Radau
    result = integrate(lambda t, y: -y, (0.0, 1.0), np.ones(1), method=Radau)
    assert result.success and abs(result.y[-1, 0] - np.exp(-1.0)) < 1e-5
