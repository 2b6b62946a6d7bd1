"""A cart-pole balanced upright by a digital LQR designed from ``linearize``.

A cart (:class:`PlanarBody` on the ``Prismatic`` joint ``rail`` along ``x``) carries a
uniform pole on the hinge ``hinge``; a force ``u`` pushes the cart (an ``Actuator`` on
the rail, the model's input). Upright, the pole is an unstable equilibrium.

The controller is designed in joint coordinates, the rail's travel and the hinge's
angle, from the model itself:
:func:`~dalembert.multibody.linearize_joints` gives ``x' = A x + B u`` about the upright
pose with ``x = (rail, hinge, rail_dot, hinge_dot)``; ``scipy.signal.cont2discrete``
holds ``u`` over each sample (zero-order hold, ``SAMPLE_TIME``), and the discrete
algebraic Riccati equation (``scipy.linalg.solve_discrete_are``) gives the gain ``K``.
The controller reads the joint coordinates with
:func:`~dalembert.multibody.joint_positions` / :func:`~dalembert.multibody.joint_velocities`
and applies ``u = -K x``, held by ``simulate(sample_time=SAMPLE_TIME)`` as a digital
controller's output is. From a ``TILT_0`` tilt the pole returns upright.

Independent answers (the tests): ``A`` and ``B`` against the linearized cart-pole
derived in its two minimal coordinates with SymPy; near upright, the simulated samples
against the linear discrete model's prediction ``x_k = (Ad - Bd K)^k x_0``.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cache

import numpy as np
import scipy.linalg
import scipy.signal
import sympy as sp

from ..multibody import (
    Actuator,
    Ground,
    Multibody,
    PlanarBody,
    Prismatic,
    Revolute,
    joint_positions,
    joint_velocities,
    linearize_joints,
    multibody_of,
)
from ..system import System
from ..trajectory import Trajectory

TITLE = "Cart-pole balanced by a digital LQR designed from linearize (sample_time, inputs)"
CART_MASS, POLE_MASS, POLE_LENGTH = 1.0, 0.5, 1.0  # kg, kg, m (a uniform pole)
G = 9.81
SAMPLE_TIME = 0.02  # s: the controller's period
#: LQR weights on (rail, hinge, rail_dot, hinge_dot) and on the force.
STATE_WEIGHTS, FORCE_WEIGHT = (1.0, 10.0, 0.1, 0.1), 0.1
TILT_0 = 0.2  # rad: the initial tilt of the pole
T_END = 6.0
FORCE = sp.Symbol("u")
JOINTS = ("rail", "hinge")


def build_multibody() -> Multibody:
    """The cart on its rail and the pole on its hinge (upright at angle 0).

    >>> mb = build_multibody()
    >>> mb.system.degrees_of_freedom, [u.name for u in mb.inputs]
    (2, ['u'])
    """
    cart = PlanarBody("cart", CART_MASS, 0.1)  # the rail keeps it from turning
    pole = PlanarBody("pole", POLE_MASS, POLE_MASS * POLE_LENGTH**2 / 12)
    rail = Prismatic("rail", Ground(), cart, axis_a=(1, 0, 0))
    hinge = Revolute("hinge", cart, pole, (0, 0, 0), (0, -POLE_LENGTH / 2, 0))
    return Multibody([cart, pole], [rail, hinge], gravity=(0.0, -G, 0.0),
                     actuators=[Actuator("push", rail, FORCE)], inputs=[FORCE],
                     name="cart-pole")


def build() -> System:
    """The cart-pole's ``System`` (6 coordinates, 4 constraints, the input ``u``).

    >>> len(build().coordinate_names)
    6
    """
    return build_multibody().system


def tilted(angle: float) -> dict[str, float]:
    """The configuration with the cart at 0 and the pole tilted by ``angle`` (rad,
    counterclockwise from upright).

    >>> tilted(0.0)["pole_y"]
    0.5
    """
    half = POLE_LENGTH / 2
    return {"pole_x": -half * float(np.sin(angle)), "pole_y": half * float(np.cos(angle)),
            "pole_theta": float(angle)}


UPRIGHT = tilted(0.0)


@dataclass(frozen=True)
class Design:
    """The digital LQR: the continuous and discrete models, the gain, the closed loop."""

    A: np.ndarray
    B: np.ndarray
    Ad: np.ndarray
    Bd: np.ndarray
    K: np.ndarray
    state_names: tuple[str, ...]

    @property
    def closed_loop(self) -> np.ndarray:
        """``Ad - Bd K``: one sample of the controlled linear model."""
        return self.Ad - self.Bd @ self.K


def design(mb: Multibody, sample_time: float = SAMPLE_TIME) -> Design:
    """The LQR designed from ``mb``'s linearization about the upright pose.

    >>> d = design(build_multibody())
    >>> d.state_names, bool(np.abs(np.linalg.eigvals(d.closed_loop)).max() < 1)
    (('rail', 'hinge', 'rail_dot', 'hinge_dot'), True)
    """
    ss = linearize_joints(mb, UPRIGHT, JOINTS)
    n, p = ss.B.shape
    Ad, Bd, *_ = scipy.signal.cont2discrete((ss.A, ss.B, np.eye(n), np.zeros((n, p))),
                                            sample_time, method="zoh")
    Q, R = np.diag(STATE_WEIGHTS), FORCE_WEIGHT * np.eye(p)
    P = scipy.linalg.solve_discrete_are(Ad, Bd, Q, R)
    K = np.linalg.solve(R + Bd.T @ P @ Bd, Bd.T @ P @ Ad)
    return Design(ss.A, ss.B, Ad, Bd, K, ss.state_names)


def joint_state(mb: Multibody, q: np.ndarray, qd: np.ndarray) -> np.ndarray:
    """``(rail, hinge, rail_dot, hinge_dot)`` at one state (the design's state).

    >>> mb = build_multibody()
    >>> q = [0.3, 0.0, 0.0, *tilted(0.1).values()]
    >>> joint_state(mb, np.array(q), np.zeros(6)).round(12).tolist()
    [0.3, 0.1, 0.0, 0.0]
    """
    return np.concatenate([joint_positions(mb, q, joints=JOINTS).array,
                           joint_velocities(mb, q, qd, joints=JOINTS).array])


@cache
def _designed() -> tuple[Multibody, Design]:
    mb = build_multibody()
    return mb, design(mb)


def controller(t: float, q: np.ndarray, qd: np.ndarray) -> float:
    """The digital LQR's force ``u = -K x`` from the joint coordinates (designed on the
    first call).

    >>> controller(0.0, np.array([0.0, 0.0, 0.0, *UPRIGHT.values()]), np.zeros(6))
    0.0
    """
    mb, d = _designed()
    return float(-(d.K @ joint_state(mb, q, qd))[0]) + 0.0


#: ``simulate``'s keywords: the tilted start, the controller and its period.
INITIAL = {"q0": tilted(TILT_0), "qd0": {}, "inputs": controller, "sample_time": SAMPLE_TIME}


def checks(system: System, traj: Trajectory) -> dict[str, float]:
    """The final tilt and cart travel, the closed loop's spectral radius, residuals."""
    angles = joint_positions(multibody_of(system), traj, joints=JOINTS)
    return {
        "final pole tilt (rad)": float(abs(angles["hinge"][-1])),
        "final cart position (m)": float(abs(angles["rail"][-1])),
        "closed-loop spectral radius (discrete, < 1)": float(
            np.abs(np.linalg.eigvals(_designed()[1].closed_loop)).max()),
        "max position residual": float(traj.position_residual.max()),
        "max velocity residual": float(traj.velocity_residual.max()),
    }
