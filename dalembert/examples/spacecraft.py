"""A spacecraft slewed by a PD attitude controller written as a Python function.

A rigid body in Euler parameters (no gravity) with three body-frame torques ``u1, u2,
u3`` declared as inputs; the controller, an ordinary Python function of the state,
computes them from the attitude error (the quaternion's vector part, the target the
identity) and the body rates:

    tau = -KP sign(b0) (b1, b2, b3) - KD omega,       omega = 2 E(b) b_dot (body).

The C loop calls it at every evaluation. The attitude converges to the target.

Independent answers:

- Lyapunov: ``W = 1/2 omega . I omega + 2 KP (1 - |b0|)`` decreases at the rate
  ``dW/dt = -KD |omega|^2`` along the closed loop (a short computation with the
  rotational equations), so ``W(t) - W(0) = -KD int |omega|^2 dt``: the integral by
  Simpson's rule on the recorded rates;
- angular momentum: ``H(t) - H(0) = int tau_world dt``, the applied torques (recorded)
  turned to the world frame and integrated, against the momentum from the motion
  (:func:`~dalembert.multibody.angular_momentum`).
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import numpy as np
import sympy as sp
from scipy.integrate import simpson

from ..multibody import Multibody, RigidBody, Torque, angular_momentum, multibody_of
from ..multibody.rotations import E_matrix, rotation_matrix
from ..system import System
from ..trajectory import Trajectory

TITLE = "Spacecraft slewed by a PD attitude controller given as a Python function (inputs)"
MASS, INERTIA = 100.0, (20.0, 30.0, 25.0)  # kg, kg m^2 (principal, body frame)
KP, KD = 5.0, 15.0
TORQUES = sp.symbols("u1 u2 u3")
T_END = 30.0
#: Start: turned 90 degrees about (1, 1, 0) / sqrt(2), tumbling slowly.
_AXIS = np.array([1.0, 1.0, 0.0]) / np.sqrt(2.0)
_B0 = np.concatenate([[np.cos(np.pi / 4)], np.sin(np.pi / 4) * _AXIS])
_OMEGA0 = np.array([0.05, -0.02, 0.03])


def build() -> System:
    """The spacecraft: 7 coordinates (center, Euler parameters), 3 torque inputs.

    >>> system = build()
    >>> [u.name for u in system.inputs], system.constraint_names
    (['u1', 'u2', 'u3'], ('craft_unit_quaternion',))
    """
    craft = RigidBody("craft", MASS, INERTIA)
    torque = Torque(craft, TORQUES, frame="body", name="actuators")
    return Multibody([craft], torques=[torque], gravity=(0, 0, 0), inputs=list(TORQUES),
                     name="spacecraft").system


def _omega(b: np.ndarray, bd: np.ndarray) -> np.ndarray:
    """Body rates ``2 E(b) b_dot`` (rows of ``b``, ``bd``)."""
    b, bd = np.atleast_2d(b), np.atleast_2d(bd)
    return 2 * np.einsum("kij,kj->ki", E_matrix(b), bd)


def pd_controller(kp: float, kd: float) -> Callable[[float, np.ndarray, np.ndarray], np.ndarray]:
    """The PD law with gains ``kp``, ``kd``: ``u(t, q, qd)``, the body torques from the
    attitude error and the body rates (coordinates in the order of :func:`build`:
    ``x, y, z, b0, b1, b2, b3``).

    Parameters
    ----------
    kp, kd
        The proportional and derivative gains.

    Examples
    --------
    >>> u = pd_controller(2.0, 1.0)
    >>> u(0.0, np.array([0, 0, 0, 0.6, 0.8, 0, 0]), np.zeros(7)).tolist()
    [-1.6, -0.0, -0.0]
    """

    def controller(t: float, q: np.ndarray, qd: np.ndarray) -> np.ndarray:
        b, bd = q[3:7], qd[3:7]
        return -kp * np.sign(b[0]) * b[1:] - kd * _omega(b, bd)[0]

    return controller


#: The PD law at the example's gains.
controller = pd_controller(KP, KD)


def _initial_rates() -> np.ndarray:
    """``b_dot = 1/2 E(b)^T omega`` for the initial body rates."""
    return 0.5 * E_matrix(_B0).T @ _OMEGA0


_EULER = ("craft_b0", "craft_b1", "craft_b2", "craft_b3")
#: ``simulate``'s keywords: the start and the controller.
INITIAL = {"q0": dict(zip(_EULER, _B0)), "qd0": dict(zip(_EULER, _initial_rates())),
           "inputs": controller}


def lyapunov(traj: Trajectory) -> np.ndarray:
    """``W = 1/2 omega . I omega + 2 KP (1 - |b0|)`` at each time."""
    b = np.column_stack([traj[f"craft_b{k}"] for k in range(4)])
    bd = np.column_stack([traj[f"craft_b{k}_dot"] for k in range(4)])
    w = _omega(b, bd)
    return 0.5 * np.einsum("ki,i,ki->k", w, INERTIA, w) + 2 * KP * (1 - np.abs(b[:, 0]))


def checks(system: System, traj: Trajectory) -> dict[str, float]:
    """Lyapunov decrease and momentum balance (quadratures of the recorded values),
    the final attitude error, residuals."""
    b = np.column_stack([traj[f"craft_b{k}"] for k in range(4)])
    bd = np.column_stack([traj[f"craft_b{k}_dot"] for k in range(4)])
    w = _omega(b, bd)
    W = lyapunov(traj)
    dissipated = KD * simpson(np.sum(w**2, axis=1), x=traj.t)
    torque_world = np.einsum("kij,kj->ki", rotation_matrix(b), traj.inputs)
    impulse = simpson(torque_world, x=traj.t, axis=0)
    H = angular_momentum(multibody_of(system), traj)
    return {
        "Lyapunov decrease relative error (dW = -KD int |w|^2)": float(
            abs((W[-1] - W[0]) + dissipated) / W[0]),
        "angular momentum change relative error (int tau dt)": float(
            np.abs(H[-1] - H[0] - impulse).max() / np.abs(impulse).max()),
        "final attitude error (rad)": float(2 * np.arccos(min(1.0, abs(b[-1, 0])))),
        "max position residual": float(traj.position_residual.max()),
    }


def plots(system: System, traj: Trajectory, out: Path) -> list[Path]:
    """``attitude.png``: the attitude error angle and the controller's torques."""
    from matplotlib.figure import Figure

    b0 = np.clip(np.abs(traj["craft_b0"]), 0.0, 1.0)
    fig = Figure(figsize=(7.0, 6.0), dpi=100)
    top, bottom = fig.subplots(2, 1, sharex=True)
    top.plot(traj.t, np.degrees(2 * np.arccos(b0)))
    top.set_ylabel("attitude error (deg)")
    top.set_title("spacecraft slew: PD controller as a Python function")
    for k, name in enumerate(traj.input_names):
        bottom.plot(traj.t, traj.inputs[:, k], label=name)
    bottom.set_xlabel("t (s)")
    bottom.set_ylabel("body torque (N m)")
    bottom.legend(loc="best", fontsize="small")
    for ax in (top, bottom):
        ax.grid(True, alpha=0.3)
    path = Path(out) / "attitude.png"
    fig.savefig(path)
    return [path]
