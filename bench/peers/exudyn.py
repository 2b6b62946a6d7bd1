"""Exudyn: the chain in redundant coordinates (``ObjectRigidBody`` with Euler parameters).

Each link is a rigid body node (position + 4 Euler parameters) with the solid
cylinder's inertia, joined by ``CreateSphericalJoint`` / ``CreateRevoluteJoint``
(hinge axis ``y``). Exudyn's implicit generalized-alpha solver (spectral radius 0.95:
its numerical damping kept small, since at 1 Newton stalls at n >= 4) with its sparse
linear solver (``EigenSparse``) and tight Newton tolerances; the time step starts
at 1e-2 and is halved until the constraint residual target is met, and the energy
error reached is reported. The residual is measured at the end from the body
outputs: joint point mismatch, hinge axis misalignment, Euler parameter norm.
"""

from __future__ import annotations

import time

import numpy as np

from .common import (
    RESIDUAL_TARGET,
    T_END,
    G,
    L,
    M,
    R,
    centers,
    energy_error,
    omega,
    tilt,
)
from .ladder import climb

TOOL = "exudyn"
STEPS = tuple(1e-2 / 2**k for k in range(4))


def versions() -> dict:
    import exudyn

    return {"exudyn": exudyn.__version__, "numpy": np.__version__}


def build(workload: str, n: int):
    """``(SystemContainer, mbs, bodies)``, assembled, and the seconds it took."""
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


def _outputs(mbs, body, kind, local=(0.0, 0.0, 0.0)):
    import exudyn as exu

    return np.asarray(mbs.GetObjectOutputBody(body, getattr(exu.OutputVariableType, kind),
                                              localPosition=list(local)))


def energy(mbs, bodies) -> float:
    """``T + V`` from the bodies' current state (V = M G z)."""
    J = np.diag([M * (3 * R**2 + L**2) / 12] * 2 + [M * R**2 / 2])
    total = 0.0
    for b in bodies:
        v = _outputs(mbs, b, "Velocity")
        w = _outputs(mbs, b, "AngularVelocityLocal")
        total += 0.5 * M * v @ v + 0.5 * w @ J @ w + M * G * _outputs(mbs, b, "Position")[2]
    return float(total)


def residual(mbs, bodies, workload: str) -> float:
    """Largest constraint violation at the current state."""
    import exudyn as exu

    worst, prev_point, prev_rot = 0.0, np.zeros(3), np.eye(3)
    for b in bodies:
        top = _outputs(mbs, b, "Position", (0.0, 0.0, L / 2))
        rot = _outputs(mbs, b, "RotationMatrix").reshape(3, 3)
        worst = max(worst, float(np.abs(top - prev_point).max()))
        if workload == "revolute":
            axis = prev_rot[:, 1]
            worst = max(worst, abs(axis @ rot[:, 0]), abs(axis @ rot[:, 2]))
        node = mbs.GetObject(b)["nodeNumber"]
        params = np.asarray(mbs.GetNodeOutput(node, exu.OutputVariableType.Coordinates)) + \
            np.asarray(mbs.GetNode(node)["referenceCoordinates"])
        worst = max(worst, abs(float(params[3:7] @ params[3:7]) - 1.0))
        prev_point = _outputs(mbs, b, "Position", (0.0, 0.0, -L / 2))
        prev_rot = rot
    return worst


def settings(h: float):
    import exudyn as exu

    s = exu.SimulationSettings()
    s.timeIntegration.endTime = T_END
    s.timeIntegration.numberOfSteps = round(T_END / h)
    s.timeIntegration.generalizedAlpha.spectralRadius = 0.95
    s.timeIntegration.newton.relativeTolerance = 1e-9
    s.timeIntegration.newton.absoluteTolerance = 1e-10
    s.timeIntegration.verboseMode = 0
    s.displayComputationTime = False
    s.displayStatistics = False
    s.solutionSettings.writeSolutionToFile = False
    s.linearSolverType = exu.LinearSolverType.EigenSparse
    return s


def run(workload: str, n: int) -> dict:
    from .common import warm_allowed

    (_, mbs0, bodies0), cold = build(workload, n)
    warm = build(workload, n)[1] if warm_allowed(cold) else None
    e0 = energy(mbs0, bodies0)
    step_cost = {}

    import exudyn as exu

    def attempt(h: float) -> dict:
        (sc, mbs, bodies), _ = build(workload, n)
        s = settings(h)
        start = time.perf_counter()
        try:
            ok = mbs.SolveDynamic(s)
        except exu.SolverError:  # Newton did not converge: try a smaller step
            ok = False
        simulate_s = time.perf_counter() - start
        steps = round(T_END / h)
        step_cost[h] = simulate_s / steps
        del sc
        return {"setting": {"solver": "generalized-alpha", "spectralRadius": 0.95,
                            "step": h, "linearSolver": "EigenSparse",
                            "newtonTolerance": [1e-9, 1e-10]},
                "simulate_s": simulate_s, "evaluations": steps, "steps": steps,
                "initial_energy": e0, "energy_error": energy_error(e0, energy(mbs, bodies), n),
                "residual": residual(mbs, bodies, workload) if ok else float("inf"),
                "finished": bool(ok)}

    record = climb(attempt, STEPS, accept=lambda r: r["residual"] <= RESIDUAL_TARGET)
    record.update(build_s=cold, build_warm_s=warm, eval_s=None,
                  step_s=step_cost.get(record["setting"]["step"]),
                  eval_note="no public single-evaluation call; step_s is one implicit step "
                            "(Newton iterations with Jacobian and sparse factorization)",
                  evaluations_note="time steps, not right-hand-side evaluations",
                  coordinates=7 * n, constraints=n * (4 if workload == "spherical" else 6),
                  build_note="model creation + Assemble twice in one process")
    return record
