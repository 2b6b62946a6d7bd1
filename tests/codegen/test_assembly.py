"""Equations assembled from parts equal the equations of the whole, derived globally.

The reference is a plain :class:`dalembert.System` written by hand as one
Lagrangian with all its constraints (a planar chain of point masses on rods),
compiled by the global route; the assembled model places one "mass" part three
times and one "rod" part three times (the first rod's far end is a fixed point,
written as a coordinate-free part).
"""

from __future__ import annotations

import numpy as np
import pytest
import sympy as sp

from dalembert import Holonomic, System, coordinates
from dalembert.codegen import c_backend
from dalembert.codegen.assembly import Part, compile_parts
from dalembert.codegen.compiled import compile_equations
from dalembert.equations.lagrange import derive_equations
from dalembert.model.model import build_part_model

m, g, L = sp.symbols("m g L", positive=True)
PARAMS = {"m": 0.7, "g": 9.81, "L": 1.3}


def reference():
    q = coordinates("x1 y1 x2 y2 x3 y3")
    xs, ys = q[0::2], q[1::2]
    T = sum(m / 2 * (x.diff() ** 2 + y.diff() ** 2) for x, y in zip(xs, ys))
    V = sum(m * g * y for y in ys)
    rods = [Holonomic(xs[0] ** 2 + ys[0] ** 2 - L**2)]
    rods += [Holonomic((xs[k] - xs[k - 1]) ** 2 + (ys[k] - ys[k - 1]) ** 2 - L**2)
             for k in (1, 2)]
    system = System(q, kinetic=T, potential=V, constraints=rods, parameters=PARAMS)
    return system


def parts():
    x, y, u, v = coordinates("px py pu pv")
    mass = build_part_model([x, y], kinetic=m / 2 * (x.diff() ** 2 + y.diff() ** 2),
                            potential=m * g * y)
    rod = build_part_model([x, y, u, v],
                           constraints=[Holonomic((u - x) ** 2 + (v - y) ** 2 - L**2)])
    anchor = build_part_model([x, y], constraints=[Holonomic(x**2 + y**2 - L**2)])
    return [
        Part(derive_equations(mass), [[0, 1], [2, 3], [4, 5]], np.zeros((3, 0))),
        Part(derive_equations(anchor), [[0, 1]], [[0]]),
        Part(derive_equations(rod), [[0, 1, 2, 3], [2, 3, 4, 5]], [[1], [2]]),
    ]


@pytest.fixture()
def cache(tmp_path, monkeypatch):
    monkeypatch.setenv("DALEMBERT_CACHE_DIR", str(tmp_path))
    return tmp_path


@pytest.mark.parametrize("backend", ["c", "numpy"])
def test_assembled_equals_global(cache, backend):
    if backend == "c" and c_backend.find_compiler() is None:
        pytest.skip("no C compiler found")
    system = reference()
    whole = compile_equations(system.equations())
    symbols = system.parameters
    assembled = compile_parts(parts(), 6, 3, symbols, backend=backend)
    assert assembled.backend == backend
    assert assembled.holonomic_rows == whole.holonomic_rows
    p = np.array([PARAMS[s.name] for s in symbols])
    rng = np.random.default_rng(3)
    for _ in range(5):
        t, q, qd = rng.normal(), rng.normal(size=6), rng.normal(size=6)
        for a, b in zip(assembled.kkt_blocks(t, q, qd, p), whole.kkt_blocks(t, q, qd, p)):
            np.testing.assert_allclose(a, b, rtol=1e-13, atol=1e-13)
        for a, b in zip(assembled.velocity_constraint(t, q, p),
                        whole.velocity_constraint(t, q, p)):
            np.testing.assert_allclose(a, b, rtol=1e-13, atol=1e-13)
        np.testing.assert_allclose(assembled.position_values(t, q, p),
                                   whole.position_values(t, q, p), rtol=1e-13, atol=1e-13)
        np.testing.assert_allclose(assembled.energy_values(t, q, qd, p),
                                   whole.energy_values(t, q, qd, p), rtol=1e-13, atol=1e-13)


def test_assembled_model_simulates_like_the_global_one(cache):
    """The solvers accept the assembled functions: same motion as the reference System."""
    system = reference()
    q0 = {"x1": 1.3, "y1": 0.0, "x2": 2.6, "y2": 0.0, "x3": 3.9, "y3": 0.0}
    ref = system.simulate((0, 1.0), q0, t_eval=[1.0])
    system.__dict__["compiled"] = compile_parts(parts(), 6, 3, system.parameters)
    fast = system.simulate((0, 1.0), q0, t_eval=[1.0])
    assert np.abs(fast.q - ref.q).max() < 1e-9


def test_rows_must_be_covered_once_and_indices_in_range():
    with pytest.raises(ValueError, match=r"cover 0\.\.2 exactly once"):
        compile_parts(parts()[:2], 6, 3, backend="numpy")
    with pytest.raises(ValueError, match=r"outside 0\.\.4"):
        compile_parts(parts(), 5, 3, backend="numpy")


def test_without_a_compiler_the_numpy_route_warns_and_agrees(cache, monkeypatch):
    monkeypatch.setattr(c_backend, "find_compiler", lambda: None)
    with pytest.warns(UserWarning, match="no C compiler"):
        assembled = compile_parts(parts(), 6, 3, reference().parameters, backend="c")
    assert assembled.backend == "numpy"
