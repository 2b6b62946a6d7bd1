"""The IFToMM A02 benchmark: N four-bar linkages in a row, through their flat positions.

``2N + 1`` links of 1 m and 1 kg (uniform rods, :class:`PlanarBody`): cranks
``crank0 .. crankN`` pinned to the ground at ``x = 0, 1, ..., N`` (joints ``O0 .. ON``),
couplers ``coupler1 .. couplerN`` pinned to the ends of neighbouring cranks (``Ak``,
``Bk``); gravity ``-y``. One degree of freedom; each time the cranks lie flat the
constraint Jacobian loses ``N`` ranks (N instantaneous extra degrees of freedom), and
a solver may stall there or leave the branch on which every crank stays parallel.
Start: a row of squares, B0 (the first crank's free end) moving at 1 m/s in ``x``.

The reference is the parallelogram's one-coordinate motion: the crank angle ``phi``
with ``J phi'' = -V cos(phi)``, ``J = (N + 1)/3 + N`` (cranks about their pivots,
couplers translating on unit circles), ``V = g ((N + 1)/2 + N)``, integrated apart.
The benchmark's criterion: B0's position and velocity within 1e-3 of it. The gallery
runs ``N = 4`` over 5 s (the benchmark's N = 40 over 20 s is ``bench/a02.py``).
"""

from __future__ import annotations

import numpy as np
from scipy.integrate import solve_ivp

from ..multibody import Ground, Multibody, PlanarBody, Revolute, multibody_of
from ..system import System
from ..trajectory import Trajectory

TITLE = "IFToMM A02: N four-bar linkages through their flat (singular) positions"
N_DEFAULT = 4
G = 9.81
T_END = 5.0


def build_multibody(N: int = N_DEFAULT, gravity: float = G) -> Multibody:
    """The mechanism (``3(2N + 1)`` coordinates, ``2(3N + 1)`` constraints)."""
    ground = Ground()
    cranks = [PlanarBody(f"crank{k}", 1.0, 1 / 12) for k in range(N + 1)]
    couplers = [PlanarBody(f"coupler{k + 1}", 1.0, 1 / 12) for k in range(N)]
    joints = [Revolute("O0", ground, cranks[0], (0, 0, 0), (-0.5, 0, 0))]
    for k in range(1, N + 1):
        joints += [Revolute(f"A{k}", cranks[k - 1], couplers[k - 1], (0.5, 0, 0), (-0.5, 0, 0)),
                   Revolute(f"B{k}", couplers[k - 1], cranks[k], (0.5, 0, 0), (0.5, 0, 0)),
                   Revolute(f"O{k}", ground, cranks[k], (k, 0, 0), (-0.5, 0, 0))]
    bodies = [cranks[0]] + [b for k in range(N) for b in (couplers[k], cranks[k + 1])]
    return Multibody(bodies, joints, gravity=(0, -gravity, 0), name=f"A02 N={N}")


def build(N: int = N_DEFAULT, gravity: float = G) -> System:
    """The mechanism's ``System``.

    >>> system = build(2)
    >>> len(system.coordinate_names), len(system.constraint_names)
    (15, 14)
    """
    return build_multibody(N, gravity).system


def initial_state(N: int = N_DEFAULT) -> dict[str, dict[str, float]]:
    """The row of squares, every crank turning at -1 rad/s (B0 at 1 m/s in ``x``)."""
    pos: dict[str, tuple[float, float]] = {}
    vel: dict[str, tuple[float, float]] = {}
    ori: dict[str, float] = {}
    spin: dict[str, float] = {}
    for k in range(N + 1):
        pos[f"crank{k}"], ori[f"crank{k}"] = (float(k), 0.5), np.pi / 2
        vel[f"crank{k}"], spin[f"crank{k}"] = (0.5, 0.0), -1.0
    for k in range(1, N + 1):
        pos[f"coupler{k}"], ori[f"coupler{k}"] = (k - 0.5, 1.0), 0.0
        vel[f"coupler{k}"], spin[f"coupler{k}"] = (1.0, 0.0), 0.0
    q0, qd0 = build_multibody(N).initial_state(positions=pos, orientations=ori,
                                               velocities=vel, angular_velocities=spin)
    return {"q0": q0, "qd0": qd0}


INITIAL = initial_state()


def reference(N: int, times: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """B0's position and velocity (rows) on the parallelogram branch at ``times``.

    >>> p, v = reference(2, np.array([0.0, 0.5]))
    >>> bool(np.allclose(p[0], [0, 1]) and np.allclose(v[0], [1, 0]))
    True
    """
    J, V = (N + 1) / 3 + N, G * ((N + 1) / 2 + N)
    end = max(float(times[-1]), 1e-9)
    sol = solve_ivp(lambda t, y: [y[1], -V * np.cos(y[0]) / J], (0.0, end),
                    [np.pi / 2, -1.0], method="DOP853", rtol=1e-13, atol=1e-13,
                    dense_output=True)
    phi, rate = sol.sol(times)
    return (np.column_stack([np.cos(phi), np.sin(phi)]),
            np.column_stack([-np.sin(phi) * rate, np.cos(phi) * rate]))


def b0(traj: Trajectory) -> tuple[np.ndarray, np.ndarray]:
    """B0's simulated position and velocity (rows)."""
    th, w = traj["crank0_theta"], traj["crank0_theta_dot"]
    return (np.column_stack([traj["crank0_x"] + 0.5 * np.cos(th),
                             traj["crank0_y"] + 0.5 * np.sin(th)]),
            np.column_stack([traj["crank0_x_dot"] - 0.5 * np.sin(th) * w,
                             traj["crank0_y_dot"] + 0.5 * np.cos(th) * w]))


def checks(system: System, traj: Trajectory) -> dict[str, float]:
    """B0 against the one-coordinate reference, the cranks' spread, energy, residuals."""
    N = (len(multibody_of(system).bodies) - 1) // 2
    p, v = b0(traj)
    p_ref, v_ref = reference(N, traj.t)
    cranks = np.column_stack([traj[f"crank{k}_theta"] for k in range(N + 1)])
    e = traj.energy
    return {
        "B0 position error (one-coordinate reference)": float(np.abs(p - p_ref).max()),
        "B0 velocity error (one-coordinate reference)": float(np.abs(v - v_ref).max()),
        "largest angle between cranks (0 on the branch)": float(np.ptp(cranks, axis=1).max()),
        "relative energy error": float(np.abs(e - e[0]).max() / abs(e[0])),
        "max position residual": float(traj.position_residual.max()),
        "max velocity residual": float(traj.velocity_residual.max()),
    }
