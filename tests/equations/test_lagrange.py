"""Equations of motion against hand-derived M, f, A, b, c."""

from __future__ import annotations

import sympy as sp

from dalembert import Holonomic, Pfaffian, PointForce, System, coordinates, t

x, y, th = coordinates("x y theta")
X, Y, XD, YD, TH, THD = sp.symbols("x y x_dot y_dot theta theta_dot")
m, g, l, k, c, a, w, q, B, W = sp.symbols("m g l k c a omega q B Omega")


def same(expr_a: sp.Matrix, expr_b: sp.Matrix) -> bool:
    return sp.simplify(sp.Matrix(expr_a) - sp.Matrix(expr_b)).is_zero_matrix


def test_cartesian_pendulum():
    eqs = System([x, y], kinetic=m / 2 * (x.diff() ** 2 + y.diff() ** 2), potential=m * g * y,
                 constraints=[Holonomic(x**2 + y**2 - l**2)]).equations()
    assert same(eqs.M, sp.diag(m, m))
    assert same(eqs.f, [0, -m * g])
    assert same(eqs.A, [[2 * X, 2 * Y]]) and same(eqs.b, [0])
    # d/dt (2 x xd + 2 y yd) = 2 x xdd + 2 y ydd + 2 xd^2 + 2 yd^2
    assert same(eqs.c, [-2 * XD**2 - 2 * YD**2])
    assert len(eqs.multipliers) == 1


def test_time_dependent_constraint():
    # x is driven: x = a sin(w t); A qdd = c must give xdd = -a w^2 sin(w t).
    eqs = System([x, y], kinetic=m / 2 * (x.diff() ** 2 + y.diff() ** 2),
                 potential=k / 2 * (y - x) ** 2,
                 constraints=[Holonomic(x - a * sp.sin(w * t))]).equations()
    assert same(eqs.A, [[1, 0]])
    assert same(eqs.b, [-a * w * sp.cos(w * t)])
    assert same(eqs.c, [-a * w**2 * sp.sin(w * t)])
    assert same(eqs.f, [k * (Y - X), -k * (Y - X)])


def test_velocity_dependent_damping():
    eqs = System([x], kinetic=m / 2 * x.diff() ** 2, potential=k / 2 * x**2,
                 generalized_forces={x: -c * x.diff()}).equations()
    assert same(eqs.M, [[m]]) and same(eqs.f, [-k * X - c * XD])
    assert eqs.A.shape == (0, 1) and eqs.c.shape == (0, 1)


def test_damping_as_point_force_on_a_pendulum():
    # Drag -c v on the bob of a pendulum in the angle theta: Q = -c l^2 theta_dot.
    bob = [l * sp.sin(th), -l * sp.cos(th), 0]
    velocity = [sp.diff(r, t) for r in bob]
    eqs = System([th], kinetic=m * l**2 / 2 * th.diff() ** 2, potential=-m * g * l * sp.cos(th),
                 forces=[PointForce([-c * v for v in velocity], bob)]).equations()
    assert same(eqs.f, [-m * g * l * sp.sin(TH) - c * l**2 * THD])


def test_charged_particle_in_a_magnetic_field():
    # L = m v^2/2 + (qB/2)(x yd - y xd): m xdd = qB yd, m ydd = -qB xd (Lorentz force).
    L = m / 2 * (x.diff() ** 2 + y.diff() ** 2) + q * B / 2 * (x * y.diff() - y * x.diff())
    eqs = System([x, y], lagrangian=L).equations()
    assert same(eqs.M, sp.diag(m, m))
    assert same(eqs.f, [q * B * YD, -q * B * XD])


def test_rotating_frame_coriolis_and_centrifugal():
    T = m / 2 * ((x.diff() - W * y) ** 2 + (y.diff() + W * x) ** 2)
    eqs = System([x, y], kinetic=T).equations()
    assert same(eqs.M, sp.diag(m, m))
    assert same(eqs.f, [2 * m * W * YD + m * W**2 * X, -2 * m * W * XD + m * W**2 * Y])


def test_time_dependent_mass_matrix_term():
    # T = m(t) xd^2 / 2 with m = 1 + t: d/dt(m xd) = m xdd + xd, so f = -xd.
    eqs = System([x], kinetic=(1 + t) / 2 * x.diff() ** 2).equations()
    assert same(eqs.M, [[1 + t]]) and same(eqs.f, [-XD])


def test_pfaffian_knife_edge_c():
    # -sin(th) xd + cos(th) yd = 0; differentiated: A qdd = (cos xd + sin yd) thd.
    eqs = System([x, y, th], kinetic=m / 2 * (x.diff() ** 2 + y.diff() ** 2 + th.diff() ** 2),
                 constraints=[Pfaffian(-sp.sin(th) * x.diff() + sp.cos(th) * y.diff())]
                 ).equations()
    assert same(eqs.A, [[-sp.sin(TH), sp.cos(TH), 0]])
    assert same(eqs.c, [(sp.cos(TH) * XD + sp.sin(TH) * YD) * THD])
