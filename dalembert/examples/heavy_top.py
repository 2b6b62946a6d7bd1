"""Heavy symmetric top on a fixed pivot, in steady precession.

A quaternion :class:`~dalembert.multibody.RigidBody` (mass ``m``, transverse and
axial moments ``A0``, ``C`` about its mass center) on a
:class:`~dalembert.multibody.Spherical` joint at its tip, the mass center a
distance ``l`` up the symmetry axis (body ``z``). With the axis tilted by
``theta`` from the vertical, the spin component ``w3`` along the axis and
``A = A0 + m l^2`` about the pivot, the top precesses steadily at ``Omega`` when
(the Lagrangian in Euler angles, e.g. Goldstein, sec. 5.7)

    m g l = C w3 Omega - A Omega^2 cos(theta),

a quadratic with a slow and a fast root; :data:`INITIAL` takes the slow one. The
pivot then pushes with ``m g`` up plus the centripetal ``m Omega^2 l sin(theta)``
towards the vertical, with no torque about the pivot.
"""

from __future__ import annotations

import numpy as np

from ..multibody import (
    Ground,
    Multibody,
    RigidBody,
    Spherical,
    angular_velocities,
    joint_reactions,
    multibody_of,
)
from ..multibody.rotations import elementary_rotation
from ..system import System
from ..trajectory import Trajectory

TITLE = "Heavy symmetric top on a pivot: steady precession (quaternions, ball joint)"
M, L, A0, C, G = 1.0, 0.2, 0.03, 0.04, 9.81
THETA0, SPIN = 0.5, 50.0
T_END = 3.0


def model(m: float = M, l: float = L, a0: float = A0, c: float = C, g: float = G) -> Multibody:
    """The top, its pivot at the world origin, gravity along ``-z``."""
    top = RigidBody("top", m, (a0, a0, c))
    pivot = Spherical("pivot", Ground(), top, point_b=(0.0, 0.0, -l))
    return Multibody([top], [pivot], gravity=(0.0, 0.0, -g), name="heavy top")


def build(m: float = M, l: float = L, a0: float = A0, c: float = C, g: float = G) -> System:
    """The top as a System: 7 coordinates, 1 + 3 constraints.

    >>> build().degrees_of_freedom
    3
    """
    return model(m, l, a0, c, g).system


def precession_rates(theta: float = THETA0, spin: float = SPIN, m: float = M, l: float = L,
                     a0: float = A0, c: float = C, g: float = G) -> tuple[float, float]:
    """Slow and fast roots ``Omega`` of the steady-precession condition.

    >>> slow, fast = precession_rates()
    >>> bool(np.isclose(slow, M * G * L / (C * SPIN), rtol=0.05))   # the gyroscopic limit
    True
    """
    a = (a0 + m * l**2) * np.cos(theta)
    disc = np.sqrt((c * spin) ** 2 - 4 * a * m * g * l)
    return (c * spin - disc) / (2 * a), (c * spin + disc) / (2 * a)


def steady_state(theta: float = THETA0, spin: float = SPIN,
                 omega: float | None = None) -> dict[str, dict[str, float]]:
    """Tilted about world ``y`` by ``theta`` and precessing at ``omega`` about world ``z``."""
    omega = precession_rates(theta, spin)[0] if omega is None else omega
    R = elementary_rotation("y", theta)
    k = R[:, 2]
    w = np.array([0.0, 0.0, omega]) + (spin - omega * np.cos(theta)) * k
    x = L * k
    q0, qd0 = model().initial_state(positions={"top": x}, orientations={"top": R},
                                    velocities={"top": np.cross(w, x)},
                                    angular_velocities={"top": w})
    return {"q0": q0, "qd0": qd0}


INITIAL = steady_state()


def draw(system: System, q: np.ndarray) -> list[np.ndarray]:
    """Pivot -> mass center line and the top's axes, which show its spin (3D polylines)."""
    return multibody_of(system).stick_figure(q, body_axes=True)


def checks(system: System, traj: Trajectory) -> dict[str, float]:
    """Steady precession from the initial state: tilt, rate, condition, pivot force, energy."""
    mb = multibody_of(system)
    top, pivot = mb.bodies[0], mb.joints[0]
    assert isinstance(top, RigidBody)  # as model() builds it
    m, l, g = top.mass, -pivot.point_b[2], -mb.gravity[2]
    a0, c = top.inertia[0, 0], top.inertia[2, 2]
    x = np.column_stack([traj["top_x"], traj["top_y"], traj["top_z"]])
    tilt = np.arccos(np.clip(x[:, 2] / l, -1.0, 1.0))
    azimuth = np.unwrap(np.arctan2(x[:, 1], x[:, 0]))
    h = np.hypot(x[0, 0], x[0, 1])
    omega = (x[0, 0] * traj["top_y_dot"][0] - x[0, 1] * traj["top_x_dot"][0]) / h**2
    spin = float(angular_velocities(mb, traj, top, "body")[0, 2])
    th = tilt[0]
    t = traj.t - traj.t[0]
    f_ref = np.column_stack([-m * omega**2 * h * np.cos(azimuth[0] + omega * t),
                             -m * omega**2 * h * np.sin(azimuth[0] + omega * t),
                             np.full(len(t), m * g)])
    force = joint_reactions(mb, traj)["pivot"]["top"].force_world
    e = traj.energy
    return {
        "steady condition residual": float(abs(
            m * g * l - c * spin * omega + (a0 + m * l**2) * omega**2 * np.cos(th)) / (m * g * l)),
        "tilt drift": float(np.abs(tilt - th).max()),
        "precession angle error": float(np.abs(azimuth - azimuth[0] - omega * t).max()),
        "pivot force relative error": float(np.abs(force - f_ref).max() / (m * g)),
        "relative energy error": float(np.abs(e - e[0]).max() / abs(e[0])),
        "max position residual": float(traj.position_residual.max()),
    }
