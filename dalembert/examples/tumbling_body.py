"""Torque-free asymmetric rigid body spun near its intermediate axis (Dzhanibekov effect).

A quaternion :class:`~dalembert.multibody.RigidBody` with principal moments
``I1 < I2 < I3`` and no gravity, started spinning about the body ``y`` axis (the
intermediate one) with a small disturbance about the other two. Rotation about
the intermediate axis is unstable: the body flips over and back periodically,
at a rate of order ``w2 sqrt((I2 - I1) (I3 - I2) / (I1 I3))``. Whatever it does,
the energy and the angular momentum in the world frame stay constant, and the
Euler parameters stay unit (they are constrained to); :func:`checks` measures
all three.
"""

from __future__ import annotations

import numpy as np

from ..multibody import Multibody, RigidBody, angular_momentum, energy, multibody_of
from ..system import System
from ..trajectory import Trajectory

TITLE = "Tumbling rigid body: torque-free spin near the intermediate axis flips over"
MASS, INERTIA = 2.0, (1.0, 2.0, 3.0)
#: Body-frame angular velocity at the start: mostly about the intermediate axis.
OMEGA0 = (0.01, 2.0, 0.01)
T_END = 20.0


def model(mass: float = MASS, inertia: tuple[float, float, float] = INERTIA) -> Multibody:
    """One rigid body, no joints, no gravity."""
    return Multibody([RigidBody("body", mass, inertia)], gravity=(0.0, 0.0, 0.0),
                     name="tumbling body")


def build(mass: float = MASS, inertia: tuple[float, float, float] = INERTIA) -> System:
    """The body as a System: 7 coordinates, the unit-quaternion constraint.

    >>> build().degrees_of_freedom
    6
    """
    return model(mass, inertia).system


def _initial() -> dict[str, dict[str, float]]:
    q0, qd0 = model().initial_state(angular_velocities={"body": OMEGA0},
                                    angular_velocity_frame="body")
    return {"q0": q0, "qd0": qd0}


INITIAL = _initial()


def draw(system: System, q: np.ndarray) -> list[np.ndarray]:
    """The body's axes through its mass center, which show its tumbling (3D polylines)."""
    return multibody_of(system).stick_figure(q, body_axes=True)


def checks(system: System, traj: Trajectory) -> dict[str, float]:
    """Conservation of energy and world angular momentum; unit Euler parameters."""
    mb = multibody_of(system)
    e, h = energy(mb, traj), angular_momentum(mb, traj)
    b = np.column_stack([traj[f"body_b{i}"] for i in range(4)])
    return {
        "relative energy error": float(np.abs(e - e[0]).max() / abs(e[0])),
        "relative angular momentum error": float(
            np.abs(h - h[0]).max() / np.linalg.norm(h[0])),
        "quaternion norm error": float(np.abs(np.linalg.norm(b, axis=1) - 1).max()),
        "max velocity residual": float(traj.velocity_residual.max()),
    }
