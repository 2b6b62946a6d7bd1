"""SymPy mechanics in minimal coordinates: derive + lambdify + ``solve_ivp``.

- planar (revolute) chain: ``KanesMethod`` with absolute link angles about ``y``;
- 3D (spherical) chain: ``sympy.physics.mechanics.System`` with ``SphericalJoint``
  (three body-fixed XYZ angles per joint, relative to the parent link).

Build = derivation + ``lambdify`` (with ``cse``) of the mass matrix, the forcing
and the energy. The right-hand side solves ``M x' = F`` with ``numpy.linalg.solve``
(DOP853, rtol bracketed from the same ladder as dalembert's and bisected to within 5%
of the coarsest meeting the energy target, ``ladder.bisect``). Minimal
coordinates: the constraint residual is zero by construction.
"""

from __future__ import annotations

import time

import numpy as np

from .common import (
    ANGLE,
    I_A,
    I_T,
    T_END,
    G,
    L,
    M,
    energy_error,
    meets,
    omega,
    time_call,
    warm_allowed,
)
from .dalembert import RTOLS
from .ladder import Prepared, bisect

TOOL = "sympy"


def versions() -> dict:
    import scipy
    import sympy

    return {"sympy": sympy.__version__, "scipy": scipy.__version__, "numpy": np.__version__}


def _planar(n: int):
    """KanesMethod, absolute angles: (mass matrix, forcing, energy, q, u, q0, u0)."""
    import sympy as sp
    from sympy.physics import mechanics as me

    q = me.dynamicsymbols(f"th1:{n + 1}")
    u = me.dynamicsymbols(f"w1:{n + 1}")
    N = me.ReferenceFrame("N")
    pivot = top = me.Point("O")
    top.set_vel(N, 0)
    bodies, loads, potential = [], [], 0
    for k in range(n):
        A = N.orientnew(f"A{k}", "Axis", [q[k], N.y])
        A.set_ang_vel(N, u[k] * N.y)
        center = top.locatenew(f"C{k}", -L / 2 * A.z)
        center.v2pt_theory(top, N, A)
        bottom = top.locatenew(f"P{k}", -L * A.z)
        bottom.v2pt_theory(top, N, A)
        bodies.append(me.RigidBody(f"B{k}", center, A, M, (me.inertia(A, I_T, I_T, I_A), center)))
        loads.append((center, -M * G * N.z))
        potential += M * G * center.pos_from(pivot).dot(N.z)
        top = bottom
    kane = me.KanesMethod(N, q_ind=q, u_ind=u, kd_eqs=[qi.diff() - ui for qi, ui in zip(q, u)])
    kane.kanes_equations(bodies, loads)
    energy = sum(b.kinetic_energy(N) for b in bodies) + potential
    x0 = np.r_[np.full(n, ANGLE), np.zeros(n)]
    return kane.mass_matrix, kane.forcing, sp.sympify(energy), q, u, x0, False


def _spatial(n: int):
    """System + SphericalJoint: (full mass matrix, full forcing, energy, q, u, x0, True)."""
    import sympy as sp
    from sympy.physics import mechanics as me

    ground = me.RigidBody("ground")
    system = me.System.from_newtonian(ground)
    N = ground.frame
    parent, links, q, u = ground, [], [], []
    for k in range(n):
        link = me.RigidBody(f"link{k + 1}", mass=M)
        link.inertia = (me.inertia(link.frame, I_T, I_T, I_A), link.masscenter)
        qk = me.dynamicsymbols(f"q{k + 1}_1:4")
        uk = me.dynamicsymbols(f"u{k + 1}_1:4")
        parent_point = None if k == 0 else -L / 2 * parent.frame.z
        joint = me.SphericalJoint(f"joint{k + 1}", parent, link, coordinates=qk, speeds=uk,
                                  parent_point=parent_point, child_point=L / 2 * link.frame.z,
                                  rot_order="XYZ", rot_type="BODY")
        system.add_bodies(link)
        system.add_joints(joint)
        links.append(link)
        q += qk
        u += uk
        parent = link
    system.apply_uniform_gravity(-G * N.z)
    system.form_eoms()
    origin = ground.masscenter
    energy = sum(b.kinetic_energy(N) + M * G * b.masscenter.pos_from(origin).dot(N.z)
                 for b in links)
    # SphericalJoint's default kinematics: u = q' (so q' in the energy is u)
    energy = energy.subs({qi.diff(): ui for qi, ui in zip(q, u)})
    w = omega("spherical")
    x0 = np.zeros(6 * n)
    x0[1] = ANGLE      # link 1: XYZ body angles (0, ANGLE, 0) = the tilt about y
    x0[3 * n] = w[0]   # q1_1' about the ground x axis (the first rotation)
    return system.mass_matrix_full, system.forcing_full, sp.sympify(energy), q, u, x0, True


def build(workload: str, n: int):
    import sympy as sp
    from sympy.physics import mechanics  # noqa: F401  (imported before the timer, as every tool)

    start = time.perf_counter()
    mass, forcing, energy, q, u, x0, full = (_spatial if workload == "spherical"
                                             else _planar)(n)
    args = [q, u]
    fns = (sp.lambdify(args, mass, cse=True), sp.lambdify(args, forcing, cse=True),
           sp.lambdify(args, energy, cse=True))
    return (fns, x0, full), time.perf_counter() - start


def run(workload: str, n: int) -> dict:
    """The measured record: :func:`prepare`, then the bisection of the rtol."""
    prepared = prepare(workload, n)
    return {**bisect(prepared), **prepared.info}


def prepare(workload: str, n: int) -> Prepared:
    """The model derived and lambdified twice (cold, warm) and ``attempt(rtol)``."""
    from scipy.integrate import solve_ivp

    (fns, x0, full), cold = build(workload, n)
    warm = build(workload, n)[1] if warm_allowed(cold) else None
    mass, forcing, energy = fns
    nq = len(x0) // 2

    def rhs(_t: float, x: np.ndarray) -> np.ndarray:
        q, u = x[:nq], x[nq:]
        sol = np.linalg.solve(mass(q, u), np.asarray(forcing(q, u), dtype=float).ravel())
        return sol if full else np.concatenate([u, sol])

    e0 = float(energy(x0[:nq], x0[nq:]))
    eval_s = time_call(lambda: rhs(0.0, x0))

    def attempt(rtol: float) -> dict:
        start, cpu = time.perf_counter(), time.process_time()
        sol = solve_ivp(rhs, (0.0, T_END), x0, method="DOP853", rtol=rtol, atol=rtol / 100)
        simulate_s, cpu_s = time.perf_counter() - start, time.process_time() - cpu
        end = sol.y[:, -1]
        return {"setting": {"method": "DOP853", "rtol": rtol, "atol": rtol / 100},
                "simulate_s": simulate_s, "cpu_s": cpu_s, "evaluations": int(sol.nfev),
                "initial_energy": e0,
                "energy_error": energy_error(e0, float(energy(end[:nq], end[nq:])), n),
                "residual": 0.0, "finished": bool(sol.success)}

    info = dict(build_s=cold, build_warm_s=warm, eval_s=eval_s, coordinates=nq,
                  constraints=0, residual_note="minimal coordinates: no constraints",
                  build_note="derive + lambdify twice in one process (SymPy caches warm)",
                  formulation="KanesMethod, absolute angles" if workload == "revolute"
                  else "System + SphericalJoint (XYZ body angles)")
    return Prepared(info, attempt, RTOLS, meets)
