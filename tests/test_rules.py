"""Keyword tables bound to signatures (:mod:`dalembert.rules`): a table that does not
match its function fails when the function is defined, a refused value is named at the
call, before the function runs; and the library's own doors are bound to tables that
name their keywords (checked here against the signatures and documented defaults)."""

from __future__ import annotations

import inspect

import pytest

from dalembert import EnsembleError, System
from dalembert.ensemble import simulate_many
from dalembert.options import simulation_options
from dalembert.rules import NONE, OneOf, PositiveNumber, checked_keywords
from dalembert.statics import equilibrium, linearize


def test_a_table_missing_a_keyword_fails_at_definition():
    with pytest.raises(TypeError, match=r"the parameter table of .*solve does not match "
                                        r"its signature: no rule for max_iter"):
        @checked_keywords({"tol": [PositiveNumber()]})
        def solve(x, *, tol=1e-9, max_iter=50):
            return x


def test_a_table_naming_a_keyword_the_function_lacks_fails_at_definition():
    with pytest.raises(TypeError, match="rules for rtol, which is not a keyword-only "
                                        "parameter"):
        @checked_keywords({"tol": [PositiveNumber()], "rtol": [PositiveNumber()]})
        def solve(x, *, tol=1e-9):
            return x


def test_a_positional_parameter_is_not_a_keyword_of_the_table():
    with pytest.raises(TypeError, match="rules for x, which is not a keyword-only"):
        @checked_keywords({"x": [PositiveNumber()], "tol": [PositiveNumber()]})
        def solve(x, *, tol=1e-9):
            return x


def test_a_table_refusing_a_default_fails_at_definition():
    with pytest.raises(TypeError, match="refuses the default of mode, 'fast'"):
        @checked_keywords({"mode": [OneOf(("exact", "rough"))]})
        def solve(x, *, mode="fast"):
            return x


def test_a_refused_value_is_named_before_the_function_runs():
    ran = []

    @checked_keywords({"tol": [PositiveNumber(), NONE], "mode": [OneOf(("a", "b"))]})
    def solve(x, *, tol=None, mode="a", **others):
        ran.append(x)
        return x

    assert solve(1, tol=0.5, mode="b", anything="passed on") == 1
    with pytest.raises(ValueError) as info:
        solve(2, tol=-1.0)
    assert str(info.value) == ("The 'tol' parameter of solve must be a finite positive "
                               "number or None; got -1.0.")
    with pytest.raises(ValueError, match="The 'mode' parameter of solve must be one of "
                                         "'a', 'b'; got 'c'"):
        solve(3, mode="c")
    assert ran == [1]


def test_the_error_class_and_the_name_in_the_message_can_be_chosen():
    @checked_keywords({"workers": [PositiveNumber()]}, caller="run_all", error=EnsembleError)
    def run(*, workers=1):
        return workers

    with pytest.raises(EnsembleError, match="The 'workers' parameter of run_all must be"):
        run(workers=0)


def keyword_only(function) -> dict[str, object]:
    parameters = inspect.signature(function).parameters.values()
    return {p.name: p.default for p in parameters if p.kind is inspect.Parameter.KEYWORD_ONLY}


@pytest.mark.parametrize("door", [System.__init__, System.simulate, System.plan,
                                  System.consistent_initial_state, simulation_options,
                                  equilibrium, linearize, simulate_many])
def test_each_door_is_bound_to_a_table_of_its_keywords(door):
    assert set(door.parameter_table) == set(keyword_only(door))


def test_simulate_and_its_options_have_the_same_defaults():
    # one option, one default: simulate's run options are simulation_options' keywords
    ours, theirs = keyword_only(System.simulate), keyword_only(simulation_options)
    shared = set(ours) & set(theirs)
    assert shared >= {"rtol", "atol", "method", "backend", "t_eval", "inputs"}
    assert {k for k in shared if ours[k] != theirs[k]} == {"redundant_constraints"}
    assert ours["redundant_constraints"] is None  # None: the System's own option
    assert set(ours) - set(theirs) == {"parameters", "fixed"}  # they belong to one run
