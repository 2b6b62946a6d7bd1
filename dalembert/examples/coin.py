"""A coin rolling on a table: a quaternion rigid body with the ``Rolling`` joint.

The same thin uniform disk as :mod:`dalembert.examples.rolling_disk`, built here
with :mod:`dalembert.multibody`: the pose is the center and Euler parameters (7
coordinates), and the rolling joint supplies the contact height (holonomic) and
the two no-slip rows (Pfaffian). Body frame: the coin's axis is body ``y``;
principal moments ``m r^2/4`` (diameters) and ``m r^2/2`` (axis).

Steady rolling round a circle of radius ``R`` at tilt ``theta`` (the axis
``b2 = (0, cos(theta), sin(theta))`` at the start, heading ``+x``) and
precession rate ``Omega`` needs the textbook condition (derived independently in
``tests/examples/test_rolling_disk.py``)::

    g sin(theta) + (3/2) Omega^2 R cos(theta) - (r/4) Omega^2 sin(theta) cos(theta) = 0

with the spin ``s = Omega R / r`` about the axis; the contact force is then
``m R Omega^2`` towards the circle's center plus ``m g`` up.
"""

from __future__ import annotations

import numpy as np

from ..multibody import Multibody, RigidBody, Rolling, joint_reactions, multibody_of
from ..multibody.rotations import elementary_rotation, rotation_matrix
from ..system import System
from ..trajectory import Trajectory

TITLE = "Coin rolling on a table: quaternion rigid body with the Rolling joint"
M, G, R_COIN = 1.0, 9.81, 0.1
THETA0, RADIUS = -0.3, 0.5
T_END = 5.0


def model(m: float = M, g: float = G, r: float = R_COIN) -> Multibody:
    """The coin and its rolling joint on the plane ``z = 0``."""
    coin = RigidBody("coin", m, (m * r**2 / 4, m * r**2 / 2, m * r**2 / 4))
    return Multibody([coin], [Rolling("roll", coin, r, axis=(0, 1, 0))],
                     gravity=(0.0, 0.0, -g), name="coin")


def build(m: float = M, g: float = G, r: float = R_COIN) -> System:
    """The coin as a System: 7 coordinates, 1 + 3 constraints.

    >>> build().degrees_of_freedom
    3
    """
    return model(m, g, r).system


def steady_rate(theta: float, radius: float, g: float = G, r: float = R_COIN) -> float:
    """``Omega`` from the steady-rolling condition (``radius > 0`` needs ``theta < 0``).

    >>> bool(np.isclose(steady_rate(0.3, 0.0) ** 2, 4 * G / (R_COIN * np.cos(0.3))))
    True
    """
    omega2 = g * np.sin(theta) / (np.cos(theta) * (r * np.sin(theta) / 4 - 1.5 * radius))
    if not omega2 > 0:
        raise ValueError("no steady rolling: the coin must lean towards the circle's center")
    return float(np.sqrt(omega2))


def steady_state(theta: float = THETA0, radius: float = RADIUS, g: float = G,
                 r: float = R_COIN) -> dict[str, dict[str, float]]:
    """``q0``/``qd0`` of steady rolling: center over the origin, heading ``+x``."""
    omega = steady_rate(theta, radius, g, r)
    spin = omega * radius / r
    R = elementary_rotation("x", theta)
    b1, b2, b3 = R.T
    q0, qd0 = model(r=r).initial_state(
        positions={"coin": (0.0, 0.0, r * np.cos(theta))}, orientations={"coin": R},
        velocities={"coin": r * spin * b1},
        angular_velocities={"coin": spin * b2 + omega * np.cos(theta) * b3})
    return {"q0": q0, "qd0": qd0}


INITIAL = steady_state()


def draw(system: System, q: np.ndarray) -> list[np.ndarray]:
    """The coin's rim, center -> contact line and body axes (3D polylines)."""
    return multibody_of(system).stick_figure(q)


def checks(system: System, traj: Trajectory) -> dict[str, float]:
    """Steady rolling from :data:`INITIAL`: tilt, circle, contact force, energy, norm.

    The steady motion (tilt, ``Omega``, ``R``) is read from the initial state, so the
    errors are meaningful for a steady start, as :data:`INITIAL` is.
    """
    mb = multibody_of(system)
    coin, roll = mb.bodies[0], mb.joints[0]
    assert isinstance(roll, Rolling)  # as model() builds it
    m, g, r = coin.mass, -mb.gravity[2], roll.radius
    b = np.column_stack([traj[f"coin_b{i}"] for i in range(4)])
    theta = np.arcsin(rotation_matrix(b)[:, 2, 1])   # the axis (body y) against the table
    velocity = np.column_stack([traj["coin_x_dot"], traj["coin_y_dot"]])
    speed = np.hypot(*velocity[0])
    radius = _radius(traj, speed)
    omega = speed / radius
    heading = np.arctan2(velocity[0, 1], velocity[0, 0]) + omega * (traj.t - traj.t[0])
    center = np.array([traj["coin_x"][0], traj["coin_y"][0]]) + radius * np.array(
        [-np.sin(heading[0]), np.cos(heading[0])])
    expected = center + radius * np.column_stack([np.sin(heading), -np.cos(heading)])
    xy = np.column_stack([traj["coin_x"], traj["coin_y"]])
    force = joint_reactions(mb, traj)["roll"]["coin"].force_world
    f_ref = np.column_stack([m * radius * omega**2 * -np.sin(heading),
                             m * radius * omega**2 * np.cos(heading), np.full(len(traj), m * g)])
    e = traj.energy
    th0 = theta[0]
    return {
        "steady condition residual": float(abs(
            g * np.sin(th0) + 1.5 * omega**2 * radius * np.cos(th0)
            - r / 4 * omega**2 * np.sin(th0) * np.cos(th0)) / g),
        "tilt drift": float(np.abs(theta - th0).max()),
        "center circle error": float(np.abs(xy - expected).max() / abs(radius)),
        "contact force relative error": float(np.abs(force - f_ref).max() / (m * g)),
        "relative energy error": float(np.abs(e - e[0]).max() / abs(e[0])),
        "quaternion norm error": float(np.abs(np.linalg.norm(b, axis=1) - 1).max()),
        "max position residual": float(traj.position_residual.max()),
    }


def _radius(traj: Trajectory, speed: float) -> float:
    """Signed circle radius ``v / Omega`` from the initial precession (heading rate)."""
    vx, vy = traj["coin_x_dot"][0], traj["coin_y_dot"][0]
    ax, ay = traj.qdd[0, 0], traj.qdd[0, 1]
    turn = (vx * ay - vy * ax) / speed**2   # heading rate of the center's velocity
    return speed / turn
