"""Whirled string against closed forms in polar coordinates.

With ``r = l(t)`` prescribed, the only force is the string's, central, so
``h = r^2 theta_dot`` is constant: ``theta(t) = theta0 + h int_0^t ds / l(s)^2``
(closed form ``(h / v) (1/l - 1/l0)`` for the steady pull ``l = l0 - v t``). The
radial equation ``m (r_ddot - r theta_dot^2) = -T`` gives ``T = m (h^2/l^3 - l'')``,
and the speed is ``sqrt(l'^2 + h^2/l^2)``. In dalembert's convention the force on the
particle is ``A^T lambda = 2 lambda (x, y)`` with ``A = (2x, 2y)``, so the tension
(towards the hole) is ``-2 lambda l``.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import quad

from dalembert.examples import whirled_string

M, L0, OMEGA0 = 1.5, 1.2, 2.5
T_END = 8.0
T_EVAL = np.linspace(0.0, T_END, 81)


def _profile(v: float, d: float, nu: float):
    """``l``, ``l'``, ``l''`` of ``l0 - v t + d sin(nu t)``, written out by hand."""
    return (lambda s: L0 - v * s + d * np.sin(nu * s),
            lambda s: -v + d * nu * np.cos(nu * s),
            lambda s: -d * nu**2 * np.sin(nu * s))


def _simulate(v: float, d: float, nu: float):
    system = whirled_string.build(m_value=M, l0_value=L0, v_value=v, d_value=d, nu_value=nu)
    start = {"q0": {"x": L0, "y": 0.0}, "qd0": {"x": -v + d * nu, "y": L0 * OMEGA0}}
    return system.simulate((0.0, T_END), **start, t_eval=T_EVAL)


@pytest.mark.parametrize("v, d, nu", [(0.05, 0.05, 2.0), (0.1, 0.0, 0.0), (0.0, 0.2, 3.0)])
def test_tension_angular_momentum_and_angle_match_closed_forms(v, d, nu):
    traj = _simulate(v, d, nu)
    l, ld, ldd = (f(T_EVAL) for f in _profile(v, d, nu))
    h = L0**2 * OMEGA0
    # Angular momentum about the hole is conserved (central force).
    h_sim = traj["x"] * traj["y_dot"] - traj["y"] * traj["x_dot"]
    assert np.abs(h_sim - h).max() / h < 1e-8
    # Tension from the multiplier against m (h^2/l^3 - l'').
    ref = M * (h**2 / l**3 - ldd)
    tension = -2.0 * traj.multiplier("string") * l
    np.testing.assert_allclose(tension, ref, rtol=1e-8)
    # Polar angle against the quadrature of h / l^2.
    length = _profile(v, d, nu)[0]
    angle = np.array([quad(lambda s: h / length(s) ** 2, 0.0, te, epsabs=1e-14,
                           epsrel=1e-13, limit=200)[0] for te in T_EVAL])
    np.testing.assert_allclose(np.unwrap(np.arctan2(traj["y"], traj["x"])), angle,
                               rtol=0, atol=1e-8)
    np.testing.assert_allclose(np.hypot(traj["x"], traj["y"]), l, rtol=1e-12)
    # Kinetic energy m/2 (l'^2 + h^2/l^2): not conserved, the string does work.
    np.testing.assert_allclose(traj.kinetic_energy, M / 2 * (ld**2 + h**2 / l**2), rtol=1e-9)


def test_steady_pull_matches_the_closed_form_angle():
    """``l = l0 - v t``: ``theta = (h/v) (1/l - 1/l0)`` and ``T = m h^2 / l^3`` exactly."""
    v = 0.1
    traj = _simulate(v, 0.0, 0.0)
    l = L0 - v * T_EVAL
    h = L0**2 * OMEGA0
    theta = h / v * (1 / l - 1 / L0)
    np.testing.assert_allclose(np.unwrap(np.arctan2(traj["y"], traj["x"])), theta,
                               rtol=0, atol=1e-8)
    np.testing.assert_allclose(-2.0 * traj.multiplier("string") * l, M * h**2 / l**3,
                               rtol=1e-8)
    # Pulling in spins the particle up: the closed form is being tested on a real change.
    assert traj["y_dot"][-1] ** 2 + traj["x_dot"][-1] ** 2 > 2 * (L0 * OMEGA0) ** 2


def test_module_checks_report_small_errors():
    system = whirled_string.build()
    traj = system.simulate((0.0, whirled_string.T_END), **whirled_string.INITIAL,
                           t_eval=T_EVAL)
    errors = whirled_string.checks(system, traj)
    assert errors["angular momentum relative drift"] < 1e-8
    assert errors["tension relative error"] < 1e-8
    assert errors["kinetic energy relative error"] < 1e-9
    assert max(errors.values()) < 1e-8
