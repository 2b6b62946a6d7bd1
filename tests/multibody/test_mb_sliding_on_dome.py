"""A rigid ball of anisotropic inertia sliding with Coulomb friction on a fixed sphere
(``multibody/contacts.py`` ``sphere_contact``, event-driven): its contact's sliding
velocity is three world components of rank 2, and its spin, which sets the sliding
velocity, follows Euler's equations with three different moments.

Reference (Newton-Euler, written here without the library): a ball of mass ``m`` and
radius ``r``, its mass centre ``x`` at its geometric centre, body inertia
``J = diag(1, 0.2, 1.1) m r^2``, on a fixed sphere of radius ``R`` centred at the
origin, under gravity ``g = (0, 0, -g)`` and a horizontal push ``P = (c t, 0, 0)`` at
its centre. With ``L = R + r`` and the outward normal ``n = x / |x|``, the contact
point is ``x - r n`` and, the sphere fixed, the sliding velocity is the velocity of
the ball's material point there,

    s = v + w x (-r n)        (w the angular velocity, world components),

tangent to the sphere (``v . n = 0`` on it, ``w x n`` is normal to ``n``). The forces
on the ball are its weight ``m g``, the push ``P``, the normal force ``N n`` and the
friction ``F = -mu N s / |s|`` while it slides; their torque about the centre is that
of ``F`` only, ``(-r n) x F`` (``N n`` passes through the centre). So

    m a = m g + P + N n + F,
    J w_b' + w_b x J w_b = R^T ((-r n) x F),       q' = q (0, w_b) / 2,

``w_b = R^T w`` the angular velocity in body components, ``R`` the rotation (body to
world) of the unit quaternion ``q`` (scalar first, Hamilton's product). Staying on the
sphere, ``|x| = L``, needs ``|x|'' = 0``: ``a . n = -(|v|^2 - (v . n)^2) / |x|``, and,
``F`` being tangent, the normal component of Newton's law gives

    N = m g n_z - P . n - m (|v|^2 - (v . n)^2) / |x|

(weight's and push's parts along ``-n``, less the centripetal force; it must stay
positive). The state ``(x, v, q, w_b)`` is integrated by SciPy's DOP853 at
``rtol = 1e-13`` (at ``1e-12`` it moves by 1e-10 at most), with the work
``W' = P . v + F . s`` of the push and of friction (the normal force does none:
``n . s = 0`` and ``n . v = 0``) as one more entry. The reference checks itself: the
centre stays at ``L`` from the origin and the mechanical energy ``m |v|^2 / 2 +
w_b . J w_b / 2 + m g z`` changes by ``W``.

The start: ``0.15`` rad from the top, the centre moving at ``0.6`` along the sphere,
the ball spinning at about 30 rad/s about an oblique axis, turned by an arbitrary
quaternion; its contact point slides at 2.4 and keeps sliding, at least at 0.75,
with ``N`` above 11 (of a weight of 14.7), over the 0.4 s of the run.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from dalembert import t as time
from dalembert.multibody import (
    Force,
    Ground,
    Multibody,
    RigidBody,
    angular_velocities,
    rotation_matrices,
    sphere_contact,
)

G, MU, M, r, R = 9.81, 0.15, 1.5, 0.1, 1.0
L = R + r
J = np.diag([1.0, 0.2, 1.1]) * M * r**2  # body frame: not a uniform sphere's 2/5 m r^2
PUSH = 10.0  # the horizontal push c t along x, in N/s
SPAN = 0.4
T_EVAL = np.linspace(0.0, SPAN, 9)

THETA0, PHI0 = 0.15, 0.4  # from the top, azimuth
N0 = np.array([np.sin(THETA0) * np.cos(PHI0), np.sin(THETA0) * np.sin(PHI0), np.cos(THETA0)])
X0 = L * N0
V0 = 0.6 * np.array([-np.sin(PHI0), np.cos(PHI0), 0.0])  # along the sphere
W0 = np.array([6.0, -24.0, 16.0])  # world components
Q0 = np.array([0.9, 0.2, -0.3, 0.25]) / np.linalg.norm([0.9, 0.2, -0.3, 0.25])


def hamilton(p: np.ndarray, q: np.ndarray) -> np.ndarray:
    """The quaternion product ``p q`` (scalar first)."""
    return np.r_[p[0] * q[0] - p[1:] @ q[1:],
                 p[0] * q[1:] + q[0] * p[1:] + np.cross(p[1:], q[1:])]


def rotation(q: np.ndarray) -> np.ndarray:
    """The rotation (body to world) of the quaternion ``q`` (normalized first)."""
    w, x, y, z = q / np.linalg.norm(q)
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                     [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                     [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]])


def contact_forces(t: float, state: np.ndarray) -> tuple[float, np.ndarray, np.ndarray]:
    """The normal force ``N``, the friction force ``F`` (world) and the sliding velocity
    ``s`` at the state ``(x, v, q, w_b, ...)`` (see the module docstring)."""
    x, v, q, w_body = state[:3], state[3:6], state[6:10], state[10:13]
    n = x / np.linalg.norm(x)
    push = np.array([PUSH * t, 0.0, 0.0])
    normal = M * G * n[2] - push @ n - M * (v @ v - (v @ n) ** 2) / np.linalg.norm(x)
    slip = v + np.cross(rotation(q) @ w_body, -r * n)
    return normal, -MU * normal * slip / np.linalg.norm(slip), slip


def newton_euler(t: float, state: np.ndarray) -> np.ndarray:
    """The rates of ``(x, v, q, w_b, W)``: Newton's and Euler's equations, the
    quaternion's kinematics and the power of the push and of friction."""
    x, v, q, w_body = state[:3], state[3:6], state[6:10], state[10:13]
    normal, friction, slip = contact_forces(t, state)
    n = x / np.linalg.norm(x)
    push = np.array([PUSH * t, 0.0, 0.0])
    a = np.array([0.0, 0.0, -G]) + (push + normal * n + friction) / M
    torque = rotation(q).T @ np.cross(-r * n, friction)  # body components
    w_dot = np.linalg.solve(J, torque - np.cross(w_body, J @ w_body))
    return np.r_[v, a, hamilton(q, np.r_[0.0, w_body]) / 2, w_dot,
                 push @ v + friction @ slip]


@pytest.fixture(scope="module")
def reference() -> dict[str, np.ndarray]:
    """The reference at :data:`T_EVAL`: the states, ``N``, ``F``, ``s``, ``w`` (world)."""
    start = np.r_[X0, V0, Q0, rotation(Q0).T @ W0, 0.0]
    solution = solve_ivp(newton_euler, (0.0, SPAN), start, method="DOP853", rtol=1e-13,
                         atol=1e-14, t_eval=T_EVAL)
    assert solution.success
    y = solution.y.T
    forces = [contact_forces(t, state) for t, state in zip(T_EVAL, y)]
    return {"y": y, "N": np.array([f[0] for f in forces]),
            "F": np.array([f[1] for f in forces]), "s": np.array([f[2] for f in forces]),
            "w": np.array([rotation(state[6:10]) @ state[10:13] for state in y])}


@pytest.fixture(scope="module")
def dome() -> tuple[Multibody, dict[str, float], dict[str, float]]:
    """The ball on the dome as a Multibody, with its initial state."""
    ball = RigidBody("ball", M, J)
    mb = Multibody([ball], gravity=(0, 0, -G), forces=[Force(ball, (PUSH * time, 0, 0))],
                   contacts=[sphere_contact("dome", Ground(), ball, R, r, friction=MU)])
    assert len(mb.contacts[0].tangents) == 3  # world components, of rank 2
    q0, qd0 = mb.initial_state(positions={"ball": X0}, orientations={"ball": Q0},
                               velocities={"ball": V0}, angular_velocities={"ball": W0})
    return mb, q0, qd0


def test_the_reference_stays_on_its_sphere_keeps_its_energy_balance_and_slides(reference):
    y = reference["y"]
    assert np.abs(np.linalg.norm(y[:, :3], axis=1) - L).max() < 1e-12
    assert np.abs(np.linalg.norm(y[:, 6:10], axis=1) - 1.0).max() < 1e-12
    energy = (M * np.sum(y[:, 3:6] ** 2, axis=1) / 2
              + np.einsum("ki,ij,kj->k", y[:, 10:13], J, y[:, 10:13]) / 2 + M * G * y[:, 2])
    assert np.abs(energy - energy[0] - y[:, 13]).max() < 1e-11
    assert -y[-1, 13] > 0.5  # friction dissipates: a balance that means something
    # in contact and sliding throughout: N > 0 and |s| far from 0
    assert reference["N"].min() > 11.0
    assert np.linalg.norm(reference["s"], axis=1).min() > 0.7
    assert np.abs(np.einsum("ki,ki->k", reference["s"], y[:, :3])).max() < 1e-12  # tangent


@pytest.mark.parametrize(("method", "backend"),
                         [("auto", "c"), ("DOP853", "c"), ("DOP853", "python")])
def test_an_anisotropic_ball_slides_on_a_dome_as_newton_euler_says(dome, reference, method,
                                                                    backend):
    mb, q0, qd0 = dome
    traj = mb.simulate((0.0, SPAN), q0, qd0, t_eval=T_EVAL, method=method, backend=backend)
    assert traj.success, traj.message
    # closed from the start to the end, never sticking: one switch, at the start
    assert [(s.t, s.closed) for s in traj.contacts.switches] == [(0.0, (0,))]
    assert traj.contacts.impacts == []
    y = reference["y"]
    x = np.column_stack([traj[f"ball_{c}"] for c in "xyz"])
    v = np.column_stack([traj[f"ball_{c}_dot"] for c in "xyz"])
    assert np.abs(x - y[:, :3]).max() < 1e-11
    assert np.abs(v - y[:, 3:6]).max() < 1e-10
    assert np.abs(np.linalg.norm(x, axis=1) - L).max() < 1e-12
    R_ref = np.array([rotation(state[6:10]) for state in y])
    assert np.abs(rotation_matrices(mb, traj, "ball") - R_ref).max() < 1e-10
    # the spin of about 30 rad/s, to 1e-10 of it in both frames
    w_body = angular_velocities(mb, traj, "ball", frame="body")
    assert np.abs(w_body - y[:, 10:13]).max() < 4e-9
    w = angular_velocities(mb, traj, "ball")
    assert np.abs(w - reference["w"]).max() < 4e-9
    # the contact's forces: the normal one and the friction's world components
    assert np.abs(traj.multiplier("dome_1") - reference["N"]).max() < 1e-9
    friction = np.column_stack([traj.multiplier(f"dome_friction_{k}") for k in (1, 2, 3)])
    assert np.abs(friction - reference["F"]).max() < 1e-9
    # the sliding velocity from the run's own state
    slip = v + np.cross(w, -r * x / np.linalg.norm(x, axis=1)[:, None])
    assert np.abs(slip - reference["s"]).max() < 1e-9
    assert np.linalg.norm(slip, axis=1).min() > 0.7
