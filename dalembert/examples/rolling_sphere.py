"""A sphere launched sliding on a floor: Coulomb friction turns sliding into rolling.

A solid sphere (mass ``m``, radius ``r``, ``I = 2/5 m r^2``) in the plane of its motion,
coordinates ``x, y, theta`` (``theta`` counterclockwise), on a floor ``y - r >= 0`` with
Coulomb friction ``mu`` along the contact point's sliding velocity
``x' + r theta'`` (:class:`~dalembert.Unilateral` with ``friction`` and ``tangents``).
Launched at ``v0`` without spin, friction ``mu m g`` slows it and spins it up until
the contact point stops sliding at ``t = 2 v0 / (7 mu g)`` (an event of the
event-driven contact mode, found to rounding); from then it rolls at ``5/7 v0``.
Friction and the normal force pass through the contact line, so the angular momentum
about it, ``m r x' - I theta'``, stays ``m r v0`` throughout (a conservation law).
"""

from __future__ import annotations

import numpy as np
import sympy as sp

from ..model.constraints import Unilateral
from ..model.coordinates import coordinates
from ..system import System
from ..trajectory import Trajectory

TITLE = "Sphere launched sliding on a floor: Coulomb friction, sliding then rolling at 5/7 v0"
m, g, r = sp.symbols("m g r", positive=True)
x, y, theta = coordinates("x y theta")
RADIUS, MU, V0 = 0.1, 0.3, 2.0
INITIAL = {"q0": {"x": 0.0, "y": RADIUS}, "qd0": {"x": V0}}
T_END = 1.0


def build(m_value: float = 1.0, g_value: float = 9.81) -> System:
    """The sphere on its floor.

    >>> build().unilateral_names
    ('floor',)
    """
    inertia = sp.Rational(2, 5) * m * r**2
    return System(
        [x, y, theta],
        kinetic=m / 2 * (x.diff() ** 2 + y.diff() ** 2) + inertia / 2 * theta.diff() ** 2,
        potential=m * g * y,
        constraints=[Unilateral(y - r, name="floor", friction=MU,
                                tangents=[x.diff() + r * theta.diff()])],
        parameters={m: m_value, g: g_value, r: RADIUS},
        name="rolling sphere",
    )


def draw(system: System, q: np.ndarray) -> list[np.ndarray]:
    """The floor, the sphere's rim and a radius marking its turn.

    >>> [len(line) for line in draw(build(), np.array([0.0, 0.1, 0.0]))]
    [2, 33, 2]
    """
    angles = np.linspace(0.0, 2 * np.pi, 33)
    rim = np.column_stack([q[0] + RADIUS * np.cos(angles), q[1] + RADIUS * np.sin(angles)])
    mark = np.array([[q[0], q[1]], [q[0] + RADIUS * np.sin(q[2]),
                                    q[1] + RADIUS * np.cos(q[2])]])
    return [np.array([[-0.2, 0.0], [2.0, 0.0]]), rim, mark]


def checks(system: System, traj: Trajectory) -> dict[str, float]:
    """The rolling speed and when it starts, the angular momentum about the contact."""
    p = system.parameter_values
    inertia = 0.4 * p["m"] * RADIUS**2
    slip = traj["x_dot"] + RADIUS * traj["theta_dot"]
    rolling = np.abs(slip) <= 1e-12 * V0
    starts = traj.t[np.argmax(rolling)] if rolling.any() else np.inf
    about = p["m"] * RADIUS * traj["x_dot"] - inertia * traj["theta_dot"]
    return {
        "rolling speed / (5/7 v0) - 1": float(abs(traj["x_dot"][-1] / (5 / 7 * V0) - 1)),
        "rolling starts, error (s)": float(abs(starts - 2 * V0 / (7 * MU * p["g"]))),
        "angular momentum about the contact, relative error": float(
            np.abs(about / (p["m"] * RADIUS * V0) - 1).max()),
        "deepest point below the floor": float(max(0.0, RADIUS - traj["y"].min())),
    }
