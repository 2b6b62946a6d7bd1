"""A closed loop of rigid rods: six links on spherical joints, both ends pinned.

Six uniform cylinders ``link1..link6`` (length ``L``, axis along body ``z``, joint
points ``(0, 0, -+L/2)``) are joined end to end by spherical joints; ``pin0``
ties the first to the ground at the origin and ``pin6`` the last to the ground at
``(D, 0, 0)``, ``D < 6 L``: ground and links form a closed loop. 42 coordinates,
6 unit-quaternion rows + 7 x 3 joint rows = 27 constraints, all independent: 15
degrees of freedom (9 of the loop, 6 spins of the rods about their own axes).

``INITIAL`` is a symmetric polygon hanging in the ``x, z`` plane (link angles
``-+60, -+40, -+15`` degrees from ``+x``), set turning rigidly about the pin axis
``x`` (a rigid rotation about a line through both pins keeps every joint
together) with link 3 also spinning about its own axis. Afterwards the motion is
irregular and three-dimensional; ``T + V`` is conserved.
"""

from __future__ import annotations

import numpy as np

from ..multibody.bodies import Ground, RigidBody
from ..multibody.builder import Multibody
from ..multibody.joints import Spherical
from ..system import System
from ..trajectory import Trajectory

TITLE = "Closed loop: six rods on spherical joints pinned to the ground at both ends"
N_LINKS, LENGTH, MASS, RADIUS = 6, 1.0, 1.0, 0.05
ANGLES = np.radians([-60.0, -40.0, -15.0, 15.0, 40.0, 60.0])
SPAN = LENGTH * float(np.cos(ANGLES).sum())
TURN_RATE, SPIN_RATE = 1.5, 4.0  # rad/s about the pin axis; link 3 about its axis
T_END = 20.0


def build_multibody(gravity: float = 9.81) -> Multibody:
    """The loop as a ``Multibody``.

    >>> build_multibody().system.degrees_of_freedom
    15
    """
    transverse = MASS * (3 * RADIUS**2 + LENGTH**2) / 12
    inertia = (transverse, transverse, MASS * RADIUS**2 / 2)
    links = [RigidBody(f"link{k + 1}", MASS, inertia) for k in range(N_LINKS)]
    start, end = (0.0, 0.0, -LENGTH / 2), (0.0, 0.0, LENGTH / 2)
    ground = Ground()
    joints = [Spherical("pin0", ground, links[0], (0, 0, 0), start)]
    joints += [Spherical(f"joint{k + 1}", links[k], links[k + 1], end, start)
               for k in range(N_LINKS - 1)]
    joints.append(Spherical(f"pin{N_LINKS}", links[-1], ground, end, (SPAN, 0.0, 0.0)))
    return Multibody(links, joints, gravity=(0.0, 0.0, -gravity), name="closed chain")


def build(gravity: float = 9.81) -> System:
    """The loop's ``System`` (42 coordinates, 27 constraints)."""
    return build_multibody(gravity).system


def _orientation(phi: float) -> np.ndarray:
    """Rotation about ``y`` taking body ``z`` to ``(cos phi, 0, sin phi)``."""
    beta = np.pi / 2 - phi
    c, s = np.cos(beta), np.sin(beta)
    return np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])


def initial_state(turn: float = TURN_RATE, spin: float = SPIN_RATE) -> dict[str, dict[str, float]]:
    """Consistent ``q0``/``qd0``: the polygon turning rigidly about ``x``, link 3 spinning.

    >>> state = initial_state()
    >>> bool(abs(state["q0"]["link6_x"] + LENGTH / 2 * np.cos(ANGLES[-1]) - SPAN) < 1e-12)
    True
    """
    u = np.column_stack([np.cos(ANGLES), np.zeros(N_LINKS), np.sin(ANGLES)])
    ends = np.vstack([np.zeros(3), np.cumsum(LENGTH * u, axis=0)])
    centers = (ends[:-1] + ends[1:]) / 2
    omega = turn * np.array([1.0, 0.0, 0.0])
    names = [f"link{k + 1}" for k in range(N_LINKS)]
    rates = {n: omega + (spin * u[k] if k == 2 else 0.0) for k, n in enumerate(names)}
    q0, qd0 = build_multibody().initial_state(
        positions=dict(zip(names, centers)),
        orientations={n: _orientation(p) for n, p in zip(names, ANGLES)},
        velocities={n: np.cross(omega, c) for n, c in zip(names, centers)},
        angular_velocities=rates,
    )
    return {"q0": q0, "qd0": qd0}


INITIAL = initial_state()


def checks(system: System, traj: Trajectory) -> dict[str, float]:
    """Energy and constraint residuals (the loop stays closed at both pins)."""
    e = traj.energy
    return {
        "relative energy error": float(np.abs(e - e[0]).max() / np.abs(e).max()),
        "max position residual": float(traj.position_residual.max()),
        "max velocity residual": float(traj.velocity_residual.max()),
    }
