"""Closed loops and redundant joints in multibody systems, against independent answers.

- A door on two coaxial hinges: the second hinge repeats the first (all 5 of its
  rows are dependent). The door swings as a compound pendulum (closed-form
  equation in the hinge angle, integrated here). The hinges' share of the load is
  indeterminate; the minimum-norm multipliers are unique and, since the problem
  is symmetric under the reflection ``y -> -y`` that swaps the hinges, each hinge
  carries half of the total reaction ``m c'' - m g`` (Newton's law for the mass
  center, from the reference motion).
- The free-hanging spherical chain (``dalembert.multibody.chain``): energy and
  constraints over 20 s for the 16-link chain (``DALEMBERT_LOOP_CHAIN_N`` changes n).
"""

from __future__ import annotations

import os

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from dalembert.errors import RedundantConstraintsWarning
from dalembert.multibody import Ground, Multibody, Revolute, RigidBody, chain, energy

pytestmark = pytest.mark.filterwarnings("error::dalembert.errors.InitialConditionsAdjusted")

G = 9.81
MASS, INERTIA, R, H = 2.0, (0.3, 0.2, 0.4), 0.5, 0.4  # hinges at y = +-H, center R below
THETA0 = 1.0


def door() -> Multibody:
    body = RigidBody("door", MASS, INERTIA)
    y = (0.0, 1.0, 0.0)
    hinges = [Revolute(f"H{k + 1}", Ground(), body, (0.0, s, 0.0), (0.0, s, R), axis_a=y)
              for k, s in enumerate((H, -H))]
    return Multibody([body], hinges, gravity=(0.0, 0.0, -G), name="door")


def door_state(theta: float) -> tuple[dict, dict]:
    c, s = np.cos(theta), np.sin(theta)
    rot = np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])  # about y by theta
    return door().initial_state(positions={"door": (-R * s, 0.0, -R * c)},
                                orientations={"door": rot})


def door_reference(times: np.ndarray) -> np.ndarray:
    """``(I_y + m R^2) th'' = -m g R sin th`` from rest at ``THETA0``: rows th, th'."""
    k = MASS * G * R / (INERTIA[1] + MASS * R**2)
    sol = solve_ivp(lambda t, y: [y[1], -k * np.sin(y[0])], (times[0], times[-1]),
                    [THETA0, 0.0], method="DOP853", rtol=1e-12, atol=1e-12, t_eval=times)
    return np.vstack([sol.y, -k * np.sin(sol.y[0])])


@pytest.fixture(scope="module")
def door_mb() -> Multibody:
    return door()


@pytest.fixture(scope="module")
def door_run(door_mb):
    mb = door_mb
    times = np.linspace(0.0, 3.0, 151)
    with pytest.warns(RedundantConstraintsWarning, match=r"1 degree\(s\) of freedom.*"
                      r"5 dependent on those listed before: H2_1, H2_2, H2_3, H2_4, H2_5"):
        traj = mb.simulate((0.0, 3.0), *door_state(THETA0), t_eval=times)
    return mb, traj, door_reference(times)


def test_second_hinge_is_named_dependent(door_mb):
    report = door_mb.system.consistent_initial_state(*door_state(THETA0))
    assert report.dependent_constraints == [f"H2_{k}" for k in range(1, 6)]
    assert report.degrees_of_freedom == 1


def test_door_swings_as_a_compound_pendulum(door_run):
    _, traj, ref = door_run
    theta = np.arctan2(-traj["door_x"], -traj["door_z"])
    assert np.abs(theta - ref[0]).max() < 1e-9  # measured 1.5e-11
    assert traj.position_residual.max() < 1e-12


def test_each_hinge_carries_half_the_load(door_run):
    _, traj, (th, w, wd) = door_run
    c, s = np.cos(th), np.sin(th)
    # c = (-R sin th, 0, -R cos th): the reaction m c'' - m g, in x and z
    ax = -R * (wd * c - w**2 * s)
    az = R * (wd * s + w**2 * c)
    total = MASS * np.column_stack([ax, az + G])
    for hinge in ("H1", "H2"):
        force = np.column_stack([traj.multiplier(f"{hinge}_1"), traj.multiplier(f"{hinge}_3")])
        assert np.abs(force - total / 2).max() < 1e-8  # measured 1.4e-10


def test_door_with_baumgarte_stabilization(door_mb):
    times = np.linspace(0.0, 2.0, 21)
    with pytest.warns(RedundantConstraintsWarning):
        traj = door_mb.simulate((0.0, 2.0), *door_state(THETA0), t_eval=times,
                               stabilization="baumgarte")
    theta = np.arctan2(-traj["door_x"], -traj["door_z"])
    assert np.abs(theta - door_reference(times)[0]).max() < 1e-8  # measured 8e-13


# -- the free-hanging spherical chain ---------------------------------------------------
CHAIN_N = int(os.environ.get("DALEMBERT_LOOP_CHAIN_N", "16"))


def tilted_turning_chain(n: int, length: float = 0.5, tilt: float = 0.9, turn: float = 2.0):
    """A straight chain tilted ``tilt`` from the vertical, turning rigidly about ``z``
    (a rigid rotation about an axis through the pivot keeps every joint together)."""
    mb = chain(n, length, 1.0, 0.02)
    c, s = np.cos(tilt), np.sin(tilt)
    down = np.array([s, 0.0, -c])
    rot = np.array([[c, 0.0, -s], [0.0, 1.0, 0.0], [s, 0.0, c]])  # body z -> -down
    omega = np.array([0.0, 0.0, turn])
    names = [f"link{k + 1}" for k in range(n)]
    centers = {k: (i + 0.5) * length * down for i, k in enumerate(names)}
    q0, qd0 = mb.initial_state(
        positions=centers, orientations=dict.fromkeys(names, rot),
        velocities={k: np.cross(omega, x) for k, x in centers.items()},
        angular_velocities=dict.fromkeys(names, omega))
    return mb, q0, qd0


@pytest.mark.validation
def test_free_hanging_spherical_chain_conserves_energy():
    mb, q0, qd0 = tilted_turning_chain(CHAIN_N)
    traj = mb.simulate((0.0, 20.0), q0, qd0, t_eval=np.linspace(0.0, 20.0, 201))
    assert traj.success
    e = energy(mb, traj)
    # measured over 20 s: n=2 3e-12, n=4 1.2e-12, n=16 7.1e-12 (residual 9.8e-15)
    assert np.abs(e - e[0]).max() / abs(e[0]) <= 1e-8
    assert traj.position_residual.max() <= 1e-12
    assert traj.velocity_residual.max() <= 1e-12
