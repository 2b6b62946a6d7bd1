"""The bead on a spinning hoop (rheonomic constraints) against its minimal equation."""

from __future__ import annotations

import numpy as np
import pytest
import sympy as sp
from scipy.integrate import solve_ivp

from dalembert.examples import bead_on_hoop as example

pytestmark = pytest.mark.filterwarnings("error::dalembert.errors.InitialConditionsAdjusted")

G, R, OMEGA = 9.81, 1.0, example.OMEGA
TIMES = np.linspace(0.0, example.T_END, 1001)


def minimal_rhs(_t: float, u: np.ndarray) -> list[float]:
    """``phi'' = (Omega^2 cos(phi) - g/R) sin(phi)``, phi from the bottom of the hoop."""
    phi, phi_dot = u
    return [phi_dot, (OMEGA**2 * np.cos(phi) - G / R) * np.sin(phi)]


def minimal_jacobi_integral(phi: np.ndarray, phi_dot: np.ndarray) -> np.ndarray:
    """``h = R^2 phi'^2 / 2 - Omega^2 R^2 sin^2(phi) / 2 - g R cos(phi)`` (m = 1)."""
    return R**2 * phi_dot**2 / 2 - OMEGA**2 * R**2 * np.sin(phi) ** 2 / 2 - G * R * np.cos(phi)


def test_minimal_equation_follows_from_the_minimal_lagrangian():
    """Euler-Lagrange of ``L = R^2 (phi'^2 + Omega^2 sin^2 phi) / 2 + g R cos(phi)`` (SymPy)."""
    tt = sp.Symbol("t")
    phi = sp.Function("phi")(tt)
    g, r, w = sp.symbols("g R Omega", positive=True)
    lag = r**2 / 2 * (phi.diff(tt) ** 2 + w**2 * sp.sin(phi) ** 2) + g * r * sp.cos(phi)
    eq = lag.diff(phi.diff(tt)).diff(tt) - lag.diff(phi)
    acc = sp.solve(eq, phi.diff(tt, 2))[0]
    assert sp.simplify(acc - (w**2 * sp.cos(phi) - g / r) * sp.sin(phi)) == 0


@pytest.fixture(scope="module")
def system():
    return example.build(g_value=G, R_value=R, Omega_value=OMEGA)


@pytest.fixture(scope="module")
def traj(system):
    return system.simulate((0.0, example.T_END), **example.INITIAL, t_eval=TIMES)


@pytest.fixture(scope="module")
def reference():
    sol = solve_ivp(minimal_rhs, (0.0, example.T_END), [example.PHI0, example.PHI_DOT0],
                    method="DOP853", rtol=1e-13, atol=1e-14, t_eval=TIMES)
    assert sol.success
    return sol.y


@pytest.mark.validation
def test_agrees_with_the_minimal_equation(traj, reference):
    q_ref, qd_ref = example.cartesian_state(*reference, TIMES, R, OMEGA)
    # measured: 3.1e-11 in position, 1.4e-10 in velocity over 10 s
    assert np.abs(traj.q - q_ref.T).max() < 1e-8
    assert np.abs(traj.qd - qd_ref.T).max() < 1e-8
    # the bead really swings through a range (not sitting at an equilibrium)
    assert np.ptp(reference[0]) > 0.5


@pytest.mark.validation
def test_jacobi_integral_is_conserved_and_energy_is_not(system, traj, reference):
    h = example.rotating_frame_energy(system, traj)
    h_minimal = minimal_jacobi_integral(*reference[:, :1])[0]
    scale = G * R
    assert abs(h[0] - h_minimal) < 1e-12 * scale  # T + V - Omega L_z is the minimal h
    assert np.abs(h - h_minimal).max() < 1e-9 * scale  # measured 8.5e-12
    e = traj.energy
    assert np.ptp(e) > 0.5 * scale  # the hoop drives the bead: measured 1.37 m g R


@pytest.mark.validation
def test_lagrangian_jacobi_integral_is_the_energy_in_inertial_coordinates(traj):
    """``L = T - V`` has no explicit time here, so ``qd . dL/dqd - L = T + V``: the
    time dependence sits in the constraints, whose forces do work. It is therefore
    not the conserved quantity (that is ``T + V - Omega L_z``, tested above)."""
    scale = G * R
    assert np.abs(traj.jacobi_integral - traj.energy).max() < 1e-12 * scale
    assert np.ptp(traj.jacobi_integral) > 0.5 * scale


@pytest.mark.validation
def test_reactions_match_closed_forms(system, traj):
    plane = example.closed_form_plane_multiplier(system, traj)
    normal = example.closed_form_normal_force(system, traj)
    assert np.abs(plane).max() > 1.0 and np.abs(normal).min() > 1.0  # not trivially zero
    assert np.abs(traj.multiplier("plane") - plane).max() / np.abs(plane).max() < 1e-8
    assert (np.abs(example.normal_force(system, traj) - normal) / np.abs(normal)).max() < 1e-8


def test_checks_contract(system, traj):
    errors = example.checks(system, traj)
    driven = "relative energy variation (driven, not conserved)"
    assert errors[driven] > 0.5
    assert max(v for k, v in errors.items() if k != driven) < 1e-9
