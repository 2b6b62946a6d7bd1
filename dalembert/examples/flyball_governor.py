"""IFToMM multibody benchmark A05: the stiff flyball governor.

A vertical shaft (a prismatic bar ``1 x 0.01 x 0.01 m``) turns freely about ``z`` on
a ground hinge at its bottom end. A cubic sleeve (``0.1 m`` edge) slides along it.
Two bars (``1 x 0.01 x 0.01 m``) hang from hinges at ``A, B = (+-0.05, 0, 1)`` on the
shaft, turning about the shaft's ``y`` axis; a 5 kg point mass sits at each bar's
far end. Instead of rigid coupler rods, a spring-damper (``K = 8e5 N/m``,
``C = 4e4 N s/m``, rest length 0.5 m) joins each bar's midpoint to the sleeve's side
(``+-0.05 m`` from its center). Density 3000 kg/m^3 for the bars and the sleeve,
gravity ``-9.81 m/s^2`` along ``z``, no driving torque. At ``t = 0`` the sleeve's
center is at ``s = 0.5 m``, the bars point 30 degrees below the horizontal (which
puts both springs at their rest length) and the whole mechanism turns rigidly at
``2 pi rad/s`` about ``z``. The output is the sleeve's height ``s(t)`` over 10 s;
the reference (minimal coordinates, the benchmark's own) is
``s(10) = 0.619622917061342 m``.

The benchmark states it as rigid bodies, hinges and a slider, so it is built as
such: a :class:`~dalembert.multibody.Multibody` of 4 quaternion rigid bodies
(28 coordinates) with a ground hinge, a prismatic joint and two hinges (24 rows with
the quaternion norms: 4 degrees of freedom) and two
:class:`~dalembert.multibody.SpringDamper`. A point mass cannot carry a hinge (it
has no orientation), so each bar and its end mass are one rigid body (mass
5.3 kg, center and inertia of the union); that is the same body the benchmark
describes. The spring's ``K / m`` and ``C / m`` make it stiff: its fast mode decays
in about 1e-4 s while the motion of interest takes seconds.

Independent checks: nothing exerts a torque about the ``z`` axis (gravity is along
it, the ground hinge turns about it), so the angular momentum ``H_z`` is conserved;
and the only dissipation is the two dampers, so ``T + V`` (the springs included)
falls by exactly the work ``int C Ldot^2 dt`` they absorb.
"""

from __future__ import annotations

import numpy as np

from ..multibody import (
    Ground,
    Multibody,
    Prismatic,
    Revolute,
    RigidBody,
    SpringDamper,
    angular_momentum,
    energy,
    multibody_of,
)
from ..system import System
from ..trajectory import Trajectory

TITLE = "IFToMM A05 stiff flyball governor: s(t) against the benchmark (springs K = 8e5)"
DENSITY, BAR, WIDTH, SLEEVE, BALL = 3000.0, 1.0, 0.01, 0.1, 5.0  # kg/m^3, m, m, m, kg
K, C, REST = 8e5, 4e4, 0.5  # N/m, N s/m, m
HALF_AB = 0.05  # the hinges A, B at x = +-0.05 on top of the shaft
S0, ALPHA0, OMEGA0, G = 0.5, np.radians(30.0), 2 * np.pi, 9.81
T_END = 10.0
#: The benchmark's reference: the sleeve height at t = 10 s (minimal coordinates).
S_REFERENCE = 0.619622917061342

M_BAR = DENSITY * BAR * WIDTH * WIDTH  # 0.3 kg
M_SLEEVE = DENSITY * SLEEVE**3  # 3 kg
M_ARM = M_BAR + BALL
#: The arm's (bar + end mass) center, from its hinge along the bar.
X_ARM = (M_BAR * BAR / 2 + BALL * BAR) / M_ARM


def _box(mass: float, a: float, b: float, c: float) -> tuple[float, float, float]:
    return (mass * (b * b + c * c) / 12, mass * (a * a + c * c) / 12,
            mass * (a * a + b * b) / 12)


def _arm_inertia() -> tuple[float, float, float]:
    """The bar (along body x) and its end mass, about their common center."""
    ixx, iyy, _ = _box(M_BAR, BAR, WIDTH, WIDTH)
    shift = iyy + M_BAR * (BAR / 2 - X_ARM) ** 2 + BALL * (BAR - X_ARM) ** 2
    return ixx, shift, shift


def model() -> Multibody:
    """The governor: shaft, sleeve, two arms; hinge, slider, two hinges, two springs."""
    ground = Ground()
    shaft = RigidBody("shaft", M_BAR, _box(M_BAR, WIDTH, WIDTH, BAR))
    sleeve = RigidBody("sleeve", M_SLEEVE, _box(M_SLEEVE, SLEEVE, SLEEVE, SLEEVE))
    arms = [RigidBody(name, M_ARM, _arm_inertia()) for name in ("arm_a", "arm_b")]
    joints = [
        Revolute("spin", ground, shaft, (0, 0, 0), (0, 0, -BAR / 2)),
        Prismatic("slide", shaft, sleeve),
        *(Revolute(f"hinge_{k}", shaft, arm, (side * HALF_AB, 0, BAR / 2), (-X_ARM, 0, 0),
                   axis_a=(0, 1, 0))
          for k, side, arm in (("a", 1, arms[0]), ("b", -1, arms[1]))),
    ]
    springs = [SpringDamper(f"spring_{k}", sleeve, arm, K, REST, C, (side * SLEEVE / 2, 0, 0),
                            (BAR / 2 - X_ARM, 0, 0))
               for k, side, arm in (("a", 1, arms[0]), ("b", -1, arms[1]))]
    return Multibody([shaft, sleeve, *arms], joints, gravity=(0, 0, -G), springs=springs,
                     name="flyball governor")


def build() -> System:
    """The governor as a System: 28 coordinates, 24 rows, 4 degrees of freedom.

    >>> system = build()
    >>> len(system.coordinate_names), len(system.constraint_names)
    (28, 24)
    """
    return model().system


def _rot_y(angle: float) -> np.ndarray:
    c, s = np.cos(angle), np.sin(angle)
    return np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])


def initial_state(mb: Multibody, s0: float = S0, alpha: float = ALPHA0,
                  omega: float = OMEGA0) -> dict[str, dict[str, float]]:
    """The benchmark's start: sleeve at ``s0``, arms ``alpha`` below the horizontal,
    everything turning rigidly at ``omega`` about ``z``."""
    w = np.array([0.0, 0.0, omega])
    shaft, sleeve, arm_a, arm_b = mb.bodies
    positions = {shaft: (0, 0, BAR / 2), sleeve: (0, 0, s0)}
    orientations = {arm_a: _rot_y(alpha), arm_b: _rot_y(np.pi - alpha)}
    velocities, rates = {}, {body: w for body in mb.bodies}
    for arm, side in ((arm_a, 1), (arm_b, -1)):
        hinge = np.array([side * HALF_AB, 0.0, BAR])
        positions[arm] = hinge + orientations[arm] @ np.array([X_ARM, 0.0, 0.0])
        velocities[arm] = np.cross(w, positions[arm])
    q0, qd0 = mb.initial_state(positions, orientations, velocities, rates)
    return {"q0": q0, "qd0": qd0}


INITIAL = initial_state(model())


def draw(system: System, q: np.ndarray) -> list[np.ndarray]:
    """The shaft, sleeve and arms (center -> joint points), 3D polylines."""
    return multibody_of(system).stick_figure(q)


def damper_work(traj: Trajectory) -> np.ndarray:
    """The work the two dampers have absorbed by each output time, ``int C Ldot^2``
    (Simpson's rule on the output times: use a fine, even grid)."""
    from scipy.integrate import cumulative_simpson

    power = np.zeros(len(traj))
    for k, side in (("a", 1), ("b", -1)):
        p = np.stack([traj[f"arm_{k}_{c}"] for c in "xyz"], axis=1)
        v = np.stack([traj[f"arm_{k}_{c}_dot"] for c in "xyz"], axis=1)
        b = np.stack([traj[f"arm_{k}_b{i}"] for i in range(4)], axis=1)
        bd = np.stack([traj[f"arm_{k}_b{i}_dot"] for i in range(4)], axis=1)
        e = np.stack([traj[f"sleeve_{c}"] for c in "xyz"], axis=1)
        ed = np.stack([traj[f"sleeve_{c}_dot"] for c in "xyz"], axis=1)
        eb = np.stack([traj[f"sleeve_b{i}"] for i in range(4)], axis=1)
        ebd = np.stack([traj[f"sleeve_b{i}_dot"] for i in range(4)], axis=1)
        r_arm, v_arm = _body_point(p, v, b, bd, np.array([BAR / 2 - X_ARM, 0.0, 0.0]))
        r_sl, v_sl = _body_point(e, ed, eb, ebd, np.array([side * SLEEVE / 2, 0.0, 0.0]))
        d, dd = r_arm - r_sl, v_arm - v_sl
        ldot = np.sum(d * dd, axis=1) / np.linalg.norm(d, axis=1)
        power += C * ldot**2
    return np.concatenate([[0.0], cumulative_simpson(power, x=traj.t)])


def _body_point(x: np.ndarray, xd: np.ndarray, b: np.ndarray, bd: np.ndarray,
                local: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """World position and velocity of the body point ``local`` (Euler parameters ``b``)."""
    w, xs, ys, zs = b.T
    R = np.array([[1 - 2 * (ys**2 + zs**2), 2 * (xs * ys - w * zs), 2 * (xs * zs + w * ys)],
                  [2 * (xs * ys + w * zs), 1 - 2 * (xs**2 + zs**2), 2 * (ys * zs - w * xs)],
                  [2 * (xs * zs - w * ys), 2 * (ys * zs + w * xs), 1 - 2 * (xs**2 + ys**2)]])
    # world angular velocity: w = 2 E(b) bdot with E = [-b_v, b0 I + [b_v]x]
    om = 2 * np.stack([-xs * bd[:, 0] + w * bd[:, 1] - zs * bd[:, 2] + ys * bd[:, 3],
                       -ys * bd[:, 0] + zs * bd[:, 1] + w * bd[:, 2] - xs * bd[:, 3],
                       -zs * bd[:, 0] - ys * bd[:, 1] + xs * bd[:, 2] + w * bd[:, 3]], axis=1)
    arm = np.einsum("ijk,j->ki", R, local)
    return x + arm, xd + np.cross(om, arm)


def checks(system: System, traj: Trajectory) -> dict[str, float]:
    """``s`` at the end against the benchmark (when run to 10 s), ``H_z``, the energy
    balance with the dampers' work, residuals."""
    mb = multibody_of(system)
    hz = angular_momentum(mb, traj)[:, 2]
    e = energy(mb, traj)
    out = {
        "relative H_z error": float(np.abs(hz - hz[0]).max() / abs(hz[0])),
        "relative energy balance error (damper work)": float(
            np.abs(e + damper_work(traj) - e[0]).max() / abs(e[0])),
        "max position residual": float(traj.position_residual.max()),
        "max velocity residual": float(traj.velocity_residual.max()),
    }
    if np.isclose(traj.t[-1], T_END):
        out["s(10) error (benchmark)"] = float(abs(traj["sleeve_z"][-1] - S_REFERENCE))
    return out

