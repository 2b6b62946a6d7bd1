"""A thin uniform disk (coin) rolling without slipping on a horizontal plane.

Coordinates: the center ``x, y, z`` and the Euler angles heading ``psi`` (about the
vertical ``Z``), tilt ``theta`` (about the horizontal rolling direction
``b1 = (cos(psi), sin(psi), 0)``; ``theta = 0`` is the upright disk) and spin ``phi``
(about the disk's axis ``b2 = cos(theta) a2 + sin(theta) Z``, ``a2 = (-sin(psi),
cos(psi), 0)``). ``b3 = -sin(theta) a2 + cos(theta) Z`` points from the contact
point to the center. The Euler angles are singular only at ``theta = +-pi/2``, the
disk lying flat, which a rolling disk never reaches here.

The disk's angular velocity is ``theta_dot b1 + s b2 + psi_dot cos(theta) b3`` with
the spin component ``s = phi_dot + psi_dot sin(theta)``. Rolling (contact point at
rest) makes the center velocity ``r (s b1 - theta_dot b2)``: its vertical part is the
derivative of the holonomic contact-height constraint ``z = r cos(theta)``, its
horizontal parts are two Pfaffian (nonholonomic) constraints. In each row the
center coordinate has coefficient 1, so the multipliers are the world components of
the contact force on the disk: ``(lambda_x, lambda_y, lambda_z)``.

Steady rolling (``theta``, ``psi_dot = Omega`` and ``s`` constant) takes the center
round a horizontal circle of signed radius ``R = r s / Omega`` (its center at
``+R a2``) under a contact force ``m R Omega^2 a2 + m g Z``, and needs

    g sin(theta) + (3/2) Omega^2 R cos(theta) - (r/4) Omega^2 sin(theta) cos(theta) = 0

(derived in ``tests/examples/test_rolling_disk.py``); :func:`steady_state` solves it
for ``Omega`` and gives the gallery's initial state.
"""

from __future__ import annotations

import numpy as np
import sympy as sp

from ..model.constraints import Holonomic, Pfaffian
from ..model.coordinates import coordinates
from ..system import System
from ..trajectory import Trajectory

TITLE = "Rolling disk (coin) on a plane: two rolling constraints and the contact height"
m, g, r = sp.symbols("m g r", positive=True)
x, y, z, psi, theta, phi = coordinates("x y z psi theta phi")


def build(m_value: float = 1.0, g_value: float = 9.81, r_value: float = 0.1) -> System:
    """The rolling disk in six coordinates with three constraints.

    >>> build().degrees_of_freedom
    3
    """
    xd, yd, zd = x.diff(), y.diff(), z.diff()
    psid, thd, phid = psi.diff(), theta.diff(), phi.diff()
    spin = phid + psid * sp.sin(theta)
    # Principal moments of a thin uniform disk: diameters m r^2/4, axis m r^2/2.
    rotational = m * r**2 / 8 * (thd**2 + (psid * sp.cos(theta)) ** 2) + m * r**2 / 4 * spin**2
    roll = r * spin
    lean = r * thd * sp.cos(theta)
    return System(
        [x, y, z, psi, theta, phi],
        kinetic=m / 2 * (xd**2 + yd**2 + zd**2) + rotational,
        potential=m * g * z,
        constraints=[
            Pfaffian(xd - roll * sp.cos(psi) - lean * sp.sin(psi), name="roll_x"),
            Pfaffian(yd - roll * sp.sin(psi) + lean * sp.cos(psi), name="roll_y"),
            Holonomic(z - r * sp.cos(theta), name="contact"),
        ],
        parameters={m: m_value, g: g_value, r: r_value},
        name="rolling disk",
    )


def steady_precession(theta0: float, radius: float, g_value: float, r_value: float) -> float:
    """``Omega`` (positive) of steady rolling at tilt ``theta0`` on a center circle ``radius``.

    With ``radius = 0`` the center stays put and ``Omega^2 = 4 g / (r cos(theta))``:

    >>> omega = steady_precession(0.3, 0.0, 9.81, 0.1)
    >>> bool(np.isclose(omega**2, 4 * 9.81 / (0.1 * np.cos(0.3))))
    True
    """
    denom = np.cos(theta0) * (r_value * np.sin(theta0) / 4 - 1.5 * radius)
    omega2 = g_value * np.sin(theta0) / denom if denom != 0 else -1.0
    if not omega2 > 0:
        raise ValueError(
            "no steady rolling: the disk must lean (theta0 != 0) towards the circle's center"
        )
    return float(np.sqrt(omega2))


def steady_state(
    theta0: float = -0.3, radius: float = 0.5, g_value: float = 9.81, r_value: float = 0.1
) -> dict[str, dict[str, float]]:
    """``q0``/``qd0`` of steady rolling with the center at the origin, heading along ``x``.

    ``radius > 0`` puts the circle's center at ``(0, radius)``; the disk then leans
    left, ``theta0 < 0``.
    """
    omega = steady_precession(theta0, radius, g_value, r_value)
    spin = omega * radius / r_value
    return {
        "q0": {"x": 0.0, "y": 0.0, "z": r_value * np.cos(theta0), "psi": 0.0,
               "theta": theta0, "phi": 0.0},
        "qd0": {"x": r_value * spin, "y": 0.0, "z": 0.0, "psi": omega, "theta": 0.0,
                "phi": spin - omega * np.sin(theta0)},
    }


THETA0, RADIUS = -0.3, 0.5
INITIAL = steady_state(THETA0, RADIUS)
T_END = 5.0


def checks(system: System, traj: Trajectory) -> dict[str, float]:
    """Steady rolling from the start: tilt, precession, circle, contact force, energy.

    The steady motion is taken from the initial state (tilt, ``Omega = psi_dot``,
    ``R = r s / Omega``), so these errors are meaningful when started in steady
    rolling, as :data:`INITIAL` is.
    """
    p = system.parameter_values
    th0, om = traj["theta"][0], traj["psi_dot"][0]
    spin = traj["phi_dot"][0] + om * np.sin(th0)
    radius = p["r"] * spin / om
    t = traj.t - traj.t[0]
    psi_t = traj["psi"][0] + om * t
    # The center's circle: its center lies at +R a2 from the start.
    xc = traj["x"][0] - radius * np.sin(traj["psi"][0])
    yc = traj["y"][0] + radius * np.cos(traj["psi"][0])
    circle = np.hypot(traj["x"] - xc - radius * np.sin(psi_t),
                      traj["y"] - yc + radius * np.cos(psi_t))
    force = p["m"] * radius * om**2 * np.stack([-np.sin(psi_t), np.cos(psi_t)], axis=1)
    lam = np.stack([traj.multiplier("roll_x"), traj.multiplier("roll_y")], axis=1)
    e = traj.energy
    return {
        "steady condition residual": float(abs(
            p["g"] * np.sin(th0) + 1.5 * om**2 * radius * np.cos(th0)
            - p["r"] / 4 * om**2 * np.sin(th0) * np.cos(th0)) / p["g"]),
        "tilt drift": float(np.abs(traj["theta"] - th0).max()),
        "precession rate drift": float(np.abs(traj["psi_dot"] - om).max() / abs(om)),
        "center circle error": float(circle.max() / abs(radius)),
        "friction force relative error": float(
            np.abs(lam - force).max() / (p["m"] * abs(radius) * om**2)),
        "normal force relative error": float(
            np.abs(traj.multiplier("contact") - p["m"] * p["g"]).max() / (p["m"] * p["g"])),
        "relative energy error": float(np.abs(e - e[0]).max() / abs(e[0])),
        "max position residual": float(traj.position_residual.max()),
    }
