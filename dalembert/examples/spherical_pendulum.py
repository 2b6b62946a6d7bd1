"""Spherical pendulum in Cartesian ``x, y, z`` held by the rod ``x^2 + y^2 + z^2 = l^2``.

Three coordinates, one holonomic constraint, two degrees of freedom. Gravity is
along ``-z`` and the rod force is central, so the vertical angular momentum
``L_z = m (x y' - y x')`` is conserved along with the energy. As in the planar
pendulum the constraint force on the bob is ``2 lambda (x, y, z)``, so the rod
tension is ``-2 lambda l = m v^2 / l + m g cos(theta)`` with ``cos(theta) = -z / l``.
"""

from __future__ import annotations

import numpy as np
import sympy as sp

from ..model.constraints import Holonomic
from ..model.coordinates import coordinates
from ..system import System
from ..trajectory import Trajectory

TITLE = "Spherical pendulum in Cartesian x, y, z with the rod x^2 + y^2 + z^2 = l^2"
m, g, l = sp.symbols("m g l", positive=True)
x, y, z = coordinates("x y z")

#: Initial polar angle from the downward vertical, azimuth and their rates (l = 1).
THETA0, PHI0, THETA_DOT0, PHI_DOT0 = 1.0, 0.0, 0.3, 2.0


def cartesian_state(
    theta: float, phi: float, theta_dot: float, phi_dot: float, l_value: float = 1.0
) -> tuple[np.ndarray, np.ndarray]:
    """Position and velocity of the bob from the spherical angles and their rates.

    >>> q, qd = cartesian_state(0.0, 0.0, 0.0, 0.0)
    >>> q.tolist(), qd.tolist()
    ([0.0, 0.0, -1.0], [0.0, 0.0, 0.0])
    """
    st, ct, sf, cf = np.sin(theta), np.cos(theta), np.sin(phi), np.cos(phi)
    q = l_value * np.array([st * cf, st * sf, -ct])
    qd = l_value * np.array([
        ct * cf * theta_dot - st * sf * phi_dot,
        ct * sf * theta_dot + st * cf * phi_dot,
        st * theta_dot,
    ])
    return q, qd


_Q0, _QD0 = cartesian_state(THETA0, PHI0, THETA_DOT0, PHI_DOT0)
INITIAL = {"q0": dict(zip("xyz", _Q0)), "qd0": dict(zip("xyz", _QD0))}
T_END = 10.0


def build(m_value: float = 1.0, g_value: float = 9.81, l_value: float = 1.0) -> System:
    """The spherical pendulum (``z`` up, pivot at the origin).

    >>> build().degrees_of_freedom
    2
    """
    return System(
        [x, y, z],
        kinetic=m / 2 * (x.diff() ** 2 + y.diff() ** 2 + z.diff() ** 2),
        potential=m * g * z,
        constraints=[Holonomic(x**2 + y**2 + z**2 - l**2, name="rod")],
        parameters={m: m_value, g: g_value, l: l_value},
        name="spherical pendulum",
    )


def vertical_angular_momentum(system: System, traj: Trajectory) -> np.ndarray:
    """``L_z = m (x y' - y x')``, conserved because gravity and the rod exert no torque about z."""
    return system.parameter_values["m"] * (traj["x"] * traj["y_dot"] - traj["y"] * traj["x_dot"])


def tension(system: System, traj: Trajectory) -> np.ndarray:
    """Rod tension from the multiplier, ``-2 lambda l``."""
    return -2.0 * traj.multiplier("rod") * system.parameter_values["l"]


def closed_form_tension(system: System, traj: Trajectory) -> np.ndarray:
    """``m v^2 / l + m g cos(theta)`` (radial balance of the bob; ``cos(theta) = -z / l``)."""
    p = system.parameter_values
    v2 = traj["x_dot"] ** 2 + traj["y_dot"] ** 2 + traj["z_dot"] ** 2
    return p["m"] * v2 / p["l"] - p["m"] * p["g"] * traj["z"] / p["l"]


def checks(system: System, traj: Trajectory) -> dict[str, float]:
    """Energy and ``L_z`` conservation, tension against the closed form, constraint residuals."""
    e = traj.energy
    lz = vertical_angular_momentum(system, traj)
    ref = closed_form_tension(system, traj)
    return {
        "relative energy error": float(np.abs(e - e[0]).max() / abs(e[0])),
        "relative L_z error": float(np.abs(lz - lz[0]).max() / abs(lz[0])),
        "tension relative error": float(
            np.abs(tension(system, traj) - ref).max() / np.abs(ref).max()
        ),
        "max position residual": float(traj.position_residual.max()),
        "max velocity residual": float(traj.velocity_residual.max()),
    }
