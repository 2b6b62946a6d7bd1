"""Actuator torques by inverse dynamics and linearizations in joint coordinates,
against minimal-coordinate models derived here with SymPy (Lagrange's equations in the
joint angles), not from the redundant model.

- A 3D double pendulum (two rigid cylinders in Euler parameters, hinges about y): the
  computed torque ``tau = M(theta) theta'' + h(theta, theta')`` of both hinges.
- The same pendulum in the plane hanging at rest: ``A`` of its linearization in the two
  hinge angles and its eigenvalues against ``M^-1 K`` of the minimal model.
- The cart-pole about the upright pose: ``A`` and ``B`` against the linearized
  equations in the cart's travel and the pole's angle.
"""

from __future__ import annotations

import numpy as np
import pytest
import sympy as sp

from dalembert.errors import ModelError
from dalembert.examples import cart_pole
from dalembert.multibody import chain, inverse_dynamics, linearize_joints

L, MASS, RADIUS, G = 1.0, 1.0, 0.05, 9.81
t = sp.Symbol("t")
th1, th2 = sp.Function("th1")(t), sp.Function("th2")(t)


def _pendulum_coordinates() -> dict[str, sp.Expr]:
    """The 14 coordinates of the 3D chain as functions of the hinge angles (by hand:
    a turn by phi about y, center ``-L/2 (sin phi, 0, cos phi)`` below its pin)."""
    phi1, phi2 = th1, th1 + th2
    out: dict[str, sp.Expr] = {}
    pin = sp.Matrix([0, 0, 0])
    for k, phi in ((1, phi1), (2, phi2)):
        down = sp.Matrix([sp.sin(phi), 0, sp.cos(phi)])
        center = pin - L / 2 * down
        pin = pin - L * down
        out.update({f"link{k}_x": center[0], f"link{k}_y": 0, f"link{k}_z": center[2],
                    f"link{k}_b0": sp.cos(phi / 2), f"link{k}_b1": 0,
                    f"link{k}_b2": sp.sin(phi / 2), f"link{k}_b3": 0})
    return out


def _computed_torque() -> tuple[sp.Expr, sp.Expr]:
    """Lagrange's equations in ``(th1, th2)``: the generalized forces of the hinges."""
    c = _pendulum_coordinates()
    I_y = MASS * (3 * RADIUS**2 + L**2) / 12
    T = sum(MASS / 2 * (c[f"link{k}_x"].diff(t) ** 2 + c[f"link{k}_z"].diff(t) ** 2)
            for k in (1, 2))
    T += I_y / 2 * (th1.diff(t) ** 2 + (th1 + th2).diff(t) ** 2)
    V = sum(MASS * G * c[f"link{k}_z"] for k in (1, 2))
    Lag = T - V
    return tuple(Lag.diff(q.diff(t)).diff(t) - Lag.diff(q) for q in (th1, th2))


def test_double_pendulum_computed_torque():
    mb = chain(2, L, MASS, RADIUS, joint="revolute")
    names = mb.system.coordinate_names
    coordinates = _pendulum_coordinates()
    # the highest derivatives first (substituting th1 first would spoil its derivatives)
    values = [(th1.diff(t, 2), 2.5), (th2.diff(t, 2), -3.0), (th1.diff(t), 1.3),
              (th2.diff(t), -0.4), (th1, 0.7), (th2, -1.1)]

    def at(expr: sp.Expr) -> float:
        return float(sp.sympify(expr).subs(values))

    q = [at(coordinates[n]) for n in names]
    qd = [at(sp.sympify(coordinates[n]).diff(t)) for n in names]
    qdd = [at(sp.sympify(coordinates[n]).diff(t, 2)) for n in names]
    expected = [at(tau) for tau in _computed_torque()]
    need = inverse_dynamics(mb, 0.0, q, qd, qdd, actuated=["joint1", "joint2"])
    assert need.torques.names == ("joint1", "joint2")
    error = np.abs(need.torques.array - expected).max()
    assert error < 1e-9 * max(1.0, np.abs(expected).max())  # measured 1.1e-14 N m (of 11)
    assert np.abs(need.residual).max() < 1e-12
    # the multipliers close the balance: M qdd - f = B tau + A^T lambda
    A = mb.system.numeric().velocity_constraint(0.0, np.array(q))[0]
    generalized = mb.system.inverse_dynamics(0.0, q, qd, qdd).required
    from dalembert.multibody import joint_jacobian

    _, J = joint_jacobian(mb, q)
    assert np.abs(J.T @ need.torques.array + A.T @ need.multipliers
                  - generalized).max() < 1e-12

    with pytest.raises(ValueError, match="cannot produce this motion"):
        inverse_dynamics(mb, 0.0, q, qd, qdd, actuated=["joint1"])
    with pytest.raises(ModelError, match="no joint of '2-link revolute chain' is actuated"):
        inverse_dynamics(mb, 0.0, q, qd, qdd)
    with pytest.raises(KeyError, match="no joint 'elbow'"):
        inverse_dynamics(mb, 0.0, q, qd, qdd, actuated=["elbow"])


def test_double_pendulum_linearization_in_hinge_angles():
    mb = chain(2, L, MASS, RADIUS, joint="revolute", planar=True)
    hanging = {"link1_y": -L / 2, "link2_y": -3 * L / 2}  # the chain's links along y
    ss = linearize_joints(mb, hanging, ["joint1", "joint2"])
    # minimal model: planar links hanging, I about the center m L^2/12 (+ the radius'
    # share the planar chain keeps: (3 r^2 + L^2)/12)
    I = MASS * (3 * RADIUS**2 + L**2) / 12
    a, b = sp.symbols("a b")
    phi1, phi2 = a, a + b
    x = [L / 2 * sp.sin(phi1), L * sp.sin(phi1) + L / 2 * sp.sin(phi2)]
    y = [-L / 2 * sp.cos(phi1), -L * sp.cos(phi1) - L / 2 * sp.cos(phi2)]
    J = sp.Matrix([[sp.diff(v, s) for s in (a, b)] for v in (x[0], y[0], x[1], y[1])])
    M = MASS * J.T * J + I * sp.Matrix([[1, 0], [0, 0]]) + I * sp.Matrix([[1, 1], [1, 1]])
    V = MASS * G * (y[0] + y[1])
    K = sp.hessian(V, (a, b))
    Mn = np.array(M.subs({a: 0, b: 0}), dtype=float)
    Kn = np.array(K.subs({a: 0, b: 0}), dtype=float)
    expected = np.block([[np.zeros((2, 2)), np.eye(2)],
                         [-np.linalg.solve(Mn, Kn), np.zeros((2, 2))]])
    assert ss.state_names == ("joint1", "joint2", "joint1_dot", "joint2_dot")
    assert np.abs(ss.A - expected).max() < 1e-9  # measured 1.4e-14
    eig = np.linalg.eigvals(ss.A)
    assert np.abs(eig.real).max() < 1e-9  # +-i omega: undamped
    omega = np.sort(np.sqrt(np.linalg.eigvals(np.linalg.solve(Mn, Kn)).real))
    assert np.abs(np.sort(eig.imag)[2:] - omega).max() < 1e-9  # measured 6.2e-15
    assert ss.B.shape == (4, 0) and ss.input_names == ()


def test_cart_pole_linearization_against_the_textbook():
    M_, m, ell, g = cart_pole.CART_MASS, cart_pole.POLE_MASS, cart_pole.POLE_LENGTH / 2, G
    I = cart_pole.POLE_MASS * cart_pole.POLE_LENGTH**2 / 12
    x, th, xd, thd, u = sp.symbols("x th xd thd u")
    # the pole's center at (x - l sin th, l cos th): th counterclockwise from upright
    vx, vy = xd - ell * sp.cos(th) * thd, -ell * sp.sin(th) * thd
    T = M_ / 2 * xd**2 + m / 2 * (vx**2 + vy**2) + I / 2 * thd**2
    V = m * g * ell * sp.cos(th)
    Mm = sp.hessian(T, (xd, thd))
    # Lagrange: Mm qdd + (velocity terms) + dV/dq = (u, 0); linear about upright at rest
    qdd = Mm.subs(th, 0).solve(sp.Matrix([u, 0]) - sp.Matrix([0, V.diff(th)]))
    state, inputs = (x, th, xd, thd), (u,)
    rows = [xd, thd, *qdd]
    A = np.array([[float(sp.diff(r, s).subs({th: 0, u: 0})) for s in state] for r in rows])
    B = np.array([[float(sp.diff(r, s).subs({th: 0})) for s in inputs] for r in rows])
    ss = linearize_joints(cart_pole.build_multibody(), cart_pole.UPRIGHT, ["rail", "hinge"])
    assert ss.input_names == ("u",)
    assert np.abs(ss.A - A).max() < 1e-9  # measured 1.3e-15
    assert np.abs(ss.B - B).max() < 1e-9  # measured 2.2e-16


def test_slider_crank_motor_torque_through_the_loop():
    """A closed loop: the crank motor's torque for a motion of the slider-crank against
    Lagrange's equation in the crank angle, ``T = 1/2 J(th) th'^2`` with the rod and the
    piston placed by the closed-form position analysis (SymPy)."""
    from dalembert.examples import slider_crank

    a, b, e = slider_crank.GEOMETRY
    rho, g = slider_crank.DENSITY, slider_crank.G
    th = sp.Function("th")(t)
    phi = sp.asin((e - a * sp.sin(th)) / b)
    pin = sp.Matrix([a * sp.cos(th), a * sp.sin(th)])
    rod = pin + b / 2 * sp.Matrix([sp.cos(phi), sp.sin(phi)])
    piston = pin + b * sp.Matrix([sp.cos(phi), sp.sin(phi)])
    coordinates = {"crank_x": pin[0] / 2, "crank_y": pin[1] / 2, "crank_theta": th,
                   "rod_x": rod[0], "rod_y": rod[1], "rod_theta": phi,
                   "piston_x": piston[0], "piston_y": sp.Float(e), "piston_theta": sp.S.Zero}
    masses = {"crank": rho * a, "rod": rho * b, "piston": slider_crank.PISTON_MASS}
    inertias = {"crank": rho * a**3 / 12, "rod": rho * b**3 / 12,
                "piston": slider_crank.PISTON_INERTIA}
    T = sum(masses[k] / 2 * (coordinates[f"{k}_x"].diff(t) ** 2
                             + coordinates[f"{k}_y"].diff(t) ** 2)
            + inertias[k] / 2 * coordinates[f"{k}_theta"].diff(t) ** 2 for k in masses)
    V = sum(masses[k] * g * coordinates[f"{k}_y"] for k in masses)
    Lag = T - V
    torque = Lag.diff(th.diff(t)).diff(t) - Lag.diff(th)
    values = [(th.diff(t, 2), -4.0), (th.diff(t), 6.0), (th, 1.1)]

    def at(expr: sp.Expr) -> float:
        return float(sp.sympify(expr).subs(values))

    mb = slider_crank.build_multibody()
    names = mb.system.coordinate_names
    q = [at(coordinates[n]) for n in names]
    qd = [at(coordinates[n].diff(t)) for n in names]
    qdd = [at(coordinates[n].diff(t, 2)) for n in names]
    need = inverse_dynamics(mb, 0.0, q, qd, qdd, actuated=["J1"])
    expected = at(torque)
    assert abs(need.torques["J1"] - expected) < 1e-9 * abs(expected)  # measured 3.8e-16 relative
    assert np.abs(need.residual).max() < 1e-10
    with pytest.raises(ModelError, match="not determined by the motion"):
        inverse_dynamics(mb, 0.0, q, qd, qdd, actuated=["J1", "J2"])
