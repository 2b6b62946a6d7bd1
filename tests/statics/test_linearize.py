"""Small oscillations about equilibria, against closed-form frequencies and mode shapes.

Each system is written in redundant Cartesian coordinates; the expected answers come
from the textbook minimal-coordinate analyses (pendulum, double pendulum, bead on a
spinning hoop, damped pendulum).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
import sympy as sp
from statics_systems import L_ROD, M_BOB, G, spinning_hoop

from dalembert import Holonomic, Pfaffian, System, coordinates
from dalembert.errors import (
    MarginalStabilityError,
    NonholonomicLinearizationError,
    NotAnEquilibriumError,
)
from dalembert.statics.equilibrium import equilibrium
from dalembert.statics.linearize import linearize


def hoop_point(phi: float, R: float) -> dict[str, float]:
    return {"x": R * math.sin(phi), "z": -R * math.cos(phi)}


# --------------------------------------------------------------------------- pendulum


def test_pendulum_frequency_sqrt_g_over_l(pendulum):
    lin = linearize(pendulum, equilibrium(pendulum, {"x": 0.3, "y": -1.0}))
    assert lin.stability == "stable"
    assert lin.degrees_of_freedom == 1
    w = lin.natural_frequencies[0]
    assert w.real == pytest.approx(math.sqrt(G / L_ROD), rel=1e-12)
    assert w.imag == 0.0
    assert lin.growth_rates[0] == 0.0
    # K = (m g / l) I from the multiplier's curvature term alone (gravity is uniform).
    np.testing.assert_allclose(lin.K, M_BOB * G / L_ROD * np.eye(2), atol=1e-12)
    np.testing.assert_allclose(lin.C, 0.0, atol=0.0)
    # Mode along x, mass-normalized: phi^T M phi = 1.
    np.testing.assert_allclose(np.abs(lin.mode_shapes[:, 0]), [1 / math.sqrt(M_BOB), 0.0],
                               atol=1e-14)
    np.testing.assert_allclose(lin.mode_shapes.T @ lin.M @ lin.mode_shapes, [[1.0]], rtol=1e-14)


def test_pendulum_state_space(pendulum):
    lin = linearize(pendulum, {"x": 0.0, "y": -L_ROD})
    w = math.sqrt(G / L_ROD)
    eig = np.sort_complex(lin.eigenvalues)
    np.testing.assert_allclose(eig, [-1j * w, 1j * w], atol=1e-12)
    # Z = (+-1, 0): a horizontal force F on the bob gives eta'' = +-F / m; a vertical
    # one is taken by the rod.
    sign = lin.Z[0, 0]
    assert abs(sign) == pytest.approx(1.0, abs=1e-15)
    np.testing.assert_allclose(lin.B_ss, [[0, 0], [sign / M_BOB, 0]], atol=1e-15)
    np.testing.assert_allclose(lin.A_ss, [[0, 1], [-w**2, 0]], atol=1e-12)
    assert lin.state_to_coordinates.shape == (4, 2)


def test_pendulum_top_reports_growth_rate(pendulum):
    top = equilibrium(pendulum, {"x": 0.2, "y": 1.0})
    lin = linearize(pendulum, top)
    assert lin.stability == "unstable"
    assert lin.omega_squared[0] == pytest.approx(-G / L_ROD, rel=1e-12)
    w = lin.natural_frequencies[0]
    assert w.real == 0.0
    assert w.imag == pytest.approx(math.sqrt(G / L_ROD), rel=1e-12)
    assert lin.growth_rates[0] == pytest.approx(math.sqrt(G / L_ROD), rel=1e-12)
    assert "growth rate" in str(lin)


def test_multipliers_computed_at_the_point(pendulum):
    # Given a bare configuration, lambda* is found there: -2 lambda l = m g at the bottom.
    lin = linearize(pendulum, [0.0, -L_ROD])
    assert -2 * lin.multipliers[0] * L_ROD == pytest.approx(M_BOB * G, rel=1e-12)


# --------------------------------------------------------------------------- double pendulum


def double_pendulum(m=1.3, g=G, l=0.8) -> System:
    x1, y1, x2, y2 = coordinates("x1 y1 x2 y2")
    ms, gs, ls = sp.symbols("m g l", positive=True)
    return System(
        [x1, y1, x2, y2],
        kinetic=ms / 2 * sum(v.diff() ** 2 for v in (x1, y1, x2, y2)),
        potential=ms * gs * (y1 + y2),
        constraints=[Holonomic(x1**2 + y1**2 - ls**2, name="upper"),
                     Holonomic((x2 - x1) ** 2 + (y2 - y1) ** 2 - ls**2, name="lower")],
        parameters={ms: m, gs: g, ls: l},
    )


def test_double_pendulum_frequencies_and_modes():
    l = 0.8
    system = double_pendulum(l=l)
    eq = equilibrium(system, {"x1": 0.1, "y1": -0.7, "x2": 0.3, "y2": -1.5})
    lin = linearize(system, eq)
    assert lin.stability == "stable"
    expected = [(2 - math.sqrt(2)) * G / l, (2 + math.sqrt(2)) * G / l]
    np.testing.assert_allclose(lin.omega_squared, expected, rtol=1e-10)
    np.testing.assert_allclose(lin.natural_frequencies.real ** 2, expected, rtol=1e-10)
    # Minimal analysis: theta2 / theta1 = +sqrt 2 (slow), -sqrt 2 (fast); with x1 = l theta1,
    # x2 = l (theta1 + theta2) that is x2 / x1 = 1 + sqrt 2 and 1 - sqrt 2; no vertical motion.
    for k, ratio in enumerate([1 + math.sqrt(2), 1 - math.sqrt(2)]):
        mode = lin.mode(k)
        assert mode["x2"] / mode["x1"] == pytest.approx(ratio, rel=1e-10)
        assert abs(mode["y1"]) + abs(mode["y2"]) < 1e-12
    np.testing.assert_allclose(lin.mode_shapes.T @ lin.M @ lin.mode_shapes, np.eye(2),
                               atol=1e-12)


# --------------------------------------------------------------------------- spinning hoop


@pytest.mark.parametrize("W", [4.5, 6.0])
def test_hoop_off_bottom_frequency(W):
    g, R = 9.81, 0.7
    system = spinning_hoop(W=W, R=R, g=g)
    phi = math.acos(g / (R * W**2))
    lin = linearize(system, equilibrium(system, hoop_point(phi + 0.2, R)))
    assert lin.stability == "stable"
    # Minimal: phi'' = (W^2 cos phi - g / R) sin phi; its derivative at cos phi* = g/(R W^2)
    # is -W^2 sin^2 phi* = -(W^2 - g^2 / (R^2 W^2)).
    assert W**2 * math.sin(phi) ** 2 == pytest.approx(W**2 - g**2 / (R**2 * W**2), rel=1e-14)
    np.testing.assert_allclose(lin.omega_squared, [W**2 - g**2 / (R**2 * W**2)], rtol=1e-11)
    # In-plane rotating-frame motion has no Coriolis coupling.
    np.testing.assert_allclose(lin.C, 0.0, atol=0.0)


@pytest.mark.parametrize("W", [0.0, 2.0, 3.5])
def test_hoop_bottom_frequency_below_critical_speed(W):
    g, R = 9.81, 0.7
    system = spinning_hoop(W=W, R=R, g=g)
    lin = linearize(system, {"x": 0.0, "z": -R})
    np.testing.assert_allclose(lin.omega_squared, [g / R - W**2], rtol=1e-12)
    assert lin.stability == "stable"
    # The top is unstable whatever the speed: omega^2 = -(g / R + W^2).
    top = linearize(system, {"x": 0.0, "z": R})
    np.testing.assert_allclose(top.omega_squared, [-(g / R + W**2)], rtol=1e-12)
    assert top.stability == "unstable"


def test_hoop_bottom_unstable_above_critical_speed():
    g, R, W = 9.81, 0.7, 5.0
    lin = linearize(spinning_hoop(W=W, R=R, g=g), {"x": 0.0, "z": -R})
    assert lin.stability == "unstable"
    assert lin.growth_rates[0] == pytest.approx(math.sqrt(W**2 - g / R), rel=1e-12)


def test_parameters_override_linearization():
    system = spinning_hoop(W=2.0)
    lin = linearize(system, {"x": 0.0, "z": -0.7}, parameters={"W": 1.0, "R": 0.7})
    np.testing.assert_allclose(lin.omega_squared, [9.81 / 0.7 - 1.0], rtol=1e-12)


def test_marginal_at_critical_speed():
    g, R = 9.81, 0.7
    system = spinning_hoop(W=math.sqrt(g / R), R=R, g=g)
    lin = linearize(system, {"x": 0.0, "z": -R})
    assert lin.stability == "marginal"
    assert abs(lin.omega_squared[0]) < 1e-12
    with pytest.raises(MarginalStabilityError, match="singular"):
        linearize(system, {"x": 0.0, "z": -R}, on_marginal="raise")


# --------------------------------------------------------------------------- damping


def test_damped_pendulum_eigenvalues():
    # Linear drag -c v on the bob: C = c I; about the bottom
    # s = -c / (2 m) +- i sqrt(g / l - (c / 2m)^2).
    x, y = coordinates("x y")
    m, g, l, c = sp.symbols("m g l c", positive=True)
    system = System(
        [x, y],
        kinetic=m / 2 * (x.diff() ** 2 + y.diff() ** 2),
        potential=m * g * y,
        generalized_forces={x: -c * x.diff(), y: -c * y.diff()},
        constraints=[Holonomic(x**2 + y**2 - l**2, name="rod")],
        parameters={m: M_BOB, g: G, l: L_ROD, c: 0.9},
    )
    lin = linearize(system, equilibrium(system, {"x": 0.2, "y": -1.0}))
    np.testing.assert_allclose(lin.C, 0.9 * np.eye(2), atol=1e-15)
    decay = 0.9 / (2 * M_BOB)
    damped = math.sqrt(G / L_ROD - decay**2)
    np.testing.assert_allclose(np.sort_complex(lin.eigenvalues),
                               [-decay - 1j * damped, -decay + 1j * damped], rtol=1e-12)
    # Natural frequencies are the undamped ones.
    assert lin.natural_frequencies[0].real == pytest.approx(math.sqrt(G / L_ROD), rel=1e-12)


# --------------------------------------------------------------------------- errors


def test_not_an_equilibrium(pendulum):
    with pytest.raises(NotAnEquilibriumError, match="unbalanced generalized force on x"):
        linearize(pendulum, {"x": 0.6 * L_ROD, "y": -0.8 * L_ROD})
    with pytest.raises(NotAnEquilibriumError, match="does not satisfy the constraints"):
        linearize(pendulum, {"x": 0.0, "y": -2 * L_ROD})


def test_nonholonomic_is_rejected():
    x, y, th = coordinates("x y theta")
    m, J = sp.symbols("m J", positive=True)
    system = System(
        [x, y, th],
        kinetic=m / 2 * (x.diff() ** 2 + y.diff() ** 2) + J / 2 * th.diff() ** 2,
        constraints=[Pfaffian(-sp.sin(th) * x.diff() + sp.cos(th) * y.diff(), name="blade")],
        parameters={m: 1.0, J: 0.1},
    )
    with pytest.raises(NonholonomicLinearizationError, match="holonomic constraints only"):
        linearize(system, [0.0, 0.0, 0.0])


# ---------------------------------------------------------------- inputs, coordinates


def test_inputs_and_a_chosen_coordinate():
    """The Cartesian pendulum pushed sideways by ``sin(u)`` (a force not affine in its
    input), in its coordinate ``x`` at the bottom: ``x'' = -g/l x + cos(u0)/m du``, the
    rod's tension ``m g + m l w^2`` not mattering at rest."""
    x, y = coordinates("x y")
    u = sp.Symbol("u")
    m, l, g = 2.0, 1.5, 9.81
    system = System([x, y], kinetic=m / 2 * (x.diff() ** 2 + y.diff() ** 2),
                    potential=m * g * y, constraints=[Holonomic(x**2 + y**2 - l**2)],
                    generalized_forces={x: sp.sin(u)}, inputs=[u])
    bottom = {"x": 0.0, "y": -l}
    ss = system.linearize(bottom).in_coordinates(["x"])
    assert ss.input_names == ("u",) and ss.state_names == ("x", "x_dot")
    assert np.abs(ss.A - [[0.0, 1.0], [-g / l, 0.0]]).max() < 1e-12
    assert np.abs(ss.B - [[0.0], [1.0 / m]]).max() < 1e-10  # measured 1.1e-15
    # about a nonzero input (an equilibrium with x held fixed): df/du = cos(u0)
    held = system.linearize(bottom, inputs={u: 0.7}, fixed=["x"])
    assert held.input_forces.shape == (2, 1) and held.input_forces[1, 0] == 0.0
    assert abs(held.input_forces[0, 0] - np.cos(0.7)) < 1e-10  # measured 1.6e-14
