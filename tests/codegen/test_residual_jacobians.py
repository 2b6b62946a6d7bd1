"""The KKT residuals' Jacobians (registry entry ``residual_jacobians``), both routes.

References: central finite differences of the residuals ``r1 = M qdd - f - A^T lam``
and ``r2 = A qdd - c`` built from the dense KKT blocks (``kkt_blocks``, a function
generated separately from the Jacobians), at random states, on both backends (the
Jacobians are exact; the differences are good to about 1e-8 of the largest entry,
so they are compared to 1e-6 of it); SymPy's dense ``Matrix.jacobian`` of the
residuals; and, for a Multibody assembled part by part (a 16-link chain of
quaternion links on ball joints, whose global equations are never built), the
global route on small mechanisms, which must agree to rounding.
"""

from __future__ import annotations

import numpy as np
import pytest
import sympy as sp

from dalembert import Holonomic, Pfaffian, System, coordinates
from dalembert import t as time
from dalembert.codegen.compiled import NumericModel, compile_equations
from dalembert.examples import heavy_top
from dalembert.multibody import chain
from dalembert.multibody.system import MultibodyDefinition

BACKENDS = ["c", "numpy"]


def residuals(num: NumericModel, t: float, q: np.ndarray, qd: np.ndarray, qdd: np.ndarray,
              lam: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    M, f, A, c = num.kkt_blocks(t, q, qd)
    return M @ qdd - f - A.T @ lam, A @ qdd - c


def finite_differences(num: NumericModel, t, q, qd, qdd, lam, h: float = 1e-6):
    """``(d r1/dq, d r1/dqd, d r2/dq, d r2/dqd)`` by central differences."""
    n = len(q)
    out = [np.zeros((n, n)), np.zeros((n, n)), np.zeros((num.m, n)), np.zeros((num.m, n))]
    for j in range(n):
        step = np.zeros(n)
        step[j] = h
        for which, (plus, minus) in enumerate([((q + step, qd), (q - step, qd)),
                                               ((q, qd + step), (q, qd - step))]):
            r_plus = residuals(num, t, *plus, qdd, lam)
            r_minus = residuals(num, t, *minus, qdd, lam)
            out[which][:, j] = (r_plus[0] - r_minus[0]) / (2 * h)
            out[2 + which][:, j] = (r_plus[1] - r_minus[1]) / (2 * h)
    return out


def assert_matches_differences(num: NumericModel, rng: np.random.Generator,
                               states: int = 3) -> None:
    for _ in range(states):
        t = rng.uniform(0, 2)
        q, qd, qdd = (rng.uniform(-1, 1, num.n) for _ in range(3))
        lam = rng.uniform(-2, 2, num.m)
        exact = num.residual_jacobians(t, q, qd, qdd, lam).dense()
        for name, J, fd in zip(("r1_q", "r1_qd", "r2_q", "r2_qd"), exact,
                               finite_differences(num, t, q, qd, qdd, lam)):
            scale = max(1.0, np.abs(fd).max())
            assert np.abs(J - fd).max() <= 1e-6 * scale, name


def rheonomic_pair() -> System:
    """Velocity-dependent forces, a rheonomic rod, a Pfaffian row with coordinate- and
    time-dependent ``b``, a velocity-coupled kinetic energy: every block is nonzero."""
    x, y, z = coordinates("x y z")
    k, c, w = sp.symbols("k c w", positive=True)
    xd, yd, zd = (v.diff() for v in (x, y, z))
    return System(
        [x, y, z],
        kinetic=(xd**2 + 2 * yd**2 + (1 + x**2) * zd**2) / 2 + x * yd * zd,
        potential=k * (x**2 + x * y + y**4) + sp.cos(z) * y,
        generalized_forces={x: -c * xd * yd + y * zd, z: -c * zd * x**2 + sp.sin(time)},
        constraints=[Holonomic(x**2 + y**2 - (1 + sp.sin(w * time) / 4)**2, name="rod"),
                     Pfaffian(zd + y * xd + sp.sin(x) * z - time * y**2, name="drift")],
        parameters={k: 2.0, c: 0.3, w: 1.5},
    )


@pytest.mark.parametrize("backend", BACKENDS)
def test_heavy_top_jacobians_match_finite_differences(backend):
    system = heavy_top.build()
    num = compile_equations(system.equations(), backend=backend).bind(system.numeric().p)
    assert_matches_differences(num, np.random.default_rng(3))


@pytest.mark.parametrize("backend", BACKENDS)
def test_hand_written_system_jacobians_match_finite_differences(backend):
    system = rheonomic_pair()
    num = compile_equations(system.equations(), backend=backend).bind(system.numeric().p)
    J = num.residual_jacobians(0.3, *np.random.default_rng(0).uniform(-1, 1, (3, 3)),
                               np.array([0.5, -0.7]))
    assert all(block.values.size for block in (J.r1_q, J.r1_qd, J.r2_q, J.r2_qd))
    assert_matches_differences(num, np.random.default_rng(5))


def test_jacobians_are_generated_on_first_use_and_reached_through_the_registry():
    system = rheonomic_pair()
    compiled = compile_equations(system.equations(), backend="c")
    assert "residual_jacobians" not in compiled.functions  # the model's build skips them
    num = compiled.bind(system.numeric().p)
    rng = np.random.default_rng(7)
    q, qd, qdd = rng.uniform(-1, 1, (3, 3))
    lam = rng.uniform(-1, 1, 2)
    blocks = num.residual_jacobians(0.4, q, qd, qdd, lam)
    handle = compiled.functions["residual_jacobians"]
    assert handle.native is not None  # C, with its address for the runtime
    values = handle.call(0.4, q, qd, qdd, lam, num.p)
    assert np.array_equal(values, num.evaluate("residual_jacobians", 0.4, q, qd, qdd, lam))
    for block, part in zip((blocks.r1_q, blocks.r1_qd, blocks.r2_q, blocks.r2_qd),
                           handle.layout.split(values)):
        assert np.array_equal(block.values, part)
    # the same dense matrices as SymPy's own Jacobians of the residuals, evaluated
    eqs = system.equations()
    M, A = eqs.M, eqs.A
    qdd_s, lam_s = sp.Matrix(eqs.qdd), sp.Matrix(eqs.multipliers)
    r1 = M * qdd_s - eqs.f - A.T * lam_s
    values_at = {**dict(zip(eqs.q, q)), **dict(zip(eqs.qd, qd)), **dict(zip(eqs.qdd, qdd)),
                 **dict(zip(eqs.multipliers, lam)), time: 0.4,
                 **dict(zip(system.model.parameters, num.p))}
    reference = np.array(r1.jacobian(sp.Matrix(eqs.qd)).subs(values_at), dtype=float)
    np.testing.assert_allclose(blocks.r1_qd.dense(), reference, rtol=1e-12, atol=1e-12)


# ---- the part route --------------------------------------------------------------

def random_arguments(num, rng):
    return (rng.uniform(0, 2), *rng.uniform(-1, 1, (3, num.n)), rng.uniform(-2, 2, num.m))


def test_a_16_link_chain_matches_finite_differences_without_global_equations(monkeypatch):
    def refuse(self):
        raise AssertionError("the global symbolic model was built")

    # part by part: no global symbolic model is built
    monkeypatch.setattr(MultibodyDefinition, "model", property(refuse))
    system = chain(16, 1.0, 1.0, 0.05).system
    num = system.numeric()
    assert_matches_differences(num, np.random.default_rng(11), states=1)


@pytest.mark.parametrize("backend", ["c", "numpy"])
def test_parts_and_global_route_agree_on_a_small_chain(backend, monkeypatch):
    monkeypatch.setenv("DALEMBERT_BACKEND", backend)
    system = chain(3, 1.0, 1.0, 0.05).system
    parts = system.numeric()
    whole = compile_equations(system.equations(), backend=backend).bind(parts.p)
    rng = np.random.default_rng(2)
    for _ in range(3):
        args = random_arguments(parts, rng)
        for a, b in zip(parts.residual_jacobians(*args).dense(),
                        whole.residual_jacobians(*args).dense()):
            np.testing.assert_allclose(a, b, rtol=1e-12, atol=1e-12 * max(1, np.abs(b).max()))
