"""Bad options of ``simulate``: refused at the door with one message form naming the option.

Property-based: for every option of the declared table
(:data:`dalembert.options.SIMULATE_PARAMETERS`), values that are wrong by
construction (not finite, not positive, of the wrong type, not a listed choice)
must raise ``ValueError("The '<option>' parameter of simulate must be ...; got
...")``, and values that are right by construction must pass. The oracle is the
option's documented meaning, not the table itself.
"""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest
from bad_input_cases import pendulum
from hypothesis import given, settings
from hypothesis import strategies as st

from dalembert import StiffStabilizationWarning, System
from dalembert.options import SIMULATE_PARAMETERS, simulation_options

FAST = settings(max_examples=30, deadline=2000)

#: Anything that is not a number at all.
NOT_NUMBERS = st.one_of(st.text(max_size=5), st.none(), st.lists(st.text(), min_size=1),
                        st.dictionaries(st.text(max_size=2), st.integers(), max_size=2),
                        st.complex_numbers(allow_nan=False).filter(lambda z: z.imag != 0),
                        st.booleans())
#: Numbers that are not finite and positive.
NOT_POSITIVE = st.one_of(st.floats(max_value=0.0), st.just(math.nan), st.just(math.inf),
                         st.integers(max_value=0))
POSITIVE = st.floats(min_value=1e-300, max_value=1e300)


def refused(name: str, value: object, **others: object) -> None:
    with pytest.raises(ValueError) as info:
        simulation_options((0.0, 1.0), **{name: value}, **others)
    text = str(info.value)
    assert text.startswith(f"The {name!r} parameter of simulate must be "), text
    assert "; got " in text, text


@pytest.mark.parametrize("name", ["first_step", "baumgarte_gain"])
@FAST
@given(value=st.one_of(NOT_NUMBERS.filter(lambda v: v is not None), NOT_POSITIVE))
def test_step_and_gain_must_be_finite_positive_numbers(name, value):
    others = {"stabilization": "baumgarte"} if name == "baumgarte_gain" else {}
    refused(name, value, **others)


@FAST
@given(value=st.one_of(NOT_NUMBERS, st.floats(max_value=0.0), st.just(math.nan),
                       st.just(-math.inf)))
def test_max_step_must_be_positive(value):
    refused("max_step", value)


@pytest.mark.parametrize("name", ["rtol", "atol"])
@FAST
@given(value=st.one_of(  # None is the method's default (options.default_tolerances)
    NOT_NUMBERS.filter(lambda v: v is not None), NOT_POSITIVE,
    st.sampled_from(["1e-9", ["1e-9", "1e-9"], b"1"]),
    st.lists(POSITIVE, min_size=1, max_size=3).flatmap(
        lambda good: NOT_POSITIVE.map(lambda bad: [*good, bad])),
    st.just([]), st.just([[1e-9, 1e-9]])))
def test_tolerances_must_be_finite_and_positive(name, value):
    refused(name, value)


@pytest.mark.parametrize("name", ["first_step", "baumgarte_gain", "max_step", "rtol", "atol"])
@FAST
@given(value=st.floats(min_value=1e-12, max_value=1.0))
def test_finite_positive_numbers_are_accepted(name, value):
    others = {"stabilization": "baumgarte"} if name == "baumgarte_gain" else {}
    simulation_options((0.0, 1.0), **{name: value}, **others)


@pytest.mark.parametrize(("name", "choices"), [
    ("method", {"RK23", "RK45", "DOP853", "Radau", "BDF", "LSODA", "IDA"}),
    ("step_control", {"PI", "scipy"}), ("backend", {"auto", "c", "python"}),
    ("redundant_constraints", {"minimum-norm", "error"}),
    ("velocity_projection", {"kinetic-energy", "least-change"}),
    ("stabilization", {"projection", "baumgarte", None})])
@FAST
@given(value=st.one_of(st.text(max_size=12), st.integers(), st.floats(allow_nan=False),
                       st.none()))
def test_choices_outside_the_list_are_refused(name, choices, value):
    if value in choices or (name == "stabilization" and value is None):
        return  # a listed choice: accepted (checked below)
    refused(name, value)


@pytest.mark.parametrize("name", ["dense_output", "progress", "native"])
@FAST
@given(value=st.one_of(st.integers(), st.text(max_size=3), st.floats(allow_nan=False),
                       st.lists(st.booleans(), max_size=2)))
def test_flags_must_be_booleans(name, value):
    refused(name, value)


@FAST
@given(value=st.one_of(st.integers(), st.text(max_size=3), st.lists(
    st.one_of(st.integers(), st.text(max_size=2), st.none()), min_size=1, max_size=3)))
def test_events_must_be_callables(value):
    refused("events", value)


@FAST
@given(value=st.one_of(st.text(max_size=4), st.integers(), st.lists(st.text(max_size=3),
                                                                    min_size=1, max_size=3),
                       st.lists(st.lists(st.floats(0, 1), min_size=2, max_size=2),
                                min_size=1, max_size=2)))
def test_t_eval_must_be_a_one_dimensional_array_of_times(value):
    refused("t_eval", value)


@FAST
@given(value=st.one_of(NOT_NUMBERS.filter(lambda v: v is not None), NOT_POSITIVE))
def test_a_sample_time_must_be_finite_and_positive(value):
    refused("sample_time", value)


@FAST
@given(value=st.one_of(NOT_NUMBERS.filter(lambda v: v is not None), NOT_POSITIVE))
def test_a_time_limit_must_be_finite_and_positive(value):
    refused("timeout", value)


@FAST
@given(value=st.one_of(NOT_NUMBERS, st.sampled_from(["Sequential", "both", "lcp"])))
def test_an_impact_law_must_be_one_of_the_laws(value):
    refused("impact_law", value)


@FAST
@given(value=st.one_of(NOT_NUMBERS, st.sampled_from(["events", "stepping", "moreau"])))
def test_a_contact_mode_must_be_one_of_the_modes(value):
    refused("contact_mode", value)


@FAST
@given(value=st.one_of(NOT_NUMBERS.filter(lambda v: v is not None), NOT_POSITIVE))
def test_a_contact_step_must_be_finite_and_positive(value):
    refused("contact_step", value, contact_mode="time-stepping")


def test_a_contact_step_needs_the_time_stepping_mode():
    with pytest.raises(ValueError, match=r"contact_step=0\.01 is the time-stepping contact"):
        simulation_options((0.0, 1.0), contact_step=0.01)
    with pytest.raises(ValueError, match=r"contact_step=2\.0 is longer than t_span"):
        simulation_options((0.0, 1.0), contact_step=2.0, contact_mode="time-stepping")


def test_every_option_of_the_table_is_exercised_here():
    covered = {"first_step", "baumgarte_gain", "max_step", "rtol", "atol", "method",
               "step_control", "backend", "redundant_constraints", "velocity_projection",
               "stabilization", "dense_output", "progress", "native", "events", "t_eval",
               "sample_time", "timeout", "impact_law", "contact_mode", "contact_step"}
    assert set(SIMULATE_PARAMETERS) == covered


# -- rules that tie an option to another, or to the model ----------------------------------
def _bottom(t, q, qd, lam, tau):
    """An event of five required parameters: no call the run makes fits it."""
    return q[0]


class _Crossing:
    """A callable object event: ``x`` crossing zero."""

    def __call__(self, t, q, qd):
        return q[0]


@pytest.fixture(scope="module")
def pend() -> System:
    return pendulum()


def _with(**attributes):
    """An event function ``q[0]`` with the attributes ``solve_ivp`` reads set."""
    def crossing(t, q, qd):
        return q[0]
    for name, value in attributes.items():
        setattr(crossing, name, value)
    return crossing


@pytest.mark.parametrize(("options", "culprit"), [
    ({"atol": [1e-9, 1e-9, 1e-9]}, "The 'atol' parameter of simulate must be a finite "
     "positive number or an array of 4 of them (one per position, then one per velocity); "
     "got [1e-09, 1e-09, 1e-09]."),
    ({"rtol": [1e-9, 1e-9]}, "The 'rtol' parameter of simulate must be a finite positive "
     "number or an array of 4 of them"),
    ({"first_step": 2.0}, "first_step=2.0 is longer than t_span (0.0, 1.0)"),
    ({"baumgarte_gain": 5.0}, "baumgarte_gain=5.0 is given with stabilization='projection'"),
    ({"method": "LSODA"}, "LSODA cannot be restarted from a projected state"),
    ({"t_eval": [0.5, 2.0]}, "t_eval must be a 1-D array of times inside t_span"),
    ({"t_eval": [0.5, 0.2]}, "t_eval must be strictly ordered"),
    ({"t_eval": [0.2, np.nan]}, "t_eval must be a 1-D array of finite times inside t_span "
     "(not finite at index 1)"),
    ({"t_eval": "0.5"}, "The 't_eval' parameter of simulate must be a 1-D array of times or "
     "None; got '0.5'."),
    ({"max_step": 0.0}, "The 'max_step' parameter of simulate must be a positive number"),
    ({"stabilization": "baumgarte", "baumgarte_gain": -5.0},
     "The 'baumgarte_gain' parameter of simulate must be a finite positive number or None; "
     "got -5.0."),
    ({"events": "ev"}, "The 'events' parameter of simulate must be a sequence of callables"),
    ({"events": [lambda t: t - 0.5]}, "The 'events' parameter of simulate: event 0 "
     "('<lambda>') takes (t), so it cannot be called as event(t, q, qd) or "
     "event(t, q, qd, lam)"),
    ({"events": [lambda t, q, qd: q[0], _bottom]}, "event 1 ('_bottom') takes (t, q, qd, lam, "
     "tau), so it cannot be called"),
    ({"events": [_with(terminal="yes")]}, "event 0 ('crossing') has terminal='yes'; give True"),
    ({"events": [_with(terminal=-1)]}, "event 0 ('crossing') has terminal=-1; give True"),
    ({"events": [_with(direction="up")]}, "event 0 ('crossing') has direction='up'; give a "
     "number"),
    ({"events": [_with(direction=np.nan)]}, "event 0 ('crossing') has direction=nan"),
])
def test_simulate_refuses_at_the_door(pend, monkeypatch, options, culprit):
    # nothing past the door runs: no initial state, no plan
    monkeypatch.setattr(System, "_plan", lambda *a, **k: pytest.fail("checked too late"))
    with pytest.raises(ValueError) as info:
        pend.simulate((0, 1), q0=[1.0, 0.0], **options)
    assert culprit in str(info.value)
    with pytest.raises(ValueError) as info:  # plan() has the same door
        pend.plan((0, 1), q0=[1.0, 0.0], **options)
    assert culprit in str(info.value)


@pytest.mark.parametrize("t_span", [(0, 0), (0, np.inf), (0,), "ab", (0, np.nan), None])
def test_bad_t_span_is_named(pend, t_span):
    with pytest.raises(ValueError, match=r"t_span must be"):
        pend.simulate(t_span, q0=[1.0, 0.0])


def test_tolerances_one_per_state_entry_are_accepted(pend):
    traj = pend.simulate((0, 0.1), q0=[1.0, 0.0], atol=[1e-12] * 4, backend="python")
    assert traj.success


def test_every_callable_form_of_an_event_is_accepted(pend):
    """A partial, a callable object, ``*args``, the multipliers' form and a builtin without
    a signature pass the door; the first four find the pendulum's first passage through
    the bottom, a quarter of the period of the exact pendulum released horizontally
    (K(1/sqrt(2)) * sqrt(l/g) * 4 / 4 = 1.8541 * sqrt(1/9.81))."""
    from functools import partial

    from scipy.special import ellipk

    quarter = ellipk(0.5) / np.sqrt(9.81)
    forms = [partial(lambda k, t, q, qd: k * q[0], 2.0), _Crossing(),
             lambda t, *state: state[0][0], lambda t, q, qd, lam: q[0]]
    for form in forms:
        traj = pend.simulate((0, 1), q0=[1.0, 0.0], events=[form], backend="python")
        assert abs(traj.t_events[0][0] - quarter) < 1e-8, form
    # signatures that cannot be read are accepted (the call decides)
    simulation_options((0.0, 1.0), events=[max, partial(max, 0.0)])


def test_a_baumgarte_gain_that_makes_an_explicit_method_crawl_is_said(pend):
    """w = 1e6 on a 10 s run: the constraint errors decay in a microsecond, so DOP853's
    steps must be that short (some 3e6 of them); Radau's need not, nor a usual gain's."""
    with pytest.warns(StiffStabilizationWarning, match=r"baumgarte_gain=1e\+06 makes the "
                      r"constraint errors decay in 1e-06 s: the explicit method DOP853 must "
                      r"take steps about that short, some 3\.3e\+06") as caught:
        pend.plan((0, 10), q0=[1.0, 0.0], stabilization="baumgarte", baumgarte_gain=1e6)
    assert caught[0].filename == __file__
    with warnings.catch_warnings():
        warnings.simplefilter("error", StiffStabilizationWarning)
        pend.plan((0, 10), q0=[1.0, 0.0], stabilization="baumgarte", baumgarte_gain=1e6,
                  method="Radau")
        pend.plan((0, 10), q0=[1.0, 0.0], stabilization="baumgarte", baumgarte_gain=50.0)
