"""Inputs in an ensemble: a case column holding an input at the case's value, the other
inputs given once (``inputs=``), and the values applied kept over an ``input``
dimension.

References: the closed form of a bead pushed along a line (``pushed_bead``), the same
case simulated alone, and the control law evaluated on the kept states.
"""

from __future__ import annotations

import numpy as np
import pytest
from ensemble_models import brake, damper, pendulum, pushed_bead, ramp

from dalembert import EnsembleWarning, InputError
from dalembert.ensemble import grid
from dalembert.errors import EnsembleError

T_EVAL = np.linspace(0.0, 2.0, 21)
M = 2.0


@pytest.fixture(scope="module")
def bead():
    return pushed_bead()


@pytest.mark.parametrize("scheduler", ["serial", "threads"])
def test_an_input_column_holds_each_case_at_its_value(bead, scheduler):
    pushes = [-1.0, 0.0, 0.5, 3.0]
    result = bead.simulate_many((0.0, 2.0), grid(u=pushes), q0=[0.0, 0.0],
                                inputs={"v": ramp}, t_eval=T_EVAL, scheduler=scheduler,
                                keep=("q", "multipliers", "inputs"), progress=False)
    ds = result.dataset
    u = np.array(pushes)[:, None]
    t = T_EVAL[None, :]
    x = (u * t**2 / 2 + t**3 / 6) / (2 * M)  # x'' = (u + t) / (2 m) from rest
    assert np.abs(ds["q"].sel(coordinate="x").values - x).max() < 1e-12
    assert np.abs(ds["q"].sel(coordinate="y").values - x).max() < 1e-12
    assert np.abs(ds["multipliers"].sel(constraint="line").values - (t - u) / 2).max() < 1e-12
    np.testing.assert_array_equal(ds["inputs"].sel(input="u").values,
                                  np.broadcast_to(u, (4, len(T_EVAL))))
    np.testing.assert_allclose(ds["inputs"].sel(input="v").values,
                               np.broadcast_to(t, (4, len(T_EVAL))), rtol=0, atol=1e-15)
    assert ds["u"].values.tolist() == pushes  # the column, a coordinate along case


def test_each_case_equals_the_case_simulated_alone(bead):
    result = bead.simulate_many((0.0, 2.0), grid(u=[0.3, 2.0], m=[1.0, 4.0]),
                                q0=[0.1, 0.1], qd0=[1.0, 1.0], inputs={"v": brake},
                                t_eval=T_EVAL, scheduler="serial", progress=False)
    for case, row in enumerate(grid(u=[0.3, 2.0], m=[1.0, 4.0]).to_dict("records")):
        alone = bead.simulate((0.0, 2.0), [0.1, 0.1], [1.0, 1.0], parameters={"m": row["m"]},
                              inputs={"u": row["u"], "v": brake}, t_eval=T_EVAL)
        assert np.abs(result.dataset["q"].values[case] - alone.q).max() < 1e-12
        assert np.abs(result.dataset["qd"].values[case] - alone.qd).max() < 1e-12


def test_kept_inputs_are_the_law_applied_to_the_kept_states(bead):
    result = bead.simulate_many((0.0, 2.0), grid(u=[0.0, 1.0]), q0=[0.5, 0.5],
                                inputs={"v": brake}, t_eval=T_EVAL, keep=("q", "qd", "inputs"),
                                scheduler="serial", progress=False)
    ds = result.dataset
    law = -3.0 * ds["qd"].sel(coordinate="x").values - ds["q"].sel(coordinate="x").values
    np.testing.assert_allclose(ds["inputs"].sel(input="v").values, law, rtol=1e-14,
                               atol=1e-14)


def test_a_case_whose_input_is_not_finite_fails_alone(bead):
    with pytest.warns(EnsembleWarning, match="2 of 3 cases"):
        result = bead.simulate_many((0.0, 1.0), grid(u=[1.0, np.nan, np.inf]), q0=[0.0, 0.0],
                                    inputs={"v": 0.0}, scheduler="serial", progress=False)
    summary = result.summary
    assert summary["status"].tolist() == ["finished", "error", "error"]
    assert "the input 'u' must be a finite number, got nan" in summary["message"][1]
    assert abs(summary["final_x"][0] - 1.0 / (4 * M)) < 1e-12  # x'' = u / (2 m)


def test_inputs_given_wrongly_are_refused_before_anything_runs(bead):
    cases = grid(u=[1.0])
    with pytest.raises(EnsembleError, match="inputs= must then be a dict by input"):
        bead.simulate_many((0.0, 1.0), cases, q0=[0.0, 0.0], inputs=lambda t: [1.0, 2.0],
                           progress=False)
    with pytest.raises(InputError, match=r"the input\(s\) v have no values"):
        bead.simulate_many((0.0, 1.0), cases, q0=[0.0, 0.0], progress=False)
    with pytest.raises(EnsembleError, match=r"an input \(u, v\)"):
        bead.simulate_many((0.0, 1.0), grid(w=[1.0]), q0=[0.0, 0.0], inputs={"v": 0.0},
                           progress=False)
    with pytest.raises(EnsembleError, match="keep names 'inputs', but the model declares no"):
        pendulum().simulate_many((0.0, 1.0), grid(l=[1.0]), q0=[0.0, -1.0], keep=("inputs",),
                                 progress=False)


@pytest.mark.parametrize("scheduler", ["serial", "threads"])
def test_case_inputs_make_each_cases_controller(bead, scheduler):
    # v = -c y' on the line x = y: 2 m x'' = u - c x', from x' = 1 at rest position:
    # x' = u / c + (1 - u / c) exp(-c t / (2 m))
    cases = grid(c=[0.5, 2.0, 8.0], u=[0.0, 1.0])
    result = bead.simulate_many((0.0, 2.0), cases, q0=[0.0, 0.0], qd0=[1.0, 1.0],
                                case_inputs=damper, t_eval=T_EVAL, keep=("qd", "inputs"),
                                rtol=1e-10, atol=1e-12, scheduler=scheduler, progress=False)
    c, u = cases["c"].to_numpy()[:, None], cases["u"].to_numpy()[:, None]
    exact = u / c + (1 - u / c) * np.exp(-c * T_EVAL[None, :] / (2 * M))
    assert np.abs(result.dataset["qd"].sel(coordinate="x").values - exact).max() < 1e-9
    np.testing.assert_allclose(result.dataset["inputs"].sel(input="v").values,
                               -c * result.dataset["qd"].sel(coordinate="y").values,
                               rtol=1e-14, atol=1e-14)


def test_case_inputs_given_wrongly_are_refused(bead):
    cases = grid(c=[1.0])
    with pytest.raises(EnsembleError, match="not both"):
        bead.simulate_many((0.0, 1.0), cases, q0=[0.0, 0.0], case_inputs=damper,
                           inputs={"u": 0.0, "v": 0.0}, progress=False)
    with pytest.raises(EnsembleError, match="The 'case_inputs' parameter of simulate_many "
                       "must be a function or None; got"):
        bead.simulate_many((0.0, 1.0), cases, q0=[0.0, 0.0], case_inputs={"v": 0.0},
                           progress=False)
    with pytest.raises(EnsembleError, match="the model declares no inputs"):
        pendulum().simulate_many((0.0, 1.0), grid(l=[1.0]), q0=[0.0, -1.0],
                                 case_inputs=damper, progress=False)
    # an input left out fails each case, named
    with pytest.warns(EnsembleWarning, match="1 of 1 cases"):
        result = bead.simulate_many((0.0, 1.0), cases, q0=[0.0, 0.0], case_inputs=damper,
                                    scheduler="serial", progress=False)
    assert "the input(s) u have no values" in result.summary["message"][0]


def test_sampled_inputs_in_an_ensemble_equal_each_case_alone(bead):
    """``sample_time`` in an ensemble: the output times (ending at ``tf``, every one a
    sample instant) each recorded once, each case as simulated alone, and the inputs
    kept the samples taken at the kept states (the brake law on them)."""
    cases = grid(u=[0.3, 2.0])
    result = bead.simulate_many((0.0, 2.0), cases, q0=[0.1, 0.1], qd0=[1.0, 1.0],
                                inputs={"v": brake}, sample_time=0.1, t_eval=T_EVAL,
                                scheduler="serial", keep=("q", "qd", "inputs"),
                                progress=False)
    assert result.failed == []
    ds = result.dataset
    for case, row in enumerate(cases.to_dict("records")):
        alone = bead.simulate((0.0, 2.0), [0.1, 0.1], [1.0, 1.0],
                              inputs={"u": row["u"], "v": brake}, sample_time=0.1,
                              t_eval=T_EVAL)
        np.testing.assert_array_equal(alone.t, T_EVAL)
        assert np.abs(ds["q"].values[case] - alone.q).max() < 1e-12
        law = [brake(t, q, qd) for t, q, qd in zip(T_EVAL, ds["q"].values[case],
                                                    ds["qd"].values[case])]
        np.testing.assert_allclose(ds["inputs"].sel(input="v").values[case], law,
                                   rtol=1e-13, atol=1e-13)
