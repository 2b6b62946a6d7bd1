"""A particle whirled on a string in a vertical circle: the string goes slack, then
catches it.

Coordinates ``x, z`` (``z`` up), the string of length ``l`` from the origin a
:class:`~dalembert.Unilateral` constraint ``l - sqrt(x^2 + z^2) >= 0``: taut at 0,
slack while positive, its multiplier the tension divided by nothing (the force
``A^T lambda`` pulls towards the origin). Launched at the bottom with
``2 g l < v0^2 < 5 g l`` it cannot go round: the tension
``m v^2 / l + m g cos(theta)`` vanishes at ``cos(theta) = (2 g l - v0^2) / (3 g l)``
(``theta`` from the bottom), where the string goes slack. The particle then flies a
parabola until it is at distance ``l`` again, and the inextensible string (``e = 0``)
catches it, taking the radial part of its kinetic energy.
"""

from __future__ import annotations

import numpy as np
import sympy as sp
from scipy.optimize import brentq

from ..model.constraints import Unilateral
from ..model.coordinates import coordinates
from ..system import System
from ..trajectory import Trajectory

TITLE = "Particle on a string in a vertical circle: slack, a parabola, caught again"
m, g, l = sp.symbols("m g l", positive=True)
x, z = coordinates("x z")
V0 = 6.0
INITIAL = {"q0": {"x": 0.0, "z": -1.0}, "qd0": {"x": V0, "z": 0.0}}
T_END = 2.0


def build(m_value: float = 1.0, g_value: float = 9.81, l_value: float = 1.0) -> System:
    """The particle on its string.

    >>> build().unilateral_names
    ('string',)
    """
    return System(
        [x, z],
        kinetic=m / 2 * (x.diff() ** 2 + z.diff() ** 2),
        potential=m * g * z,
        constraints=[Unilateral(l - sp.sqrt(x**2 + z**2), name="string")],
        parameters={m: m_value, g: g_value, l: l_value},
        name="slack string",
    )


def draw(system: System, q: np.ndarray) -> list[np.ndarray]:
    """The string from the origin to the particle.

    >>> draw(build(), np.array([0.0, -1.0]))[0].tolist()
    [[0.0, 0.0], [0.0, -1.0]]
    """
    return [np.array([[0.0, 0.0], [q[0], q[1]]])]


def checks(system: System, traj: Trajectory) -> dict[str, float]:
    """Where the string goes slack, when it catches the particle and what that costs,
    against the closed forms (the catch where the parabola from the slack point meets
    the circle)."""
    p = system.parameter_values
    gravity, length, mass = p["g"], p["l"], p["m"]
    assert traj.contacts is not None
    slack = next(s for s in traj.contacts.switches[1:] if not s.closed)
    caught = traj.contacts.impacts[0]
    (px, pz), (vx, vz) = slack.q, slack.qd
    theta = np.arccos((2 * gravity * length - V0**2) / (3 * gravity * length))

    def radius(s: float) -> float:
        return float(np.hypot(px + vx * s, pz + vz * s - gravity * s**2 / 2) - length)

    flight = brentq(radius, 0.05, 5.0, xtol=1e-15)  # it leaves the circle inwards
    at = np.array([px + vx * flight, pz + vz * flight - gravity * flight**2 / 2])
    radial = np.array([vx, vz - gravity * flight]) @ at / length
    return {
        "slack angle error (rad)": float(abs(np.arctan2(px, -pz) - theta)),
        "catch time error": float(abs(caught.t - slack.t - flight)),
        "energy lost at the catch, relative error": float(
            abs(caught.energy_lost / (mass * radial**2 / 2) - 1)),
        "max position residual": float(traj.position_residual.max()),
    }
