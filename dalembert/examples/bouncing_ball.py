"""A ball bouncing on a floor: a unilateral constraint with restitution.

Coordinates ``x, y`` (``y`` up), the floor ``y >= 0`` a
:class:`~dalembert.Unilateral` constraint with Newton's coefficient ``e``. Dropped
from ``h0`` while moving sideways, it falls for ``t_1 = sqrt(2 h0 / g)``; bounce ``k``
sends it up at ``e^k`` times the first impact speed, so the impacts come at
``t_1 (1 + 2 (e + ... + e^k))``, the apexes reach ``e^(2k) h0`` and each impact loses
``1 - e^2`` of the kinetic energy of the fall. The bounces accumulate at
``t_inf = t_1 (1 + e) / (1 - e)``: once an impact is slower than the floor's
``rest_speed`` it is plastic, and the ball rests on the floor, which then pushes with
its weight.
"""

from __future__ import annotations

import numpy as np
import sympy as sp

from ..model.constraints import Unilateral
from ..model.coordinates import coordinates
from ..system import System
from ..trajectory import Trajectory

TITLE = "Ball bouncing on a floor (restitution e): impacts, then rest"
m, g, e = sp.symbols("m g e", positive=True)
x, y = coordinates("x y")
H0, SIDEWAYS, E = 1.0, 0.3, 0.8
INITIAL = {"q0": {"x": 0.0, "y": H0}, "qd0": {"x": SIDEWAYS, "y": 0.0}}
T_END = 5.0


def build(m_value: float = 1.0, g_value: float = 9.81, e_value: float = E) -> System:
    """The ball over its floor.

    >>> build().unilateral_names
    ('floor',)
    """
    return System(
        [x, y],
        kinetic=m / 2 * (x.diff() ** 2 + y.diff() ** 2),
        potential=m * g * y,
        constraints=[Unilateral(y, name="floor", restitution=e_value)],
        parameters={m: m_value, g: g_value},
        name="bouncing ball",
    )


def draw(system: System, q: np.ndarray) -> list[np.ndarray]:
    """The floor and the ball (a point).

    >>> [a.tolist() for a in draw(build(), np.array([0.5, 1.0]))]
    [[[-0.5, 0.0], [2.0, 0.0]], [[0.5, 1.0]]]
    """
    return [np.array([[-0.5, 0.0], [2.0, 0.0]]), np.array([[q[0], q[1]]])]


def checks(system: System, traj: Trajectory) -> dict[str, float]:
    """Impact times, energy lost, the time it comes to rest and the floor's force then."""
    p = system.parameter_values
    gravity, mass = p["g"], p["m"]
    t1 = np.sqrt(2 * H0 / gravity)
    assert traj.contacts is not None
    impacts = traj.contacts.impacts
    k = np.arange(len(impacts))
    bounces = np.array([i.qd_before[1] for i in impacts])
    plastic = -bounces < system.model.constraints.unilateral[0].rest_speed
    elastic = ~plastic
    expected = t1 + 2 * t1 * np.cumsum(np.r_[0.0, E ** np.arange(1, len(impacts))])
    lost = np.array([i.energy_lost for i in impacts])
    fall = mass * bounces**2 / 2
    rest = traj.contacts.switches[-1].t
    return {
        "impact time error": float(np.abs(np.array([i.t for i in impacts]) - expected)[k < 20]
                                   .max()),
        "energy lost per impact, error / first fall's energy": float(
            np.abs(lost - (1 - E**2) * fall)[elastic].max() / fall[0]),
        "rest time error": float(abs(rest - t1 * (1 + E) / (1 - E))),
        "floor force at rest / weight - 1": float(
            abs(traj.multiplier("floor")[-1] / (mass * gravity) - 1)),
        "deepest point below the floor": float(max(0.0, -traj["y"].min())),
    }
