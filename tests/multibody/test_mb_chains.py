"""Chains in redundant coordinates against the same chains in minimal coordinates.

The reference is derived here, independently of the multibody layer: a hand
Lagrangian in joint angles (absolute angles per link), written with elementary
rotation matrices and the Euler-angle kinematic matrix, differentiated with SymPy
and integrated with ``solve_ivp`` (DOP853, rtol 1e-12).

- Particle chains: point masses on massless rods (``Distance`` joints); particle
  ``k`` hangs from particle ``k-1`` along ``u_k = Rx(a_k) Ry(b_k) (0, 0, -1)``.
- Rigid spherical chains (``chain(..., joint="spherical")``): link ``k`` has the
  absolute orientation ``R_k = Rx(a_k) Ry(b_k) Rz(c_k)`` (intrinsic XYZ), whose
  body angular velocity is
  ``[[cb cc, sc, 0], [-cb sc, cc, 0], [sb, 0, 1]] (a', b', c')``.
- Rigid revolute chains: planar, ``R_k = Ry(th_k)``, ``w_body = (0, th_k', 0)``.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest
import sympy as sp
from scipy.integrate import solve_ivp

from dalembert import InitialConditionsAdjusted
from dalembert.multibody import (
    Distance,
    Ground,
    Multibody,
    Particle,
    chain,
    point_positions,
    rotation_matrices,
)

G = 9.81


def rot(axis: str, a: sp.Expr) -> sp.Matrix:
    c, s = sp.cos(a), sp.sin(a)
    if axis == "x":
        return sp.Matrix([[1, 0, 0], [0, c, -s], [0, s, c]])
    if axis == "y":
        return sp.Matrix([[c, 0, s], [0, 1, 0], [-s, 0, c]])
    return sp.Matrix([[c, -s, 0], [s, c, 0], [0, 0, 1]])


class MinimalModel:
    """``T``, ``V`` in angles ``q`` -> lambdified ``M(q) qdd = f(q, qd)``."""

    def __init__(self, q, qd, T, V, outputs):
        L = T - V
        p = sp.Matrix([L]).jacobian(qd).T
        M = p.jacobian(qd)
        f = sp.Matrix([L]).jacobian(q).T - p.jacobian(q) * qd
        args = [*q, *qd]
        self.M = sp.lambdify(args, M, cse=True)
        self.f = sp.lambdify(args, f, cse=True)
        self.outputs = sp.lambdify(args, outputs, cse=True)
        self.n = len(q)

    def rhs(self, t, y):
        M = np.array(self.M(*y), dtype=float)
        f = np.array(self.f(*y), dtype=float).ravel()
        return np.concatenate([y[self.n:], np.linalg.solve(M, f)])

    def solve(self, y0, t_eval):
        sol = solve_ivp(self.rhs, (t_eval[0], t_eval[-1]), y0, method="DOP853", rtol=1e-12,
                        atol=1e-12, t_eval=t_eval)
        assert sol.success
        return sol.y.T


def particle_chain_reference(n, mass, length):
    a = sp.symbols(f"a1:{n + 1}")
    b = sp.symbols(f"b1:{n + 1}")
    q = sp.Matrix([v for pair in zip(a, b) for v in pair])
    qd = sp.Matrix(sp.symbols(f"qd1:{2 * n + 1}"))
    r = sp.zeros(3, 1)
    positions, velocities = [], []
    T = V = 0
    for k in range(n):
        r = r + length * rot("x", a[k]) * rot("y", b[k]) * sp.Matrix([0, 0, -1])
        v = r.jacobian(q) * qd
        positions.append(r)
        velocities.append(v)
        T += mass / 2 * v.dot(v)
        V += mass * G * r[2]
    outputs = sp.Matrix([*[c for p in positions for c in p], *[c for v in velocities for c in v]])
    return MinimalModel(q, qd, T, V, outputs)


def rigid_chain_reference(n, mass, length, radius, kind):
    It = mass * (3 * radius**2 + length**2) / 12
    inertia = sp.diag(It, It, mass * radius**2 / 2)
    per = 3 if kind == "spherical" else 1
    q = sp.Matrix(sp.symbols(f"q1:{per * n + 1}"))
    qd = sp.Matrix(sp.symbols(f"qd1:{per * n + 1}"))
    top = sp.zeros(3, 1)
    T = V = 0
    out = []
    for k in range(n):
        ang, rate = q[per * k: per * (k + 1), 0], qd[per * k: per * (k + 1), 0]
        if kind == "spherical":
            al, be, ga = ang
            R = rot("x", al) * rot("y", be) * rot("z", ga)
            cb, sb, cc, sc = sp.cos(be), sp.sin(be), sp.cos(ga), sp.sin(ga)
            J = sp.Matrix([[cb * cc, sc, 0], [-cb * sc, cc, 0], [sb, 0, 1]])
            w = J * rate
        else:
            R = rot("y", ang[0])
            w = sp.Matrix([0, rate[0], 0])
        cm = top + R * sp.Matrix([0, 0, -length / 2])
        v = cm.jacobian(q) * qd
        T += mass / 2 * v.dot(v) + (w.T * inertia * w)[0, 0] / 2
        V += mass * G * cm[2]
        top = top + R * sp.Matrix([0, 0, -length])
        out += [*cm, *R, *(R * w), *v]
    return MinimalModel(q, qd, T, V, sp.Matrix(out))


def compare(traj_points, ref_points):
    return np.abs(traj_points - ref_points).max()


@pytest.mark.validation
@pytest.mark.parametrize("n", [2, 3])
def test_particle_chain_matches_minimal_coordinates(n):
    mass, length = 0.7, 0.9
    ref = particle_chain_reference(n, mass, length)
    angles = np.array([0.5, -0.3, 0.9, 0.2, -0.4, 0.6])[: 2 * n]
    rates = np.array([0.3, 1.1, -0.8, 0.5, 0.2, -0.6])[: 2 * n]
    y0 = np.concatenate([angles, rates])
    out0 = np.array(ref.outputs(*y0), dtype=float).ravel()
    pos0, vel0 = out0[: 3 * n].reshape(n, 3), out0[3 * n:].reshape(n, 3)

    bobs = [Particle(f"p{k + 1}", mass) for k in range(n)]
    rods = [Distance(f"rod{k + 1}", parent, bob, length)
            for k, (parent, bob) in enumerate(zip([Ground(), *bobs[:-1]], bobs))]
    mb = Multibody(bobs, rods, gravity=(0, 0, -G))
    q0, qd0 = mb.initial_state(positions=dict(zip(bobs, pos0)), velocities=dict(zip(bobs, vel0)))
    t = np.linspace(0.0, 3.0, 61)
    traj = mb.simulate((0.0, 3.0), q0, qd0, t_eval=t)
    y = ref.solve(y0, t)
    out = np.array([np.array(ref.outputs(*row), dtype=float).ravel() for row in y])
    err = max(compare(point_positions(mb, traj, bob), out[:, 3 * k: 3 * k + 3])
              for k, bob in enumerate(bobs))
    assert err < 1e-8


def rigid_chain_initial(mb, ref, n, y0):
    """Pose and velocities of every link from the reference's exact outputs."""
    out0 = np.array(ref.outputs(*y0), dtype=float).ravel().reshape(n, 18)
    links = [mb.body(f"link{k + 1}") for k in range(n)]
    return links, mb.initial_state(
        positions={b: out0[k, :3] for k, b in enumerate(links)},
        orientations={b: out0[k, 3:12].reshape(3, 3) for k, b in enumerate(links)},
        velocities={b: out0[k, 15:] for k, b in enumerate(links)},
        angular_velocities={b: out0[k, 12:15] for k, b in enumerate(links)},
    )


# n = 3 (measured: 5.7 s spherical, 3.9 s revolute on 2 cores; errors over 2 s: positions
# 2.0e-12 / 1.3e-12, rotation matrices 4.3e-12 / 4.2e-12)
@pytest.mark.validation
@pytest.mark.parametrize(("n", "kind"), [(2, "spherical"), (2, "revolute"),
                                         (3, "spherical"), (3, "revolute")])
def test_rigid_chain_matches_minimal_coordinates(n, kind):
    mass, length, radius = 1.3, 0.8, 0.06
    ref = rigid_chain_reference(n, mass, length, radius, kind)
    mb = chain(n, length, mass, radius, joint=kind, gravity=(0, 0, -G))
    per = 3 if kind == "spherical" else 1
    angles = np.array([0.4, -0.2, 0.3, -0.5, 0.3, 0.1, 0.2, 0.4, -0.3])[: per * n]
    rates = np.array([0.5, -0.4, 2.0, 0.6, 0.3, -1.5, -0.7, 0.2, 1.0])[: per * n]
    y0 = np.concatenate([angles, rates])
    links, (q0, qd0) = rigid_chain_initial(mb, ref, n, y0)
    t = np.linspace(0.0, 2.0, 41)
    with warnings.catch_warnings():
        warnings.simplefilter("error", InitialConditionsAdjusted)  # already consistent
        traj = mb.simulate((0.0, 2.0), q0, qd0, t_eval=t)
    y = ref.solve(y0, t)
    out = np.array([np.array(ref.outputs(*row), dtype=float).ravel() for row in y]).reshape(
        len(t), n, 18)
    for k, link in enumerate(links):
        assert compare(point_positions(mb, traj, link), out[:, k, :3]) < 1e-8
        R = rotation_matrices(mb, traj, link).reshape(len(t), 9)
        assert compare(R, out[:, k, 3:12]) < 1e-8
