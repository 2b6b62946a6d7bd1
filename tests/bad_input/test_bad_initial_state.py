"""Bad initial values and models that are wrong only in numbers: named, never silently run.

Non-finite inputs are refused at the door; finite inputs the model cannot evaluate
(an overflow, a division by zero) are named with the value that is not finite; a
negative kinetic energy, a constraint too small for the projection's tolerance and
an ill-conditioned KKT matrix (a thin rod) are refused with their cause. The
checks must not refuse what is right: a quaternion body's singular inertia block,
an indefinite Lagrangian, a mass matrix positive only where the constraints allow
motion, a small constraint written in a scaled form.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest
import sympy as sp
from bad_input_cases import PARAMETERS, T2, g, m, pendulum, x, y

from dalembert import (
    ConstraintError,
    Holonomic,
    InitialConditionError,
    InitialConditionsAdjusted,
    ModelError,
    ParameterError,
    SingularSystemError,
    System,
    coordinates,
)
from dalembert.examples import spherical_chain
from dalembert.multibody import chain
from dalembert.solvers.kkt.dense import check_kkt


@pytest.fixture(scope="module")
def pend() -> System:
    return pendulum()


@pytest.mark.parametrize(("q0", "qd0", "error", "culprit"), [
    ([np.nan, 0.0], None, InitialConditionError, "q0 is not finite for x"),
    ({"y": np.inf}, None, InitialConditionError, "q0 is not finite for y"),
    ([1.0, 0.0], [0.0, -np.inf], InitialConditionError, "qd0 is not finite for y"),
    (["a", 0.0], None, InitialConditionError, "q0 must be numbers"),
    ({"x": "a"}, None, InitialConditionError, "q0['x'] = 'a' is not a number"),
    # every coordinate, in order (as a mechanism's initial_state gives them)
    ({"x": np.nan, "y": 0.0}, None, InitialConditionError, "q0 is not finite for x"),
    ({"x": 1.0, "y": "a"}, None, InitialConditionError, "q0['y'] = 'a' is not a number"),
    ([1.0, 0.0, 0.0], None, InitialConditionError, "q0 has 3 values for 2 coordinates (x, y)"),
    ({"z": 1.0}, None, InitialConditionError, "q0 names 'z', which is not a coordinate"),
    ({42: 1.0}, None, ModelError, "42 is not a coordinate or parameter name"),
    # finite but overflowing: qd0^2 is infinite in the constraint's acceleration term
    ([1.0, 0.0], [0.0, 1e200], InitialConditionError,
     "the model is not finite at the initial state: the acceleration term c of "
     "constraint 'rod' is -inf. The initial values and parameters are finite (largest |q|: "
     "1 for x; largest |qd|: 1e+200 for y_dot"),
])
def test_bad_initial_values_are_named(pend, q0, qd0, error, culprit):
    with pytest.raises(error) as info:
        pend.simulate((0, 1), q0=q0, qd0=qd0)
    assert culprit in str(info.value)


@pytest.mark.parametrize(("options", "error", "culprit"), [
    ({"fixed": 42}, InitialConditionError, "fixed must be a sequence of coordinates, got 42"),
    ({"fixed": ["z"]}, InitialConditionError, "fixed names 'z', which is not a coordinate"),
    ({"parameters": {"g": np.inf}}, ParameterError, "parameter 'g' = inf is not finite"),
    ({"parameters": [1.0]}, ParameterError, "parameters must be a dict"),
    ({"parameters": {"t": 1.0}}, ParameterError, "('t' is time, dalembert.t"),
])
def test_bad_simulate_arguments_are_named(pend, options, error, culprit):
    with pytest.raises(error) as info:
        pend.simulate((0, 1), q0=[1.0, 0.0], **options)
    assert culprit in str(info.value)


def test_division_by_zero_at_the_start_is_named():
    q = sp.Function("q")(sp.Symbol("t"))
    system = System([q], kinetic=q.diff() ** 2 / 2, potential=1 / q)
    with pytest.raises(InitialConditionError, match=r"the generalized force on 'q' is"):
        system.simulate((0, 1), q0=[0.0])


def test_model_undefined_only_where_the_positions_are_projected_from_is_accepted():
    # V = 1/x is undefined at the x = 0 given, defined at x = 1 where the constraint puts
    # it; y moves freely at speed 1: y = t.
    system = System([x, y], kinetic=T2, potential=1 / x, parameters={m: 1.0},
                    constraints=[Holonomic(x - 1, name="wall")])
    with pytest.warns(InitialConditionsAdjusted):
        traj = system.simulate((0, 1), q0=[0.0, 0.0], qd0=[0.0, 1.0], t_eval=[1.0])
    np.testing.assert_allclose([traj["x"][-1], traj["y"][-1]], [1.0, 1.0], atol=1e-12)


# -- negative kinetic energy ---------------------------------------------------------------
def test_negative_mass_of_a_free_spring_is_refused():
    # m x'' = -k x with m = -1 runs away as cosh t; the message names x and M[x, x].
    spring = System([x], kinetic=m / 2 * x.diff() ** 2, potential=x**2 / 2,
                    parameters={m: -1.0})
    with pytest.raises(ModelError, match=r"kinetic energy is negative for some velocities.*"
                                         r"eigenvalue -1 in the block of x.*M\[x, x\] = -1"):
        spring.simulate((0, 1), q0=[1.0])


def test_negative_mass_of_a_constrained_pendulum_is_refused():
    with pytest.raises(ModelError, match=r"kinetic energy is negative for some velocities.*"
                                         r"in the block of x, along x: \+1; M\[x, x\] = -1"):
        pendulum(parameters={**PARAMETERS, m: -1.0}).simulate((0, 1), q0=[1.0, 0.0])


def test_mass_matrix_positive_where_the_constraints_allow_motion_is_accepted():
    # T = (-x'^2 + 3 y'^2) / 2 on x = y: T = s'^2 along s = x = y, V = s^2: s = cos t.
    system = System([x, y], kinetic=(-x.diff() ** 2 + 3 * y.diff() ** 2) / 2,
                    potential=(x**2 + y**2) / 2, constraints=[Holonomic(x - y, name="tie")])
    traj = system.simulate((0, 1), q0=[1.0, 1.0], t_eval=[1.0])
    assert abs(traj["x"][-1] - np.cos(1.0)) < 1e-9


def test_indefinite_lagrangian_is_accepted():
    # L = x' y' - x y: x'' = -x and y'' = -y (M = [[0, 1], [1, 0]] is indefinite).
    system = System([x, y], lagrangian=x.diff() * y.diff() - x * y)
    traj = system.simulate((0, 1), q0=[1.0, 2.0], t_eval=[1.0])
    np.testing.assert_allclose([traj["x"][-1], traj["y"][-1]], [np.cos(1), 2 * np.cos(1)],
                               atol=1e-9)


def test_quaternion_bodies_with_singular_inertia_blocks_are_accepted():
    mb = spherical_chain.model(2)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no warning either: the state is consistent
        traj = mb.system.simulate((0, 0.1), **spherical_chain.bent_state(mb))
    assert traj.success


# -- constraints too small for the projection's tolerance ------------------------------
@pytest.mark.parametrize("length", [1e-300, 1e-10, 1e-6])
def test_rod_too_short_for_the_absolute_tolerance_is_refused(length):
    # x^2 + y^2 - l^2 with l = 1e-300 underflows to x^2 + y^2: Newton stopped at |r| = 1e-7
    # with residual 1e-14, and the run treated the rod as no constraint.
    system = pendulum(parameters={**PARAMETERS, "l": length})
    with pytest.raises(ConstraintError, match=r"constraint 'rod' .* cannot be resolved at the "
                                              r"initial state: its gradient there is only"):
        system.simulate((0, 1), q0=[length, 0.0])


def test_short_rod_written_in_scaled_form_is_accepted():
    # k (x^2 + y^2) - 1 with k = 1 / l^2, l = 1e-6 m: small oscillations at sqrt(g / l).
    length, k = 1e-6, sp.Symbol("k")
    system = pendulum(constraints=[Holonomic(k * (x**2 + y**2) - 1, name="rod")],
                      parameters={"m": 1.0, "g": 9.81, "k": length**-2})
    rest = system.equilibrium({"x": 0.1 * length, "y": -length})
    omega = system.linearize(rest).natural_frequencies[0]
    assert abs(omega / np.sqrt(9.81 / length) - 1) < 1e-9
    with pytest.warns(InitialConditionsAdjusted):  # q0 is off the circle by 0.5 %
        traj = system.simulate((0, 1e-3), q0=[0.1 * length, -length])
    assert np.abs(np.hypot(traj["x"], traj["y"]) / length - 1).max() < 1e-10


# -- ill-conditioned KKT matrices: thin rods -----------------------------------------------
def test_thin_rod_is_called_ill_conditioned_with_the_cause():
    mb = chain(1, 0.5, 1.0, 1e-5, joint="spherical")  # axial inertia 5e-11 of 0.02
    with pytest.raises(SingularSystemError) as info:
        mb.system.simulate((0, 1), *mb.initial_state())
    text = str(info.value)
    assert "is ill-conditioned at the initial state (condition number" in text
    assert "the motion of link1_b" in text
    assert "a direction with almost no inertia, such as the spin of a thin rod" in text
    assert "Distance joint" in text and "not determined" not in text


def test_thinner_rod_is_refused_at_construction_with_the_cause():
    with pytest.raises(ModelError, match=r"the inertia tensor of 'link1' is nearly singular "
                                         r"\(principal values 5e-15, .*spin about that axis"):
        chain(1, 0.5, 1.0, 1e-7, joint="spherical")


def test_nearly_dependent_constraints_are_named_as_the_cause():
    # two constraints in nearly the same direction: rows (1, 0, 0) and (1, 1e-5, 0) of A
    M = np.eye(3)
    A = np.array([[1.0, 0.0, 0.0], [1.0, 1e-5, 0.0]])
    with pytest.raises(SingularSystemError, match=r"ill-conditioned here.*constraints are "
                                                  r"nearly dependent"):
        check_kkt(M, A, ("x", "y", "z"), "here")


def test_exactly_singular_kkt_is_still_called_singular():
    system = System([x, y], kinetic=m / 2 * x.diff() ** 2, parameters={m: 1.0})
    with pytest.raises(SingularSystemError, match=r"is singular at the initial state.*the "
                                                  r"motion of y is not determined"):
        system.simulate((0, 1), q0=[0.0, 0.0])


def test_kinetic_energy_of_a_double_counted_model_is_unaffected():
    # a sanity check that the new checks leave an ordinary model alone
    system = System([x, y], kinetic=T2, potential=m * g * y, parameters={m: 1.0, g: 9.81})
    traj = system.simulate((0, 1), q0=[0.0, 0.0], t_eval=[1.0])
    assert abs(traj["y"][-1] + 9.81 / 2) < 1e-9


def light_coordinate_system(size: int, light: float) -> System:
    """``size`` coordinates: x0 free with mass ``light``, the others unit masses joined by
    rigid links (past the dense solver's size, so the sparse screen runs first)."""
    q = coordinates(" ".join(f"x{i}" for i in range(size)))
    T = light / 2 * q[0].diff() ** 2 + sum(qi.diff() ** 2 / 2 for qi in q[1:])
    rods = [Holonomic(q[i] - q[i + 1] - 1, name=f"link{i}") for i in range(1, size - 1)]
    return System(q, kinetic=T, constraints=rods)


@pytest.mark.parametrize("dense_check", [True, False])
def test_ill_conditioned_large_model_is_explained(monkeypatch, dense_check):
    # condition number ~ 3 / 1e-13: above both limits, below singular to working precision
    from dalembert.solvers import initialization

    if not dense_check:
        monkeypatch.setattr(initialization, "DENSE_CHECK_MAX", 10)  # as for a huge model
    system = light_coordinate_system(40, 1e-13)
    with pytest.raises(SingularSystemError) as info:
        system.consistent_initial_state({f"x{i}": -float(i) for i in range(40)})
    text = str(info.value)
    assert "is ill-conditioned at the initial state (condition number" in text
    assert "a thin rod" in text and "not determined" not in text
    if dense_check:
        assert "the motion of x0 would be determined to only about" in text


@pytest.mark.parametrize(("planar", "keyword", "value", "culprit"), [
    (True, "positions", {"x": 0.5}, "the position of 'link1' must be 2 or 3 finite numbers"),
    (True, "orientations", {"theta": 1.0}, "the orientation of planar body 'link1' must be "
     "an angle about z or a 3x3 rotation matrix about z"),
    (True, "angular_velocities", "fast", "the angular velocity of 'link1' must be a number "
     "or 3 finite numbers, got 'fast'"),
    (False, "positions", {"x": 0.5}, "the position of 'link1' must be 3 finite numbers"),
    (False, "orientations", {"q": 1.0}, "the orientation of 'link1' must be a 3x3 rotation "
     "matrix or 4 Euler parameters"),
    (False, "angular_velocities", {"w": 1.0}, "the angular velocity of 'link1' must be 3 "
     "finite numbers"),
])
def test_a_body_value_nested_too_deep_or_not_numbers_is_named(planar, keyword, value, culprit):
    """``positions={"link1": {"x": 0.5}}`` (one level too deep) names the body and what
    it takes (it gave float()'s TypeError naming nothing)."""
    mb = chain(2, 1.0, 1.0, 0.05, planar=planar, **({"joint": "revolute"} if planar else {}))
    with pytest.raises(InitialConditionError) as info:
        mb.initial_state(**{keyword: {"link1": value}})
    assert culprit in str(info.value)
    if isinstance(value, dict):
        assert "(a dict: give the numbers themselves" in str(info.value)
