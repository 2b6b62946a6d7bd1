"""A bead on a hoop of radius ``R`` spinning at the constant rate ``Omega`` about the vertical.

Rheonomic: the bead's Cartesian ``x, y, z`` (``z`` up, hoop centre at the origin)
are held by two constraints that involve time, the hoop's rotating plane
``-sin(Omega t) x + cos(Omega t) y = 0`` and its circle ``x^2 + y^2 + z^2 = R^2``.
One degree of freedom, the angle ``phi`` from the bottom, with the minimal equation
``phi'' = (Omega^2 cos(phi) - g / R) sin(phi)``.

The hoop drives the bead, so the energy ``T + V`` is not conserved: the plane's
constraint force does work. In these inertial coordinates ``L = T - V`` has no
explicit time, so ``traj.jacobi_integral`` (``qd . dL/dqd - L``) equals ``T + V``
and is not conserved either. The conserved quantity is the Jacobi integral of the
minimal description, ``h = m R^2 phi'^2 / 2 - m Omega^2 R^2 sin(phi)^2 / 2 -
m g R cos(phi)``, which in Cartesian terms is the rotating-frame energy
``T + V - Omega L_z`` with ``L_z = m (x y' - y x')``.

The multipliers are the hoop's reactions. The plane's force ``lambda_plane
(-sin(Omega t), cos(Omega t), 0)`` is all the azimuthal force, so ``lambda_plane =
2 m Omega rho'`` (Coriolis; ``rho`` the signed distance from the axis). The circle's
force ``2 lambda_hoop r`` is the inward normal force ``N = -2 lambda_hoop R =
m |v_rel|^2 / R - m g z / R + m Omega^2 rho^2 / R`` (radial balance in the rotating
frame; ``v_rel`` the velocity relative to the hoop).
"""

from __future__ import annotations

import numpy as np
import sympy as sp

from ..model.constraints import Holonomic
from ..model.coordinates import coordinates, t
from ..system import System
from ..trajectory import Trajectory

TITLE = "Bead on a hoop spinning about the vertical (rheonomic constraints)"
m, g, R, Omega = sp.symbols("m g R Omega", positive=True)
x, y, z = coordinates("x y z")

#: Initial angle from the bottom and its rate; with Omega^2 R > g the bottom is unstable.
PHI0, PHI_DOT0 = 0.3, 0.0
OMEGA = 4.0


def cartesian_state(
    phi: float, phi_dot: float, time: float = 0.0, R_value: float = 1.0, Omega_value: float = OMEGA
) -> tuple[np.ndarray, np.ndarray]:
    """Position and velocity of the bead at angle ``phi`` on the hoop at time ``time``.

    >>> q, qd = cartesian_state(0.0, 0.0)
    >>> q.tolist(), qd.tolist()
    ([0.0, 0.0, -1.0], [0.0, 0.0, 0.0])
    """
    a = Omega_value * time
    rho, rho_dot = R_value * np.sin(phi), R_value * np.cos(phi) * phi_dot
    q = np.array([rho * np.cos(a), rho * np.sin(a), -R_value * np.cos(phi)])
    qd = np.array([
        rho_dot * np.cos(a) - Omega_value * rho * np.sin(a),
        rho_dot * np.sin(a) + Omega_value * rho * np.cos(a),
        R_value * np.sin(phi) * phi_dot,
    ])
    return q, qd


_Q0, _QD0 = cartesian_state(PHI0, PHI_DOT0)
INITIAL = {"q0": dict(zip("xyz", _Q0)), "qd0": dict(zip("xyz", _QD0))}
T_END = 10.0


def build(
    m_value: float = 1.0, g_value: float = 9.81, R_value: float = 1.0, Omega_value: float = OMEGA
) -> System:
    """The bead on the spinning hoop (hoop in the ``x, z`` plane at ``t = 0``).

    >>> build().degrees_of_freedom
    1
    """
    return System(
        [x, y, z],
        kinetic=m / 2 * (x.diff() ** 2 + y.diff() ** 2 + z.diff() ** 2),
        potential=m * g * z,
        constraints=[
            Holonomic(-sp.sin(Omega * t) * x + sp.cos(Omega * t) * y, name="plane"),
            Holonomic(x**2 + y**2 + z**2 - R**2, name="hoop"),
        ],
        parameters={m: m_value, g: g_value, R: R_value, Omega: Omega_value},
        name="bead on a spinning hoop",
    )


def rotating_frame_energy(system: System, traj: Trajectory) -> np.ndarray:
    """``T + V - Omega L_z``: the conserved Jacobi integral of the minimal description."""
    p = system.parameter_values
    lz = p["m"] * (traj["x"] * traj["y_dot"] - traj["y"] * traj["x_dot"])
    return traj.energy - p["Omega"] * lz


def _frame(system: System, traj: Trajectory) -> tuple[dict[str, float], np.ndarray, np.ndarray]:
    """Parameter values, ``rho`` and ``rho'`` (``rho`` along the hoop's in-plane horizontal)."""
    p = system.parameter_values
    a = p["Omega"] * traj.t
    rho = traj["x"] * np.cos(a) + traj["y"] * np.sin(a)
    # d/dt of rho; the term Omega (-x sin + y cos) vanishes on the plane constraint
    rho_dot = traj["x_dot"] * np.cos(a) + traj["y_dot"] * np.sin(a)
    return p, rho, rho_dot


def closed_form_plane_multiplier(system: System, traj: Trajectory) -> np.ndarray:
    """``lambda_plane = 2 m Omega rho'``: the azimuthal (Coriolis) force the hoop exerts."""
    p, _, rho_dot = _frame(system, traj)
    return 2.0 * p["m"] * p["Omega"] * rho_dot


def normal_force(system: System, traj: Trajectory) -> np.ndarray:
    """Inward normal force of the hoop from the multiplier, ``-2 lambda_hoop R``."""
    return -2.0 * traj.multiplier("hoop") * system.parameter_values["R"]


def closed_form_normal_force(system: System, traj: Trajectory) -> np.ndarray:
    """``m |v_rel|^2 / R - m g z / R + m Omega^2 rho^2 / R`` (rotating-frame radial balance)."""
    p, rho, _ = _frame(system, traj)
    w = p["Omega"]
    v_rel2 = ((traj["x_dot"] + w * traj["y"]) ** 2 + (traj["y_dot"] - w * traj["x"]) ** 2
              + traj["z_dot"] ** 2)
    return p["m"] / p["R"] * (v_rel2 - p["g"] * traj["z"] + w**2 * rho**2)


def _relative_error(value: np.ndarray, ref: np.ndarray) -> float:
    return float(np.abs(value - ref).max() / np.abs(ref).max())


def checks(system: System, traj: Trajectory) -> dict[str, float]:
    """Jacobi integral, reactions against closed forms, energy variation, residuals."""
    h, e = rotating_frame_energy(system, traj), traj.energy
    scale = system.parameter_values["m"] * system.parameter_values["g"] * \
        system.parameter_values["R"]
    return {
        "plane reaction relative error": _relative_error(
            traj.multiplier("plane"), closed_form_plane_multiplier(system, traj)
        ),
        "normal force relative error": _relative_error(
            normal_force(system, traj), closed_form_normal_force(system, traj)
        ),
        "relative Jacobi integral error": float(np.abs(h - h[0]).max() / scale),
        "relative energy variation (driven, not conserved)": float(
            np.abs(e - e[0]).max() / scale
        ),
        "max position residual": float(traj.position_residual.max()),
        "max velocity residual": float(traj.velocity_residual.max()),
    }
