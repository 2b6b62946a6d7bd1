"""Planar four-bar linkage built from 3D rigid bodies and revolute joints.

Ground pivots ``O2 = (0, 0, 0)`` and ``O4 = (d, 0, 0)``, crank ``O2 A`` (length
``a``), coupler ``A B`` (``b``) and rocker ``O4 B`` (``c``) move in the ``x, z``
plane (gravity ``-z``), hinged about ``y`` by four :class:`Revolute` joints
``J1`` (ground-crank), ``J2`` (crank-coupler), ``J3`` (coupler-rocker) and ``J4``
(rocker-ground). 3 rigid bodies give 21 coordinates; 3 unit-quaternion rows and
4 x 5 joint equations give 23 constraints, yet the mechanism has 1 degree of
freedom: the loop's three out-of-plane motions (``y`` translation, rotations about
``x`` and ``z``) are each blocked four times. Once ``J1..J3`` fix them, the
out-of-plane rows of ``J4`` (``J4_2``: ``d_y = 0``; ``J4_4, J4_5``: axes parallel)
are combinations of earlier rows, so ``rank(A) = 20`` (Exudyn stops here with
"System Jacobian seems to be singular"). dalembert names them, warns and proceeds
with the minimum-norm multipliers.

Link angles ``theta_k`` are measured from ``+x`` towards ``+z``. The position
relation is Freudenstein's equation (from ``|b e3|^2 = |d + c e4 - a e2|^2``)::

    K1 cos(th4) - K2 cos(th2) + K3 = cos(th2 - th4),
    K1 = d / a,  K2 = d / c,  K3 = (a^2 - b^2 + c^2 + d^2) / (2 a c).

The default links (``a, b, c, d = 1, 3, 2.5, 3``) satisfy Grashof's condition
with the crank shortest: the crank turns all the way round.
"""

from __future__ import annotations

import numpy as np

from ..multibody.bodies import Ground, RigidBody
from ..multibody.builder import Multibody
from ..multibody.joints import Revolute
from ..multibody.rotations import rotation_matrix
from ..system import System
from ..trajectory import Trajectory

TITLE = "Planar four-bar linkage from 3D revolute joints (3 redundant constraints)"
#: Link lengths ``(a, b, c, d)``: crank, coupler, rocker, ground.
Lengths = tuple[float, float, float, float]
LENGTHS: Lengths = (1.0, 3.0, 2.5, 3.0)  # crank a, coupler b, rocker c, ground d
LINKS = ("crank", "coupler", "rocker")
DENSITY, RADIUS = 1.0, 0.02  # kg/m of each link, link radius (m)
THETA2_0, OMEGA2_0 = np.pi / 3, 6.0  # initial crank angle (rad) and rate (rad/s)
T_END = 10.0
#: Rows of J4 that the earlier joints make dependent (see the module docstring).
DEPENDENT = ("J4_2", "J4_4", "J4_5")


def freudenstein(theta2: float | np.ndarray, lengths: Lengths = LENGTHS,
                 branch: int = 1) -> float | np.ndarray:
    """Rocker angle ``th4`` from the crank angle (closed form; ``branch`` = +-1).

    ``P cos(th4) + Q sin(th4) + R = 0`` with ``P = K1 - cos th2``, ``Q = -sin th2``,
    ``R = K3 - K2 cos th2``, so ``th4 = atan2(Q, P) + branch acos(-R / |(P, Q)|)``.

    >>> a, b, c, d = LENGTHS
    >>> th2 = 0.7; th4 = freudenstein(th2)
    >>> e = np.exp(1j * th4) * c + d - a * np.exp(1j * th2)  # coupler vector b e3
    >>> bool(abs(abs(e) - b) < 1e-12)
    True
    """
    a, b, c, d = lengths
    k1, k2, k3 = d / a, d / c, (a**2 - b**2 + c**2 + d**2) / (2 * a * c)
    p, q, r = k1 - np.cos(theta2), -np.sin(theta2), k3 - k2 * np.cos(theta2)
    return np.arctan2(q, p) + branch * np.arccos(-r / np.hypot(p, q))


def link_angles(theta2: float, lengths: Lengths = LENGTHS) -> tuple[float, float, float]:
    """``(th2, th3, th4)`` of the open assembly (``B`` above the ground line)."""
    a, _, c, d = lengths
    th4 = float(freudenstein(theta2, lengths))
    th3 = np.arctan2(c * np.sin(th4) - a * np.sin(theta2),
                     d + c * np.cos(th4) - a * np.cos(theta2))
    return theta2, float(th3), th4


def link_rates(angles: tuple[float, float, float], omega2: float,
               lengths: Lengths = LENGTHS) -> tuple[float, float, float]:
    """``(w2, w3, w4)`` from the loop's velocity relation ``a w2 i e2 + b w3 i e3 = c w4 i e4``."""
    a, b, c, _ = lengths
    th2, th3, th4 = angles
    lhs = np.array([[-b * np.sin(th3), c * np.sin(th4)], [b * np.cos(th3), -c * np.cos(th4)]])
    rhs = np.array([a * omega2 * np.sin(th2), -a * omega2 * np.cos(th2)])
    w3, w4 = np.linalg.solve(lhs, rhs)
    return omega2, float(w3), float(w4)


def _about_y(phi: float) -> np.ndarray:
    """Rotation taking body ``x`` to ``(cos phi, 0, sin phi)`` (about ``-y`` by ``phi``)."""
    c, s = np.cos(phi), np.sin(phi)
    return np.array([[c, 0.0, -s], [0.0, 1.0, 0.0], [s, 0.0, c]])


def build_multibody(lengths: Lengths = LENGTHS, gravity: float = 9.81) -> Multibody:
    """The linkage as a ``Multibody``; each link a uniform rod along its body ``x``."""
    a, b, c, d = lengths
    bodies = []
    for name, length in zip(LINKS, (a, b, c)):
        mass = DENSITY * length
        axial, transverse = mass * RADIUS**2 / 2, mass * (3 * RADIUS**2 + length**2) / 12
        bodies.append(RigidBody(name, mass, (axial, transverse, transverse)))
    crank, coupler, rocker = bodies
    ground, y = Ground(), (0.0, 1.0, 0.0)
    joints = [
        Revolute("J1", ground, crank, (0, 0, 0), (-a / 2, 0, 0), axis_a=y),
        Revolute("J2", crank, coupler, (a / 2, 0, 0), (-b / 2, 0, 0), axis_a=y),
        Revolute("J3", coupler, rocker, (b / 2, 0, 0), (c / 2, 0, 0), axis_a=y),
        Revolute("J4", rocker, ground, (-c / 2, 0, 0), (d, 0, 0), axis_a=y),
    ]
    return Multibody(bodies, joints, gravity=(0.0, 0.0, -gravity), name="four-bar")


def build(lengths: Lengths = LENGTHS, gravity: float = 9.81) -> System:
    """The linkage's ``System`` (21 coordinates, 23 constraints, 1 degree of freedom).

    >>> system = build()
    >>> len(system.coordinate_names), len(system.constraint_names)
    (21, 23)
    """
    return build_multibody(lengths, gravity).system


def initial_state(
    theta2: float = THETA2_0, omega2: float = OMEGA2_0, lengths: Lengths = LENGTHS
) -> dict[str, dict[str, float]]:
    """Consistent ``q0``/``qd0`` from the closed-form position and velocity analysis."""
    a, b, c, d = lengths
    angles = link_angles(theta2, lengths)
    rates = link_rates(angles, omega2, lengths)
    e = [np.array([np.cos(p), 0.0, np.sin(p)]) for p in angles]
    de = [w * np.array([-np.sin(p), 0.0, np.cos(p)]) for p, w in zip(angles, rates)]
    centers = [a / 2 * e[0], a * e[0] + b / 2 * e[1], np.array([d, 0, 0]) + c / 2 * e[2]]
    velocities = [a / 2 * de[0], a * de[0] + b / 2 * de[1], c / 2 * de[2]]
    mb = build_multibody(lengths)
    q0, qd0 = mb.initial_state(
        positions=dict(zip(LINKS, centers)), velocities=dict(zip(LINKS, velocities)),
        orientations={k: _about_y(p) for k, p in zip(LINKS, angles)},
        angular_velocities={k: (0.0, -w, 0.0) for k, w in zip(LINKS, rates)},
    )
    return {"q0": q0, "qd0": qd0}


INITIAL = initial_state()


def angle(traj: Trajectory, link: str) -> np.ndarray:
    """A link's angle from ``+x`` towards ``+z`` along the trajectory (from its quaternion)."""
    b = np.column_stack([traj[f"{link}_b{k}"] for k in range(4)])
    R = rotation_matrix(b)
    return np.arctan2(R[:, 2, 0], R[:, 0, 0])


def freudenstein_error(traj: Trajectory) -> float:
    """Largest ``|th4 - th4(th2)|`` (wrapped) over the output times."""
    diff = angle(traj, "rocker") - freudenstein(angle(traj, "crank"))
    return float(np.abs(np.angle(np.exp(1j * diff))).max())


def checks(system: System, traj: Trajectory) -> dict[str, float]:
    """Freudenstein's relation, energy, constraint residuals."""
    e = traj.energy
    return {
        "Freudenstein output-angle error": freudenstein_error(traj),
        "relative energy error": float(np.abs(e - e[0]).max() / abs(e[0])),
        "max position residual": float(traj.position_residual.max()),
        "max velocity residual": float(traj.velocity_residual.max()),
    }
