"""Joint constraints differentiated on their expression trees equal SymPy's derivatives."""

from __future__ import annotations

import copy

import numpy as np
import pytest
import sympy as sp

from dalembert import t as time
from dalembert.equations.lagrange import derive_equations
from dalembert.model.constraints import Holonomic
from dalembert.model.coordinates import coordinates
from dalembert.model.model import build_part_model
from dalembert.multibody import (
    Distance,
    Fixed,
    Ground,
    PlanarBody,
    Prismatic,
    Revolute,
    RigidBody,
    Universal,
)
from dalembert.multibody.derivatives import NotPolynomial, holonomic_rates
from dalembert.multibody.parts import _constraint_equations, _template_body


def test_rates_of_a_polynomial_are_exact():
    x, y, xd, yd = sp.symbols("x y x_dot y_dot")
    psi = [x**2 * y + (x - 2 * y) ** 3 * sp.sqrt(2), x * y - 1]
    A, c = holonomic_rates(psi, [x, y], [xd, yd])
    A_ref = sp.Matrix(psi).jacobian([x, y])
    c_ref = -(A_ref * sp.Matrix([xd, yd])).jacobian([x, y]) * sp.Matrix([xd, yd])
    assert sp.expand(A - A_ref) == sp.zeros(2, 2)
    assert sp.expand(c - c_ref) == sp.zeros(2, 1)


def test_rates_through_sines_and_cosines_are_exact():
    x, y, xd, yd = sp.symbols("x y x_dot y_dot")
    psi = [x * sp.cos(y) - sp.sin(y) ** 2 + sp.sin(2 * x + y), sp.cos(x) * sp.sin(y) - 1]
    A, c = holonomic_rates(psi, [x, y], [xd, yd])
    A_ref = sp.Matrix(psi).jacobian([x, y])
    c_ref = -(A_ref * sp.Matrix([xd, yd])).jacobian([x, y]) * sp.Matrix([xd, yd])
    assert sp.simplify(A - A_ref) == sp.zeros(2, 2)
    assert sp.simplify(sp.expand(c - c_ref)) == sp.zeros(2, 1)


def test_other_functions_are_refused():
    x, y = sp.symbols("x y")
    with pytest.raises(NotPolynomial):
        holonomic_rates([sp.exp(x) + y], [x, y], sp.symbols("a b"))


def skew_joints():
    a = RigidBody("a", 1.0, (0.1, 0.2, 0.3))
    b = RigidBody("b", 1.0, (0.1, 0.2, 0.3))
    return [
        Revolute("hinge", a, b, (0.1, 0, -0.5), (0, 0.2, 0.5), axis_a=(0.3, 0.5, 0.8),
                 axis_b=(0.6, -0.2, 0.1)),
        Revolute("top", Ground(), b, (0, 0, 1), (0, 0, 0.5), axis_a=(1, 1, 0)),
        Universal("cardan", a, b, (0, 0, -0.5), (0, 0, 0.5)),
        Prismatic("slider", a, b, (0, 0, -0.5), (0, 0, 0.5), axis_a=(0, 0.6, 0.8)),
        Fixed("weld", a, b, (0.1, 0, -0.5), (0, 0, 0.2)),
        *planar_joints(),
    ]


def planar_joints():
    a, b = PlanarBody("pa", 1.0, 0.1), PlanarBody("pb", 1.0, 0.1)
    return [
        Revolute("pin", a, b, (0.3, -0.5, 0), (-0.1, 0.5, 0)),
        Revolute("ground_pin", Ground(), b, (1, 2, 0), (0, 0.5, 0)),
        Prismatic("planar_slider", a, b, (0, 0.2, 0), (0.1, 0, 0), axis_a=(0.6, 0.8, 0),
                  axis_b=(1, 0, 0)),
        Fixed("planar_weld", a, b, (0.1, -0.5, 0), (0, 0.2, 0)),
        Distance("planar_rod", a, b, 1.5, (0.1, 0.3, 0), (-0.2, 0, 0)),
    ]


def assert_same_values(fast, whole, names):
    """Equal values of the equations' ``names`` at random states."""
    assert fast.model.constraints.names == whole.model.constraints.names
    q, qd = whole.model.coords.q, whole.model.coords.qd
    values = np.random.default_rng(2).normal(size=(3, 2 * len(q)))
    pairs = [(getattr(fast, k), getattr(whole, k)) for k in names]
    for mine, ref in pairs:
        mine, ref = (sp.lambdify([*q, *qd], e, "numpy") for e in (mine, ref))
        for v in values:
            np.testing.assert_allclose(mine(*v), ref(*v), rtol=1e-12, atol=1e-12)


@pytest.mark.parametrize("joint", skew_joints(), ids=lambda j: j.name)
def test_joint_equations_match_the_general_derivation(joint):
    template = copy.copy(joint)
    template.body_a = _template_body(joint.body_a, "a")
    template.body_b = _template_body(joint.body_b, "b")
    coords = [*template.body_a.coordinates, *template.body_b.coordinates]
    fast = _constraint_equations(coords, template.constraints(), "joint")
    whole = derive_equations(build_part_model(coords, constraints=template.constraints()))
    assert_same_values(fast, whole, ("A", "b", "c"))


def test_constraints_with_time_take_the_general_route():
    x, y = coordinates("x y")
    rows = [Holonomic(x - sp.cos(time), name="driven"), Holonomic(x * y - 1, name="hyperbola")]
    fast = _constraint_equations([x, y], rows, "driver")
    whole = derive_equations(build_part_model([x, y], constraints=rows))
    assert fast.b == whole.b != sp.zeros(2, 1)
    assert fast.c == whole.c
