"""The compiled-C route: same values as the NumPy route, disk cache, fallbacks."""

from __future__ import annotations

import warnings

import numpy as np
import pytest
import sympy as sp

from dalembert.codegen import c_backend
from dalembert.codegen.compiled import compile_equations
from dalembert.errors import NativeUnavailableWarning
from dalembert.examples import coin, spherical_chain

needs_cc = pytest.mark.skipif(c_backend.find_compiler() is None, reason="no C compiler found")
x, y, k = sp.symbols("x y k")
#: Trig, roots, powers (integer, negative, fractional, in denominators), atan2,
#: exp/log, a rational.
EXPRS = [sp.sin(x) * sp.exp(y) + k, sp.atan2(x, y), sp.sqrt(x**2 + y**2) / k,
         x**3 - y**-2 + sp.Rational(1, 3) * x ** sp.Rational(5, 2), sp.log(1 + y**2) * sp.cos(k),
         sp.Abs(x - y) * sp.tanh(x), sp.pi * x**4, x / y**2, x / y**3, k * (x + 1) / y**4,
         x / (k * y**3)]


@pytest.fixture()
def cache(tmp_path, monkeypatch):
    monkeypatch.setenv("DALEMBERT_CACHE_DIR", str(tmp_path))
    monkeypatch.setattr(c_backend, "_WARNED", set())  # each test sees its warnings
    return tmp_path


def evaluate(use):
    spec = ("f", [("q", [x, y]), ("p", [k])], EXPRS)
    (fn,) = c_backend.build_flat_functions([spec], use=use)
    return fn


@needs_cc
def test_c_matches_sympy_at_random_points(cache):
    fn = evaluate("c")
    assert hasattr(fn, "library")
    rng = np.random.default_rng(0)
    for _ in range(20):
        q, p = rng.uniform(0.1, 2.0, size=2), rng.uniform(0.5, 2.0, size=1)
        expected = [float(e.subs({x: q[0], y: q[1], k: p[0]})) for e in EXPRS]
        assert np.allclose(fn(q, p), expected, rtol=1e-14, atol=0)


@needs_cc
@pytest.mark.parametrize("module", [spherical_chain, coin], ids=["chain2", "coin"])
def test_c_and_numpy_equations_agree(cache, module):
    system = module.build(2) if module is spherical_chain else module.build()
    eqs = system.equations()
    fast, slow = (compile_equations(eqs, backend=b).bind(system.numeric().p)
                  for b in ("c", "numpy"))
    assert fast.compiled.backend == "c" and slow.compiled.backend == "numpy"
    q0 = np.resize(np.r_[1.0, 0.2, -0.3, 0.9, 0.1, -0.2, 0.3], fast.n)  # away from singular
    rng = np.random.default_rng(1)
    for _ in range(5):
        t, q, qd = rng.uniform(0, 1), q0 + 0.1 * rng.normal(size=fast.n), rng.normal(size=fast.n)
        for a, b in zip(fast.kkt_sparse(t, q, qd), slow.kkt_sparse(t, q, qd)):
            assert np.allclose(a, b, rtol=1e-12, atol=1e-12)
        for a, b in zip(fast.velocity_sparse(t, q), slow.velocity_sparse(t, q)):
            assert np.allclose(a, b, rtol=1e-12, atol=1e-12)
        assert np.allclose(fast.position_constraint(t, q), slow.position_constraint(t, q),
                           rtol=1e-12, atol=1e-12)
        assert np.allclose(fast.energies(t, q, qd), slow.energies(t, q, qd), rtol=1e-12)


@needs_cc
def test_cache_hit_runs_neither_cse_nor_the_compiler(cache, monkeypatch):
    evaluate("c")
    assert len(list((cache / "c").glob("*.so"))) == 1

    def forbidden(*args, **kwargs):
        raise AssertionError("regenerated on a cache hit")

    monkeypatch.setattr(c_backend.subprocess, "run", forbidden)
    monkeypatch.setattr(c_backend.sp, "cse", forbidden)
    fn = evaluate("c")
    assert np.isclose(fn(np.array([1.0, 2.0]), np.array([3.0]))[0], np.sin(1) * np.exp(2) + 3)


def test_cache_key_tells_expressions_apart():
    f = sp.Function("f")
    shared = sp.sin(x) * y  # a subexpression shared by several outputs, digested once

    def key(exprs, arguments=(("q", [x, y]), ("p", [k]))):
        return c_backend._cache_key([("g", list(arguments), exprs)], "cc", "v")

    base = [shared + 1, shared**2, f(x)]
    assert key(base) == key([shared + 1, shared**2, f(x)])
    for other in ([shared + 2, shared**2, f(x)], [shared + 1, shared**3, f(x)],
                  [shared + 1, shared**2, sp.Function("h")(x)], [shared + 1, shared**2, f(y)],
                  [shared + sp.Float(1.0), shared**2, f(x)], base[:2]):
        assert key(other) != key(base), other
    assert key(base, (("q", [y, x]), ("p", [k]))) != key(base)


def test_numpy_fallback_without_a_compiler(cache, monkeypatch):
    monkeypatch.setattr(c_backend, "find_compiler", lambda: None)
    with pytest.warns(NativeUnavailableWarning, match="no C compiler found"):
        assert c_backend.backend() == "numpy"
    fn = evaluate(None)
    assert not hasattr(fn, "library")
    assert np.isclose(fn(np.array([1.0, 2.0]), np.array([3.0]))[0], np.sin(1) * np.exp(2) + 3)


def test_failing_compiler_warns_and_falls_back(cache, monkeypatch):
    monkeypatch.setenv("CC", "false")
    with pytest.warns(UserWarning, match="using NumPy"):
        fn = evaluate("c")
    assert np.isclose(fn(np.array([1.0, 2.0]), np.array([3.0]))[1], np.arctan2(1.0, 2.0))


def test_backend_environment_variable(monkeypatch):
    monkeypatch.setenv("DALEMBERT_BACKEND", "numpy")
    assert c_backend.backend() == "numpy"
    monkeypatch.setenv("DALEMBERT_BACKEND", "fortran")
    with pytest.raises(ValueError, match="DALEMBERT_BACKEND must be one of"):
        c_backend.backend()


@needs_cc
def test_unwritable_cache_falls_back_with_a_hint(tmp_path, monkeypatch):
    blocker = tmp_path / "file"
    blocker.write_text("not a folder")
    monkeypatch.setenv("DALEMBERT_CACHE_DIR", str(blocker))
    with pytest.warns(UserWarning, match="DALEMBERT_CACHE_DIR"):
        fn = evaluate("c")
    assert not hasattr(fn, "library")


@needs_cc
def test_a_spring_over_a_squared_length_oscillates_at_its_frequency(cache):
    """``V = x^2 / (2 l^2)`` (unit mass): ``x = cos(t / l)``. A power in a denominator
    was once printed as ``x/(l)*(l)``, which C reads as ``x``: the frequency was 1."""
    from dalembert import System, coordinates

    (q,) = coordinates("q")
    length = sp.Symbol("l", positive=True)
    for exponent in (2, 3):
        spring = System([q], kinetic=q.diff()**2 / 2,
                        potential=q**2 / (2 * length**exponent), parameters={length: 2.0})
        traj = spring.simulate((0.0, 1.0), {q: 1.0}, t_eval=[1.0], backend="c")
        assert traj.q[0, 0] == pytest.approx(np.cos(2.0 ** (-exponent / 2)), abs=1e-10)


#: Switching functions: saturation, dead zones, Coulomb-like laws, their derivatives.
SWITCHING = [sp.Piecewise((x, x > 0), (-x, True)), sp.Heaviside(x), sp.Heaviside(x, 0.25),
             sp.sign(x), sp.Abs(x), sp.Min(x, k), sp.Max(x, 1, k),
             sp.Piecewise((1, x < -1), (x**2, x < 1), (2, True)),
             sp.Piecewise((x, (x > 0) & (x < k)), (0, True)),
             sp.Piecewise((x, x > 0)),  # no value for x <= 0: NaN, as SymPy says
             sp.Max(-k, sp.Min(k, 3 * x)).diff(x)]  # a saturation's derivative


@needs_cc
@pytest.mark.parametrize("expr", SWITCHING, ids=str)
def test_switching_functions_compile_to_c(cache, expr):
    spec = ("f", [("q", [x]), ("p", [k])], [expr])
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no fallback to NumPy
        (fn,) = c_backend.build_flat_functions([spec], use="c")
    assert hasattr(fn, "library")
    for value in (-2.0, -1.0, -0.2, 0.0, 0.2, 0.5, 1.0, 2.0):  # both sides and the switches
        exact = expr.subs({x: value, k: 0.5})
        expected = float("nan") if exact is sp.nan else float(exact.rewrite(sp.Piecewise)) \
            if exact.has(sp.DiracDelta) is False else 0.0
        np.testing.assert_equal(fn(np.array([value]), np.array([0.5])), [expected])


@needs_cc
def test_a_saturated_controller_stays_in_c_and_matches_numpy(cache, monkeypatch):
    """A pendulum pushed back by a torque saturating at +-limit (``Min``/``Max``): the C
    functions equal NumPy's on both sides of the saturation and at its corners."""
    from dalembert import System, coordinates

    (theta,) = coordinates("theta")
    gain, limit = sp.symbols("gain limit", positive=True)
    torque = sp.Max(-limit, sp.Min(limit, -gain * theta))
    models = {}
    for backend in ("c", "numpy"):
        monkeypatch.setenv("DALEMBERT_BACKEND", backend)
        system = System([theta], kinetic=theta.diff()**2 / 2, potential=-9.81 * sp.cos(theta),
                        generalized_forces={theta: torque}, parameters={gain: 40.0, limit: 2.0})
        models[backend] = system.numeric()
        assert models[backend].compiled.backend == backend
    for angle in np.linspace(-0.2, 0.2, 41):  # the corners at +-0.05
        state = (0.0, np.array([angle]), np.array([0.3]))
        for c_value, numpy_value in zip(models["c"].kkt_blocks(*state),
                                        models["numpy"].kkt_blocks(*state)):
            np.testing.assert_allclose(c_value, numpy_value, rtol=1e-15, atol=0)
