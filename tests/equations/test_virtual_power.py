"""Virtual power (Kane) against Lagrange: the same particles and forces two ways.

Each system is built once as a :class:`dalembert.System` (``T`` from the particles'
velocities, gravity and springs in ``V``, non-conservative forces as PointForces)
and once through :func:`virtual_power_equations` (every force a PointForce, no
energy at all). ``M`` must agree exactly; ``f`` exactly or, where ``simplify`` would
be slow (square roots of spring lengths, drag magnitudes), numerically at random
states.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import pytest
import sympy as sp

from dalembert import Holonomic, ModelError, PointForce, System, coordinates, t
from dalembert.equations.virtual_power import virtual_power_equations

m, m1, m2, g, l, l1, l2, k, c, R, w, eps, nu, a, L0 = sp.symbols(
    "m m1 m2 g l l1 l2 k c R w epsilon nu a L0", positive=True
)
RNG = np.random.default_rng(20240611)


@dataclass
class Case:
    """One system: particles, potential, conservative and other forces."""

    coords: list
    particles: list
    potential: sp.Expr
    conservative: list  # the forces that V stands for, as PointForces
    other_forces: list = field(default_factory=list)
    constraints: list = field(default_factory=list)
    exact_f: bool = True

    def system(self) -> System:
        return System(self.coords, kinetic=kinetic_energy(self.particles),
                      potential=self.potential, forces=self.other_forces,
                      constraints=self.constraints)

    def virtual_power(self) -> tuple[sp.Matrix, sp.Matrix]:
        return virtual_power_equations(self.particles, self.conservative + self.other_forces,
                                       self.coords)


def kinetic_energy(particles: list) -> sp.Expr:
    """``sum m |dr/dt|^2 / 2`` through SymPy's own derivative of the dynamic symbols."""
    return sum(mass / 2 * sum(sp.diff(ri, t) ** 2 for ri in r) for mass, r in particles)


def weight(mass: sp.Expr, r: list, axis: int = 1) -> PointForce:
    """Gravity ``-mass g`` along ``axis`` (y in planar cases, z in spatial ones)."""
    force = [0, 0, 0]
    force[axis] = -mass * g
    return PointForce(force=force, point=r, name="weight")


def cartesian_pendulum() -> Case:
    """Bob on a rod, plus a horizontal spring pulling it to ``x = 0``."""
    x, y = coordinates("x y")
    r = [x, y, 0]
    return Case(
        [x, y], [(m, r)], m * g * y + k / 2 * x**2,
        [weight(m, r), PointForce(force=[-k * x, 0, 0], point=r, name="spring")],
        constraints=[Holonomic(x**2 + y**2 - l**2, name="rod")],
    )


def spherical_pendulum() -> Case:
    th, ph = coordinates("theta phi")
    r = [l * sp.sin(th) * sp.cos(ph), l * sp.sin(th) * sp.sin(ph), -l * sp.cos(th)]
    return Case([th, ph], [(m, r)], -m * g * l * sp.cos(th), [weight(m, r, axis=2)])


def double_pendulum() -> Case:
    """Cartesian double pendulum; bob 2 tied to ``(a, 0)`` by a spring of rest length L0."""
    x1, y1, x2, y2 = coordinates("x1 y1 x2 y2")
    r1, r2 = [x1, y1, 0], [x2, y2, 0]
    d = sp.sqrt((x2 - a) ** 2 + y2**2)
    spring = PointForce(force=[-k * (d - L0) * (x2 - a) / d, -k * (d - L0) * y2 / d, 0],
                        point=r2, name="spring")
    return Case(
        [x1, y1, x2, y2], [(m1, r1), (m2, r2)],
        m1 * g * y1 + m2 * g * y2 + k / 2 * (d - L0) ** 2,
        [weight(m1, r1), weight(m2, r2), spring],
        constraints=[Holonomic(x1**2 + y1**2 - l1**2, name="rod1"),
                     Holonomic((x2 - x1) ** 2 + (y2 - y1) ** 2 - l2**2, name="rod2")],
        exact_f=False,
    )


def hoop_angle() -> sp.Expr:
    """Prescribed, non-uniform rotation of the hoop about the vertical."""
    return w * t + eps * sp.sin(nu * t)


def rotating_hoop() -> Case:
    """Bead on a hoop of radius R driven about the vertical axis: rheonomic r(theta, t)."""
    (th,) = coordinates("theta")
    phi = hoop_angle()
    r = [R * sp.sin(th) * sp.cos(phi), R * sp.sin(th) * sp.sin(phi), -R * sp.cos(th)]
    return Case([th], [(m, r)], -m * g * R * sp.cos(th), [weight(m, r, axis=2)])


def rotating_hoop_redundant() -> Case:
    """The same bead in hoop-frame coordinates ``(u, v)`` with ``u^2 + v^2 = R^2``."""
    u, v = coordinates("u v")
    phi = hoop_angle()
    r = [u * sp.cos(phi), u * sp.sin(phi), v]
    return Case([u, v], [(m, r)], m * g * v, [weight(m, r, axis=2)],
                constraints=[Holonomic(u**2 + v**2 - R**2, name="hoop")])


def damped_particle(quadratic: bool = False) -> Case:
    """Planar particle in polar coordinates: spring to the origin, gravity, damping."""
    rho, th = coordinates("rho theta")
    r = [rho * sp.cos(th), rho * sp.sin(th), 0]
    vel = [sp.diff(ri, t) for ri in r]
    scale = c * sp.sqrt(sum(vi**2 for vi in vel)) if quadratic else c
    damping = PointForce(force=[-scale * vi for vi in vel], point=r, name="damping")
    spring = PointForce(force=[-k * r[0], -k * r[1], 0], point=r, name="spring")
    return Case([rho, th], [(m, r)], m * g * r[1] + k / 2 * rho**2, [weight(m, r), spring],
                other_forces=[damping], exact_f=not quadratic)


CASES = {
    "cartesian pendulum": cartesian_pendulum,
    "spherical pendulum": spherical_pendulum,
    "double pendulum": double_pendulum,
    "rotating hoop": rotating_hoop,
    "rotating hoop (u, v)": rotating_hoop_redundant,
    "linear damping": damped_particle,
    "quadratic drag": lambda: damped_particle(quadratic=True),
}


def is_zero(expr: sp.Matrix) -> bool:
    """Exactly zero. ``sin^2 = 1 - cos^2`` after expanding settles most cases at once;
    ``simplify`` (slow on these trigonometric sums) is the fallback."""
    zero = sp.zeros(*expr.shape)
    expanded = sp.expand(expr)
    pythagoras = {sp.sin(s.args[0]) ** 2: 1 - sp.cos(s.args[0]) ** 2
                  for s in expanded.atoms(sp.sin)}
    if sp.expand(expanded.subs(pythagoras)) == zero:
        return True
    return sp.simplify(expanded) == zero


def max_numeric_difference(a: sp.Matrix, b: sp.Matrix, symbols: list, n_states: int = 6):
    """Largest ``|a - b|`` and largest ``|a|`` at random states and parameter values."""
    fa, fb = (sp.lambdify(symbols, e, "numpy") for e in (a, b))
    worst, scale = 0.0, 0.0
    for _ in range(n_states):
        x = RNG.uniform(0.3, 1.7, len(symbols))
        va, vb = np.asarray(fa(*x), float), np.asarray(fb(*x), float)
        worst, scale = max(worst, np.abs(va - vb).max()), max(scale, np.abs(va).max())
    return worst, scale


@pytest.mark.parametrize("name", list(CASES))
def test_mass_matrix_agrees_exactly(name):
    case = CASES[name]()
    M_vp, _ = case.virtual_power()
    assert is_zero(case.system().equations().M - M_vp)


@pytest.mark.parametrize("name", list(CASES))
def test_right_hand_side_agrees(name):
    case = CASES[name]()
    eqs = case.system().equations()
    _, f_vp = case.virtual_power()
    if case.exact_f:
        assert is_zero(eqs.f - f_vp)
        return
    symbols = [t, *eqs.q, *eqs.qd, *eqs.model.parameters]
    worst, scale = max_numeric_difference(eqs.f, f_vp, symbols)
    assert scale > 0.1  # a real comparison, not of two zeros
    assert worst <= 1e-12 * scale


def test_rotating_hoop_closed_form():
    """``theta'' = sin(theta) (phi'(t)^2 cos(theta) - g / R)`` for the driven hoop."""
    M, f = rotating_hoop().virtual_power()
    theta = sp.Symbol("theta")
    phid = sp.diff(hoop_angle(), t)
    expected = sp.sin(theta) * (phid**2 * sp.cos(theta) - g / R)
    assert is_zero(M - sp.Matrix([[m * R**2]]))
    assert is_zero(f - sp.Matrix([m * R**2 * expected]))


def test_constrained_accelerations_match_kkt_of_simulate():
    """Same A: simulate's KKT accelerations equal those from the virtual-power M, f."""
    case = cartesian_pendulum()
    values = {m: 1.3, g: 9.81, l: 0.8, k: 2.5}
    system = System(case.coords, kinetic=kinetic_energy(case.particles),
                    potential=case.potential, constraints=case.constraints, parameters=values)
    theta0 = 0.9
    traj = system.simulate((0.0, 1.5), q0={"x": 0.8 * np.sin(theta0), "y": -0.8 * np.cos(theta0)},
                           qd0={"x": 1.1 * np.cos(theta0), "y": 1.1 * np.sin(theta0)},
                           t_eval=np.linspace(0.0, 1.5, 7))
    eqs = system.equations()
    M_vp, f_vp = (e.subs(values) for e in case.virtual_power())
    args = [t, *eqs.q, *eqs.qd]
    blocks = sp.lambdify(args, [M_vp, f_vp, eqs.A.subs(values), eqs.c.subs(values)], "numpy")
    for ti, qi, qdi, qddi, lam in zip(traj.t, traj.q, traj.qd, traj.qdd, traj.multipliers):
        M, f, A, cc = (np.asarray(b, float) for b in blocks(ti, *qi, *qdi))
        n, mc = M.shape[0], A.shape[0]
        K = np.block([[M, A.T], [A, np.zeros((mc, mc))]])
        sol = np.linalg.solve(K, np.concatenate([f.ravel(), cc.ravel()]))
        assert np.abs(sol[:n] - qddi).max() <= 1e-12 * max(1.0, np.abs(qddi).max())
        assert np.abs(-sol[n:] - lam).max() <= 1e-12 * max(1.0, np.abs(lam).max())


def test_plain_symbols_and_planar_vectors():
    """Plain-symbol coordinates and 2-vectors; the symbols are those System uses."""
    x, y = sp.symbols("x y")
    M, f = virtual_power_equations(
        [(m, [x, y])], [PointForce(force=[-c * sp.Symbol("x_dot"), -m * g], point=[x, y])],
        [x, y],
    )
    assert sp.diag(m, m) == M
    assert sp.Matrix([-c * sp.Symbol("x_dot"), -m * g]) == f


@pytest.mark.parametrize(
    ("particles", "forces", "message"),
    [
        ([(m, [sp.Derivative(sp.Function("x")(t), t), 0])], [], "depends on velocities"),
        ([m], [], "a \\(mass, position\\) pair"),
        ([(m, [1, 2, 3, 4])], [], "4 components"),
        ([], ["gravity"], "PointForce"),
    ],
)
def test_rejects_bad_input(particles, forces, message):
    with pytest.raises(ModelError, match=message):
        virtual_power_equations(particles, forces, coordinates("x"))
