"""A dumbbell thrown under gravity: two particles joined by a massless rigid rod.

Six coordinates (both particles' ``x, y, z``, ``z`` up), one holonomic constraint
``|r1 - r2|^2 = d^2``, five degrees of freedom. The centre of mass flies on the
free-fall parabola; the rod spins at the constant rate ``omega`` in a fixed plane
(gravity pulls both ends equally, so it exerts no torque about the centre of mass
and puts no load on the rod). The constraint force on particle 1 is
``2 lambda (r1 - r2)``, so the rod tension is ``-2 lambda d``, which must equal the
centripetal force ``mu d omega^2`` with the reduced mass ``mu = m1 m2 / (m1 + m2)``.
"""

from __future__ import annotations

import numpy as np
import sympy as sp

from ..model.constraints import Holonomic
from ..model.coordinates import coordinates
from ..system import System
from ..trajectory import Trajectory

TITLE = "Dumbbell thrown under gravity: two masses on a rigid rod |r1 - r2| = d"
m1, m2, g, d = sp.symbols("m1 m2 g d", positive=True)
x1, y1, z1, x2, y2, z2 = coordinates("x1 y1 z1 x2 y2 z2")
NAMES = ("x1", "y1", "z1", "x2", "y2", "z2")

# Particle 1 at the origin, particle 2 one rod length (d = 1) away along x, the rod
# spinning about an axis tilted out of the vertical while the whole body is thrown.
_R1, _R2 = np.zeros(3), np.array([1.0, 0.0, 0.0])
_V1, _V2 = np.array([1.0, -0.5, 5.0]), np.array([1.0, 1.5, 6.0])
INITIAL = {"q0": dict(zip(NAMES, np.concatenate([_R1, _R2]))),
           "qd0": dict(zip(NAMES, np.concatenate([_V1, _V2])))}
T_END = 5.0


def build(
    m1_value: float = 1.0, m2_value: float = 2.0, g_value: float = 9.81, d_value: float = 1.0
) -> System:
    """The dumbbell (``z`` up).

    >>> build().degrees_of_freedom
    5
    """
    r1, r2 = sp.Matrix([x1, y1, z1]), sp.Matrix([x2, y2, z2])
    v1, v2 = r1.diff(), r2.diff()
    return System(
        [x1, y1, z1, x2, y2, z2],
        kinetic=m1 / 2 * v1.dot(v1) + m2 / 2 * v2.dot(v2),
        potential=g * (m1 * z1 + m2 * z2),
        constraints=[Holonomic((r1 - r2).dot(r1 - r2) - d**2, name="rod")],
        parameters={m1: m1_value, m2: m2_value, g: g_value, d: d_value},
        name="dumbbell",
    )


def positions(traj: Trajectory) -> tuple[np.ndarray, np.ndarray]:
    """Positions of the two particles, arrays of shape (len(t), 3)."""
    return traj.q[:, :3], traj.q[:, 3:]


def velocities(traj: Trajectory) -> tuple[np.ndarray, np.ndarray]:
    """Velocities of the two particles, arrays of shape (len(t), 3)."""
    return traj.qd[:, :3], traj.qd[:, 3:]


def center_of_mass(system: System, r1: np.ndarray, r2: np.ndarray) -> np.ndarray:
    """``(m1 r1 + m2 r2) / (m1 + m2)`` (works for positions and velocities alike)."""
    p = system.parameter_values
    return (p["m1"] * r1 + p["m2"] * r2) / (p["m1"] + p["m2"])


def closed_form_center_of_mass(system: System, traj: Trajectory) -> np.ndarray:
    """The free-fall parabola ``c0 + w0 t - g t^2 / 2 e_z`` from the first output state."""
    c0 = center_of_mass(system, *positions(traj))[0]
    w0 = center_of_mass(system, *velocities(traj))[0]
    tau = (traj.t - traj.t[0])[:, None]
    c = c0 + w0 * tau
    c[:, 2] -= system.parameter_values["g"] * tau[:, 0] ** 2 / 2
    return c


def tension(system: System, traj: Trajectory) -> np.ndarray:
    """Rod tension from the multiplier, ``-2 lambda d``."""
    return -2.0 * traj.multiplier("rod") * system.parameter_values["d"]


def closed_form_tension(system: System, traj: Trajectory) -> np.ndarray:
    """``mu d omega^2 = mu |v1 - v2|^2 / d`` (the relative velocity is perpendicular to the rod)."""
    p = system.parameter_values
    v1, v2 = velocities(traj)
    mu = p["m1"] * p["m2"] / (p["m1"] + p["m2"])
    return mu * np.sum((v1 - v2) ** 2, axis=1) / p["d"]


def checks(system: System, traj: Trajectory) -> dict[str, float]:
    """Tension and centre of mass against the closed forms, energy, constraint residuals."""
    ref = closed_form_tension(system, traj)
    c = center_of_mass(system, *positions(traj))
    e = traj.energy
    return {
        "tension relative error": float(
            np.abs(tension(system, traj) - ref).max() / np.abs(ref).max()
        ),
        "centre of mass error": float(
            np.abs(c - closed_form_center_of_mass(system, traj)).max()
        ),
        "relative energy error": float(np.abs(e - e[0]).max() / abs(e[0])),
        "max position residual": float(traj.position_residual.max()),
        "max velocity residual": float(traj.velocity_residual.max()),
    }
