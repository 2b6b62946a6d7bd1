"""The direction a contact at rest starts to slide in, with two sliding velocities.

Reference: a solid cylinder (mass ``m``, radius ``r``, ``I = m r^2 / 2``) lying on a
floor, its axis along ``y`` (held level: it rolls along ``x``, slides along ``y``),
pushed at its axis from rest by a constant horizontal force ``F``. In its minimal
coordinates ``x, y, theta`` (``z = r``), with the friction force ``f`` at the contact,

    m x'' = F_x + f_x,   m y'' = F_y + f_y,   I theta'' = r f_x,

so the contact point's acceleration is ``a = (F_x / m + k f_x / m, F_y / m + f_y / m)``,
``k = 1 + m r^2 / I = 3``: its tangential mass is three times smaller along ``x``.
Rolling without sliding needs ``f = -(F_x / k, F_y)``, within the cone
``|f| <= mu m g`` (so a push ``|F| > mu m g`` may still roll it). Beyond, it slides
with ``f = -mu m g d`` along ``d = a / |a|``: ``a = s d`` with ``s > 0`` gives
``d = (F_x / m / (s + k mu g), F_y / m / (s + mu g))``, and ``|d| = 1`` is the quartic

    (F_x/m)^2 (s + mu g)^2 + (F_y/m)^2 (s + k mu g)^2 = (s + k mu g)^2 (s + mu g)^2

in ``s``; the direction of the excess force, ``(F_x / k, F_y)``, differs from ``d``
(by 16 degrees for the 12 N push below). The force stays constant and so does ``d``:
the motion is ``x = x'' t^2 / 2`` and so on.
"""

from __future__ import annotations

import numpy as np
import pytest
import sympy as sp

from dalembert import System, Unilateral, coordinates

M, R, G, MU = 1.0, 0.2, 9.81, 0.3
INERTIA = M * R**2 / 2
K = 1 + M * R**2 / INERTIA
X, Y, Z, TH = coordinates("x y z theta")


def cylinder(push: np.ndarray) -> System:
    return System([X, Y, Z, TH], kinetic=M / 2 * (X.diff() ** 2 + Y.diff() ** 2
                                                  + Z.diff() ** 2) + INERTIA / 2 * TH.diff() ** 2,
                  potential=M * G * Z - push[0] * X - push[1] * Y,
                  constraints=[Unilateral(Z - R, name="floor", friction=MU,
                                          tangents=[X.diff() + R * TH.diff(), Y.diff()])])


def sliding_direction(push: np.ndarray) -> np.ndarray:
    """``d`` from the quartic's positive root (see the module docstring)."""
    ax, ay = push / M
    b1, b2 = np.poly1d([1.0, MU * G]), np.poly1d([1.0, K * MU * G])
    quartic = (b2 * b1) ** 2 - ax**2 * b1**2 - ay**2 * b2**2
    (s,) = [float(v.real) for v in quartic.roots if abs(v.imag) < 1e-9 and v.real > 0]
    return np.array([ax / (s + K * MU * G), ay / (s + MU * G)])


@pytest.mark.parametrize(("force", "angle"), [(12.0, 0.5), (5.0, 0.6), (20.0, 2.0)])
def test_a_cylinder_pushed_beyond_its_cone_slides_where_its_contact_accelerates(force, angle):
    push = force * np.array([np.cos(angle), np.sin(angle)])
    assert np.hypot(push[0] / K, push[1]) > MU * M * G  # it cannot roll
    d = sliding_direction(push)
    assert abs(np.linalg.norm(d) - 1.0) < 1e-14
    friction = -MU * M * G * d
    qdd = np.array([(push[0] + friction[0]) / M, (push[1] + friction[1]) / M, 0.0,
                    R * friction[0] / INERTIA])
    t = np.linspace(0.0, 0.3, 7)
    traj = cylinder(push).simulate((0.0, 0.3), {"z": R}, t_eval=t)
    assert traj.success, traj.message
    assert len(traj.contacts.switches) == 1  # it slides from the start to the end
    forces = np.column_stack([traj.multiplier("floor_friction_1"),
                              traj.multiplier("floor_friction_2")])
    assert np.abs(forces - friction).max() < 1e-10  # from the start on
    # later on, friction follows the sliding velocity's direction, in which the
    # rolling x' + r theta' cancels about two digits
    assert np.abs(traj.qdd - qdd).max() < 1e-10 * np.abs(qdd).max()
    assert np.abs(traj.qdd[0] - qdd).max() < 1e-12 * np.abs(qdd).max()  # the onset
    assert np.abs(traj.q[:, [0, 1, 3]] - np.outer(t**2 / 2, qdd[[0, 1, 3]])).max() < 1e-10
    slip = np.column_stack([traj["x_dot"] + R * traj["theta_dot"], traj["y_dot"]])[1:]
    assert np.abs(slip / np.linalg.norm(slip, axis=1)[:, None] - d).max() < 1e-10


def test_a_cylinder_pushed_harder_than_mu_m_g_may_still_roll():
    """Its contact holds ``(F_x / 3, F_y)``: within the cone though ``|F|`` is not."""
    push = 4.0 * np.array([np.cos(0.3), np.sin(0.3)])
    assert np.linalg.norm(push) > MU * M * G > np.hypot(push[0] / K, push[1])
    t = np.linspace(0.0, 0.3, 7)
    traj = cylinder(push).simulate((0.0, 0.3), {"z": R}, t_eval=t)
    assert traj.success, traj.message
    rolling = push[0] / (M + INERTIA / R**2)
    assert np.abs(traj["x"] - rolling * t**2 / 2).max() < 1e-12
    assert np.abs(traj["y"]).max() < 1e-12
    assert np.abs(traj.multiplier("floor_friction_2") + push[1]).max() < 1e-12


GROWING = 10.0 * np.array([np.cos(0.5), np.sin(0.5)])  # the push c t, along 0.5 rad


def growing_push_reference(t: np.ndarray):
    """The pushed cylinder's sliding equations from its onset (see the test below),
    ``s`` a state of its own, integrated by SciPy's Radau with their exact Jacobian;
    with the onset instant and direction."""
    from scipy.integrate import solve_ivp

    c = GROWING
    onset = MU * M * G / np.hypot(c[0] / K, c[1])
    rolling = M + INERTIA / R**2
    x0, xd0 = c[0] * onset**3 / 6 / rolling, c[0] * onset**2 / 2 / rolling

    def equations(t, z):
        _, _, _, sx, sy, thd = z
        f = -MU * M * G * np.array([sx, sy]) / np.hypot(sx, sy)
        return [sx - R * thd, sy, thd, (c[0] * t + f[0]) / M + R**2 * f[0] / INERTIA,
                (c[1] * t + f[1]) / M, R * f[0] / INERTIA]

    def jacobian(t, z):
        s = z[3:5]
        size = np.linalg.norm(s)
        turn = (np.eye(2) - np.outer(s, s) / size**2) / size  # d(s / |s|) / ds
        J = np.zeros((6, 6))
        J[0, 3], J[0, 5], J[1, 4], J[2, 5] = 1.0, -R, 1.0, 1.0
        J[3, 3:5] = -MU * G * (1.0 + M * R**2 / INERTIA) * turn[0]
        J[4, 3:5] = -MU * G * turn[1]
        J[5, 3:5] = -R * MU * M * G * turn[0] / INERTIA
        return J

    d0 = np.array([c[0] / K, c[1]]) / np.hypot(c[0] / K, c[1])
    reference = solve_ivp(equations, (onset, 1.0), [x0, 0.0, -x0 / R, *(1e-13 * d0), -xd0 / R],
                          method="Radau", jac=jacobian, rtol=1e-13, atol=1e-16, t_eval=t)
    assert reference.success
    return reference, onset, d0


def growing_push_cylinder(tangents) -> System:
    """The cylinder pushed by ``c t``, its sliding velocity ``tangents(s_x, s_y)``."""
    X, Y, Z, TH = coordinates("x y z theta")
    time = sp.Symbol("t")
    c = GROWING
    return System([X, Y, Z, TH], kinetic=M / 2 * (X.diff() ** 2 + Y.diff() ** 2
                                                  + Z.diff() ** 2) + INERTIA / 2 * TH.diff() ** 2,
                  potential=M * G * Z - c[0] * time * X - c[1] * time * Y,
                  constraints=[Unilateral(Z - R, name="floor", friction=MU,
                                          tangents=tangents(X.diff() + R * TH.diff(),
                                                            Y.diff()))])


def test_a_cylinder_pushed_by_a_growing_force_slips_from_rest_and_follows_its_velocity():
    """A push ``c t`` at 0.5 rad: it rolls (``x'' = c_x t / (m + I / r^2)``) until its
    sticking force ``(c_x t / 3, c_y t)`` reaches ``mu m g``, then slides with friction
    ``f = -mu m g s / |s|`` along its sliding velocity ``s = (x' + r theta', y')``,
    which turns from its onset direction towards the push as the push grows (near
    ``s = 0`` that direction is stiff: the run must step through it). Against those
    equations, ``s`` a state of its own (``s_x' = (c_x t + f_x) / m + r^2 f_x / I``),
    integrated by SciPy's Radau with their exact Jacobian from the closed-form state at
    the onset, ``s`` seeded with 1e-13 along the onset direction (seeded with 1e-11,
    or integrated by LSODA or BDF, the reference moves by less than 1e-11)."""
    t = np.linspace(0.6, 1.0, 5)
    reference, onset, d0 = growing_push_reference(t)
    system = growing_push_cylinder(lambda sx, sy: [sx, sy])
    # DOP853 at its 1e-11 throughout; the default method switches to Radau (rtol 1e-8)
    # in the stiff stretch after the onset and keeps its tolerance (relative errors)
    for method, tol in (("DOP853", 2e-11), ("auto", 1e-8)):
        traj = system.simulate((0.0, 1.0), {"z": R}, t_eval=t, timeout=120, method=method)
        assert traj.success, traj.message
        (slip,) = [s.t for s in traj.contacts.switches if s.t > 0]
        assert abs(slip - onset) < 1e-12
        q_ref, s_ref = reference.y[:3].T, reference.y[3:5].T
        assert (np.abs(traj.q[:, [0, 1, 3]] - q_ref) / (1 + np.abs(q_ref))).max() < tol
        s = np.column_stack([traj["x_dot"] + R * traj["theta_dot"], traj["y_dot"]])
        assert (np.abs(s - s_ref) / (1 + np.abs(s_ref))).max() < tol
        w_ref = reference.y[5]
        assert (np.abs(traj["theta_dot"] - w_ref) / (1 + np.abs(w_ref))).max() < tol
    assert traj.stats["n_switches"] >= 1
    # by t = 1 it has turned by a tenth of a radian from its onset direction
    assert np.arccos(s[-1] @ d0 / np.linalg.norm(s[-1])) > 0.1


def test_a_contact_sliding_in_three_world_components_slips_from_rest_the_same():
    """The same cylinder, its sliding velocity written as three world components of
    rank 2 (``Q (s_x, s_y, 0)``, ``Q`` a rotation, as a contact between two spheres
    gives it): the same motion, the friction along ``Q`` of the planar one. Its onset
    too takes the direction its contact point accelerates in (without that it stalled
    at the onset: steps of 1e-12 s until its time limit)."""
    Q = np.array(sp.rot_axis1(0.7) * sp.rot_axis2(0.4), dtype=float)
    t = np.linspace(0.6, 1.0, 5)
    reference, onset, _ = growing_push_reference(t)
    system = growing_push_cylinder(
        lambda sx, sy: [float(Q[i, 0]) * sx + float(Q[i, 1]) * sy for i in range(3)])
    traj = system.simulate((0.0, 1.0), {"z": R}, t_eval=t, timeout=60, method="DOP853")
    assert traj.success, traj.message
    (slip,) = [s.t for s in traj.contacts.switches if s.t > 0]
    assert abs(slip - onset) < 1e-12
    q_ref, s_ref = reference.y[:3].T, reference.y[3:5].T
    assert (np.abs(traj.q[:, [0, 1, 3]] - q_ref) / (1 + np.abs(q_ref))).max() < 2e-11
    s = np.column_stack([traj["x_dot"] + R * traj["theta_dot"], traj["y_dot"]])
    assert (np.abs(s - s_ref) / (1 + np.abs(s_ref))).max() < 2e-11
    # friction -mu m g along Q (s / |s|, 0), the normal force m g
    forces = np.column_stack([traj.multiplier(f"floor_friction_{i}") for i in (1, 2, 3)])
    along = -MU * M * G * s_ref / np.linalg.norm(s_ref, axis=1)[:, None]
    assert np.abs(forces - along @ Q[:, :2].T).max() < 1e-10
    assert np.abs(traj.multiplier("floor") - M * G).max() < 1e-10
