"""A particle whirled on a string that is pulled in through a hole at a prescribed rate.

Planar coordinates ``x, y`` (the hole at the origin, no force in the plane but the
string's). The string length is prescribed, ``l(t) = l0 - v t + d sin(nu t)`` (pulled
in at speed ``v`` with a superposed tug), so the constraint ``x^2 + y^2 - l(t)^2 = 0``
is rheonomic: it does work, and energy is not conserved.

The constraint force on the particle is ``A^T lambda = 2 lambda (x, y)``, so the
string tension (pulling towards the hole) is ``T = -2 lambda l``. The force is
central, so the angular momentum per unit mass ``h = x y_dot - y x_dot = l^2
theta_dot`` is conserved, and the radial equation ``m (r_ddot - r theta_dot^2) = -T``
with ``r = l`` gives the closed forms

    T = m (h^2 / l^3 - l''),        kinetic energy = m/2 (l'^2 + h^2 / l^2).
"""

from __future__ import annotations

import numpy as np
import sympy as sp

from ..model.constraints import Holonomic
from ..model.coordinates import coordinates, t
from ..system import System
from ..trajectory import Trajectory

TITLE = "Particle on a string pulled in through a hole: a rheonomic constraint"
m, l0, v, d, nu = sp.symbols("m l0 v d nu", real=True)
x, y = coordinates("x y")
#: The prescribed string length.
LENGTH = l0 - v * t + d * sp.sin(nu * t)
OMEGA0 = 2.0
T_END = 8.0


def build(
    m_value: float = 1.0,
    l0_value: float = 1.0,
    v_value: float = 0.05,
    d_value: float = 0.05,
    nu_value: float = 2.0,
) -> System:
    """The particle on the string of length ``l0 - v t + d sin(nu t)``.

    >>> build().degrees_of_freedom
    1
    """
    return System(
        [x, y],
        kinetic=m / 2 * (x.diff() ** 2 + y.diff() ** 2),
        constraints=[Holonomic(x**2 + y**2 - LENGTH**2, name="string")],
        parameters={m: m_value, l0: l0_value, v: v_value, d: d_value, nu: nu_value},
        name="whirled string",
    )


def length(system: System, time: np.ndarray, order: int = 0) -> np.ndarray:
    """The prescribed length ``l(t)`` or its ``order``-th time derivative."""
    p = system.parameter_values
    expr = LENGTH.diff(t, order).subs({s: p[s.name] for s in (l0, v, d, nu)})
    return sp.lambdify(t, expr, "numpy")(time) * np.ones_like(time, dtype=float)


def initial_state(
    l0_value: float = 1.0, v_value: float = 0.05, d_value: float = 0.05, nu_value: float = 2.0,
    omega0: float = OMEGA0,
) -> dict[str, dict[str, float]]:
    """``q0``/``qd0`` on the positive ``x`` axis, turning at ``omega0``, radial speed ``l'(0)``."""
    return {
        "q0": {"x": l0_value, "y": 0.0},
        "qd0": {"x": -v_value + d_value * nu_value, "y": l0_value * omega0},
    }


INITIAL = initial_state()


def tension(system: System, traj: Trajectory) -> np.ndarray:
    """String tension from the multiplier, ``-2 lambda l``."""
    return -2.0 * traj.multiplier("string") * length(system, traj.t)


def angular_momentum(traj: Trajectory) -> np.ndarray:
    """Angular momentum per unit mass about the hole, ``x y_dot - y x_dot``."""
    return traj["x"] * traj["y_dot"] - traj["y"] * traj["x_dot"]


def checks(system: System, traj: Trajectory) -> dict[str, float]:
    """Tension, angular momentum and kinetic energy against the closed forms."""
    p = system.parameter_values
    h = angular_momentum(traj)
    h0 = h[0]
    lt, ld, ldd = (length(system, traj.t, k) for k in range(3))
    ref_tension = p["m"] * (h0**2 / lt**3 - ldd)
    ref_kinetic = p["m"] / 2 * (ld**2 + h0**2 / lt**2)
    return {
        "tension relative error": float(
            np.abs(tension(system, traj) - ref_tension).max() / np.abs(ref_tension).max()
        ),
        "angular momentum relative drift": float(np.abs(h - h0).max() / abs(h0)),
        "kinetic energy relative error": float(
            np.abs(traj.kinetic_energy - ref_kinetic).max() / ref_kinetic.max()
        ),
        "max position residual": float(traj.position_residual.max()),
        "max velocity residual": float(traj.velocity_residual.max()),
    }
