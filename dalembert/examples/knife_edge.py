"""Knife edge (and Chaplygin sled) on a horizontal plane: a nonholonomic blade.

Coordinates ``x, y`` (the blade's contact point) and the heading ``theta``. The
blade cannot slide sideways: ``-sin(theta) x_dot + cos(theta) y_dot = 0``, a
:class:`~dalembert.Pfaffian` constraint that is not integrable. The mass center
lies a distance ``a`` ahead of the blade along the body axis; ``a = 0`` (the
default) is the knife edge, ``a != 0`` the Chaplygin sled. ``J`` is the moment
of inertia about the mass center.

With ``A = (-sin(theta), cos(theta), 0)`` the constraint force ``A^T lambda`` is
``lambda`` times the blade's left normal ``n = (-sin(theta), cos(theta))``:
``lambda`` is the signed lateral force of the ground on the blade (positive to the
left). Newton's law for the mass center along ``n`` gives, with the forward speed
``u`` of the blade and ``omega = theta_dot``,

    lambda = m (u omega + a omega_dot),   omega_dot = -m a u omega / (J + m a^2),

(the sled's reduced equations are ``u_dot = a omega^2`` and the ``omega_dot`` above).
For the knife edge (``a = 0``) ``u`` and ``omega`` stay constant, ``lambda = m u
omega``, and the contact point runs on a circle of radius ``u / omega``.
"""

from __future__ import annotations

import numpy as np
import sympy as sp

from ..model.constraints import Pfaffian
from ..model.coordinates import coordinates
from ..system import System
from ..trajectory import Trajectory

TITLE = "Knife edge / Chaplygin sled: a blade that cannot slide sideways (nonholonomic)"
m, J, a = sp.symbols("m J a", real=True)
x, y, theta = coordinates("x y theta")
SPEED, OMEGA, THETA0 = 1.5, 0.8, 0.3
INITIAL = {
    "q0": {"x": 0.0, "y": 0.0, "theta": THETA0},
    "qd0": {"x": SPEED * np.cos(THETA0), "y": SPEED * np.sin(THETA0), "theta": OMEGA},
}
T_END = 10.0


def build(m_value: float = 2.0, J_value: float = 0.3, a_value: float = 0.0) -> System:
    """The knife edge (``a_value = 0``) or the Chaplygin sled (``a_value != 0``).

    >>> build().degrees_of_freedom
    2
    """
    xd, yd, thd = x.diff(), y.diff(), theta.diff()
    # Velocity of the mass center, a distance a ahead of the blade.
    vgx = xd - a * sp.sin(theta) * thd
    vgy = yd + a * sp.cos(theta) * thd
    return System(
        [x, y, theta],
        kinetic=m / 2 * (vgx**2 + vgy**2) + J / 2 * thd**2,
        constraints=[Pfaffian(-sp.sin(theta) * xd + sp.cos(theta) * yd, name="blade")],
        parameters={m: m_value, J: J_value, a: a_value},
        name="knife edge" if a_value == 0 else "Chaplygin sled",
    )


def forward_speed(traj: Trajectory) -> np.ndarray:
    """Speed of the contact point along the blade, ``u``."""
    th = traj["theta"]
    return traj["x_dot"] * np.cos(th) + traj["y_dot"] * np.sin(th)


def closed_form_lateral_force(system: System, traj: Trajectory) -> np.ndarray:
    """``m (u omega + a omega_dot)`` with the sled's ``omega_dot`` (Newton along the normal)."""
    p = system.parameter_values
    u, om = forward_speed(traj), traj["theta_dot"]
    om_dot = -p["m"] * p["a"] * u * om / (p["J"] + p["m"] * p["a"] ** 2)
    return p["m"] * (u * om + p["a"] * om_dot)


def circle_center(traj: Trajectory) -> tuple[float, float, float]:
    """Center and signed radius ``u / omega`` of the knife edge's circle, from the start."""
    u0, om0, th0 = forward_speed(traj)[0], traj["theta_dot"][0], traj["theta"][0]
    radius = u0 / om0
    return traj["x"][0] - radius * np.sin(th0), traj["y"][0] + radius * np.cos(th0), radius


def checks(system: System, traj: Trajectory) -> dict[str, float]:
    """Lateral force, energy; for the knife edge also the constant rates and the circle."""
    ref = closed_form_lateral_force(system, traj)
    e = traj.energy
    out = {
        "lateral force relative error": float(
            np.abs(traj.multiplier("blade") - ref).max() / np.abs(ref).max()
        ),
        "relative energy error": float(np.abs(e - e[0]).max() / abs(e[0])),
        "max velocity residual": float(traj.velocity_residual.max()),
    }
    if system.parameter_values["a"] == 0:
        u, om = forward_speed(traj), traj["theta_dot"]
        xc, yc, radius = circle_center(traj)
        dist = np.hypot(traj["x"] - xc, traj["y"] - yc)
        out["speed drift"] = float(np.abs(u - u[0]).max() / abs(u[0]))
        out["turn rate drift"] = float(np.abs(om - om[0]).max() / abs(om[0]))
        out["circle radius relative error"] = float(np.abs(dist - abs(radius)).max() / abs(radius))
    return out
