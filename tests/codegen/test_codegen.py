"""Generated NumPy code against direct SymPy evaluation."""

from __future__ import annotations

import numpy as np
import pytest
import sympy as sp

from dalembert import Holonomic, Pfaffian, System, coordinates, t
from dalembert.codegen.compiled import compile_equations
from dalembert.codegen.numpy_printer import generate_function

x, y, th = coordinates("x y theta")
m, g, l, k, W = sp.symbols("m g l k Omega", positive=True)


def rich_system() -> System:
    """Rotating frame, trig, time dependence, both constraint kinds: exercises cse."""
    T = m / 2 * ((x.diff() - W * y) ** 2 + (y.diff() + W * x) ** 2) \
        + m * l**2 / 2 * th.diff() ** 2 * (1 + sp.sin(th) ** 2)
    V = m * g * l * (1 - sp.cos(th)) + k / 2 * (x**2 + y**2) * sp.exp(-t)
    return System(
        [x, y, th], kinetic=T, potential=V,
        generalized_forces={th: -sp.sqrt(1 + th.diff() ** 2) * th.diff()},
        constraints=[Holonomic(x * sp.cos(t) + y - l * sp.sin(th), name="h"),
                     Pfaffian(sp.cos(th) * x.diff() - y.diff() + t, name="p")],
        parameters={m: 1.3, g: 9.81, l: 0.7, k: 2.0, W: 0.4},
    )


def test_generate_function_matches_sympy_at_random_points():
    a, b, p = sp.symbols("a b p")
    exprs = sp.Matrix([[sp.sin(a) * sp.exp(b) + p, sp.atan2(a, b)],
                       [sp.sqrt(a**2 + b**2) / p, 0]])
    vec = sp.Matrix([sp.sin(a) * sp.exp(b), sp.log(1 + b**2) * p])
    fn = generate_function("f", [("q", [a, b]), ("p", [p])], [("E", exprs), ("v", vec)])
    rng = np.random.default_rng(1)
    for _ in range(20):
        q, pv = rng.normal(size=2), rng.uniform(0.5, 2, size=1)
        E, v = fn(q, pv)
        subs = {a: q[0], b: q[1], p: pv[0]}
        assert E.shape == (2, 2) and v.shape == (2,)
        np.testing.assert_allclose(E, np.array(exprs.subs(subs).evalf(), dtype=float),
                                   rtol=1e-14, atol=1e-15)
        np.testing.assert_allclose(v, np.array(vec.subs(subs).evalf(), dtype=float).ravel(),
                                   rtol=1e-14, atol=1e-15)
    assert "def f(q, p):" in fn.__source__


def test_compiled_equations_match_sympy():
    system = rich_system()
    eqs = system.equations()
    num = system.numeric()
    params = dict(zip(system.parameters, num.p))
    rng = np.random.default_rng(7)
    worst = 0.0
    for _ in range(10):
        ti, q, qd = rng.uniform(0, 3), rng.normal(size=3), rng.normal(size=3)
        subs = {t: ti, **dict(zip(eqs.q, q)), **dict(zip(eqs.qd, qd)), **params}
        for got, sym in zip(num.kkt_blocks(ti, q, qd), (eqs.M, eqs.f, eqs.A, eqs.c)):
            ref = np.array(sym.subs(subs).evalf(30), dtype=float).reshape(np.shape(got))
            worst = max(worst, np.abs(got - ref).max() / max(1.0, np.abs(ref).max()))
        _, b = num.velocity_constraint(ti, q)
        ref_b = np.array(eqs.b.subs(subs).evalf(30), dtype=float).ravel()
        np.testing.assert_allclose(b, ref_b, rtol=1e-13, atol=1e-13)
        psi = float(system.model.constraints.psi[0].subs(subs).evalf(30))
        assert abs(num.position_constraint(ti, q)[0] - psi) < 1e-13
    assert worst < 1e-13


def test_single_coordinate_keeps_matrix_shapes():
    # A 1x1 mass matrix and a 0x1 constraint matrix stay 2-D (they were once returned
    # 1-D, which broke the KKT assembly of unconstrained one-coordinate systems).
    system = System([x], kinetic=m / 2 * x.diff() ** 2, parameters={m: 2.0})
    M, f, A, c = system.numeric().kkt_blocks(0.0, np.array([0.0]), np.array([1.0]))
    assert M.shape == (1, 1) and f.shape == (1,) and A.shape == (0, 1) and c.shape == (0,)
    A, b = system.numeric().velocity_constraint(0.0, np.array([0.0]))
    assert A.shape == (0, 1) and b.shape == (0,)


def test_energies_and_jacobi_integral():
    system = rich_system()
    num = system.numeric()
    q, qd = np.array([0.3, -0.2, 0.5]), np.array([0.1, 0.4, -0.7])
    T, V, h = num.energies(1.0, q, qd)
    L = system.model.lagrangian
    subs = {t: 1.0, **dict(zip(system.model.coords.q, q)),
            **dict(zip(system.model.coords.qd, qd)), **dict(zip(system.parameters, num.p))}
    assert abs(T - float(system.model.kinetic.subs(subs))) < 1e-14
    assert abs(V - float(system.model.potential.subs(subs))) < 1e-14
    h_ref = sum(v * L.diff(v) for v in system.model.coords.qd) - L
    assert abs(h - float(h_ref.subs(subs))) < 1e-13


def test_lagrangian_only_energies_are_nan():
    system = System([x], lagrangian=x.diff() ** 2 / 2 - x**2 / 2)
    T, V, h = system.numeric().energies(0.0, np.array([1.0]), np.array([2.0]))
    assert np.isnan(T) and np.isnan(V) and h == pytest.approx(2.5, abs=1e-15)


def test_parameters_rebind_without_regenerating():
    system = rich_system()
    compiled = compile_equations(system.equations())
    p = system.numeric().p
    a = compiled.bind(p).kkt_blocks(0.0, np.ones(3), np.ones(3))[1]
    b = compiled.bind(p * 2).kkt_blocks(0.0, np.ones(3), np.ones(3))[1]
    assert not np.allclose(a, b)


def test_one_coordinate_named_q_and_one_parameter_named_p():
    # Single-symbol arguments whose symbol has the argument's own name were once
    # unpacked as scalars, so the arrays q and p broke the generated code.
    q = coordinates("q")[0]
    p = sp.Symbol("p")
    system = System([q], kinetic=q.diff() ** 2 / 2, potential=p * q**2 / 2, parameters={p: 1.0})
    traj = system.simulate((0, np.pi), q0=[1.0])
    assert abs(traj["q"][-1] + 1.0) < 1e-10  # cos(pi)


def test_user_symbols_named_like_temporaries_do_not_clash():
    # cse temporaries print as x0, x1...; coordinates called x0, x1 must stay distinct.
    x0, x1, p0 = sp.symbols("x0 x1 x2")
    shared = sp.sin(x0 + x1)
    exprs = sp.Matrix([shared * x1 + p0, shared**2 - x0, sp.cos(x0 + x1) * shared])
    fn = generate_function("f", [("q", [x0, x1]), ("p", [p0])], [("v", exprs)])
    q, pv = np.array([0.3, -1.1]), np.array([2.5])
    want = np.array(exprs.subs({x0: q[0], x1: q[1], p0: pv[0]}).evalf(), dtype=float).ravel()
    np.testing.assert_allclose(fn(q, pv)[0], want, rtol=1e-15, atol=1e-15)


def test_chain_kkt_blocks_match_direct_evaluation():
    from dalembert.multibody import chain

    system = chain(2, 1.0, 1.0, 0.05).system
    eqs = system.equations()
    blocks = [sp.lambdify([*eqs.q, *eqs.qd], mat) for mat in (eqs.M, eqs.f, eqs.A, eqs.c)]
    rng = np.random.default_rng(5)
    q, qd = rng.normal(size=14), rng.normal(size=14)
    for got, fn in zip(system.numeric().kkt_blocks(0.0, q, qd), blocks):
        want = np.asarray(fn(*q, *qd), dtype=float)
        np.testing.assert_allclose(got, want.reshape(got.shape), rtol=1e-13, atol=1e-13)
