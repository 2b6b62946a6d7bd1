"""The static function (:mod:`dalembert.codegen.static`), on both routes and backends.

References:
- the derivatives themselves: SymPy's dense ``Matrix.jacobian`` of the global
  equations (``system.equations()``), lambdified, at random states -- independent of
  the sparse differentiation, the part-by-part assembly and the code generation;
- statics of a long chain, which must not build the global symbolic equations:
  the closed form (hanging straight down, the pivot carrying the whole weight) and
  the small oscillations of the same chain derived by hand in absolute angles.
"""

from __future__ import annotations

import functools
import warnings

import numpy as np
import pytest
import sympy as sp

from dalembert import Holonomic, Pfaffian, System, coordinates
from dalembert import t as time
from dalembert.examples import load
from dalembert.examples.chain_frequencies import hand_modes
from dalembert.multibody import (
    Force,
    Ground,
    Multibody,
    Particle,
    Revolute,
    RigidBody,
    Rolling,
    Spherical,
    SpringDamper,
    chain,
)
from dalembert.multibody.system import MultibodyDefinition


def pfaffian_with_drift() -> System:
    """A damped particle pair with a rheonomic rod and a Pfaffian row whose ``b``
    depends on the coordinates (rest needs ``b = 0``), and velocity-dependent forces."""
    x, y, z = coordinates("x y z")
    k, c, w = sp.symbols("k c w", positive=True)
    xd, yd, zd = (v.diff() for v in (x, y, z))
    return System(
        [x, y, z],
        kinetic=(xd**2 + 2 * yd**2 + zd**2) / 2 + x * yd * zd,
        potential=k * (x**2 + x * y + y**4) + sp.cos(z) * y,
        generalized_forces={x: -c * xd + y * zd, z: -c * zd * x**2},
        constraints=[Holonomic(x**2 + y**2 - (1 + sp.sin(w * time) / 4)**2, name="rod"),
                     Pfaffian(zd + y * xd + sp.sin(x) * z - y**2, name="drift")],
        parameters={k: 2.0, c: 0.3, w: 1.5},
    )


def loaded_mechanism() -> Multibody:
    """Quaternion and point bodies, joints, a rolling wheel, a spring-damper, a force."""
    a = RigidBody("a", 1.2, (0.1, 0.2, 0.3))
    b = RigidBody("b", 0.8, [[0.2, 0.01, 0.0], [0.01, 0.3, 0.02], [0.0, 0.02, 0.25]])
    wheel = RigidBody("wheel", 2.0, (0.25, 0.5, 0.25))
    p = Particle("p", 0.3)
    joints = [Revolute("hinge", Ground(), a, (0, 0, 1), (0, 0, 0.5), axis_a=(0, 1, 0)),
              Spherical("ball", a, b, (0, 0, -0.5), (0, 0, 0.5)),
              Rolling("roll", wheel, 0.5, axis=(0, 1, 0))]
    return Multibody([a, b, p, wheel], joints,
                     forces=[Force(a, (0.3, 0, 0), point=(0, 0.1, 0), frame="body")],
                     springs=[SpringDamper("s", b, p, 3.0, 0.4, 0.0, point_a=(0, 0.1, 0))])


SYSTEMS = {
    "pfaffian-with-drift": pfaffian_with_drift,
    "hoop": lambda: load("hoop").build(),
    "knife-edge": lambda: load("knife-edge").build(),
    "mechanism": lambda: loaded_mechanism().system,
    "chain": lambda: chain(3, 1.0, 1.0, 0.05).system,
}


@functools.cache
def reference(name: str):
    """Dense SymPy Jacobians of the global equations at rest, lambdified."""
    eqs = SYSTEMS[name]().equations()
    q, qd = sp.Matrix(eqs.q), sp.Matrix(eqs.qd)
    lam = sp.Matrix(sp.symbols(f"lam0:{eqs.A.rows}"))
    rest = dict.fromkeys(qd, 0)
    f0 = eqs.f.xreplace(rest)
    G = (f0 + eqs.A.T * lam).jacobian(q)
    C = -eqs.f.jacobian(qd).xreplace(rest)
    Jb = eqs.b.jacobian(q)
    args = [time, list(q), list(lam), list(eqs.model.parameters)]
    return sp.lambdify(args, [G, C, Jb], modules="numpy")


def random_state(system: System, rng: np.random.Generator) -> np.ndarray:
    """Random coordinates, each body's Euler parameters a unit quaternion (the rolling
    contact's geometry is real only for rotations)."""
    q = rng.normal(size=len(system.coordinate_names))
    names = system.coordinate_names
    for k, name in enumerate(names):
        if name.endswith("_b0"):
            q[k:k + 4] /= np.linalg.norm(q[k:k + 4])
    return q


@pytest.mark.parametrize("backend", ["c", "numpy"])
@pytest.mark.parametrize("name", list(SYSTEMS))
def test_static_derivatives_match_sympy_jacobians(name, backend, monkeypatch):
    monkeypatch.setenv("DALEMBERT_BACKEND", backend)
    system = SYSTEMS[name]()
    num = system.numeric()
    assert num.compiled.backend == backend
    ref = reference(name)
    rng = np.random.default_rng(0)
    pattern = num.compiled.static.pattern
    for _ in range(3):
        t, q, lam = rng.normal(), random_state(system, rng), rng.normal(size=num.m)
        G, C, Jb = (np.array(a, dtype=float) for a in ref(t, q, lam, num.p))
        values = num.static_derivatives(t, q)
        np.testing.assert_allclose(values.balance_jacobian(lam), G, rtol=1e-12, atol=1e-12)
        np.testing.assert_allclose(values.damping(), C, rtol=1e-12, atol=1e-12)
        rows = list(pattern.rest_rows)
        np.testing.assert_allclose(values.rest_jacobian()[rows], Jb[rows], rtol=1e-12,
                                   atol=1e-12)
        np.testing.assert_allclose(num.forces_at_rest(t, q),
                                   num.kkt_blocks(t, q, np.zeros(num.n))[1], rtol=0, atol=0)


def test_rest_rows_are_the_pfaffian_rows_with_a_drift():
    system = pfaffian_with_drift()
    assert system.numeric().compiled.static.pattern.rest_rows == (1,)
    assert load("knife-edge").build().numeric().compiled.static.pattern.rest_rows == ()


@pytest.fixture
def no_global_model(monkeypatch):
    """Statics of a multibody system must not derive its global symbolic equations."""
    def refuse(self):
        raise AssertionError("the global symbolic model was built")

    monkeypatch.setattr(MultibodyDefinition, "model", property(refuse))


def hand_derived_chain_modes(n: int, length: float, mass: float, radius: float, g: float):
    """omega^2 of ``n`` uniform rods hung in a row, in absolute angles, linearized by
    hand (the gallery's chain-frequencies example holds the derivation)."""
    return hand_modes(length, n, mass, radius, g)[0] ** 2


def test_long_planar_chain_statics_from_parts(no_global_model):
    n, length, mass, radius, g = 64, 1.0, 1.0, 0.05, 9.81
    mb = chain(n, length, mass, radius, joint="revolute", planar=True)
    system = mb.system
    rng = np.random.default_rng(3)
    guess = {}
    for k in range(n):  # near hanging straight down, each link a little off
        guess |= {f"link{k + 1}_x": 0.05 * rng.normal(),
                  f"link{k + 1}_y": -(k + 0.5) * length + 0.05 * rng.normal(),
                  f"link{k + 1}_theta": 0.05 * rng.normal()}
    rest = system.equilibrium(guess)
    centers = np.array([[rest[f"link{k + 1}_x"], rest[f"link{k + 1}_y"]] for k in range(n)])
    np.testing.assert_allclose(centers[:, 0], 0.0, atol=1e-12)
    np.testing.assert_allclose(centers[:, 1], -(np.arange(n) + 0.5) * length, atol=1e-12)
    lifted = sum(rest.constraint_force(f"link{k + 1}_y") for k in range(n))
    assert lifted == pytest.approx(n * mass * g, rel=1e-12)  # the pivot holds everything
    assert rest.stability == "stable"
    modes = system.linearize(rest)
    expected = hand_derived_chain_modes(n, length, mass, radius, g)
    np.testing.assert_allclose(np.sort(modes.omega_squared.real), expected, rtol=1e-9)


def test_quaternion_chain_statics_from_parts(no_global_model):
    """Spherical joints: every in-plane mode twice (x and y swings) and one spin per
    link about its own axis, without stiffness (marginal)."""
    n, length, mass, radius, g = 6, 1.0, 1.0, 0.05, 9.81
    mb = chain(n, length, mass, radius)
    rng = np.random.default_rng(4)
    guess = {}
    for k in range(n):  # near hanging straight down, each link a little off
        guess |= {f"link{k + 1}_z": -(k + 0.5) * length, f"link{k + 1}_b0": 1.0}
    guess = {name: guess.get(name, 0.0) + 0.02 * rng.normal()
             for name in mb.system.coordinate_names}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        rest = mb.system.equilibrium(guess)
        modes = mb.system.linearize(rest)
    assert rest.stability == "marginal"
    lifted = sum(rest.constraint_force(f"link{k + 1}_z") for k in range(n))
    assert lifted == pytest.approx(n * mass * g, rel=1e-12)
    omega2 = np.sort(modes.omega_squared.real)
    np.testing.assert_allclose(omega2[:n], 0.0, atol=1e-9)
    expected = np.repeat(hand_derived_chain_modes(n, length, mass, radius, g), 2)
    np.testing.assert_allclose(omega2[n:], expected, rtol=1e-9)
