"""Offset slider-crank built from planar bodies: crank, connecting rod and piston.

The crank ``O A`` (length ``a``, a uniform rod) turns about the ground pivot
``O = (0, 0)``; the connecting rod ``A B`` (``b``, uniform) carries the piston at
``B``, which slides along the guide ``y = e`` (an offset ``e`` makes the
mechanism asymmetric). Gravity is ``-y``; nothing drives the crank, so the
mechanism is free and conservative. Three :class:`PlanarBody` links (``crank``,
``rod``, ``piston``) give 9 coordinates; the pins ``J1`` (ground-crank), ``J2``
(crank-rod), ``J3`` (rod-piston) and the ``Prismatic`` ``guide`` (ground-piston)
give 4 x 2 = 8 independent rows: 1 degree of freedom.

Link angles are counterclockwise from ``+x``: the crank's ``th``, the rod's ``phi``
with ``B - A = b (cos phi, sin phi)``. The position relation, in closed form::

    sin(phi) = (e - a sin th) / b,    x_B = a cos th + sqrt(b^2 - (a sin th - e)^2),

and the crank turns all the way round when ``b > a + |e|``.
"""

from __future__ import annotations

import numpy as np

from ..multibody import (
    Ground,
    Multibody,
    PlanarBody,
    Prismatic,
    Revolute,
    joint_reactions,
    multibody_of,
)
from ..system import System
from ..trajectory import Trajectory

TITLE = "Offset slider-crank from planar bodies: crank, connecting rod and piston on a guide"
#: ``(a, b, e)``: crank and rod lengths, guide offset.
Geometry = tuple[float, float, float]
GEOMETRY: Geometry = (1.0, 3.0, 0.25)  # crank a, rod b, guide offset e (m)
LINKS = ("crank", "rod")
DENSITY = 1.0  # kg/m of each link (uniform slender rods)
PISTON_MASS, PISTON_INERTIA = 2.0, 0.01  # kg, kg m^2 (the piston does not turn)
THETA_0, OMEGA_0 = np.pi / 3, 6.0  # initial crank angle (rad) and rate (rad/s)
G = 9.81
T_END = 10.0


def piston_position(theta: float | np.ndarray, geometry: Geometry = GEOMETRY) -> np.ndarray:
    """``x_B`` from the crank angle (closed form).

    >>> float(piston_position(0.0, (1.0, 3.0, 0.0)))
    4.0
    """
    a, b, e = geometry
    return a * np.cos(theta) + np.sqrt(b**2 - (a * np.sin(theta) - e) ** 2)


def rod_kinematics(theta: float | np.ndarray, omega: float | np.ndarray,
                   alpha: float | np.ndarray,
                   geometry: Geometry = GEOMETRY) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The rod's ``(phi, phi', phi'')`` from the crank's angle, rate and acceleration.

    From ``b sin(phi) = e - a sin(th)``, differentiated once and twice.
    """
    a, b, e = geometry
    phi = np.arcsin((e - a * np.sin(theta)) / b)
    rate = -a * np.cos(theta) * omega / (b * np.cos(phi))
    accel = ((a * np.sin(theta) * omega**2 - a * np.cos(theta) * alpha) / b
             + np.sin(phi) * rate**2) / np.cos(phi)
    return phi, rate, accel


def build_multibody(geometry: Geometry = GEOMETRY, piston_mass: float = PISTON_MASS,
                    gravity: float = G) -> Multibody:
    """The mechanism as a ``Multibody``; each link a uniform rod along its body ``x``."""
    a, b, e = geometry
    crank, rod = (PlanarBody(name, DENSITY * length, DENSITY * length**3 / 12)
                  for name, length in zip(LINKS, (a, b)))
    piston = PlanarBody("piston", piston_mass, PISTON_INERTIA)
    ground = Ground()
    joints = [
        Revolute("J1", ground, crank, (0, 0, 0), (-a / 2, 0, 0)),
        Revolute("J2", crank, rod, (a / 2, 0, 0), (-b / 2, 0, 0)),
        Revolute("J3", rod, piston, (b / 2, 0, 0), (0, 0, 0)),
        Prismatic("guide", ground, piston, (0, e, 0), (0, 0, 0), axis_a=(1, 0, 0)),
    ]
    return Multibody([crank, rod, piston], joints, gravity=(0.0, -gravity, 0.0),
                     name="slider-crank")


def build(geometry: Geometry = GEOMETRY, piston_mass: float = PISTON_MASS,
          gravity: float = G) -> System:
    """The mechanism's ``System`` (9 coordinates, 8 constraints, 1 degree of freedom).

    >>> system = build()
    >>> len(system.coordinate_names), len(system.constraint_names)
    (9, 8)
    """
    return build_multibody(geometry, piston_mass, gravity).system


def initial_state(theta: float = THETA_0, omega: float = OMEGA_0,
                  geometry: Geometry = GEOMETRY) -> dict[str, dict[str, float]]:
    """Consistent ``q0``/``qd0`` from the closed-form position and velocity analysis."""
    a, b = geometry[:2]
    phi, rate, _ = rod_kinematics(theta, omega, 0.0, geometry)
    u_crank, u_rod = (np.array([np.cos(p), np.sin(p)]) for p in (theta, phi))
    du_crank, du_rod = (w * np.array([-np.sin(p), np.cos(p)])
                        for p, w in ((theta, omega), (phi, rate)))
    pin_a, v_a = a * u_crank, a * du_crank
    positions = {"crank": pin_a / 2, "rod": pin_a + b / 2 * u_rod, "piston": pin_a + b * u_rod}
    velocities = {"crank": v_a / 2, "rod": v_a + b / 2 * du_rod, "piston": v_a + b * du_rod}
    q0, qd0 = build_multibody(geometry).initial_state(
        positions=positions, velocities=velocities,
        orientations={"crank": theta, "rod": phi, "piston": 0.0},
        angular_velocities={"crank": omega, "rod": rate, "piston": 0.0},
    )
    return {"q0": q0, "qd0": qd0}


INITIAL = initial_state()


def geometry_of(mb: Multibody) -> tuple[float, float, float]:
    """``(a, b, e)`` read back from the joints of :func:`build_multibody`."""
    j1, j2, guide = mb.joint("J1"), mb.joint("J2"), mb.joint("guide")
    return 2 * abs(j1.point_b[0]), 2 * abs(j2.point_b[0]), float(guide.point_a[1])


def draw(system: System, q: np.ndarray) -> list[np.ndarray]:
    """Crank and rod as one polyline ``O -> A -> B``, the piston block and the guide.

    >>> lines = draw(build(), [0.0, 0.5, np.pi / 2, 1.5, 0.75, -np.pi / 6, 3.0, 0.25, 0.0])
    >>> lines[0].round(12).tolist()
    [[0.0, 0.0], [0.0, 1.0], [3.0, 0.25]]
    """
    q = np.asarray(q, dtype=float)
    a, b, e = geometry_of(multibody_of(system))
    th, piston = q[2], q[6:8]
    block = piston + 0.15 * np.array([[-1, -1], [1, -1], [1, 1], [-1, 1], [-1, -1]])
    rail = np.array([[b - a - 0.5, e - 0.15], [a + b + 0.5, e - 0.15]])
    return [np.array([[0.0, 0.0], a * np.array([np.cos(th), np.sin(th)]), piston]), block, rail]


def piston_error(traj: Trajectory, geometry: Geometry = GEOMETRY) -> float:
    """Largest ``|x_B - x_B(th)|`` (closed form at the simulated crank angle)."""
    return float(np.abs(traj["piston_x"] - piston_position(traj["crank_theta"], geometry)).max())


def guide_force(mb: Multibody, traj: Trajectory) -> np.ndarray:
    """The guide's normal force ``N`` on the piston from Newton-Euler, given the crank's motion.

    The guide is frictionless, so the pin ``J3`` alone pushes the piston along ``x``:
    ``P_x = m_p x_B''``, and ``P_y = m_p g - N``. The rod's moment balance about ``A``,
    ``I phi'' + m_r (G_r - A) x a_G = (B - A) x (-P) + (G_r - A) x m_r g``, then gives ``N``;
    ``phi``, ``a_G`` and ``x_B''`` follow from the closed-form position analysis.
    """
    geometry = geometry_of(mb)
    a, b, _ = geometry
    rod, piston = mb.bodies[1], mb.bodies[2]
    assert isinstance(rod, PlanarBody)  # as build_multibody() builds it
    g = -float(mb.gravity[1])
    th, w, al = traj["crank_theta"], traj["crank_theta_dot"], traj["crank_theta_ddot"]
    phi, dphi, ddphi = rod_kinematics(th, w, al, geometry)
    acc_a = a * np.stack([-np.sin(th) * al - np.cos(th) * w**2,
                          np.cos(th) * al - np.sin(th) * w**2])
    turn = np.stack([-np.sin(phi) * ddphi - np.cos(phi) * dphi**2,
                     np.cos(phi) * ddphi - np.sin(phi) * dphi**2])
    acc_g, acc_b = acc_a + b / 2 * turn, acc_a + b * turn
    half = b / 2 * np.stack([np.cos(phi), np.sin(phi)])  # G_r - A; B - A is twice this
    lhs = rod.moment * ddphi + rod.mass * (half[0] * acc_g[1] - half[1] * acc_g[0])
    weight = -rod.mass * g * half[0]
    # (B - A) x (-P) = 2 half x (-m_p x_B'', N - m_p g), solved for N
    rest = lhs - weight - 2 * half[1] * piston.mass * acc_b[0]
    return piston.mass * g + rest / (2 * half[0])


def checks(system: System, traj: Trajectory) -> dict[str, float]:
    """Closed-form piston position, guide force, piston force balance, energy, residuals."""
    mb = multibody_of(system)
    reactions = joint_reactions(mb, traj)
    guide = reactions["guide"]["piston"].force_world[:, 1]
    pin = reactions["J3"]["piston"].force_world[:, 1]
    scale = np.abs(guide).max()
    weight = mb.bodies[2].mass * float(mb.gravity[1])
    e = traj.energy
    return {
        "piston position error (closed form)": piston_error(traj, geometry_of(mb)),
        "guide force relative error (Newton-Euler)": float(
            np.abs(guide - guide_force(mb, traj)).max() / scale),
        "piston y force balance, relative": float(np.abs(pin + guide + weight).max() / scale),
        "relative energy error": float(np.abs(e - e[0]).max() / abs(e[0])),
        "max position residual": float(traj.position_residual.max()),
        "max velocity residual": float(traj.velocity_residual.max()),
    }
