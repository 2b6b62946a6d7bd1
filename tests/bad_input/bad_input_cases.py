"""Shared models of the bad-input suite: a Cartesian pendulum and a free particle."""

from __future__ import annotations

import sympy as sp

from dalembert import Holonomic, System, coordinates

x, y = coordinates("x y")
m, g, l = sp.symbols("m g l", positive=True)
T2 = m / 2 * (x.diff() ** 2 + y.diff() ** 2)
ROD = Holonomic(x**2 + y**2 - l**2, name="rod")
PARAMETERS = {m: 1.0, g: 9.81, l: 1.0}


def pendulum(**changes: object) -> System:
    """The Cartesian pendulum; ``changes`` replace its constructor arguments."""
    kwargs: dict[str, object] = dict(kinetic=T2, potential=m * g * y, constraints=[ROD],
                                     parameters=PARAMETERS)
    kwargs.update(changes)
    return System([x, y], **kwargs)
