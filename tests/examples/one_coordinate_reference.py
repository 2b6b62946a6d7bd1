"""A one-degree-of-freedom mechanism in its own coordinate, for reference answers.

With the configuration a function of one angle ``th``, ``T = 1/2 J(th) th'^2`` and
``V(th)``, Euler-Lagrange gives ``J th'' + 1/2 J' th'^2 + V' = 0``; it is derived
with SymPy and integrated tightly with ``solve_ivp``.
"""

from __future__ import annotations

import numpy as np
import sympy as sp
from scipy.integrate import solve_ivp


def angle_history(J: sp.Expr, V: sp.Expr, th: sp.Symbol, theta0: float, omega0: float,
                  times: np.ndarray) -> np.ndarray:
    """``th`` at ``times`` (the first is the start) from ``th(0) = theta0, th'(0) = omega0``."""
    w = sp.Symbol("w")
    accel = -(J.diff(th) * w**2 / 2 + V.diff(th)) / J
    f = sp.lambdify((th, w), accel, cse=True)
    sol = solve_ivp(lambda t, y: [y[1], f(y[0], y[1])], (times[0], times[-1]),
                    [theta0, omega0], method="DOP853", rtol=1e-12, atol=1e-12, t_eval=times)
    assert sol.success
    return sol.y[0]
