"""Static equilibria of constrained Systems against closed forms and an independent minimization.

Sign convention: ``M qdd = f + A^T lambda``; at rest ``f(q, 0) + A^T lambda = 0``.
For a rod ``x^2 + y^2 - l^2 = 0`` the force on the bob is ``2 lambda (x, y)``, so the
rod tension (pulling towards the pivot) is ``-2 lambda l``.
"""

from __future__ import annotations

import dataclasses
import itertools
import math

import numpy as np
import pytest
import scipy.optimize
import sympy as sp
from statics_systems import L_ROD, M_BOB, G, spinning_hoop

from dalembert import Holonomic, InitialConditionError, Pfaffian, System, coordinates
from dalembert.errors import (
    EquilibriumNotFoundError,
    InconsistentConstraintsError,
    MarginalStabilityError,
)
from dalembert.examples import cartesian_pendulum
from dalembert.statics.equilibrium import equilibrium

# --------------------------------------------------------------------------- builders




def hoop_point(phi: float, R: float) -> dict[str, float]:
    """The bead at angle ``phi`` from the bottom."""
    return {"x": R * math.sin(phi), "z": -R * math.cos(phi)}


N_MASSES, SPAN, LINK, MASS = 20, 15.0, 1.0, 0.7


def pinned_chain() -> System:
    """20 point masses, 21 rigid links, pinned at (0, 0) and (SPAN, 0); y up."""
    m, g, L, D = sp.symbols("m g L D", positive=True)
    xs = coordinates(" ".join(f"x{i}" for i in range(1, N_MASSES + 1)))
    ys = coordinates(" ".join(f"y{i}" for i in range(1, N_MASSES + 1)))
    points = [(sp.Integer(0), sp.Integer(0)), *zip(xs, ys), (D, sp.Integer(0))]
    links = [
        Holonomic((p[0] - q[0]) ** 2 + (p[1] - q[1]) ** 2 - L**2, name=f"link{j + 1}")
        for j, (q, p) in enumerate(itertools.pairwise(points))
    ]
    return System(
        [c for pair in zip(xs, ys) for c in pair],
        kinetic=sum(m / 2 * (x.diff() ** 2 + y.diff() ** 2) for x, y in zip(xs, ys)),
        potential=sum(m * g * y for y in ys),
        constraints=links,
        parameters={m: MASS, g: G, L: LINK, D: SPAN},
        name="pinned chain",
    )


# --------------------------------------------------------------------------- pendulum


def test_pendulum_bottom_tension_is_weight(pendulum):
    eq = equilibrium(pendulum, {"x": 0.4, "y": -1.0})
    assert eq["x"] == pytest.approx(0.0, abs=1e-12)
    assert eq["y"] == pytest.approx(-L_ROD, abs=1e-12)
    tension = -2 * eq.multiplier("rod") * L_ROD
    assert tension == pytest.approx(M_BOB * G, rel=1e-12)
    # The rod holds the bob up: A^T lambda = (0, m g).
    np.testing.assert_allclose(eq.constraint_forces, [0.0, M_BOB * G], atol=1e-11)
    np.testing.assert_array_equal(eq.reaction, eq.constraint_forces)
    assert eq.stability == "stable"
    # K = -2 lambda I = (m g / l) I; the tangent is x: one eigenvalue m g / l.
    np.testing.assert_allclose(eq.stiffness_eigenvalues, [M_BOB * G / L_ROD], rtol=1e-12)
    assert eq.residual <= 1e-11
    assert eq.method == "newton"


def test_pendulum_top_is_found_and_unstable(pendulum):
    eq = equilibrium(pendulum, [0.2, 1.3])
    np.testing.assert_allclose(eq.q, [0.0, L_ROD], atol=1e-12)
    assert eq.stability == "unstable"
    # The rod is in compression at the top: tension -m g.
    assert -2 * eq.multiplier("rod") * L_ROD == pytest.approx(-M_BOB * G, rel=1e-12)
    np.testing.assert_allclose(eq.stiffness_eigenvalues, [-M_BOB * G / L_ROD], rtol=1e-12)


def test_parameters_override_and_no_regeneration(pendulum):
    eq = equilibrium(pendulum, {"x": 0.1, "y": -1.0}, parameters={"l": 3.0, "m": 1.0})
    np.testing.assert_allclose(eq.q, [0.0, -3.0], atol=1e-12)
    assert -2 * eq.multiplier("rod") * 3.0 == pytest.approx(G, rel=1e-12)
    assert eq.parameter_values == {"g": G, "l": 3.0, "m": 1.0}


def test_fixed_coordinate_needs_the_closed_form_holding_force(pendulum):
    # Bob held at x = 0.6 l: y = -0.8 l, and the horizontal force needed is m g tan(theta).
    eq = equilibrium(pendulum, {"x": 0.6 * L_ROD, "y": -0.5}, fixed=["x"])
    np.testing.assert_allclose(eq.q, [0.6 * L_ROD, -0.8 * L_ROD], atol=1e-12)
    np.testing.assert_allclose(eq.holding_forces, [M_BOB * G * 0.75, 0.0], rtol=1e-12)
    assert eq.fixed == ("x",)
    assert eq.stability == "stable"  # no free motion left
    assert eq.stiffness_eigenvalues.size == 0
    assert "holding forces" in str(eq)


def test_result_access_and_text(pendulum):
    eq = equilibrium(pendulum, {"x": 0.4, "y": -1.0})
    assert eq.by_name() == {"x": eq["x"], "y": eq["y"]}
    assert eq[cartesian_pendulum.y] == eq["y"]
    assert eq.multipliers_by_name() == {"rod": eq.multiplier("rod")}
    assert eq.constraint_force("y") == pytest.approx(M_BOB * G, rel=1e-12)
    text = str(eq)
    for piece in ("stable equilibrium", "rod = ", "constraint forces", "stiffness"):
        assert piece in text
    with pytest.raises(KeyError, match="coordinates are x, y"):
        eq["z"]
    with pytest.raises(KeyError, match="constraints are rod"):
        eq.multiplier("string")
    with pytest.raises(dataclasses.FrozenInstanceError):
        eq.stability = "unstable"
    with pytest.raises(ValueError):
        eq.q[0] = 1.0


# --------------------------------------------------------------------------- double pendulum


def test_double_pendulum_hanging_tensions():
    x1, y1, x2, y2 = coordinates("x1 y1 x2 y2")
    m, g, l = sp.symbols("m g l", positive=True)
    system = System(
        [x1, y1, x2, y2],
        kinetic=m / 2 * sum(v.diff() ** 2 for v in (x1, y1, x2, y2)),
        potential=m * g * (y1 + y2),
        constraints=[Holonomic(x1**2 + y1**2 - l**2, name="upper"),
                     Holonomic((x2 - x1) ** 2 + (y2 - y1) ** 2 - l**2, name="lower")],
        parameters={m: 1.3, g: G, l: 0.8},
    )
    eq = equilibrium(system, {"x1": 0.2, "y1": -0.7, "x2": -0.1, "y2": -1.5})
    np.testing.assert_allclose(eq.q, [0, -0.8, 0, -1.6], atol=1e-12)
    # The upper rod carries both bobs, the lower one.
    tensions = -2 * eq.multipliers * 0.8
    np.testing.assert_allclose(tensions, [2 * 1.3 * G, 1.3 * G], rtol=1e-12)
    assert eq.stability == "stable"


# --------------------------------------------------------------------------- spinning hoop


@pytest.mark.parametrize("W", [4.5, 6.0])
def test_hoop_off_bottom_equilibrium_above_critical_speed(W):
    g, R = 9.81, 0.7
    assert g / R < W**2
    system = spinning_hoop(W=W, R=R, g=g)
    phi = math.acos(g / (R * W**2))
    eq = equilibrium(system, hoop_point(0.7 * phi + 0.2, R))
    np.testing.assert_allclose(eq.q, list(hoop_point(phi, R).values()), atol=1e-12)
    assert eq.stability == "stable"
    # Radial balance: 2 lambda = -m W^2 (the x-equation m W^2 x + 2 lambda x = 0).
    assert eq.multiplier("hoop") == pytest.approx(-0.3 * W**2 / 2, rel=1e-12)
    bottom = equilibrium(system, hoop_point(0.05, R))
    np.testing.assert_allclose(bottom.q, [0.0, -R], atol=1e-12)
    assert bottom.stability == "unstable"


def test_hoop_bottom_is_stable_below_critical_speed():
    system = spinning_hoop(W=2.0)
    assert 2.0**2 < 9.81 / 0.7
    eq = equilibrium(system, hoop_point(0.6, 0.7))
    np.testing.assert_allclose(eq.q, [0.0, -0.7], atol=1e-12)
    assert eq.stability == "stable"
    # Kr = m (g / R - W^2) on the unit tangent (1, 0).
    np.testing.assert_allclose(eq.stiffness_eigenvalues, [0.3 * (9.81 / 0.7 - 4.0)], rtol=1e-12)
    top = equilibrium(system, hoop_point(2.9, 0.7))
    np.testing.assert_allclose(top.q, [0.0, 0.7], atol=1e-12)
    assert top.stability == "unstable"


def test_hoop_at_critical_speed_is_marginal():
    g, R = 9.81, 0.7
    system = spinning_hoop(W=math.sqrt(g / R), g=g, R=R)
    eq = equilibrium(system, hoop_point(0.05, R))
    # A pitchfork: the residual grows like x^3 there, so Newton converges only linearly
    # and a residual of 1e-12 pins x down to about its cube root.
    assert eq.residual <= 1e-12
    np.testing.assert_allclose(eq.q, [0.0, -R], atol=1e-4)
    assert eq.stability == "marginal"
    with pytest.raises(MarginalStabilityError, match=r"singular: eigenvalue .* along \(x: \+1"):
        equilibrium(system, hoop_point(0.05, R), on_marginal="raise")


# --------------------------------------------------------------------------- pinned chain


def _chain_closed_form() -> tuple[np.ndarray, np.ndarray, float]:
    """Positions, link tensions and horizontal tension of the hanging chain.

    The horizontal tension ``H`` is the same in every link and the vertical one grows by
    ``m g`` at each mass; by symmetry the middle link (11) is level, so link ``j`` has
    slope ``tan(theta_j) = (j - 11) m g / H``; ``H`` closes the span.
    """
    j = np.arange(1, N_MASSES + 2)
    middle = (N_MASSES + 2) / 2

    def closure(c: float) -> float:
        return LINK * np.sum(1 / np.sqrt(1 + ((j - middle) * c) ** 2)) - SPAN

    c = scipy.optimize.brentq(closure, 1e-6, 1e3, xtol=1e-15, rtol=1e-15)
    theta = np.arctan((j - middle) * c)
    points = np.cumsum(LINK * np.column_stack([np.cos(theta), np.sin(theta)]), axis=0)
    H = MASS * G / c
    return points[:N_MASSES], H / np.cos(theta), H


def _chain_by_minimization() -> np.ndarray:
    """Minimize V over the 21 link angles subject to end closure (SLSQP)."""
    j = np.arange(1, N_MASSES + 2)
    weight = MASS * G * LINK * (N_MASSES + 1 - j)  # mass i sits below links 1..i

    result = scipy.optimize.minimize(
        lambda th: weight @ np.sin(th),
        np.linspace(-0.9, 0.9, N_MASSES + 1),
        jac=lambda th: weight * np.cos(th),
        constraints=[
            {"type": "eq", "fun": lambda th: LINK * np.cos(th).sum() - SPAN,
             "jac": lambda th: -LINK * np.sin(th)},
            {"type": "eq", "fun": lambda th: LINK * np.sin(th).sum(),
             "jac": lambda th: LINK * np.cos(th)},
        ],
        method="SLSQP",
        options={"ftol": 1e-15, "maxiter": 1000},
    )
    assert result.success, result.message
    points = np.cumsum(LINK * np.column_stack([np.cos(result.x), np.sin(result.x)]), axis=0)
    return points[:N_MASSES]


@pytest.fixture(scope="module")
def chain_equilibrium():
    system = pinned_chain()
    # A shallow parabola (too short): the projection stretches it onto the links.
    x = np.arange(1, N_MASSES + 1) * SPAN / (N_MASSES + 1)
    guess = np.column_stack([x, -0.05 * x * (SPAN - x)]).ravel()
    return equilibrium(system, guess)


@pytest.mark.validation
def test_chain_shape_matches_independent_minimization(chain_equilibrium):
    eq = chain_equilibrium
    assert eq.stability == "stable"
    points = eq.q.reshape(N_MASSES, 2)
    np.testing.assert_allclose(points, _chain_by_minimization(), atol=1e-7)
    closed, tensions, _ = _chain_closed_form()
    np.testing.assert_allclose(points, closed, atol=1e-12)
    # Link tension -2 lambda L (each link constraint is |p_j - p_{j-1}|^2 - L^2).
    np.testing.assert_allclose(-2 * eq.multipliers * LINK, tensions, rtol=1e-11)


@pytest.mark.validation
def test_chain_support_reactions_carry_the_weight(chain_equilibrium):
    eq = chain_equilibrium
    points = eq.q.reshape(N_MASSES, 2)
    # The pins act on the chain through the end links: 2 lambda (p - pin).
    left = 2 * eq.multiplier("link1") * (points[0] - [0.0, 0.0])
    right = 2 * eq.multiplier(f"link{N_MASSES + 1}") * (points[-1] - [SPAN, 0.0])
    weight = N_MASSES * MASS * G
    assert left[1] + right[1] == pytest.approx(weight, rel=1e-12, abs=1e-10)
    assert left[0] + right[0] == pytest.approx(0.0, abs=1e-10)
    _, _, H = _chain_closed_form()
    assert left[0] == pytest.approx(-H, rel=1e-11)  # the left pin pulls outwards with H


# --------------------------------------------------------------------------- nonholonomic


def test_knife_edge_on_incline_equilibrium_with_blade_reaction():
    # Blade on a plane inclined along y: it rests only when pointing across the slope
    # (theta = 0), the blade's lateral reaction balancing the downhill pull m g sin(alpha).
    x, y, th = coordinates("x y theta")
    m, g, J, alpha = sp.symbols("m g J alpha", positive=True)
    system = System(
        [x, y, th],
        kinetic=m / 2 * (x.diff() ** 2 + y.diff() ** 2) + J / 2 * th.diff() ** 2,
        potential=m * g * sp.sin(alpha) * y,
        constraints=[Pfaffian(-sp.sin(th) * x.diff() + sp.cos(th) * y.diff(), name="blade")],
        parameters={m: 2.0, g: G, J: 0.1, alpha: 0.3},
    )
    eq = equilibrium(system, {"x": 1.0, "y": 2.0, "theta": 0.2})
    assert eq["theta"] == pytest.approx(0.0, abs=1e-12)
    assert eq.multiplier("blade") == pytest.approx(2.0 * G * math.sin(0.3), rel=1e-12)
    assert eq.stability == "undetermined"


# --------------------------------------------------------------------------- errors


def test_no_equilibrium_on_an_inclined_wire():
    # A bead on a straight inclined wire slides forever: no equilibrium anywhere.
    x, y = coordinates("x y")
    m, g = sp.symbols("m g", positive=True)
    system = System([x, y], kinetic=m / 2 * (x.diff() ** 2 + y.diff() ** 2),
                    potential=m * g * y, constraints=[Holonomic(y - x / 2, name="wire")],
                    parameters={m: 1.0, g: G})
    with pytest.raises(EquilibriumNotFoundError) as info:
        equilibrium(system, {"x": 1.0, "y": 0.5}, max_iter=20)
    message = str(info.value)
    for piece in ("no static equilibrium found near the guess", "Newton", "unbalanced",
                  "Try a guess closer", "fixed="):
        assert piece in message


def test_constraints_that_cannot_hold_together():
    x, y, z = coordinates("x y z")
    m = sp.Symbol("m", positive=True)
    system = System([x, y, z], kinetic=m / 2 * (x.diff() ** 2 + y.diff() ** 2 + z.diff() ** 2),
                    potential=m * z,
                    constraints=[Holonomic(x**2 + y**2 - 1, name="circle"),
                                 Holonomic(y - 2, name="line")],
                    parameters={m: 1.0})
    with pytest.raises(InconsistentConstraintsError, match="cannot be satisfied near the guess"):
        equilibrium(system, {"x": 0.5, "y": 1.0, "z": 0.0})


def test_fixed_coordinate_out_of_reach(pendulum):
    with pytest.raises(InconsistentConstraintsError, match=r"with x held fixed.*fix fewer"):
        equilibrium(pendulum, {"x": 2 * L_ROD, "y": -1.0}, fixed=["x"])


def test_guess_at_a_singular_point_of_the_constraints(pendulum):
    # At the pivot the rod constraint's gradient 2 (x, y) vanishes.
    with pytest.raises(InconsistentConstraintsError, match="rank 0 < 1"):
        equilibrium(pendulum, {"x": 0.0, "y": 0.0})


def test_bad_arguments(pendulum):
    with pytest.raises(InitialConditionError, match="guess names 'z'"):
        equilibrium(pendulum, {"z": 1.0})
    with pytest.raises(InitialConditionError, match="3 values for 2 coordinates"):
        equilibrium(pendulum, [1.0, 2.0, 3.0])
    with pytest.raises(ValueError, match="tol"):
        equilibrium(pendulum, [0.1, -1.0], tol=0.0)
    with pytest.raises(ValueError, match="on_marginal"):
        equilibrium(pendulum, [0.1, -1.0], on_marginal="ignore")
    with pytest.raises(ValueError, match="The 't' parameter of equilibrium must be a finite "
                       "number; got inf"):
        equilibrium(pendulum, [0.1, -1.0], t=math.inf)
