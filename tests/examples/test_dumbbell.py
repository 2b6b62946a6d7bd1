"""The thrown dumbbell against its closed-form motion: parabola plus uniform rotation."""

from __future__ import annotations

import numpy as np
import pytest

from dalembert.examples import dumbbell as example

pytestmark = pytest.mark.filterwarnings("error::dalembert.errors.InitialConditionsAdjusted")

G, D = 9.81, 1.0
TIMES = np.linspace(0.0, example.T_END, 501)


def closed_form_motion(
    m1: float, m2: float, q0: np.ndarray, qd0: np.ndarray, times: np.ndarray
) -> tuple[np.ndarray, np.ndarray, float]:
    """Both particles' positions (len(t), 6) and the rod's angular rate, independently.

    The centre of mass falls freely; the rod vector ``r = r1 - r2`` (length D, with
    ``r' = v0`` perpendicular to it) turns uniformly in the plane of ``r0`` and ``v0``:
    ``r(t) = cos(w t) r0 + sin(w t) v0 / w`` with ``w = |v0| / D``.
    """
    r1, r2, v1, v2 = q0[:3], q0[3:], qd0[:3], qd0[3:]
    total = m1 + m2
    c = (m1 * r1 + m2 * r2) / total + np.outer(times, (m1 * v1 + m2 * v2) / total)
    c[:, 2] -= G * times**2 / 2
    r0, v0 = r1 - r2, v1 - v2
    w = np.linalg.norm(v0) / D
    rel = np.outer(np.cos(w * times), r0) + np.outer(np.sin(w * times), v0 / w)
    return np.hstack([c + m2 / total * rel, c - m1 / total * rel]), w


def initial_arrays() -> tuple[np.ndarray, np.ndarray]:
    q0 = np.array([example.INITIAL["q0"][k] for k in example.NAMES])
    qd0 = np.array([example.INITIAL["qd0"][k] for k in example.NAMES])
    return q0, qd0


def test_initial_state_is_a_rigid_rod():
    q0, qd0 = initial_arrays()
    r0, v0 = q0[:3] - q0[3:], qd0[:3] - qd0[3:]
    assert np.linalg.norm(r0) == pytest.approx(D, abs=1e-15)
    assert r0 @ v0 == 0.0


@pytest.fixture(scope="module", params=[(1.0, 2.0), (3.0, 0.5)], ids=["m2=2m1", "m1=6m2"])
def case(request):
    m1, m2 = request.param
    system = example.build(m1_value=m1, m2_value=m2, g_value=G, d_value=D)
    traj = system.simulate((0.0, example.T_END), **example.INITIAL, t_eval=TIMES)
    return m1, m2, system, traj


@pytest.mark.validation
def test_motion_matches_closed_form(case):
    m1, m2, _, traj = case
    q_ref, _ = closed_form_motion(m1, m2, *initial_arrays(), TIMES)
    assert np.abs(traj.q - q_ref).max() < 1e-8  # measured 7e-12, 1.3e-11 over 5 s (|q| up to ~100)


@pytest.mark.validation
def test_center_of_mass_on_its_parabola(case):
    _, _, system, traj = case
    c = example.center_of_mass(system, *example.positions(traj))
    q_ref, _ = closed_form_motion(case[0], case[1], *initial_arrays(), TIMES)
    c_ref = example.center_of_mass(system, q_ref[:, :3], q_ref[:, 3:])
    assert np.abs(c - c_ref).max() < 1e-8  # measured 4e-12, 1.1e-11


@pytest.mark.validation
def test_rod_tension_is_the_centripetal_force(case):
    m1, m2, system, traj = case
    _, w = closed_form_motion(m1, m2, *initial_arrays(), TIMES[:1])
    mu = m1 * m2 / (m1 + m2)
    expected = mu * D * w**2  # constant: gravity loads both ends equally
    # measured 5e-11 and 8e-11 for the two mass pairs
    assert np.abs(example.tension(system, traj) / expected - 1).max() < 1e-8


@pytest.mark.validation
def test_energy_is_conserved(case):
    traj = case[3]
    e = traj.energy
    assert np.abs(e - e[0]).max() / abs(e[0]) < 1e-9  # measured 1.7e-12, 3.7e-12
    # measured 8e-13: the projection aims at 1e-14 * max|q|, and |q| reaches ~100 here
    assert traj.position_residual.max() < 1e-11


def test_checks_contract(case):
    _, _, system, traj = case
    errors = example.checks(system, traj)
    assert max(errors.values()) < 1e-9
