"""Tests of dalembert.statics.extremum against closed-form constrained extrema.

Sign convention under test: the augmented function is Phi + lambda^T psi, so at a
constrained extremum grad Phi = -J^T lambda.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
import sympy as sp
from sympy.physics.mechanics import dynamicsymbols

from dalembert.errors import (
    DependentConstraintsError,
    ExtremumConvergenceError,
    GuessError,
    MissingParameterError,
    SymbolicSolveError,
    TooManyConstraintsError,
)
from dalembert.statics.extremum import (
    all_extrema,
    extremum,
    stationarity_conditions,
)

x, y, z = sp.symbols("x y z")
R = 1 / math.sqrt(2)

# x*y on x^2 + y^2 = 1. At (s1, s2)/sqrt(2): y + 2 lambda x = 0 gives lambda = -s1 s2 / 2;
# the tangent is t = (-s2, s1)/sqrt(2) and t^T [[2 lambda, 1], [1, 2 lambda]] t = 2 lambda - s1 s2.
CIRCLE_POINTS = [
    # (s1, s2), kind, value, lambda, reduced Hessian eigenvalue
    ((1, 1), "maximum", 0.5, -0.5, -2.0),
    ((-1, -1), "maximum", 0.5, -0.5, -2.0),
    ((1, -1), "minimum", -0.5, 0.5, 2.0),
    ((-1, 1), "minimum", -0.5, 0.5, 2.0),
]


# --------------------------------------------------------------------------- x*y on the unit circle


@pytest.mark.parametrize(("signs", "kind", "value", "lam", "eigenvalue"), CIRCLE_POINTS)
def test_circle_extrema_from_nearby_guesses(signs, kind, value, lam, eigenvalue):
    guess = {"x": 0.9 * signs[0], y: 0.4 * signs[1]}
    e = extremum(x * y, [x**2 + y**2 - 1], [x, y], guess)
    np.testing.assert_allclose(e.x, [signs[0] * R, signs[1] * R], atol=1e-12)
    assert e.kind == kind
    assert e.value == pytest.approx(value, abs=1e-12)
    np.testing.assert_allclose(e.multipliers, [lam], atol=1e-12)
    np.testing.assert_allclose(e.reduced_hessian_eigenvalues, [eigenvalue], atol=1e-10)
    assert e.residual <= 1e-12
    assert e.method == "newton"
    assert 0 < e.iterations <= 10


def test_circle_all_extrema_finds_exactly_the_four_points():
    found = all_extrema(x * y, [x**2 + y**2 - 1], [x, y])
    assert len(found) == 4
    by_point = {(round(e.x[0] / R), round(e.x[1] / R)): e for e in found}
    for signs, kind, value, lam, eigenvalue in CIRCLE_POINTS:
        e = by_point[signs]
        np.testing.assert_allclose(e.x, [signs[0] * R, signs[1] * R], atol=1e-14)
        assert (e.kind, e.method, e.iterations) == (kind, "symbolic", 0)
        assert e.value == pytest.approx(value, abs=1e-14)
        assert e.multipliers[0] == pytest.approx(lam, abs=1e-14)
        assert e.reduced_hessian_eigenvalues[0] == pytest.approx(eigenvalue, abs=1e-12)


def test_eq_constraint_sequence_guess_and_sides():
    # Eq(lhs, rhs) means psi = lhs - rhs; swapping the sides flips the multiplier.
    e = extremum(x * y, [sp.Eq(x**2 + y**2, 1)], [x, y], [0.8, 0.6])
    flipped = extremum(x * y, [sp.Eq(1, x**2 + y**2)], [x, y], np.array([0.8, 0.6]))
    np.testing.assert_allclose(e.x, [R, R], atol=1e-12)
    assert e.multipliers[0] == pytest.approx(-0.5, abs=1e-12)
    assert flipped.multipliers[0] == pytest.approx(0.5, abs=1e-12)


def test_dynamicsymbols_are_plain_unknowns():
    q1, q2 = dynamicsymbols("q1 q2")
    e = extremum(q1 * q2, [q1**2 + q2**2 - 1], [q1, q2], {q1: 0.8, "q2(t)": -0.6})
    assert e.by_name() == pytest.approx({"q1": R, "q2": -R}, abs=1e-12)
    assert e.kind == "minimum"
    assert e.multipliers_by_name() == pytest.approx({"lambda_1": 0.5}, abs=1e-12)


def test_default_guess_and_partial_mapping_start_at_one():
    assert extremum(x * y, [x**2 + y**2 - 1], [x, y]).by_name() == pytest.approx(
        {"x": R, "y": R}, abs=1e-12
    )
    e = extremum(x * y, [x**2 + y**2 - 1], [x, y], {"y": -0.3})
    np.testing.assert_allclose(e.x, [R, -R], atol=1e-12)


def test_extremum_is_immutable_and_printable():
    e = extremum(x * y, [x**2 + y**2 - 1], [x, y], [0.8, 0.6])
    with pytest.raises(dataclasses.FrozenInstanceError):
        e.kind = "minimum"  # type: ignore[misc]
    with pytest.raises(ValueError):
        e.x[0] = 0.0
    text = str(e)
    assert "maximum" in text
    assert "x = 0.707106781187" in text
    assert "lambda_1 = -0.5" in text


# ------------------------------------------------------------------------- point nearest to a plane


def test_distance_to_plane_matches_projection():
    a, b, c = sp.symbols("a b c")
    p = np.array([0.5, -1.0, 2.0])
    normal, d = np.array([1.0, 2.0, -2.0]), 3.0
    phi = (x - a) ** 2 + (y - b) ** 2 + (z - c) ** 2
    plane = normal[0] * x + normal[1] * y + normal[2] * z - d
    # Closed form: x* = p - s n with s = (n.p - d)/|n|^2; 2 (x* - p) = -lambda n gives
    # lambda = 2 s; the distance squared is (n.p - d)^2 / |n|^2; H = 2 I on the plane.
    s = (normal @ p - d) / (normal @ normal)
    parameters = {"a": p[0], b: p[1], "c": p[2]}

    e = extremum(phi, [plane], [x, y, z], [0, 0, 0], parameters=parameters)
    np.testing.assert_allclose(e.x, p - s * normal, atol=1e-12)
    np.testing.assert_allclose(e.multipliers, [2 * s], atol=1e-12)
    assert e.value == pytest.approx(s**2 * (normal @ normal), abs=1e-12)
    assert e.kind == "minimum"
    np.testing.assert_allclose(e.reduced_hessian_eigenvalues, [2, 2], atol=1e-12)

    (symbolic,) = all_extrema(phi, [plane], [x, y, z], parameters=parameters)
    np.testing.assert_allclose(symbolic.x, p - s * normal, atol=1e-14)
    assert symbolic.kind == "minimum"


# --------------------------------------------------------------------------- two constraints


def test_linear_function_on_circle_of_sphere_and_plane():
    # x + 2y + 3z on x^2 + y^2 + z^2 = 1, x = y. With x = y: maximize 3x + 3z on
    # 2x^2 + z^2 = 1; Cauchy-Schwarz gives the maximum 3 sqrt(6)/2 at (1, 1, 2)/sqrt(6).
    # grad = -lambda_1 (2x, 2y, 2z) - lambda_2 (1, -1, 0) there: lambda = (-3 sqrt(6)/4, 1/2);
    # the reduced Hessian is 2 lambda_1 (H = 2 lambda_1 I, tangent of length 1).
    phi, constraints = x + 2 * y + 3 * z, [x**2 + y**2 + z**2 - 1, x - y]
    top = np.array([1, 1, 2]) / math.sqrt(6)
    lam = np.array([-3 * math.sqrt(6) / 4, 0.5])
    expected = {
        "maximum": (top, 3 * math.sqrt(6) / 2, lam),
        "minimum": (-top, -3 * math.sqrt(6) / 2, np.array([-lam[0], lam[1]])),
    }
    for guess, kind in (([0.5, 0.3, 0.7], "maximum"), ([-0.2, -0.5, -0.9], "minimum")):
        e = extremum(phi, constraints, [x, y, z], guess)
        point, value, multipliers = expected[kind]
        assert e.kind == kind
        np.testing.assert_allclose(e.x, point, atol=1e-12)
        np.testing.assert_allclose(e.multipliers, multipliers, atol=1e-12)
        assert e.value == pytest.approx(value, abs=1e-12)
        np.testing.assert_allclose(e.reduced_hessian_eigenvalues, [2 * multipliers[0]], atol=1e-10)

    found = all_extrema(phi, constraints, [x, y, z])
    assert [e.kind for e in found] == ["minimum", "maximum"]
    for e in found:
        point, value, multipliers = expected[e.kind]
        np.testing.assert_allclose(e.x, point, atol=1e-14)
        np.testing.assert_allclose(e.multipliers, multipliers, atol=1e-14)


# --------------------------------------------------------------------------- other kinds


def test_saddle_on_a_plane():
    # x^2 - y^2 + z on z = 0: stationary at the origin, lambda = -1, curvatures 2 and -2.
    e = extremum(x**2 - y**2 + z, [z], [x, y, z], [0.3, 0.2, 0.1])
    np.testing.assert_allclose(e.x, 0, atol=1e-14)
    assert e.kind == "saddle"
    np.testing.assert_allclose(e.multipliers, [-1])
    np.testing.assert_allclose(e.reduced_hessian_eigenvalues, [-2, 2], atol=1e-12)


def test_constant_function_on_constraint_is_degenerate():
    # x^2 + y^2 is 1 everywhere on the unit circle: every point is stationary with
    # lambda = -1 and the Hessian 2 I + 2 lambda I of the augmented function vanishes.
    e = extremum(x**2 + y**2, [x**2 + y**2 - 1], [x, y], [1.0, 0.5])
    assert e.kind == "degenerate"
    assert float(np.hypot(*e.x)) == pytest.approx(1, abs=1e-12)
    assert e.value == pytest.approx(1, abs=1e-12)
    np.testing.assert_allclose(e.multipliers, [-1], atol=1e-12)
    np.testing.assert_allclose(e.reduced_hessian_eigenvalues, [0], atol=1e-12)


def test_as_many_constraints_as_variables_is_isolated():
    e = extremum(x + y, [x - 1, y - 2], [x, y])
    np.testing.assert_allclose(e.x, [1, 2])
    np.testing.assert_allclose(e.multipliers, [-1, -1])
    assert e.kind == "isolated"
    assert e.reduced_hessian_eigenvalues.size == 0


def test_unconstrained_minimum():
    e = extremum((x - 1) ** 2 + 3 * (y + 2) ** 2, [], [x, y], [0, 0])
    np.testing.assert_allclose(e.x, [1, -2], atol=1e-12)
    assert e.kind == "minimum"
    assert e.multipliers.size == 0
    np.testing.assert_allclose(e.reduced_hessian_eigenvalues, [2, 6], atol=1e-12)


# ------------------------------------------------------------------------- stationarity_conditions


def test_stationarity_conditions_of_circle_problem():
    sc = stationarity_conditions(x * y, [sp.Eq(x**2 + y**2, 1)], [x, y])
    (lam,) = sc.multipliers
    assert lam == sp.Symbol("lambda_1")
    assert sp.expand(sc.augmented - (x * y + lam * (x**2 + y**2 - 1))) == 0
    expected = [y + 2 * lam * x, x + 2 * lam * y, x**2 + y**2 - 1]
    assert all(isinstance(eq, sp.Eq) for eq in sc.equations)
    assert [sp.expand(eq.lhs - want) for eq, want in zip(sc.equations, expected)] == [0, 0, 0]
    assert r"\lambda_{1}" in sc.latex()
    assert r"\partial x" in sc.latex()
    assert sc._repr_latex_().startswith("$")


def test_stationarity_conditions_with_functions_of_time_and_symbolic_parameters():
    q = dynamicsymbols("q")
    k = sp.Symbol("k")
    sc = stationarity_conditions(k * q**2 / 2, [q - 1], [q])
    assert sp.simplify(sc.equations[0].lhs - (k * q + sc.multipliers[0])) == 0


# --------------------------------------------------------------------------- errors


def test_no_stationary_point_reports_what_was_tried():
    # x on x y = 1: 1 + lambda y = 0 needs lambda != 0, then lambda x = 0 needs x = 0,
    # which violates x y = 1. No stationary point exists.
    with pytest.raises(ExtremumConvergenceError) as info:
        extremum(x, [x * y - 1], [x, y], [1, 1])
    message = str(info.value)
    assert "(x=1, y=1)" in message
    assert "iterations" in message
    assert "residual" in message
    assert "scipy.optimize.root" in message
    assert "another guess" in message
    assert isinstance(info.value, RuntimeError)
    assert all_extrema(x, [x * y - 1], [x, y]) == []


def test_tangent_constraints_give_a_hint():
    # The circle and the line x = 1 touch at (1, 0), where the gradients (2, 0) and
    # (1, 0) are parallel and grad y = (0, 1) is not in their span: no multipliers exist.
    with pytest.raises(ExtremumConvergenceError, match="nearly dependent"):
        extremum(y, [x**2 + y**2 - 1, x - 1], [x, y], [0.9, 0.3])


def test_dependent_constraints_are_named():
    constraints = [z, x + y - 1, 2 * x + 2 * y - 2]
    with pytest.raises(DependentConstraintsError) as info:
        extremum(x**2 + y**2 + z**2, constraints, [x, y, z])
    assert info.value.indices == (1, 2)
    assert "1 (x + y - 1), 2 (2*x + 2*y - 2)" in str(info.value)
    assert "(x=0.5, y=0.5, z=0)" in str(info.value)
    assert isinstance(info.value, ValueError)
    with pytest.raises(DependentConstraintsError, match="rank-deficient"):
        all_extrema(x**2 + y**2 + z**2, constraints, [x, y, z])


def test_more_constraints_than_variables():
    with pytest.raises(TooManyConstraintsError, match="3 constraints but only 2 variables"):
        extremum(x, [x - 1, y, x + y], [x, y])
    with pytest.raises(ValueError, match="3 constraints"):
        stationarity_conditions(x, [x - 1, y, x + y], [x, y])


@pytest.mark.parametrize(
    ("guess", "match"),
    [
        ({"w": 1.0}, "'w', which is not a variable"),
        ({z: 1.0}, "not a variable"),
        ([1.0], "1 values but there are 2 variables"),
        ([math.nan, 1.0], "not finite: x=nan"),
        ({"y": math.inf}, "not finite: y=inf"),
        ({"x": "one"}, "guess for x"),
        ("xy", "mapping or a sequence"),
    ],
)
def test_bad_guess(guess, match):
    with pytest.raises(GuessError, match=match) as info:
        extremum(x * y, [x**2 + y**2 - 1], [x, y], guess)
    assert isinstance(info.value, ValueError)


def test_missing_parameter_is_named():
    a, b = sp.symbols("a b")
    with pytest.raises(MissingParameterError, match=r"symbol\(s\) a, b") as info:
        extremum(a * x + b * y, [x**2 + y**2 - 1], [x, y])
    assert isinstance(info.value, ValueError)
    with pytest.raises(MissingParameterError, match="b"):
        extremum(a * x + b * y, [x**2 + y**2 - 1], [x, y], parameters={"a": 1})


@pytest.mark.parametrize(
    ("parameters", "match"),
    [
        ({"c": 1.0}, "'c' does not appear"),
        ({"x": 1.0, "a": 1.0}, "'x' is a variable"),
        ({"a": math.nan}, "not finite"),
        ({"a": "heavy"}, "not a number"),
    ],
)
def test_bad_parameters(parameters, match):
    a = sp.Symbol("a")
    with pytest.raises(ValueError, match=match):
        extremum(a * x, [x**2 + y**2 - 1], [x, y], parameters=parameters)


def test_malformed_problems():
    with pytest.raises(ValueError, match="identically True"):
        extremum(x, [sp.Eq(x, x)], [x, y])
    with pytest.raises(ValueError, match="does not involve any variable"):
        extremum(x, [z - 1], [x, y])
    with pytest.raises(ValueError, match="not a symbol"):
        extremum(x, [], [x + y])
    with pytest.raises(ValueError, match="tol"):
        extremum(x * y, [x**2 + y**2 - 1], [x, y], tol=0)
    with pytest.raises(ValueError, match="max_iter"):
        extremum(x * y, [x**2 + y**2 - 1], [x, y], max_iter=0)


def test_all_extrema_rejects_transcendental_equations():
    with pytest.raises(SymbolicSolveError, match="polynomial"):
        all_extrema(sp.sin(x) + y, [y], [x, y])


def test_all_extrema_rejects_a_continuum():
    with pytest.raises(SymbolicSolveError, match="not isolated"):
        all_extrema(x**2 + y**2, [x**2 + y**2 - 1], [x, y])


def test_all_extrema_reports_when_sympy_gives_up(monkeypatch):
    def give_up(*args, **kwargs):
        raise NotImplementedError("no algorithms")

    monkeypatch.setattr(sp, "solve", give_up)  # the module calls sympy.solve
    with pytest.raises(SymbolicSolveError, match=r"sympy\.solve could not solve"):
        all_extrema(x * y, [x**2 + y**2 - 1], [x, y])
