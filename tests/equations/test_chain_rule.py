"""The shared-subexpression differentiator (:mod:`dalembert.equations.chain_rule`).

References: SymPy's own ``diff`` of the same expressions (the very same expressions
must come out: the generated code, and so every number, stays what it was), and
central finite differences of the expressions evaluated by ``lambdify``.
"""

from __future__ import annotations

import numpy as np
import pytest
import sympy as sp

from dalembert.equations.chain_rule import Differentiator

x, y, z, a = sp.symbols("x y z a")
L = sp.sqrt((x - 2 * y) ** 2 + z**2 + 1)

EXPRESSIONS = [
    3 * x**2 * y - y**3 + 7,
    (L - a) ** 2 * sp.sin(x * z) / L,
    sp.atan2(y, x + 3) * sp.exp(-z * x) + sp.log(x**2 + 1) * sp.cos(L),
    (1 + x * y) ** sp.Rational(-3, 2) * sp.tanh(z) + sp.asin(x / 4),
    sp.Abs(x - y) * L + sp.Piecewise((x**2, x > y), (y * z, True)),  # left to SymPy
    x**y + sp.Max(x, z) * a,  # a variable exponent and a non-function class: SymPy's rules
    sp.Function("u")(x, z) * y + sp.Heaviside(x) * z,  # an undefined function
]


@pytest.mark.parametrize("expr", EXPRESSIONS, ids=range(len(EXPRESSIONS)))
def test_derivatives_are_sympys_very_expressions(expr):
    # the same rules applied the same way: the same expression, not only the same value
    d = Differentiator()
    for v in (x, y, z, a):
        assert d.diff(expr, v) == sp.diff(expr, v), (expr, v)


def test_derivatives_match_finite_differences():
    expr = EXPRESSIONS[1] + EXPRESSIONS[2] + EXPRESSIONS[3]
    d = Differentiator()
    value = sp.lambdify((x, y, z, a), expr)
    point = np.array([0.3, -0.4, 0.7, 0.5])
    h = 1e-6
    for k, v in enumerate((x, y, z, a)):
        step = np.zeros(4)
        step[k] = h
        fd = (value(*(point + step)) - value(*(point - step))) / (2 * h)
        exact = float(d.diff(expr, v).subs(dict(zip((x, y, z, a), point))))
        assert exact == pytest.approx(fd, rel=1e-8, abs=1e-8)


def test_a_shared_subexpression_is_differentiated_once_per_variable():
    taken: list[tuple[sp.Basic, sp.Basic]] = []

    class Counting(Differentiator):
        def _derivative(self, expr, v):
            taken.append((expr, v))
            return super()._derivative(expr, v)

    d = Counting()
    rows = [L * x**k + sp.sin(L) * y for k in range(5)]
    for row in rows:
        for v in (x, y, z):
            d.diff(row, v)
    assert len(taken) == len(set(taken))  # never twice
    assert sum(expr == L for expr, _ in taken) == 3  # once by each variable


def test_what_does_not_contain_the_variable_is_zero_without_a_look_inside():
    d = Differentiator()
    assert d.diff(L * sp.sin(x), a) == 0
    assert d.free_symbols(L * sp.sin(x)) == {x, y, z}
    assert d.free_symbols(sp.Derivative(sp.Function("u")(x), x) * y) == {x, y}


def test_residual_and_lagrange_derivations_are_those_of_sympys_diff():
    """A spring of rest length ``l0`` and a damper on a particle in the plane on a
    rheonomic rod: the shared derivatives of the residuals' Jacobians and of the
    equations are entry for entry the expressions of SymPy's ``diff`` alone."""
    from dalembert import Holonomic, PointForce, System, coordinates
    from dalembert import t as time
    from dalembert.equations.residual import residual_jacobian_entries, residuals
    from dalembert.equations.sparse import jacobian_entries, rate

    p, q = coordinates("p q")
    k, c, l0, w = sp.symbols("k c l0 w", positive=True)
    pd, qd = p.diff(), q.diff()
    length = sp.sqrt(p**2 + q**2)
    damper = -c * (p * pd + q * qd) / length**2
    system = System([p, q], kinetic=(pd**2 + qd**2) / 2 + sp.sin(w * time) * pd,
                    potential=k / 2 * (length - l0) ** 2,
                    forces=[PointForce([damper * p, damper * q, 0], [p, q, 0])],
                    constraints=[Holonomic(p - sp.cos(q) - time, name="rod")])
    eqs = system.equations()
    found = residual_jacobian_entries(eqs)
    r1, r2 = residuals(eqs)
    for rows, block in ((r1, "r1"), (r2, "r2")):
        for variables, by in ((eqs.q, "q"), (eqs.qd, "qd")):
            assert getattr(found, f"{block}_{by}") == jacobian_entries(rows, variables)
    # f by SymPy's diff alone: dL/dq - d/dt dL/dqd + Q
    L, coords = system.model.lagrangian, system.model.coords
    for j, (qj, qdj) in enumerate(zip(coords.q, coords.qd)):
        momentum = sp.diff(L, qdj)
        convective, explicit = rate(momentum, coords.q, coords.qd, time)
        assert eqs.f[j] == sp.diff(L, qj) - convective - explicit + system.model.Q[j]
