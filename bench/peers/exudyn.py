"""Exudyn: the chain in redundant coordinates, 3D or planar rigid bodies.

- 3D (spherical) chain: each link a rigid body node (position + 4 Euler parameters,
  ``CreateRigidBody``) with the solid cylinder's inertia, joined by
  ``CreateSphericalJoint``;
- planar (revolute) chain: Exudyn's own planar formulation, each link a
  ``NodeRigidBody2D`` (x, y, angle) with an ``ObjectRigidBody2D`` (inertia about z:
  the cylinder's transverse one), joined by ``RevoluteJoint2D`` between
  ``MarkerBodyPosition`` markers at the link ends, gravity by ``LoadMassProportional``.
  The chain lies in the x-y plane (gravity along -y), link ``k``'s center at
  ``(k + 1/2) L (sin a, -cos a)``, ``a`` the tilt: the common chain's x-z plane laid
  on x-y and mirrored in x (same energy and motion). ``build_3d`` keeps the 3D-body
  hinge chain (``CreateRevoluteJoint``, axis ``y``) to compare.

Exudyn's implicit generalized-alpha solver (spectral radius 0.95: its numerical
damping kept small, since at 1 Newton stalls at n >= 4) with its sparse linear
solver (``EigenSparse``) and tight Newton tolerances; the time step is the largest
meeting both targets (energy and residual), bracketed from the ladder (1e-2 halved;
doubled until it misses when 1e-2 meets them) and bisected to within 5%
(``ladder.bisect``). Where no step of the ladder meets the energy target, the first
step (1e-2), which meets the residual target, is kept and marked "accepted" (the
residual alone cannot set the step: every step that converges meets it). The residual is
measured at the end from the body outputs: joint point mismatch, and for 3D bodies
hinge axis misalignment and Euler parameter norm.
"""

from __future__ import annotations

import math
import time

import numpy as np

from .common import (
    ANGLE,
    I_A,
    I_T,
    RESIDUAL_TARGET,
    T_END,
    G,
    L,
    M,
    R,
    centers,
    energy_error,
    meets,
    omega,
    tilt,
)
from .ladder import Prepared, bisect

TOOL = "exudyn"
STEPS = tuple(1e-2 / 2**k for k in range(4))


def versions() -> dict:
    import exudyn

    return {"exudyn": exudyn.__version__, "numpy": np.__version__}


def build(workload: str, n: int):
    """``(SystemContainer, mbs, bodies)``, assembled, and the seconds it took.

    The 3D chain has 3D bodies, the planar chain planar ones (:func:`build_2d`).
    """
    return (build_3d if workload == "spherical" else build_2d)(workload, n)


def build_3d(workload: str, n: int):
    """The chain of 3D bodies (Euler parameters), spherical or hinge (axis ``y``) joints."""
    import exudyn as exu
    from exudyn.utilities import InertiaCylinder

    start = time.perf_counter()
    sc = exu.SystemContainer()
    mbs = sc.AddSystem()
    ground = mbs.CreateGround(referencePosition=[0.0, 0.0, 0.0])
    inertia = InertiaCylinder(M / (np.pi * R**2 * L), L, R, 2)
    rot, w, c = tilt(), omega(workload), centers(n)
    down = rot @ np.array([0.0, 0.0, -L])
    parent, bodies = ground, []
    for k in range(n):
        body = mbs.CreateRigidBody(
            referencePosition=list(c[k]), referenceRotationMatrix=rot,
            initialVelocity=list(np.cross(w, c[k])), initialAngularVelocity=list(w),
            inertia=inertia, gravity=[0.0, 0.0, -G],
            nodeType=exu.NodeType.RotationEulerParameters)
        point = list(k * down)
        if workload == "spherical":
            mbs.CreateSphericalJoint(bodyNumbers=[parent, body], position=point)
        else:
            mbs.CreateRevoluteJoint(bodyNumbers=[parent, body], position=point, axis=[0, 1, 0])
        bodies.append(body)
        parent = body
    mbs.Assemble()
    return (sc, mbs, bodies), time.perf_counter() - start


def build_2d(workload: str, n: int):
    """The planar chain of 2D bodies in the x-y plane, at rest (``workload`` "revolute").

    A link's body frame has its axis along local ``-y`` (top end at ``(0, L/2)``), so
    its angle is the tilt from hanging straight down.
    """
    import exudyn as exu
    from exudyn import itemInterface as ei

    if workload != "revolute":
        raise ValueError(f"planar bodies carry only the revolute chain, not {workload!r}")
    start = time.perf_counter()
    sc = exu.SystemContainer()
    mbs = sc.AddSystem()
    ground = mbs.AddObject(ei.ObjectGround())
    above = mbs.AddMarker(ei.MarkerBodyPosition(bodyNumber=ground, localPosition=[0.0] * 3))
    down = L * np.array([np.sin(ANGLE), -np.cos(ANGLE)])
    bodies = []
    for k in range(n):
        x, y = (k + 0.5) * down
        node = mbs.AddNode(ei.NodeRigidBody2D(referenceCoordinates=[x, y, ANGLE]))
        body = mbs.AddObject(ei.ObjectRigidBody2D(mass=M, inertia=I_T, nodeNumber=node))
        mass = mbs.AddMarker(ei.MarkerBodyMass(bodyNumber=body))
        mbs.AddLoad(ei.LoadMassProportional(markerNumber=mass, loadVector=[0.0, -G, 0.0]))
        top = mbs.AddMarker(ei.MarkerBodyPosition(bodyNumber=body,
                                                  localPosition=[0.0, L / 2, 0.0]))
        mbs.AddObject(ei.ObjectJointRevolute2D(markerNumbers=[above, top]))
        above = mbs.AddMarker(ei.MarkerBodyPosition(bodyNumber=body,
                                                    localPosition=[0.0, -L / 2, 0.0]))
        bodies.append(body)
    mbs.Assemble()
    return (sc, mbs, bodies), time.perf_counter() - start


def _outputs(mbs, body, kind, local=(0.0, 0.0, 0.0)):
    import exudyn as exu

    return np.asarray(mbs.GetObjectOutputBody(body, getattr(exu.OutputVariableType, kind),
                                              localPosition=list(local)))


def planar(mbs, bodies) -> bool:
    """Whether the chain is made of 2D bodies."""
    return str(mbs.GetObject(bodies[0])["objectType"]) == "RigidBody2D"


def axis_end(mbs, bodies, sign: float) -> tuple[float, float, float]:
    """Body-frame point at the top (``sign`` 1) or bottom (-1) end of a link's axis."""
    return (0.0, sign * L / 2, 0.0) if planar(mbs, bodies) else (0.0, 0.0, sign * L / 2)


def energy(mbs, bodies) -> float:
    """``T + V`` from the bodies' current state (V = M G times the upward coordinate)."""
    if planar(mbs, bodies):  # up is y; the angular velocity is about z
        J, up = np.diag([0.0, 0.0, I_T]), 1
    else:
        J, up = np.diag([I_T, I_T, I_A]), 2
    total = 0.0
    for b in bodies:
        v = _outputs(mbs, b, "Velocity")
        w = _outputs(mbs, b, "AngularVelocityLocal")
        total += 0.5 * M * v @ v + 0.5 * w @ J @ w + M * G * _outputs(mbs, b, "Position")[up]
    return float(total)


def residual(mbs, bodies, workload: str) -> float:
    """Largest constraint violation at the current state."""
    import exudyn as exu

    flat = planar(mbs, bodies)
    top, bottom = axis_end(mbs, bodies, 1.0), axis_end(mbs, bodies, -1.0)
    worst, prev_point, prev_rot = 0.0, np.zeros(3), np.eye(3)
    for b in bodies:
        worst = max(worst, float(np.abs(_outputs(mbs, b, "Position", top) - prev_point).max()))
        prev_point = _outputs(mbs, b, "Position", bottom)
        if flat:  # x, y, angle: the joint points are the only constraints
            continue
        rot = _outputs(mbs, b, "RotationMatrix").reshape(3, 3)
        if workload == "revolute":
            axis = prev_rot[:, 1]
            worst = max(worst, abs(axis @ rot[:, 0]), abs(axis @ rot[:, 2]))
        node = mbs.GetObject(b)["nodeNumber"]
        params = np.asarray(mbs.GetNodeOutput(node, exu.OutputVariableType.Coordinates)) + \
            np.asarray(mbs.GetNode(node)["referenceCoordinates"])
        worst = max(worst, abs(float(params[3:7] @ params[3:7]) - 1.0))
        prev_rot = rot
    return worst


def settings(h: float, t_end: float = T_END):
    import exudyn as exu

    s = exu.SimulationSettings()
    s.timeIntegration.endTime = t_end
    s.timeIntegration.numberOfSteps = math.ceil(t_end / h - 1e-9)  # a step <= h
    s.timeIntegration.generalizedAlpha.spectralRadius = 0.95
    s.timeIntegration.newton.relativeTolerance = 1e-9
    s.timeIntegration.newton.absoluteTolerance = 1e-10
    s.timeIntegration.verboseMode = 0
    s.displayComputationTime = False
    s.displayStatistics = False
    s.solutionSettings.writeSolutionToFile = False
    s.linearSolverType = exu.LinearSolverType.EigenSparse
    return s


def simulate(workload: str, n: int, h: float, builder=build, t_end: float = T_END):
    """A fresh chain (``builder``, default :func:`build`) simulated to ``t_end`` at step ``h``.

    Returns ``(mbs, bodies, finished, seconds, cpu_seconds)``, the seconds those of
    ``SolveDynamic`` alone. Nothing is kept between calls, so a repeat is the same run.
    """
    import exudyn as exu

    (sc, mbs, bodies), _ = builder(workload, n)
    s = settings(h, t_end)
    start, cpu = time.perf_counter(), time.process_time()
    try:
        ok = mbs.SolveDynamic(s)
    except exu.SolverError:  # Newton did not converge: try a smaller step
        ok = False
    simulate_s, cpu_s = time.perf_counter() - start, time.process_time() - cpu
    del sc
    return mbs, bodies, bool(ok), simulate_s, cpu_s


def run(workload: str, n: int, builder=build) -> dict:
    """The measured record; ``builder`` :func:`build_3d` times the 3D-body hinge chain."""
    prepared = prepare(workload, n, builder)
    record = {**bisect(prepared), **prepared.info}
    record["step_s"] = record["simulate_s"] / record["steps"]
    return record


def prepare(workload: str, n: int, builder=build) -> Prepared:
    """The model built twice (cold, warm) and ``attempt(step)``."""
    from .common import warm_allowed

    (_, mbs0, bodies0), cold = builder(workload, n)
    warm = builder(workload, n)[1] if warm_allowed(cold) else None
    e0 = energy(mbs0, bodies0)
    flat = planar(mbs0, bodies0)

    def attempt(h: float) -> dict:
        mbs, bodies, ok, simulate_s, cpu_s = simulate(workload, n, h, builder)
        steps = math.ceil(T_END / h - 1e-9)
        return {"setting": {"solver": "generalized-alpha", "spectralRadius": 0.95,
                            "step": T_END / steps, "linearSolver": "EigenSparse",
                            "newtonTolerance": [1e-9, 1e-10]},
                "simulate_s": simulate_s, "cpu_s": cpu_s, "evaluations": steps, "steps": steps,
                "initial_energy": e0, "energy_error": energy_error(e0, energy(mbs, bodies), n),
                "residual": residual(mbs, bodies, workload) if ok else float("inf"),
                "finished": ok}

    joint = "CreateSphericalJoint" if workload == "spherical" else "CreateRevoluteJoint"
    info = dict(build_s=cold, build_warm_s=warm, eval_s=None,
                  eval_note="no public single-evaluation call; step_s is one implicit step "
                            "(Newton iterations with Jacobian and sparse factorization)",
                  evaluations_note="time steps, not right-hand-side evaluations",
                  coordinates=(3 if flat else 7) * n,
                  constraints=(2 if flat else 4 if workload == "spherical" else 6) * n,
                  formulation="NodeRigidBody2D + ObjectRigidBody2D, RevoluteJoint2D" if flat
                  else f"CreateRigidBody (Euler parameters), {joint}",
                  build_note="model creation + Assemble twice in one process")
    def residual_met(r: dict) -> bool:
        return r["residual"] <= RESIDUAL_TARGET

    return Prepared(info, attempt, STEPS, meets, fallback=residual_met)
