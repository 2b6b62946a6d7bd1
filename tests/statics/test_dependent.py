"""Statics of a mechanism with dependent constraints: the four-bar built from 3D hinges.

Three of its 23 constraint rows are combinations of the others (a planar loop closed
with 3D revolute joints). References, independent of the library:

- the equilibrium: the crank angle where ``dV/dtheta = 0`` in one coordinate, from
  the loop's closed-form position and velocity analysis (Freudenstein);
- the pin forces: the three links' free-body diagrams in the plane (9 equations, 8
  unknown pin-force components), solved by hand below;
- the small oscillations: ``omega^2 = V''(theta) / J(theta)`` with the effective
  inertia ``J`` of the one-coordinate model.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from scipy.optimize import brentq

from dalembert.errors import ConstraintError, RedundantConstraintsWarning
from dalembert.examples import four_bar
from dalembert.statics import equilibrium

G = 9.81
A_, B_, C_, D_ = four_bar.LENGTHS
MASSES = [four_bar.DENSITY * length for length in (A_, B_, C_)]


def unit(phi: float) -> np.ndarray:
    return np.array([np.cos(phi), np.sin(phi)])  # (x, z) of a link at angle phi


def centers_and_rates(theta: float) -> tuple[list[np.ndarray], list[np.ndarray], tuple]:
    """Link centers, their velocities per unit crank rate, and the link rates."""
    angles = four_bar.link_angles(theta)
    rates = four_bar.link_rates(angles, 1.0)
    e = [unit(p) for p in angles]
    de = [w * np.array([-np.sin(p), np.cos(p)]) for p, w in zip(angles, rates)]
    centers = [A_ / 2 * e[0], A_ * e[0] + B_ / 2 * e[1], np.array([D_, 0.0]) + C_ / 2 * e[2]]
    velocities = [A_ / 2 * de[0], A_ * de[0] + B_ / 2 * de[1], C_ / 2 * de[2]]
    return centers, velocities, rates


def dV(theta: float) -> float:
    """``dV/dtheta = g sum m_k dz_k/dtheta``, exact from the velocity analysis."""
    return G * sum(m * v[1] for m, v in zip(MASSES, centers_and_rates(theta)[1]))


@pytest.fixture(scope="module")
def hanging():
    """The stable rest of the crank, from ``dV/dtheta = 0`` in one coordinate."""
    grid = np.linspace(0.0, 2 * np.pi, 721)
    slope = np.array([dV(x) for x in grid])
    # a minimum: the slope crosses zero upwards
    k = next(i for i in range(len(grid) - 1) if slope[i] < 0 <= slope[i + 1])
    theta = brentq(dV, grid[k], grid[k + 1], xtol=1e-15)
    system = four_bar.build()
    guess = four_bar.initial_state(theta + 0.2, 0.0)["q0"]
    with pytest.warns(RedundantConstraintsWarning, match=r"J4_2, J4_4, J4_5"):
        rest = system.equilibrium(guess)
    return theta, system, rest


def test_the_warning_points_at_the_users_call(hanging):
    _, system, rest = hanging
    with pytest.warns(RedundantConstraintsWarning) as caught:
        system.equilibrium(rest.q)
        equilibrium(system, rest.q)  # the function the method is an alias of
    assert [w.filename for w in caught] == [__file__, __file__]


def test_equilibrium_of_the_four_bar_is_the_minimum_of_v(hanging):
    theta, _, rest = hanging
    centers = centers_and_rates(theta)[0]
    for link, center in zip(four_bar.LINKS, centers):
        assert abs(rest[f"{link}_x"] - center[0]) < 1e-10
        assert abs(rest[f"{link}_z"] - center[1]) < 1e-10
    assert rest.stability == "stable"
    assert rest.dependent_constraints == four_bar.DEPENDENT


def pin_forces_by_hand(theta: float) -> np.ndarray:
    """``F1..F4`` (rows, (x, z)): ground on crank at O2, crank on coupler at A, coupler
    on rocker at B, ground on rocker at O4, from the links' free-body diagrams."""
    th2, _, th4 = four_bar.link_angles(theta)
    O2, A = np.zeros(2), A_ * unit(th2)
    O4 = np.array([D_, 0.0])
    B = O4 + C_ * unit(th4)
    G2, G3, G4 = centers_and_rates(theta)[0]
    W = [np.array([0.0, -m * G]) for m in MASSES]

    def moment(r: np.ndarray) -> np.ndarray:  # r x F in the plane, as a row acting on F
        return np.array([-r[1], r[0]])

    E, Z = np.eye(2), np.zeros((2, 2))
    rows = [
        np.hstack([E, -E, Z, Z]),                                    # crank forces
        np.hstack([moment(O2 - G2), -moment(A - G2), np.zeros(4)]),  # crank moments
        np.hstack([Z, E, -E, Z]),                                    # coupler forces
        np.hstack([np.zeros(2), moment(A - G3), -moment(B - G3), np.zeros(2)]),
        np.hstack([Z, Z, E, E]),                                     # rocker forces
        np.hstack([np.zeros(4), moment(B - G4), moment(O4 - G4)]),
    ]
    matrix = np.vstack([np.atleast_2d(r) for r in rows])
    rhs = np.concatenate([-W[0], [0.0], -W[1], [0.0], -W[2], [0.0]])
    forces, *_ = np.linalg.lstsq(matrix, rhs, rcond=None)
    assert np.abs(matrix @ forces - rhs).max() < 1e-12  # consistent: it is at rest
    return forces.reshape(4, 2)


def test_reactions_match_the_free_body_diagrams(hanging):
    theta, system, rest = hanging
    by_hand = pin_forces_by_hand(theta)
    num = system.numeric()
    A, _ = num.velocity_constraint(rest.t, rest.q)
    names = system.coordinate_names
    lam = rest.multipliers

    def joint_force(joint: str, link: str) -> np.ndarray:
        rows = [i for i, c in enumerate(system.constraint_names) if c.startswith(joint + "_")]
        generalized = A[rows].T @ lam[rows]
        return np.array([generalized[names.index(f"{link}_{c}")] for c in "xz"])

    scale = sum(MASSES) * G
    expected = {("J1", "crank"): by_hand[0], ("J2", "coupler"): by_hand[1],
                ("J2", "crank"): -by_hand[1], ("J3", "rocker"): by_hand[2],
                ("J4", "rocker"): by_hand[3]}
    for (joint, link), force in expected.items():
        assert np.abs(joint_force(joint, link) - force).max() < 1e-9 * scale, (joint, link)
    # the reactions A^T lambda balance the weights (translations) exactly
    for link, m in zip(four_bar.LINKS, MASSES):
        assert abs(rest.constraint_forces[names.index(f"{link}_z")] - m * G) < 1e-9 * scale


def test_small_oscillations_match_the_one_coordinate_model(hanging):
    theta, system, rest = hanging
    _, velocities, rates = centers_and_rates(theta)
    transverse = [m * (3 * four_bar.RADIUS**2 + length**2) / 12
                  for m, length in zip(MASSES, (A_, B_, C_))]
    inertia = sum(m * v @ v + i * w**2
                  for m, v, i, w in zip(MASSES, velocities, transverse, rates))
    h = 1e-5
    stiffness = (dV(theta + h) - dV(theta - h)) / (2 * h)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RedundantConstraintsWarning)
        modes = system.linearize(rest)
    assert modes.degrees_of_freedom == 1
    omega = float(np.real(modes.natural_frequencies[0]))
    assert abs(omega - np.sqrt(stiffness / inertia)) < 1e-7 * omega


def test_dependent_constraints_refused_when_asked(hanging):
    theta, system, _ = hanging
    guess = four_bar.initial_state(theta, 0.0)["q0"]
    with pytest.raises(ConstraintError, match=r"'J4_2'.*combinations of the constraints"):
        system.equilibrium(guess, redundant_constraints="error")
