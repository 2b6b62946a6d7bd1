"""The sparse derivation against the plain dense SymPy formulas, written out here.

The reference takes every derivative with ``Matrix.jacobian`` (no skipping, no
term splitting) straight from the model's Lagrangian, constraint expressions and
forces; both sides are evaluated at random points.
"""

from __future__ import annotations

import numpy as np
import pytest
import sympy as sp

from dalembert import Holonomic, Pfaffian, PointForce, System, coordinates, t
from dalembert.equations.sparse import dense, gradient, nonzero_entries, rate
from dalembert.multibody import chain

x, y, th = coordinates("x y theta")
m, g, l, k, a, w, c = sp.symbols("m g l k a omega c", positive=True)


def dense_reference(model) -> dict[str, sp.Matrix]:
    """``M, f, A, b, c`` by the textbook formulas, every derivative taken densely."""
    coords = model.coords
    q, qd = sp.Matrix(coords.q), sp.Matrix(coords.qd)
    L = sp.Matrix([model.lagrangian])
    p = L.jacobian(qd).T
    rows_A, rows_b = [], []
    for kind, expr in zip(model.constraints.kinds, model.constraints.exprs):
        if kind == "holonomic":
            rows_A.append(sp.Matrix([expr]).jacobian(q))
            rows_b.append(expr.diff(t))
        else:
            rows_A.append(sp.Matrix([expr]).jacobian(qd))
            rows_b.append(expr.xreplace(dict.fromkeys(coords.qd, 0)))
    A = sp.Matrix.vstack(*rows_A) if rows_A else sp.zeros(0, coords.n)
    b = sp.Matrix(len(rows_b), 1, rows_b)
    gv = A * qd + b
    return {
        "M": p.jacobian(qd),
        "f": L.jacobian(q).T - p.jacobian(q) * qd - p.diff(t) + model.Q,
        "A": A, "b": b,
        "c": -(gv.jacobian(q) * qd + gv.diff(t)) if rows_A else sp.zeros(0, 1),
    }


def worst_difference(system: System, points: int = 5) -> float:
    """Largest |fast - dense| relative to max(1, |dense|) over random states."""
    model, eqs = system.model, system.equations()
    ref = dense_reference(model)
    args = [t, *model.coords.q, *model.coords.qd, *model.parameters]
    rng = np.random.default_rng(3)
    worst = 0.0
    for name in ("M", "f", "A", "b", "c"):
        fast = getattr(eqs, name)
        assert fast.shape == ref[name].shape, name
        if fast.shape[0] == 0:
            continue
        fn_fast, fn_ref = sp.lambdify(args, fast), sp.lambdify(args, ref[name])
        for _ in range(points):
            vals = rng.uniform(0.3, 1.2, size=len(args))
            got, want = np.asarray(fn_fast(*vals), float), np.asarray(fn_ref(*vals), float)
            worst = max(worst, float(np.max(np.abs(got - want) / np.maximum(1, np.abs(want)))))
    return worst


def test_rheonomic_constraint_and_velocity_dependent_forces():
    # Driven x, a string of time-varying length, quadratic drag on theta, a blade.
    T = m / 2 * (x.diff() ** 2 + y.diff() ** 2) + m * l**2 / 2 * (1 + t) * th.diff() ** 2
    V = m * g * y + k / 2 * (x - y) ** 2 * sp.cos(th)
    drag = PointForce([-c * x.diff() * sp.Abs(x.diff()), -c * y.diff(), 0], [x, y, 0])
    system = System(
        [x, y, th], kinetic=T, potential=V,
        generalized_forces={th: -c * th.diff() ** 3},
        forces=[drag],
        constraints=[Holonomic(x**2 + y**2 - (l + a * sp.sin(w * t)) ** 2, name="string"),
                     Pfaffian(sp.cos(th) * x.diff() - y.diff() + a * t, name="blade")],
    )
    assert worst_difference(system) < 1e-13


def test_lagrangian_with_gyroscopic_terms_and_no_constraints():
    W = sp.Symbol("Omega")
    L = m / 2 * ((x.diff() - W * y) ** 2 + (y.diff() + W * x) ** 2) - k * x * y * sp.exp(-t)
    assert worst_difference(System([x, y], lagrangian=L)) < 1e-13


def test_quaternion_chain_matches_dense_formulas():
    system = chain(2, 1.0, 1.0, 0.05).system
    assert worst_difference(system, points=3) < 1e-12


def test_gradient_equals_jacobian_and_skips_absent_variables():
    u, v, s = sp.symbols("u v s")
    exprs = [u**2 * v + sp.sin(s) * v + 3, sp.exp(u * v), u, sp.S(4), (u + v) ** 3 * s]
    for e in exprs:
        dense_row = sp.Matrix([e]).jacobian([u, v, s])
        sparse_row = gradient(e, [u, v, s])
        assert all(sp.expand(dense_row[j] - sparse_row.get(j, 0)) == 0 for j in range(3))
        assert all(d != 0 for d in sparse_row.values())


def test_rate_is_the_total_time_derivative_split():
    u, ud = sp.symbols("u u_dot")
    e = u**3 * sp.sin(t)
    convective, explicit = rate(e, [u], [ud], t)
    total = sp.diff(e.subs(u, sp.Function("U")(t)), t)
    expected = total.subs(sp.Derivative(sp.Function("U")(t), t), ud).subs(sp.Function("U")(t), u)
    assert sp.simplify(convective + explicit - expected) == 0


def test_dense_and_nonzero_entries_round_trip():
    entries = {(0, 2): sp.Symbol("a"), (1, 0): sp.S(5)}
    mat = dense(entries, 2, 3)
    assert mat.shape == (2, 3) and nonzero_entries(mat) == entries
    assert dense({}, 0, 3).shape == (0, 3)


def test_non_quadratic_kinetic_energy_still_names_the_velocities():
    from dalembert.errors import ModelError

    with pytest.raises(ModelError, match="x_dot and x_dot"):
        System([x, y], kinetic=x.diff() ** 4 + y.diff() ** 2).equations()
