"""The Cartesian pendulum and its independent reference in the angle (minimal coordinates).

Shared by the solver tests (imported by name; fixtures are re-exported by each test module).
"""

from __future__ import annotations

import numpy as np
import sympy as sp
from scipy.integrate import solve_ivp
from scipy.special import ellipk

from dalembert import Holonomic, System, coordinates

G = 9.81
THETA0 = 1.0
Q0 = {"x": np.sin(THETA0), "y": -np.cos(THETA0)}
#: Exact period of the pendulum released at rest from THETA0 (l = 1).
PERIOD = 4.0 / np.sqrt(G) * ellipk(np.sin(THETA0 / 2) ** 2)


def build_pendulum() -> System:
    x, y = coordinates("x y")
    m, g, l = sp.symbols("m g l", positive=True)
    return System([x, y], kinetic=m / 2 * (x.diff() ** 2 + y.diff() ** 2), potential=m * g * y,
                  constraints=[Holonomic(x**2 + y**2 - l**2, name="rod")],
                  parameters={m: 1.0, g: G, l: 1.0}, name="pendulum")


def reference_solution():
    """theta(t) from theta'' = -g sin(theta), integrated separately (dense, t in [0, 4])."""
    sol = solve_ivp(lambda t, s: [s[1], -G * np.sin(s[0])], (0, 4), [THETA0, 0.0],
                    method="DOP853", rtol=1e-13, atol=1e-13, dense_output=True)
    return sol.sol


def position_error(traj, reference) -> float:
    theta = reference(traj.t)[0]
    return float(max(np.abs(traj["x"] - np.sin(theta)).max(),
                     np.abs(traj["y"] + np.cos(theta)).max()))
