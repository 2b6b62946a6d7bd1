"""Double pendulum in Cartesian coordinates ``x1, y1, x2, y2`` held by two rigid rods.

Four coordinates, two holonomic constraints (``x1^2 + y1^2 = l^2`` and
``(x2 - x1)^2 + (y2 - y1)^2 = l^2``), two degrees of freedom; equal masses ``m``
and rod lengths ``l``, ``y`` up, pivot at the origin. Hanging straight down it
is in stable equilibrium, with small-oscillation frequencies
``omega^2 = (2 -+ sqrt 2) g / l``. Released from rest at the angles
``THETA0`` it swings (chaotically at larger angles) and conserves ``T + V``.
"""

from __future__ import annotations

import numpy as np
import sympy as sp

from ..model.constraints import Holonomic
from ..model.coordinates import coordinates
from ..system import System
from ..trajectory import Trajectory

TITLE = "Double pendulum in Cartesian x1, y1, x2, y2 with two rigid rods"
m, g, l = sp.symbols("m g l", positive=True)
x1, y1, x2, y2 = coordinates("x1 y1 x2 y2")
NAMES = ("x1", "y1", "x2", "y2")
#: Release angles of the two rods from the downward vertical (rad), at rest.
THETA0 = (0.6, -0.4)


def positions_from_angles(theta1: float, theta2: float,
                          length: float = 1.0) -> dict[str, float]:
    """Coordinates of both bobs for rod angles measured from the downward vertical.

    >>> {k: round(v, 12) for k, v in positions_from_angles(0.0, 0.0).items()}
    {'x1': 0.0, 'y1': -1.0, 'x2': 0.0, 'y2': -2.0}
    """
    p1 = length * np.array([np.sin(theta1), -np.cos(theta1)])
    p2 = p1 + length * np.array([np.sin(theta2), -np.cos(theta2)])
    return dict(zip(NAMES, (float(v) for v in (*p1, *p2))))


INITIAL = {"q0": positions_from_angles(*THETA0), "qd0": dict.fromkeys(NAMES, 0.0)}
T_END = 10.0
#: Near hanging straight down (not on the rods: equilibrium() projects it).
EQUILIBRIUM_GUESS = {"x1": 0.1, "y1": -0.9, "x2": 0.15, "y2": -1.9}


def build(m_value: float = 1.0, g_value: float = 9.81, l_value: float = 1.0) -> System:
    """The double pendulum (``y`` up, pivot at the origin).

    >>> build().degrees_of_freedom
    2
    """
    v1 = x1.diff() ** 2 + y1.diff() ** 2
    v2 = x2.diff() ** 2 + y2.diff() ** 2
    return System(
        [x1, y1, x2, y2],
        kinetic=m / 2 * (v1 + v2),
        potential=m * g * (y1 + y2),
        constraints=[
            Holonomic(x1**2 + y1**2 - l**2, name="rod1"),
            Holonomic((x2 - x1) ** 2 + (y2 - y1) ** 2 - l**2, name="rod2"),
        ],
        parameters={m: m_value, g: g_value, l: l_value},
        name="double pendulum",
    )


def draw(system: System, q: np.ndarray) -> list[np.ndarray]:
    """The two rods as one polyline pivot -> bob 1 -> bob 2 (``q`` in coordinate order).

    >>> draw(build(), np.array([0.0, -1.0, 0.0, -2.0]))[0].tolist()
    [[0.0, 0.0], [0.0, -1.0], [0.0, -2.0]]
    """
    q = np.asarray(q, dtype=float)
    return [np.array([[0.0, 0.0], [q[0], q[1]], [q[2], q[3]]])]


def checks(system: System, traj: Trajectory) -> dict[str, float]:
    """Energy conservation and constraint residuals."""
    e = traj.energy
    return {
        "relative energy error": float(np.abs(e - e[0]).max() / abs(e[0])),
        "max position residual": float(traj.position_residual.max()),
        "max velocity residual": float(traj.velocity_residual.max()),
    }
