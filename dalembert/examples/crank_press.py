"""A crank press: a motor turns a slider-crank at constant speed against a press load.

The mechanism of :mod:`.slider_crank` (crank ``a``, rod ``b``, guide offset ``e``,
planar bodies) with a :class:`~dalembert.multibody.Driver` on the crank pin: the
crank angle is prescribed, ``th = th0 + omega t``, and nothing is left free (no
degree of freedom). On its forward stroke, once the piston passes ``x = X_PRESS``,
the work piece resists with a force ``F0`` (a ``Piecewise`` in the piston's position
and velocity, evaluated in C). The question the example answers is the classic one:
what torque must the motor supply? It is the driver's multiplier ``motor_1``.

Independent answer: the power balance of the minimal model. With the closed-form
kinematics of the crank angle (positions, velocities and accelerations of the link
centers, :func:`.slider_crank.rod_kinematics`),

    tau omega = dT/dt + dV/dt + F0 v_B    (while pressing),

every term from the closed form at the prescribed motion, none from the simulation.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import sympy as sp

from ..model.coordinates import t as time
from ..multibody import Driver, Force, Multibody, multibody_of
from ..system import System
from ..trajectory import Trajectory
from . import slider_crank

TITLE = "Crank press: a motor at constant speed against a press load; its torque (driver)"
THETA_0, OMEGA = 0.0, 2 * np.pi  # rad, rad/s: one turn a second
X_PRESS, F_PRESS = 3.6, 400.0  # m, N: where the work piece starts, its resistance
T_END = 2.0
draw = slider_crank.draw


def build() -> System:
    """The press (9 coordinates, 9 rows: 8 joint rows and the motor).

    >>> system = build()
    >>> len(system.coordinate_names), system.constraint_names[-1]
    (9, 'motor_1')
    """
    mb = slider_crank.build_multibody()
    piston = mb.body("piston")
    x, xd = piston.coordinates[0], piston.coordinates[0].diff(time)
    load = sp.Piecewise((-F_PRESS, (x > X_PRESS) & (xd > 0)), (0, True))
    motor = Driver("motor", mb.joint("J1"), THETA_0 + OMEGA * time)
    return Multibody(mb.bodies, [*mb.joints, motor], gravity=mb.gravity,
                     forces=[Force(piston, (load, 0, 0), name="press")],
                     name="crank press").system


INITIAL = slider_crank.initial_state(THETA_0, OMEGA)


def motor_torque(times: np.ndarray) -> np.ndarray:
    """The motor torque from the power balance of the closed-form motion (see module)."""
    a, b, _ = slider_crank.GEOMETRY
    rho, g = slider_crank.DENSITY, slider_crank.G
    th = THETA_0 + OMEGA * np.asarray(times, dtype=float)
    phi, dphi, ddphi = slider_crank.rod_kinematics(th, OMEGA, 0.0)
    u, du = np.stack([np.cos(th), np.sin(th)]), np.stack([-np.sin(th), np.cos(th)])
    w, dw = np.stack([np.cos(phi), np.sin(phi)]), np.stack([-np.sin(phi), np.cos(phi)])
    v_a, acc_a = a * OMEGA * du, -a * OMEGA**2 * u
    v_b = v_a + b * dphi * dw
    acc_b = acc_a + b * ddphi * dw - b * dphi**2 * w
    m_crank, m_rod, m_piston = rho * a, rho * b, slider_crank.PISTON_MASS
    kinetic = (m_crank * np.sum(v_a / 2 * acc_a / 2, axis=0)
               + m_rod * np.sum((v_a + v_b) / 2 * (acc_a + acc_b) / 2, axis=0)
               + rho * b**3 / 12 * dphi * ddphi + m_piston * np.sum(v_b * acc_b, axis=0))
    potential = g * (m_crank * v_a[1] / 2 + m_rod * (v_a[1] + v_b[1]) / 2 + m_piston * v_b[1])
    x_b = slider_crank.piston_position(th)
    pressing = (x_b > X_PRESS) & (v_b[0] > 0)
    return (kinetic + potential + np.where(pressing, F_PRESS * v_b[0], 0.0)) / OMEGA


def checks(system: System, traj: Trajectory) -> dict[str, float]:
    """Motor torque (power balance, away from the press's on/off instants), piston
    position (closed form), residuals."""
    torque = traj.multiplier("motor_1")
    expected = motor_torque(traj.t)
    x_b = slider_crank.piston_position(THETA_0 + OMEGA * traj.t)
    # at the instants the load switches the torque jumps: compare away from them
    switch = np.abs(np.diff((x_b > X_PRESS).astype(int), prepend=0)) > 0
    away = ~(switch | np.roll(switch, -1))
    return {
        "motor torque relative error (power balance)": float(
            np.abs(torque - expected)[away].max() / np.abs(expected).max()),
        "piston position error (closed form)": float(np.abs(traj["piston_x"] - x_b).max()),
        "max position residual": float(traj.position_residual.max()),
        "max velocity residual": float(traj.velocity_residual.max()),
    }


def plots(system: System, traj: Trajectory, out: Path) -> list[Path]:
    """``motor_torque.png``: the motor torque over the crank angle, with the closed form."""
    from matplotlib.figure import Figure

    angle = np.degrees(THETA_0 + OMEGA * traj.t)
    fig = Figure(figsize=(7.0, 4.2), dpi=100)
    ax = fig.add_subplot()
    ax.plot(angle, traj.multiplier("motor_1"), label="driver multiplier motor_1")
    ax.plot(angle, motor_torque(traj.t), "--", label="power balance (closed form)")
    ax.set_xlabel("crank angle (deg)")
    ax.set_ylabel("motor torque (N m)")
    ax.set_title(f"{multibody_of(system).name}: torque to turn at {OMEGA:.3g} rad/s")
    ax.grid(True, alpha=0.3)
    ax.legend(loc="best", fontsize="small")
    path = Path(out) / "motor_torque.png"
    fig.savefig(path)
    return [path]
