"""Pendulum in Cartesian coordinates ``x, y`` held by the rod ``x^2 + y^2 = l^2``.

Two coordinates, one holonomic constraint, one degree of freedom. The multiplier
gives the rod tension: the constraint force on the bob is ``A^T lambda =
2 lambda (x, y)``, so the tension (pulling towards the pivot) is ``-2 lambda l``,
which must equal ``m v^2 / l + m g cos(theta)``.
"""

from __future__ import annotations

import numpy as np
import sympy as sp

from ..model.constraints import Holonomic
from ..model.coordinates import coordinates
from ..system import System
from ..trajectory import Trajectory

TITLE = "Pendulum in Cartesian x, y with the rod x^2 + y^2 = l^2"
m, g, l = sp.symbols("m g l", positive=True)
x, y = coordinates("x y")
THETA0 = 1.0
INITIAL = {"q0": {"x": np.sin(THETA0), "y": -np.cos(THETA0)}, "qd0": {"x": 0.0, "y": 0.0}}
T_END = 10.0
#: Near the bottom (off the circle: equilibrium() projects it).
EQUILIBRIUM_GUESS = {"x": 0.1, "y": -0.9}


def build(m_value: float = 1.0, g_value: float = 9.81, l_value: float = 1.0) -> System:
    """The Cartesian pendulum (``y`` up, pivot at the origin).

    >>> build().degrees_of_freedom
    1
    """
    return System(
        [x, y],
        kinetic=m / 2 * (x.diff() ** 2 + y.diff() ** 2),
        potential=m * g * y,
        constraints=[Holonomic(x**2 + y**2 - l**2, name="rod")],
        parameters={m: m_value, g: g_value, l: l_value},
        name="cartesian pendulum",
    )


def draw(system: System, q: np.ndarray) -> list[np.ndarray]:
    """The rod as a polyline pivot -> bob (``q`` in coordinate order).

    >>> draw(build(), np.array([0.6, -0.8]))[0].tolist()
    [[0.0, 0.0], [0.6, -0.8]]
    """
    q = np.asarray(q, dtype=float)
    return [np.array([[0.0, 0.0], [q[0], q[1]]])]


def tension(system: System, traj: Trajectory) -> np.ndarray:
    """Rod tension from the multiplier, ``-2 lambda l``."""
    return -2.0 * traj.multiplier("rod") * system.parameter_values["l"]


def closed_form_tension(system: System, traj: Trajectory) -> np.ndarray:
    """``m v^2 / l + m g cos(theta)`` with ``theta`` measured from the downward vertical."""
    p = system.parameter_values
    v2 = traj["x_dot"] ** 2 + traj["y_dot"] ** 2
    cos_theta = -traj["y"] / p["l"]
    return p["m"] * v2 / p["l"] + p["m"] * p["g"] * cos_theta


def checks(system: System, traj: Trajectory) -> dict[str, float]:
    """Tension against the closed form, energy conservation, constraint residual."""
    ref = closed_form_tension(system, traj)
    e = traj.energy
    return {
        "tension relative error": float(
            np.abs(tension(system, traj) - ref).max() / np.abs(ref).max()
        ),
        "relative energy error": float(np.abs(e - e[0]).max() / abs(e[0])),
        "max position residual": float(traj.position_residual.max()),
        "max velocity residual": float(traj.velocity_residual.max()),
    }
