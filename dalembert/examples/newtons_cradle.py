"""Newton's cradle: five balls on strings, touching, the first one released.

Each ball hangs from its own pivot on a rod of length ``l`` (coordinates ``x_k, y_k``,
a holonomic constraint each); neighbours touch, and their contact is a
:class:`~dalembert.Unilateral` constraint on the distance of the centres,
``|r_(k+1) - r_k| - 2 r >= 0``, elastic (``e = 1``). The first ball, released from
the angle ``THETA0``, arrives at the bottom at ``v = sqrt(2 g l (1 - cos THETA0))``;
at the impact the rods are vertical and the contacts horizontal, so with the default
sequential impact law each collision of equal balls exchanges their velocities: the
first four stop and the last leaves at ``v``, swinging up to ``THETA0`` (the outcome
real cradles show; ``impact_law="simultaneous"`` gives every ball a share instead).
Energy is conserved through the impacts.
"""

from __future__ import annotations

import numpy as np
import sympy as sp
from scipy.special import ellipk

from ..model.constraints import Holonomic, Unilateral
from ..model.coordinates import coordinates
from ..system import System
from ..trajectory import Trajectory

TITLE = "Newton's cradle: five balls on strings, elastic contacts, sequential impacts"
m, g, l, r = sp.symbols("m g l r", positive=True)
COUNT, RADIUS, LENGTH, THETA0 = 5, 0.05, 1.0, 0.5
X = coordinates(" ".join(f"x{k}" for k in range(COUNT)))
Y = coordinates(" ".join(f"y{k}" for k in range(COUNT)))
PIVOTS = 2 * RADIUS * np.arange(COUNT)
_q0 = {f"x{k}": float(PIVOTS[k]) for k in range(COUNT)}
_q0.update({f"y{k}": -LENGTH for k in range(COUNT)})
_q0.update({"x0": -LENGTH * np.sin(THETA0), "y0": -LENGTH * np.cos(THETA0)})
INITIAL = {"q0": _q0}
T_END = 4.0


def build(m_value: float = 0.1, g_value: float = 9.81) -> System:
    """Five balls on rods of length ``LENGTH``, touching at rest.

    >>> build().unilateral_names
    ('contact0', 'contact1', 'contact2', 'contact3')
    """
    rods = [Holonomic((X[k] - float(PIVOTS[k])) ** 2 + Y[k] ** 2 - l**2, name=f"rod{k}")
            for k in range(COUNT)]
    contacts = [Unilateral(sp.sqrt((X[k + 1] - X[k]) ** 2 + (Y[k + 1] - Y[k]) ** 2) - 2 * r,
                           name=f"contact{k}", restitution=1.0) for k in range(COUNT - 1)]
    return System(
        [*X, *Y],
        kinetic=m / 2 * sum(c.diff() ** 2 for c in (*X, *Y)),
        potential=m * g * sum(Y),
        constraints=rods + contacts,
        parameters={m: m_value, g: g_value, l: LENGTH, r: RADIUS},
        name="Newton's cradle",
    )


def draw(system: System, q: np.ndarray) -> list[np.ndarray]:
    """The rods from the pivots to the balls.

    >>> len(draw(build(), np.r_[np.zeros(5), -np.ones(5)]))
    5
    """
    return [np.array([[PIVOTS[k], 0.0], [q[k], q[COUNT + k]]]) for k in range(COUNT)]


def checks(system: System, traj: Trajectory) -> dict[str, float]:
    """The first impact against the closed form (the last ball leaves at the first's
    speed, the others stop), the impact times against the pendulum's period (released
    from rest, the first ball arrives after a quarter of it; each impact sends one end
    ball out and back in half of it: ``T = 4 sqrt(l / g) K(sin^2(THETA0 / 2))``), and
    the energy through every impact."""
    p = system.parameter_values
    assert traj.contacts is not None
    impacts = traj.contacts.impacts
    v = np.sqrt(2 * p["g"] * LENGTH * (1 - np.cos(THETA0)))
    expected = np.zeros(2 * COUNT)
    expected[COUNT - 1] = v
    period = 4 * np.sqrt(LENGTH / p["g"]) * ellipk(np.sin(THETA0 / 2) ** 2)
    times = np.array([i.t for i in impacts])
    energy = traj.energy
    return {
        "velocities after the first impact, error": float(
            np.abs(impacts[0].qd_after - expected).max()),
        "impact time error": float(np.abs(times - period / 4
                                          - period / 2 * np.arange(len(times))).max()),
        "energy lost in the impacts": float(sum(abs(i.energy_lost) for i in impacts)),
        "relative energy error": float(np.abs(energy - energy[0]).max() / abs(energy[0])),
    }
