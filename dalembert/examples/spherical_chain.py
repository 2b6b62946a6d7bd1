"""A chain of rigid links on ball joints, hung from a fixed point, swinging in 3D.

Built with :func:`dalembert.multibody.chain`: ``N`` uniform cylinders (quaternion
rigid bodies), ``Spherical`` joints ground -> link 1 -> ... -> link ``N``. It starts
from rest in a bent 3D shape and turning rigidly about the vertical through the
pivot. Gravity along ``-z`` and a pivot on that axis exert no torque about it, so
besides the energy the vertical angular momentum ``H_z`` about the pivot is
conserved; :func:`checks` measures both and the constraint residuals. (Agreement
with the same chain in joint angles is tested in ``tests/multibody``.)
"""

from __future__ import annotations

import numpy as np

from ..multibody import Multibody, angular_momentum, chain, energy, multibody_of
from ..system import System
from ..trajectory import Trajectory

TITLE = "Chain of rigid links on ball joints swinging in 3D (quaternions, 4 links)"
N, LENGTH, MASS, RADIUS = 4, 0.5, 1.0, 0.03
#: Spin of the whole bent chain about the vertical at the start (rad/s).
SPIN = 1.5
T_END = 5.0


def model(n: int = N, length: float = LENGTH, mass: float = MASS,
          radius: float = RADIUS) -> Multibody:
    return chain(n, length, mass, radius, joint="spherical")


def build(n: int = N, length: float = LENGTH, mass: float = MASS,
          radius: float = RADIUS) -> System:
    """The chain as a System: ``7 N`` coordinates, ``N + 3 N`` constraints."""
    return model(n, length, mass, radius).system


def bent_state(mb: Multibody, length: float = LENGTH,
               spin: float = SPIN) -> dict[str, dict[str, float]]:
    """Links pointing down and outwards at growing azimuths, turning rigidly about ``z``."""
    n = len(mb.bodies)
    positions, orientations, velocities, rates = {}, {}, {}, {}
    top = np.zeros(3)
    w = np.array([0.0, 0.0, spin])
    for k, link in enumerate(mb.bodies):
        tilt, azimuth = 0.4 + 0.5 * k / n, 1.1 * k
        down = np.array([np.sin(tilt) * np.cos(azimuth), np.sin(tilt) * np.sin(azimuth),
                         -np.cos(tilt)])
        up = -down  # body z runs from the link's bottom to its top
        side = np.cross(up, [0.0, 0.0, 1.0]) if abs(up[2]) < 0.999 else np.array([1.0, 0, 0])
        side /= np.linalg.norm(side)
        center = top + down * length / 2
        positions[link], orientations[link] = center, np.column_stack(
            [side, np.cross(up, side), up])
        velocities[link], rates[link] = np.cross(w, center), w
        top = top + down * length
    q0, qd0 = mb.initial_state(positions, orientations, velocities, rates)
    return {"q0": q0, "qd0": qd0}


INITIAL = bent_state(model())


def draw(system: System, q: np.ndarray) -> list[np.ndarray]:
    """The links (center -> joint points) and their mass centers (3D polylines)."""
    return multibody_of(system).stick_figure(q)


def checks(system: System, traj: Trajectory) -> dict[str, float]:
    """Energy and the vertical angular momentum are conserved; constraint residuals."""
    mb = multibody_of(system)
    e = energy(mb, traj)
    hz = angular_momentum(mb, traj)[:, 2]
    return {
        "relative energy error": float(np.abs(e - e[0]).max() / abs(e[0])),
        "relative H_z error": float(np.abs(hz - hz[0]).max() / abs(hz[0])),
        "max position residual": float(traj.position_residual.max()),
        "max velocity residual": float(traj.velocity_residual.max()),
    }
