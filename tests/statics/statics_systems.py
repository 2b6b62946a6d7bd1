"""Systems shared by the equilibrium and linearization tests."""

from __future__ import annotations

import sympy as sp

from dalembert import Holonomic, System, coordinates

M_BOB, G, L_ROD = 2.0, 9.81, 1.5


def spinning_hoop(m=0.3, g=9.81, R=0.7, W=2.0) -> System:
    """Bead on a hoop spinning at rate W, in the hoop's rotating plane (x horizontal, z up)."""
    x, z = coordinates("x z")
    ms, gs, Rs, Ws = sp.symbols("m g R W", positive=True)
    return System(
        [x, z],
        kinetic=ms / 2 * (x.diff() ** 2 + z.diff() ** 2 + Ws**2 * x**2),
        potential=ms * gs * z,
        constraints=[Holonomic(x**2 + z**2 - Rs**2, name="hoop")],
        parameters={ms: m, gs: g, Rs: R, Ws: W},
        name="spinning hoop",
    )
