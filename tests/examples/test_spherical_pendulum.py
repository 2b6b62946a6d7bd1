"""The Cartesian spherical pendulum against the minimal (theta, phi) equations."""

from __future__ import annotations

import numpy as np
import pytest
import sympy as sp
from scipy.integrate import solve_ivp

from dalembert.examples import spherical_pendulum as example

pytestmark = pytest.mark.filterwarnings("error::dalembert.errors.InitialConditionsAdjusted")

G, L = 9.81, 1.0
TIMES = np.linspace(0.0, example.T_END, 1001)


def minimal_rhs(_t: float, u: np.ndarray) -> list[float]:
    """Hand-derived from ``L = l^2 (theta'^2 + sin^2(theta) phi'^2) / 2 + g l cos(theta)`` (m = 1).

    ``theta'' = sin cos phi'^2 - (g/l) sin`` and ``phi'' = -2 cot(theta) theta' phi'``.
    """
    theta, _phi, theta_dot, phi_dot = u
    s, c = np.sin(theta), np.cos(theta)
    return [theta_dot, phi_dot, s * c * phi_dot**2 - G / L * s, -2.0 * c / s * theta_dot * phi_dot]


def test_hand_derived_equations_match_the_minimal_lagrangian():
    """Euler-Lagrange of the minimal Lagrangian (SymPy, independent of dalembert)."""
    tt = sp.Symbol("t")
    th, ph = sp.Function("theta")(tt), sp.Function("phi")(tt)
    g, l = sp.symbols("g l", positive=True)
    lag = l**2 / 2 * (th.diff(tt) ** 2 + sp.sin(th) ** 2 * ph.diff(tt) ** 2) + g * l * sp.cos(th)
    eqs = [lag.diff(q.diff(tt)).diff(tt) - lag.diff(q) for q in (th, ph)]
    acc = sp.solve(eqs, [th.diff(tt, 2), ph.diff(tt, 2)], dict=True)[0]
    thd, phd = th.diff(tt), ph.diff(tt)
    hand = {
        th.diff(tt, 2): sp.sin(th) * sp.cos(th) * phd**2 - g / l * sp.sin(th),
        ph.diff(tt, 2): -2 * sp.cos(th) / sp.sin(th) * thd * phd,
    }
    for key, value in hand.items():
        assert sp.simplify(acc[key] - value) == 0


@pytest.fixture(scope="module")
def system():
    return example.build(g_value=G, l_value=L)


@pytest.fixture(scope="module")
def traj(system):
    return system.simulate((0.0, example.T_END), **example.INITIAL, t_eval=TIMES)


@pytest.fixture(scope="module")
def reference():
    u0 = [example.THETA0, example.PHI0, example.THETA_DOT0, example.PHI_DOT0]
    sol = solve_ivp(minimal_rhs, (0.0, example.T_END), u0, method="DOP853",
                    rtol=1e-13, atol=1e-14, t_eval=TIMES)
    assert sol.success
    return sol.y


def test_initial_state_is_away_from_the_pole(reference):
    # L_z != 0 keeps theta away from 0, where the minimal equations are singular
    assert reference[0].min() > 0.3


@pytest.mark.validation
def test_agrees_with_the_minimal_equations(traj, reference):
    theta, phi, theta_dot, phi_dot = reference
    q_ref, qd_ref = example.cartesian_state(theta, phi, theta_dot, phi_dot, L)
    # measured: 2.7e-11 in position, 8.5e-11 in velocity over 10 s
    assert np.abs(traj.q - q_ref.T).max() < 1e-8
    assert np.abs(traj.qd - qd_ref.T).max() < 1e-8


@pytest.mark.validation
def test_vertical_angular_momentum_and_energy_are_conserved(system, traj, reference):
    lz = example.vertical_angular_momentum(system, traj)
    theta0 = reference[0, 0]
    lz_minimal = L**2 * np.sin(theta0) ** 2 * example.PHI_DOT0  # m l^2 sin^2(theta) phi'
    assert abs(lz[0] - lz_minimal) < 1e-12
    assert np.abs(lz - lz_minimal).max() / abs(lz_minimal) < 1e-9  # measured 2e-11
    e = traj.energy
    assert np.abs(e - e[0]).max() / abs(e[0]) < 1e-9  # measured 4e-11


@pytest.mark.validation
def test_tension_matches_closed_form(system, traj):
    ref = example.closed_form_tension(system, traj)
    assert ref.min() > 0
    assert (np.abs(example.tension(system, traj) - ref) / ref).max() < 1e-8


def test_checks_contract(system, traj):
    errors = example.checks(system, traj)
    assert set(errors) >= {"relative energy error", "relative L_z error", "max position residual"}
    assert max(errors.values()) < 1e-9
