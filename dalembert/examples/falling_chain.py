"""A chain of rods dropped onto a table: many contacts, the time-stepping mode.

Eight point masses joined by seven rigid rods (holonomic constraints), each mass above
a frictionless table ``y >= 0`` (a :class:`~dalembert.Unilateral` constraint, plastic).
Dropped tilted and moving sideways, the chain lands end first and its masses strike in
a cascade; the event-driven mode would resolve each of dozens of impacts and contact
switches, the time-stepping mode (``contact_mode="time-stepping"``, Moreau-Jean steps)
steps over them. Independent checks: the table and the rods push vertically and
internally, so the horizontal momentum stays what it was (a conservation law); nothing
goes below the table; the rods keep their lengths; the chain ends flat on the table.
"""

from __future__ import annotations

import numpy as np
import sympy as sp

from ..model.constraints import Holonomic, Unilateral
from ..model.coordinates import coordinates
from ..system import System
from ..trajectory import Trajectory

TITLE = "Chain of rods dropped onto a table: many contacts, time-stepping (Moreau-Jean)"
COUNT, LINK, TILT, DROP, SIDEWAYS = 8, 0.15, 0.35, 0.25, 0.4
m, g = sp.symbols("m g", positive=True)
X = coordinates(" ".join(f"x{k}" for k in range(COUNT)))
Y = coordinates(" ".join(f"y{k}" for k in range(COUNT)))
_q0 = {f"x{k}": k * LINK * np.cos(TILT) for k in range(COUNT)}
_q0.update({f"y{k}": DROP + k * LINK * np.sin(TILT) for k in range(COUNT)})
INITIAL = {"q0": _q0, "qd0": {f"x{k}": SIDEWAYS for k in range(COUNT)},
           "contact_mode": "time-stepping", "contact_step": 2e-3}
T_END = 1.2


def build(m_value: float = 0.1, g_value: float = 9.81) -> System:
    """The chain over its table.

    >>> len(build().unilateral_names)
    8
    """
    rods = [Holonomic((X[k + 1] - X[k]) ** 2 + (Y[k + 1] - Y[k]) ** 2 - LINK**2,
                      name=f"rod{k}") for k in range(COUNT - 1)]
    table = [Unilateral(y, name=f"table{k}") for k, y in enumerate(Y)]
    return System([*X, *Y], kinetic=m / 2 * sum(c.diff() ** 2 for c in (*X, *Y)),
                  potential=m * g * sum(Y), constraints=rods + table,
                  parameters={m: m_value, g: g_value}, name="falling chain")


def draw(system: System, q: np.ndarray) -> list[np.ndarray]:
    """The table and the chain.

    >>> [len(line) for line in draw(build(), np.zeros(16))]
    [2, 8]
    """
    return [np.array([[-0.2, 0.0], [2.0, 0.0]]), np.column_stack([q[:COUNT], q[COUNT:]])]


def checks(system: System, traj: Trajectory) -> dict[str, float]:
    """Horizontal momentum (conserved), the table, the rods, the chain at rest."""
    mass = system.parameter_values["m"]
    momentum = mass * traj.qd[:, :COUNT].sum(axis=1)
    expected = mass * COUNT * SIDEWAYS
    return {
        "horizontal momentum, relative error": float(np.abs(momentum / expected - 1).max()),
        "deepest point below the table": float(max(0.0, -traj.q[:, COUNT:].min())),
        "max rod length residual": float(traj.position_residual.max()),
        "height of the chain at the end": float(np.abs(traj.q[-1, COUNT:]).max()),
    }
