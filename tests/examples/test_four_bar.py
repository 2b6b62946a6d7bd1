"""The four-bar linkage (3 redundant joint equations) against independent answers.

- Position: Freudenstein's relation between crank and rocker angles (closed form).
- Motion: the same linkage in its one minimal coordinate, the crank angle ``th``:
  ``T = 1/2 J(th) th'^2`` with the link angles from the closed-form position
  analysis, Euler-Lagrange ``J th'' + 1/2 J' th'^2 + V' = 0``, derived here with
  SymPy and integrated with ``solve_ivp``.
- Which rows are dependent: out of the plane, ``J1..J3`` already fix the loop, so
  the out-of-plane rows of ``J4`` (``d_y``, and the two axis rows) repeat them.
"""

from __future__ import annotations

import numpy as np
import pytest
import sympy as sp
from one_coordinate_reference import angle_history

from dalembert import ConstraintError
from dalembert.errors import RedundantConstraintsWarning
from dalembert.examples import four_bar as example
from dalembert.multibody import energy

pytestmark = pytest.mark.filterwarnings("error::dalembert.errors.InitialConditionsAdjusted")

T_END = 5.0  # about five crank turns
TIMES = np.linspace(0.0, T_END, 501)
G = 9.81


@pytest.fixture(scope="module")
def system():
    return example.build()


@pytest.fixture(scope="module")
def traj(system):
    with pytest.warns(RedundantConstraintsWarning, match=r"1 degree\(s\) of freedom.*"
                      r"3 dependent on those listed before: J4_2, J4_4, J4_5"):
        return system.simulate((0.0, T_END), **example.INITIAL, t_eval=TIMES)


def test_dependent_rows_are_named_and_one_degree_of_freedom(system):
    report = system.consistent_initial_state(**example.INITIAL)
    assert not report.changed  # the closed-form initial state is consistent
    assert report.dependent_constraints == ["J4_2", "J4_4", "J4_5"]
    assert report.rank.rank == 20 and report.degrees_of_freedom == 1
    assert "J4_2, J4_4, J4_5" in str(report)


def test_error_option_names_the_dependent_rows(system):
    with pytest.raises(ConstraintError, match=r"dependent \(redundant\) constraints at the "
                       r"initial state: constraint 'J4_2' .*constraint 'J4_4' .*'J4_5'"):
        system.simulate((0.0, 0.1), **example.INITIAL, redundant_constraints="error")


@pytest.mark.validation
def test_rocker_follows_freudenstein(traj):
    assert traj.success
    assert example.freudenstein_error(traj) < 1e-9  # measured 1.4e-14


@pytest.mark.validation
def test_constraints_and_energy(traj):
    assert traj.position_residual.max() <= 1e-12  # measured 9.9e-15
    assert traj.velocity_residual.max() <= 1e-12  # measured 1.8e-15
    e = energy(example.build_multibody(), traj)  # evaluated from the bodies, not the model
    assert np.abs(e - e[0]).max() / abs(e[0]) < 1e-9  # measured 1.1e-11


def minimal_reference(times: np.ndarray) -> np.ndarray:
    """Crank angle from the one-coordinate Lagrangian (see the module docstring)."""
    a, b, c, d = example.LENGTHS
    th = sp.Symbol("th")
    k1, k2, k3 = d / a, d / c, (a**2 - b**2 + c**2 + d**2) / (2 * a * c)
    p, q, r = k1 - sp.cos(th), -sp.sin(th), k3 - k2 * sp.cos(th)
    th4 = sp.atan2(q, p) + sp.acos(-r / sp.sqrt(p**2 + q**2))
    th3 = sp.atan2(c * sp.sin(th4) - a * sp.sin(th), d + c * sp.cos(th4) - a * sp.cos(th))
    e = [sp.Matrix([sp.cos(phi), sp.sin(phi)]) for phi in (th, th3, th4)]
    centers = [a / 2 * e[0], a * e[0] + b / 2 * e[1], sp.Matrix([d, 0]) + c / 2 * e[2]]
    J, V = sp.S.Zero, sp.S.Zero
    for length, center, phi in zip((a, b, c), centers, (th, th3, th4)):
        m = example.DENSITY * length
        inertia = m * (3 * example.RADIUS**2 + length**2) / 12
        v = center.diff(th)
        J += m * v.dot(v) + inertia * phi.diff(th) ** 2
        V += m * G * center[1]
    return angle_history(J, V, th, example.THETA2_0, example.OMEGA2_0, times)


@pytest.mark.validation
def test_crank_motion_matches_minimal_coordinates(traj):
    crank = np.unwrap(example.angle(traj, "crank"))
    crank += example.THETA2_0 - crank[0]
    assert np.abs(crank - minimal_reference(TIMES)).max() < 1e-8  # measured 7e-11


def test_checks_contract(system, traj):
    errors = example.checks(system, traj)
    assert max(errors.values()) < 1e-9
