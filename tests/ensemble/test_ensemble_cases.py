"""Case tables: the grid's combinations, seeded sampling, the columns checked at the door."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from scipy import stats

from dalembert import EnsembleError
from dalembert.ensemble import grid, sample
from dalembert.ensemble.cases import read_cases


def test_grid_is_every_combination_first_axis_slowest():
    cases = grid(l=[1.0, 2.0, 3.0], theta=[0.1, 0.2])
    expected = [[l, th] for l in (1.0, 2.0, 3.0) for th in (0.1, 0.2)]  # nested loops
    assert cases.columns.tolist() == ["l", "theta"]
    assert cases.to_numpy().tolist() == expected


@pytest.mark.parametrize("axes", [{}, {"l": []}, {"l": [[1.0, 2.0]]}, {"l": ["long"]}])
def test_grid_refuses_what_is_not_a_list_of_numbers(axes):
    with pytest.raises(EnsembleError, match="grid"):
        grid(**axes)


def test_sample_draws_from_one_seeded_generator_column_by_column():
    dist = {"m": stats.uniform(0.9, 0.2), "theta": stats.norm(0.5, 0.1), "g": 9.81}
    cases = sample(dist, 50, seed=12)
    rng = np.random.default_rng(12)  # the same draws made by hand, in the same order
    m = stats.uniform(0.9, 0.2).rvs(size=50, random_state=rng)
    theta = stats.norm(0.5, 0.1).rvs(size=50, random_state=rng)
    assert np.array_equal(cases["m"], m) and np.array_equal(cases["theta"], theta)
    assert (cases["g"] == 9.81).all()
    assert cases.equals(sample(dist, 50, seed=12))
    assert not np.array_equal(sample(dist, 50, seed=13)["m"], m)


def test_sample_takes_functions_and_joint_distributions():
    joint = stats.multivariate_normal([1.0, 2.0], [[1.0, 0.9], [0.9, 1.0]])
    cases = sample({("a", "b"): joint, "c": lambda rng, n: rng.integers(1, 4, n)}, 4000,
                   seed=3)
    assert cases.columns.tolist() == ["a", "b", "c"]
    assert abs(np.corrcoef(cases["a"], cases["b"])[0, 1] - 0.9) < 0.02
    assert set(cases["c"]) == {1.0, 2.0, 3.0}


@pytest.mark.parametrize("args, match", [
    (({"m": stats.norm()}, 0, 1), "positive whole number"),
    (({"m": stats.norm()}, 5, "seed"), "integer seed"),
    (({}, 5, 1), "dict"),
    (({("a", "b"): stats.norm()}, 5, 1), "1 value\\(s\\) per case for 2 name"),
])
def test_sample_refuses_bad_arguments(args, match):
    with pytest.raises(EnsembleError, match=match):
        sample(*args)


def test_columns_are_sorted_into_parameters_positions_velocities_inputs():
    cases = read_cases(pd.DataFrame({"l": [1.0], "x": [0.1], "x_dot": [0.0], "u": [2.0]}),
                       ["g", "l", "m"], ["x", "y"], None, ["u"])
    assert cases.columns.parameters == ("l",)
    assert cases.columns.positions == ("x",)
    assert cases.columns.velocities == ("x_dot",)
    assert cases.columns.inputs == ("u",)


def test_a_column_naming_nothing_is_refused_by_name():
    with pytest.raises(EnsembleError, match="'lenght' is not a parameter \\(g, l, m\\)"):
        read_cases([{"lenght": 1.0}], ["g", "l", "m"], ["x", "y"], None)
    # with an initial_state function, the column is one of its variables
    cases = read_cases([{"angle": 1.0}], ["g", "l", "m"], ["x", "y"], lambda case: None)
    assert cases.columns.other == ("angle",)


@pytest.mark.parametrize("cases, match", [
    ([], "no cases"),
    ([{"l": 1.0}, {"m": 2.0}], "every case must give the same names"),
    ([{"l": "long"}], "not a number"),
    ("l=1", "DataFrame"),
])
def test_bad_case_tables(cases, match):
    with pytest.raises(EnsembleError, match=match):
        read_cases(cases, ["l", "m"], ["x"], None)
