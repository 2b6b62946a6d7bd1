"""Knife edge and Chaplygin sled against closed forms and separately integrated equations.

Knife edge (blade at the mass center, no applied force): the only force is the
lateral blade force ``F n`` with ``n = (-sin(theta), cos(theta))``, so the torque
about the mass center vanishes (``omega`` constant) and the force is normal to the
velocity (the speed ``v`` is constant). The contact point therefore runs on a
circle of radius ``v / omega`` with ``theta = theta0 + omega t``; its acceleration is
``v omega n``, so ``F = m v omega``. Since ``A = (-sin(theta), cos(theta), 0)`` gives
``A^T lambda = lambda n``, the convention ``M qdd = f + A^T lambda`` makes
``lambda = +m v omega`` (positive: pushing to the left when turning left).

Chaplygin sled (mass center a distance ``a`` ahead of the blade, inertia ``J`` about
the mass center): with the blade's forward speed ``u`` and ``omega = theta_dot``,
Newton-Euler for the mass center velocity ``u e1 + a omega e2`` gives the classic
reduced equations ``u_dot = a omega^2``, ``(J + m a^2) omega_dot = -m a u omega``
(Bloch, Nonholonomic Mechanics and Control, sec. 1.7), the lateral force
``m (u omega + a omega_dot)``, and the reconstruction ``x_dot = u cos(theta)``,
``y_dot = u sin(theta)``.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from dalembert.examples import knife_edge

M, J = 2.0, 0.3
T_END = 10.0
T_EVAL = np.linspace(0.0, T_END, 201)


def _start(v: float, omega: float, theta0: float, x0: float = 0.5, y0: float = -0.2) -> dict:
    return {
        "q0": {"x": x0, "y": y0, "theta": theta0},
        "qd0": {"x": v * np.cos(theta0), "y": v * np.sin(theta0), "theta": omega},
    }


@pytest.fixture(scope="module")
def knife():
    return knife_edge.build(m_value=M, J_value=J)


@pytest.fixture(scope="module")
def sled():
    return knife_edge.build(m_value=M, J_value=J, a_value=0.4)


@pytest.mark.parametrize("v, omega", [(1.5, 0.8), (1.2, -0.6), (-0.9, 0.7)])
def test_knife_edge_runs_on_the_closed_form_circle(knife, v, omega):
    x0, y0, th0 = 0.5, -0.2, 0.3
    traj = knife.simulate((0.0, T_END), **_start(v, omega, th0, x0, y0), t_eval=T_EVAL)
    radius = v / omega
    xc, yc = x0 - radius * np.sin(th0), y0 + radius * np.cos(th0)
    theta = th0 + omega * T_EVAL
    np.testing.assert_allclose(traj["theta"], theta, rtol=0, atol=1e-9)
    np.testing.assert_allclose(traj["x"], xc + radius * np.sin(theta), rtol=0, atol=1e-8)
    np.testing.assert_allclose(traj["y"], yc - radius * np.cos(theta), rtol=0, atol=1e-8)
    # Signed lateral force: m v omega (derived in the module docstring above).
    np.testing.assert_allclose(traj.multiplier("blade"), M * v * omega, rtol=1e-9)
    e = traj.energy
    assert np.abs(e - e[0]).max() / e[0] < 1e-9
    assert traj.velocity_residual.max() < 1e-12


def _sled_reference(a: float, start: dict) -> tuple[np.ndarray, np.ndarray]:
    """The sled's reduced equations, integrated on their own; returns states and lambda."""
    jp = J + M * a**2

    def rhs(_t, s):
        _x, _y, th, u, om = s
        return [u * np.cos(th), u * np.sin(th), om, a * om**2, -M * a * u * om / jp]

    th0 = start["q0"]["theta"]
    u0 = start["qd0"]["x"] * np.cos(th0) + start["qd0"]["y"] * np.sin(th0)
    s0 = [start["q0"]["x"], start["q0"]["y"], th0, u0, start["qd0"]["theta"]]
    sol = solve_ivp(rhs, (0.0, T_END), s0, t_eval=T_EVAL, method="DOP853",
                    rtol=1e-12, atol=1e-14)
    _x, _y, _th, u, om = sol.y
    lam = M * (u * om + a * (-M * a * u * om / jp))
    return sol.y, lam


@pytest.mark.validation
def test_chaplygin_sled_matches_its_reduced_equations(sled):
    start = _start(1.0, 1.2, 0.3)
    traj = sled.simulate((0.0, T_END), **start, t_eval=T_EVAL)
    ref, lam = _sled_reference(0.4, start)
    for i, name in enumerate(("x", "y", "theta")):
        np.testing.assert_allclose(traj[name], ref[i], rtol=0, atol=1e-8, err_msg=name)
    np.testing.assert_allclose(traj["theta_dot"], ref[4], rtol=0, atol=1e-8)
    np.testing.assert_allclose(traj.multiplier("blade"), lam, rtol=0,
                               atol=1e-8 * np.abs(lam).max())
    e = traj.energy
    assert np.abs(e - e[0]).max() / e[0] < 1e-9
    # The sled's turning dies out while its speed grows: a real, non-trivial motion.
    assert abs(ref[4, -1]) < 0.5 * abs(ref[4, 0])


def test_module_checks_report_small_errors(knife, sled):
    traj = knife.simulate((0.0, knife_edge.T_END), **knife_edge.INITIAL, t_eval=T_EVAL)
    errors = knife_edge.checks(knife, traj)
    assert set(errors) >= {"lateral force relative error", "relative energy error",
                           "circle radius relative error", "speed drift", "turn rate drift"}
    assert max(errors.values()) < 1e-9
    traj = sled.simulate((0.0, knife_edge.T_END), **knife_edge.INITIAL, t_eval=T_EVAL)
    errors = knife_edge.checks(sled, traj)
    assert "circle radius relative error" not in errors
    assert max(errors.values()) < 1e-9
