"""The SciPy internals the adapter relies on still exist (a SciPy release may move them).

``pyproject.toml`` bounds SciPy below the next release; before raising the bound,
this test says which private name or attribute moved.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import BDF, DOP853, RK23, RK45, Radau

from dalembert.solvers.steppers import scipy_ivp


def decay(t, y):
    return -y


@pytest.mark.parametrize("cls", [RK23, RK45, DOP853])
def test_runge_kutta_attributes(cls):
    solver = cls(decay, 0.0, np.ones(2), 1.0)
    solver.step()
    assert isinstance(solver, scipy_ivp.RungeKutta)
    for name in ("h_abs", "h_previous", "f", "K", "A", "B", "C", "P", "n_stages",
                 "error_estimator_order", "t_old", "y_old", "_estimate_error_norm"):
        assert hasattr(solver, name), f"{cls.__name__} has no {name!r}"
    if cls is DOP853:
        for name in ("K_extended", "A_EXTRA", "C_EXTRA", "D", "E3", "E5"):
            assert hasattr(solver, name), f"DOP853 has no {name!r}"
        assert solver.D.shape[0] == scipy_ivp.INTERPOLATOR_POWER - 3
    else:
        assert hasattr(solver, "E")


def test_step_constants_and_functions():
    assert 0 < scipy_ivp.MIN_FACTOR < 1 < scipy_ivp.MAX_FACTOR
    assert 0 < scipy_ivp.SAFETY < 1


@pytest.mark.parametrize("cls", [RK23, RK45, DOP853])
def test_tableau_of_reads_a_consistent_method(cls):
    """The coefficients tableau_of reads satisfy the order conditions a tableau must:
    rows of A summing to C, weights B summing to 1, error weights E summing to 0."""
    tb = scipy_ivp.tableau_of(cls)
    assert tb.order == cls.order and tb.n_stages == cls.n_stages
    assert np.allclose(tb.A.sum(axis=1), tb.C, atol=1e-14)
    assert abs(tb.B.sum() - 1) < 1e-14 and abs(tb.E.sum()) < 1e-14
    assert abs(tb.B @ tb.C - 0.5) < 1e-14  # second order
    assert (tb.P is None) == (cls is DOP853) == (tb.D is not None)


@pytest.mark.parametrize("cls", [BDF, Radau, DOP853])
def test_restart_continues_from_the_given_state(cls):
    """After a restart the solver integrates from the new state: exp(-t) from 0.5."""
    solver = cls(decay, 0.0, np.ones(1), 2.0, rtol=1e-10, atol=1e-12)
    solver.step()
    t1 = solver.t
    scipy_ivp.restart(solver, 0.5 * np.exp(-t1) * np.ones(1))
    while solver.status == "running":
        solver.step()
    assert abs(solver.y[0] - 0.5 * np.exp(-2.0)) < 1e-8


@pytest.mark.parametrize("cls", [RK23, RK45, DOP853])
def test_dense_output_attributes(cls):
    """What interpolant_form reads of the explicit solvers' interpolants."""
    solver = cls(decay, 0.0, np.ones(2), 1.0)
    solver.step()
    dense = solver.dense_output()
    kind, y_old, rows = scipy_ivp.interpolant_form(dense)
    assert kind == ("dop853" if cls is DOP853 else "power")
    assert np.array_equal(y_old, np.ones(2)) and rows.shape[1] == 2
    implicit = Radau(decay, 0.0, np.ones(2), 1.0)
    implicit.step()
    assert scipy_ivp.interpolant_form(implicit.dense_output()) is None


class _ScipysOwnStep(scipy_ivp.SteppedRadau):
    """A SteppedRadau whose take_step is SciPy's own step, read back from a twin."""

    def __init__(self, *args, **kwargs) -> None:
        super().__init__(*args, **kwargs)
        self.twin = Radau(*args, **kwargs)

    def take_step(self, t, y, f, h_abs):
        twin = self.twin
        twin.step()
        return scipy_ivp.RadauEnd(twin.t_old, twin.y_old, twin.t, twin.y, twin.f, twin.Z,
                                  twin.h_abs, twin.h_abs_old, twin.error_norm_old)


def test_stepped_radau_continues_as_scipys_radau():
    """The attributes a SteppedRadau writes after a step are the ones SciPy's Radau reads:
    its dense output and its state agree with SciPy's own step by step."""
    solver = _ScipysOwnStep(decay, 0.0, np.ones(2), 1.0, rtol=1e-6, atol=1e-9)
    assert 0 < solver.newton_tolerance < 0.03 and solver.tolerances.atol.shape == (2,)
    for _ in range(3):
        solver.step()
        twin = solver.twin
        assert (solver.t, solver.t_old, solver.h_abs) == (twin.t, twin.t_old, twin.h_abs)
        t = 0.5 * (solver.t_old + solver.t)
        assert np.array_equal(solver.dense_output()(t), twin.dense_output()(t))
        assert np.array_equal(solver.sol(t), twin.sol(t))  # the next step's Newton guess
