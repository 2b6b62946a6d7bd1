"""Systems from ``sympy.physics.mechanics.LagrangesMethod``.

References: the same systems written natively (a damped Cartesian pendulum, the
gallery's Chaplygin sled), simulated alongside; SymPy's own solution of its
equations for the accelerations and multipliers (``mass_matrix_full`` /
``forcing_full``) and its symbolic ``eom``; the closed-form rod tension.
"""

from __future__ import annotations

import numpy as np
import pytest
import sympy as sp
from sympy.physics.mechanics import (
    KanesMethod,
    LagrangesMethod,
    Lagrangian,
    Particle,
    Point,
    ReferenceFrame,
    RigidBody,
    dynamicsymbols,
    inertia,
)

from dalembert import Holonomic, ModelError, System, coordinates
from dalembert.examples import knife_edge
from dalembert.model.sympy_mechanics import PRIVATE_NAMES
from dalembert.solvers.kkt.dense import solve_kkt

M, G, L, C = 1.3, 9.81, 0.8, 0.4
Q0 = {"x": L * np.sin(1.0), "y": -L * np.cos(1.0)}
QD0 = {"x": 0.3 * np.cos(1.0), "y": 0.3 * np.sin(1.0)}


def sympy_pendulum():
    """A particle on a rod, in x, y, damped by a force -c v applied at the particle."""
    x, y = dynamicsymbols("x y")
    m, g, l, c = sp.symbols("m g l c", positive=True)
    N = ReferenceFrame("N")
    O, P = Point("O"), Point("P")
    O.set_vel(N, 0)
    P.set_pos(O, x * N.x + y * N.y)
    P.set_vel(N, x.diff() * N.x + y.diff() * N.y)
    bob = Particle("bob", P, m)
    bob.potential_energy = m * g * y
    lm = LagrangesMethod(Lagrangian(N, bob), [x, y], forcelist=[(P, -c * P.vel(N))],
                         frame=N, hol_coneqs=[x**2 + y**2 - l**2])
    return lm, {m: M, g: G, l: L, c: C}


def native_pendulum() -> System:
    x, y = coordinates("x y")
    m, g, l, c = sp.symbols("m g l c", positive=True)
    return System([x, y], kinetic=m / 2 * (x.diff()**2 + y.diff()**2), potential=m * g * y,
                  generalized_forces={x: -c * x.diff(), y: -c * y.diff()},
                  constraints=[Holonomic(x**2 + y**2 - l**2, name="rod")],
                  parameters={m: M, g: G, l: L, c: C})


def test_pendulum_moves_as_the_native_model():
    lm, values = sympy_pendulum()
    imported = System.from_lagranges_method(lm, parameters=values)
    span, times = (0.0, 3.0), np.linspace(0.0, 3.0, 61)
    a = imported.simulate(span, Q0, QD0, t_eval=times)
    b = native_pendulum().simulate(span, Q0, QD0, t_eval=times)
    assert np.abs(a.q - b.q).max() < 1e-10
    assert np.abs(a.qd - b.qd).max() < 1e-10
    assert np.abs(a.multipliers - b.multipliers).max() < 1e-10
    # the rod pulls with m v^2 / l + m g cos(theta); A^T lambda = 2 lambda (x, y)
    v2 = (a.qd**2).sum(axis=1)
    tension = M * v2 / L + M * G * (-a.q[:, 1] / L)
    assert np.abs(-2 * a.multipliers[:, 0] * L - tension).max() < 1e-9


def test_multipliers_are_sympys_numeric_ones_and_its_eom_has_the_other_sign():
    lm, values = sympy_pendulum()
    eom = lm.form_lagranges_equations().subs(values)
    x, y = lm.q
    state = [x, y, x.diff(), y.diff()]
    full = sp.lambdify(state, (lm.mass_matrix_full.subs(values),
                               lm.forcing_full.subs(values)), modules="numpy")
    q, qd = np.array([Q0["x"], Q0["y"]]), np.array([QD0["x"], QD0["y"]])
    Mf, Ff = (np.array(a, dtype=float) for a in full(*q, *qd))
    solution = np.linalg.solve(Mf, Ff.ravel())  # unknowns: [qd, qdd, lambda]
    imported = System.from_lagranges_method(lm, parameters=values)
    qdd, lam = solve_kkt(*imported.numeric().kkt_blocks(0.0, q, qd))
    assert np.abs(qdd - solution[2:4]).max() < 1e-12
    assert lam[0] == pytest.approx(solution[4], rel=1e-12)
    at = {x: q[0], y: q[1], x.diff(): qd[0], y.diff(): qd[1],
          x.diff().diff(): qdd[0], y.diff().diff(): qdd[1]}
    assert np.abs(np.array(eom.subs({**at, lm.lam_vec[0]: -lam[0]}), dtype=float)).max() < 1e-12
    assert np.abs(np.array(eom.subs({**at, lm.lam_vec[0]: lam[0]}), dtype=float)).max() > 1


def test_nonholonomic_sled_moves_as_the_gallery_one():
    x, y, theta = dynamicsymbols("x y theta")
    m, J, a = sp.symbols("m J a")
    N = ReferenceFrame("N")
    B = N.orientnew("B", "Axis", [theta, N.z])
    O, G_ = Point("O"), Point("G")
    O.set_vel(N, 0)
    G_.set_pos(O, (x + a * sp.cos(theta)) * N.x + (y + a * sp.sin(theta)) * N.y)
    G_.set_vel(N, G_.pos_from(O).dt(N))
    body = RigidBody("sled", G_, B, m, (inertia(B, 0, 0, J), G_))
    lm = LagrangesMethod(Lagrangian(N, body), [x, y, theta], frame=N,
                         nonhol_coneqs=[-sp.sin(theta) * x.diff() + sp.cos(theta) * y.diff()])
    values = {m: 2.0, J: 0.3, a: 0.25}
    imported = System.from_lagranges_method(lm, parameters=values)
    assert imported.constraint_names == ("nonholonomic_1",)
    reference = knife_edge.build(2.0, 0.3, 0.25)
    times = np.linspace(0.0, 4.0, 41)
    one = imported.simulate((0.0, 4.0), **knife_edge.INITIAL, t_eval=times)
    two = reference.simulate((0.0, 4.0), **knife_edge.INITIAL, t_eval=times)
    assert np.abs(one.q - two.q).max() < 1e-10
    assert np.abs(one.multipliers - two.multipliers).max() < 1e-10


def test_kanes_method_and_a_method_as_coordinates_are_refused():
    q, u = dynamicsymbols("q u")
    N = ReferenceFrame("N")
    kane = KanesMethod(N, [q], [u], kd_eqs=[q.diff() - u])
    with pytest.raises(ModelError, match="KanesMethod gives equations in generalized speeds"):
        System.from_lagranges_method(kane)
    lm, _ = sympy_pendulum()
    with pytest.raises(ModelError, match=r"use System\.from_lagranges_method"):
        System(lm)


def test_the_private_names_read_from_sympy_exist():
    lm, _ = sympy_pendulum()
    for name in PRIVATE_NAMES:
        assert hasattr(lm, name), name
