"""IFToMM A02, the N-four-bar mechanism: dalembert's two loops against Exudyn.

The benchmark (Gonzalez, Dopico, Lugris, Cuadrado, Multibody System Dynamics 16,
2006): ``2N + 1`` links of 1 m and 1 kg (uniform rods), cranks pinned to the ground at
``x = 0, 1, ..., N``, couplers joining their ends; gravity ``-y``. Start: a row of
squares, point B0 (the first crank's end) moving at 1 m/s in ``x``; 20 s, 400 outputs.
Each pass through the horizontal position gains N instantaneous degrees of freedom.
The reference is the parallelogram's one-coordinate motion, the crank angle ``phi``
with ``J phi'' = -V cos(phi)``, ``J = (N + 1)/3 + N``, ``V = g ((N + 1)/2 + N)``
(integrated here with ``solve_ivp`` at 1e-13); a run passes when B0's position and
velocity stay within 1e-3 of it.

dalembert runs at its default settings (rtol 1e-11) in the C loop and the Python loop;
Exudyn (generalized-alpha, planar bodies, if installed) at each step size of a ladder,
passing or not. Writes ``bench/results/a02.json``.

Usage: ``python bench/a02.py [--n 40] [--t-end 20] [--steps 1e-2 5e-3 2.5e-3]``
(the full benchmark takes minutes: not for a shared machine).
"""

from __future__ import annotations

import argparse
import json
import platform
import time
import warnings
from pathlib import Path

import numpy as np
from scipy.integrate import solve_ivp

G = 9.81
OUT = Path(__file__).resolve().parent / "results" / "a02.json"
TOL = 1e-3


def reference(N: int, times: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """B0's position and velocity (rows) of the one-coordinate motion at ``times``."""
    J, V = (N + 1) / 3 + N, G * ((N + 1) / 2 + N)
    sol = solve_ivp(lambda t, y: [y[1], -V * np.cos(y[0]) / J], (0.0, times[-1]),
                    [np.pi / 2, -1.0], method="DOP853", rtol=1e-13, atol=1e-13,
                    t_eval=times)
    phi, rate = sol.y
    return (np.column_stack([np.cos(phi), np.sin(phi)]),
            np.column_stack([-np.sin(phi) * rate, np.cos(phi) * rate]))


def dalembert_model(N: int):
    """The gallery example's mechanism and start (a row of squares, B0 at 1 m/s)."""
    from dalembert.examples.n_four_bar import build_multibody, initial_state

    start = initial_state(N)
    return build_multibody(N, G), start["q0"], start["qd0"]


def run_dalembert(N: int, t_end: float, backend: str) -> dict:
    mb, q0, qd0 = dalembert_model(N)
    times = np.linspace(0.0, t_end, round(20 * t_end) + 1)
    mb.system.numeric()  # the build is not timed
    start = time.perf_counter()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        traj = mb.system.simulate((0.0, t_end), q0, qd0, backend=backend, t_eval=times)
    seconds = time.perf_counter() - start
    th, w = traj["crank0_theta"], traj["crank0_theta_dot"]
    p = np.column_stack([traj["crank0_x"] + 0.5 * np.cos(th), traj["crank0_y"] + 0.5 * np.sin(th)])
    v = np.column_stack([traj["crank0_x_dot"] - 0.5 * np.sin(th) * w,
                         traj["crank0_y_dot"] + 0.5 * np.cos(th) * w])
    p_ref, v_ref = reference(N, traj.t) if len(traj.t) > 1 else (p, v)
    dp, dv = float(np.abs(p - p_ref).max()), float(np.abs(v - v_ref).max())
    return {"tool": "dalembert", "loop": backend, "seconds": seconds,
            "status": traj.status, "t_reached": float(traj.t[-1]),
            "position_error": dp, "velocity_error": dv,
            "passed": bool(traj.success and dp < TOL and dv < TOL),
            "steps": traj.stats.get("n_steps"), "nfev": traj.stats.get("nfev")}


def run_exudyn(N: int, t_end: float, h: float) -> dict:
    """Planar bodies and 2D revolute joints, generalized-alpha at step ``h``."""
    import exudyn as exu
    from exudyn import itemInterface as ei

    sc = exu.SystemContainer()
    mbs = sc.AddSystem()
    ground = mbs.AddObject(ei.ObjectGround())

    def link(center, angle, velocity, spin):
        node = mbs.AddNode(ei.NodeRigidBody2D(referenceCoordinates=[*center, angle],
                                              initialVelocities=[*velocity, spin]))
        body = mbs.AddObject(ei.ObjectRigidBody2D(mass=1.0, inertia=1 / 12, nodeNumber=node))
        mass = mbs.AddMarker(ei.MarkerBodyMass(bodyNumber=body))
        mbs.AddLoad(ei.LoadMassProportional(markerNumber=mass, loadVector=[0.0, -G, 0.0]))
        return body

    def pin(body_a, local_a, body_b, local_b):
        a = mbs.AddMarker(ei.MarkerBodyPosition(bodyNumber=body_a, localPosition=[*local_a, 0]))
        b = mbs.AddMarker(ei.MarkerBodyPosition(bodyNumber=body_b, localPosition=[*local_b, 0]))
        mbs.AddObject(ei.ObjectJointRevolute2D(markerNumbers=[a, b]))

    # a link's local x axis runs along it, from -0.5 to 0.5
    cranks = [link((k, 0.5), np.pi / 2, (0.5, 0.0), -1.0) for k in range(N + 1)]
    for k in range(N + 1):
        ground_marker = mbs.AddMarker(ei.MarkerBodyPosition(bodyNumber=ground,
                                                            localPosition=[k, 0.0, 0.0]))
        end = mbs.AddMarker(ei.MarkerBodyPosition(bodyNumber=cranks[k],
                                                  localPosition=[-0.5, 0.0, 0.0]))
        mbs.AddObject(ei.ObjectJointRevolute2D(markerNumbers=[ground_marker, end]))
    for k in range(1, N + 1):
        coupler = link((k - 0.5, 1.0), 0.0, (1.0, 0.0), 0.0)
        pin(cranks[k - 1], (0.5, 0.0), coupler, (-0.5, 0.0))
        pin(coupler, (0.5, 0.0), cranks[k], (0.5, 0.0))
    sensors = [mbs.AddSensor(ei.SensorBody(bodyNumber=cranks[0], localPosition=[0.5, 0, 0],
                                           outputVariableType=kind, storeInternal=True))
               for kind in (exu.OutputVariableType.Position, exu.OutputVariableType.Velocity)]
    mbs.Assemble()
    s = exu.SimulationSettings()
    s.timeIntegration.endTime = t_end
    s.timeIntegration.numberOfSteps = round(t_end / h)
    s.timeIntegration.generalizedAlpha.spectralRadius = 0.95
    s.timeIntegration.newton.relativeTolerance = 1e-9
    s.timeIntegration.newton.absoluteTolerance = 1e-10
    s.timeIntegration.verboseMode = 0
    s.displayComputationTime = s.displayStatistics = False
    s.solutionSettings.writeSolutionToFile = False
    s.solutionSettings.sensorsWritePeriod = t_end / 400
    s.linearSolverType = exu.LinearSolverType.EigenSparse
    start = time.perf_counter()
    try:
        ok = bool(mbs.SolveDynamic(s))
    except exu.SolverError:
        ok = False
    seconds = time.perf_counter() - start
    p, v = (np.asarray(mbs.GetSensorStoredData(k)) for k in sensors)
    result = {"tool": "exudyn", "step": h, "seconds": seconds, "finished": ok}
    if ok and len(p) > 1:
        p_ref, v_ref = reference(N, p[:, 0])
        dp = float(np.abs(p[:, 1:3] - p_ref).max())
        dv = float(np.abs(v[:, 1:3] - v_ref).max())
        result.update(position_error=dp, velocity_error=dv, passed=bool(dp < TOL and dv < TOL))
    else:
        result.update(passed=False)
    return result


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, default=40)
    parser.add_argument("--t-end", type=float, default=20.0)
    parser.add_argument("--steps", type=float, nargs="*",
                        default=[1e-2, 5e-3, 4e-3, 2.5e-3, 2e-3, 1.25e-3, 1e-3, 5e-4, 2.5e-4])
    parser.add_argument("--out", type=Path, default=OUT)
    args = parser.parse_args()
    runs = [run_dalembert(args.n, args.t_end, backend) for backend in ("c", "python")]
    try:
        import exudyn

        runs += [run_exudyn(args.n, args.t_end, h) for h in args.steps]
        exudyn_version = exudyn.__version__
    except ImportError:
        exudyn_version = None
    for r in runs:
        print({k: (f"{v:.3g}" if isinstance(v, float) else v) for k, v in r.items()})
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps({
        "benchmark": "IFToMM A02, N-four-bar", "n": args.n, "t_end": args.t_end,
        "criterion": f"B0 position and velocity within {TOL} of the one-coordinate reference",
        "machine": platform.platform(), "exudyn": exudyn_version, "runs": runs}, indent=1))
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
