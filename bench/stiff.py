"""Benchmark: the stiff 16-link planar chain (joint springs), every tool at two accuracies.

Workload (``bench/stiff_chain.py``): the suite's 16-link planar chain (1 kg, 1 m, r =
5 cm cylinders, hung from a fixed pin, every link tilted 30 degrees, at rest) with a
torsional spring ``k`` and damper ``c`` on joints 2..16 (rest: the chain straight),
``c`` giving the fastest mode of the linearized chain a damping ratio of 0.05; 10 s
simulated; ``k`` in 1e2, 1e4, 1e6, 1e8. Accuracy = the largest absolute angle error
of the links at t = 10 s against the minimal-coordinate reference of
``bench/stiff_chain.py`` (DOP853 at rtol 1e-12, checked at 1e-10; cached in
``bench/results/stiff_reference.json``, computed when missing).

Each (tool, k) runs in a fresh process under a time cap (``--cap``): for each target
(1e-3 rad, then 1e-6 rad) its coarsest setting meeting it is found by bisection to
within 5% (``bench/peers/ladder.py``), then that setting is run again in timing
rounds (5 under 1 s, 3 under 10 s, 2 under 30 s, else 1), the fastest round's wall
and CPU seconds kept. Results in ``bench/results/stiff.json``.

Tools: dalembert with each method of :data:`METHODS` (redundant coordinates,
``PlanarBody`` links and 2-row pins, ``JointSpring`` on the revolute joints); MuJoCo
RK4 and implicitfast (hinges with ``stiffness``/``damping``); Exudyn
generalized-alpha (2D bodies, ``RevoluteJoint2D``, a ``CoordinateSpringDamper``
between consecutive links' angle coordinates).

Usage: ``python bench/stiff.py [--k K ...] [--tools T ...] [--cap S] [--n LINKS]``
(``--n``: a chain of other length, the same links and springs, its own reference).
"""

from __future__ import annotations

import argparse
import json
import math
import os
import subprocess
import sys
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))

from bench import stiff_chain as sc  # noqa: E402
from bench.peers import ladder  # noqa: E402
from bench.peers.ladder import Prepared, bisect  # noqa: E402
from bench.suite import SINGLE_THREAD, machine, rounds_for  # noqa: E402

#: dalembert's methods benchmarked: a new method is one more name here.
METHODS = ["DOP853", "Radau", "auto", "BDF", "IDA"]
PEERS = ["mujoco-RK4", "mujoco-implicitfast", "exudyn-GA"]
TOOLS = [f"dalembert-{m}" for m in METHODS] + PEERS
TARGETS = (1e-3, 1e-6)
REFERENCE = HERE / "results" / "stiff_reference.json"
#: The chain's links (``--n``; 16, the issue's chain, by default).
LINKS = sc.N
#: Each attempt also keeps its angle error and counts (the ladder keeps the energy's).
ladder.KEPT = (*ladder.KEPT, "angle_error", "n_steps", "steps", "njev", "nlu", "n_switches")
#: Tolerance ladder of dalembert's methods (atol = rtol / 100), as the suite's.
RTOLS = (1e-1, 3e-2, 1e-2, 3e-3, 1e-3, 3e-4, 1e-4, 3e-5, 1e-5, 3e-6, 1e-6, 1e-7, 1e-8, 1e-9,
         1e-10, 1e-11, 1e-12)
#: Step ladders: MuJoCo's from 2e-2 down by 2^(1/3) a rung, Exudyn's halved.
MUJOCO_STEPS = tuple(2e-2 / 2 ** (j / 3) for j in range(46))
EXUDYN_STEPS = tuple(1e-2 / 2**j for j in range(16))


def reference_angles(k: float) -> np.ndarray:
    """The reference's absolute angles at ``T_END`` (computed and cached if missing)."""
    cached = json.loads(REFERENCE.read_text()) if REFERENCE.exists() else {}
    key = sc.reference_key(k, LINKS)
    if key not in cached:
        subprocess.run([sys.executable, str(HERE / "stiff_chain.py"), "--k", str(k),
                        "--n", str(LINKS), "--out", str(REFERENCE)], check=True)
        cached = json.loads(REFERENCE.read_text())
    return np.asarray(cached[key]["phi"])


def angle_record(phi: np.ndarray, ref: np.ndarray) -> dict:
    err = float(np.max(np.abs(phi - ref))) if np.all(np.isfinite(phi)) else math.inf
    # no energy target here: NaN keeps the ladder's energy check (``common.meets``) off
    return {"angle_error": err, "energy_error": math.nan}


# ---------------------------------------------------------------- dalembert


def dalembert_chain(k: float, c: float):
    """The stiff chain as a dalembert multibody, its code generated: ``(multibody,
    q0, qd0, body names)``; ``phi = -theta`` of each body is the reference's angle."""
    from dalembert.multibody import JointSpring, Multibody, chain

    base = chain(LINKS, sc.L, sc.M, sc.R, joint="revolute", planar=True)
    springs = [JointSpring(f"spring{i + 1}", base.joints[i], k, c) for i in range(1, LINKS)]
    mb = Multibody(base.bodies, base.joints, gravity=(0.0, -sc.G, 0.0),
                   joint_springs=springs, name="stiff chain")
    mb.system.compiled  # derive and generate code now  # noqa: B018
    names = [b.name for b in mb.bodies]
    down = sc.L * np.array([-np.sin(sc.ANGLE), -np.cos(sc.ANGLE)])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        q0, qd0 = mb.initial_state(
            positions={n: (j + 0.5) * down for j, n in enumerate(names)},
            orientations=dict.fromkeys(names, -sc.ANGLE))
    return mb, q0, qd0, names


def prepare_dalembert(method: str, k: float, c: float, ref: np.ndarray) -> Prepared:
    start = time.perf_counter()
    mb, q0, qd0, names = dalembert_chain(k, c)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        # a short run first: the method's own code (the implicit methods' Jacobian, the C
        # loop's library) is generated and compiled at its first use, not in a timing
        mb.simulate((0.0, 1e-3), q0, qd0, method=method)
    build_s = time.perf_counter() - start

    def attempt(rtol: float) -> dict:
        start, cpu = time.perf_counter(), time.process_time()
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            traj = mb.simulate((0.0, sc.T_END), q0, qd0, method=method, rtol=rtol,
                               atol=rtol / 100, t_eval=[sc.T_END])
        wall, cpu_s = time.perf_counter() - start, time.process_time() - cpu
        phi = -np.array([traj[f"{n}_theta"][-1] for n in names])  # theta = -phi
        finished = traj.status == "finished" if isinstance(traj.status, str) \
            else bool(traj.status == 0)
        return {"setting": {"method": method, "rtol": rtol, "atol": rtol / 100},
                "simulate_s": wall, "cpu_s": cpu_s, "finished": bool(finished),
                **{key: int(traj.stats[key]) for key in ("nfev", "njev", "nlu", "n_steps",
                                                           "n_switches")
                   if key in traj.stats},
                "evaluations": int(traj.stats.get("nfev", 0)),
                "residual": float(traj.position_residual.max()),
                **angle_record(phi, ref)}

    info = {"build_s": build_s, "coordinates": 3 * LINKS, "constraints": 2 * LINKS}
    return Prepared(info, attempt, RTOLS, lambda r: True)


# ---------------------------------------------------------------- MuJoCo


def prepare_mujoco(integrator: str, k: float, c: float, ref: np.ndarray) -> Prepared:
    import mujoco

    start = time.perf_counter()
    spec = mujoco.MjSpec()
    spec.compiler.degree = False
    spec.compiler.inertiafromgeom = mujoco.mjtInertiaFromGeom.mjINERTIAFROMGEOM_FALSE
    spec.option.integrator = getattr(mujoco.mjtIntegrator, f"mjINT_{integrator.upper()}")
    spec.option.gravity = [0.0, 0.0, -sc.G]
    spec.option.disableflags |= mujoco.mjtDisableBit.mjDSBL_CONTACT
    parent = spec.worldbody
    for j in range(LINKS):
        body = parent.add_body(name=f"link{j + 1}", pos=[0.0, 0.0, 0.0 if j == 0 else -sc.L],
                               explicitinertial=True, mass=sc.M, ipos=[0.0, 0.0, -sc.L / 2],
                               inertia=[sc.I_C, sc.I_C, sc.M * sc.R**2 / 2])
        # relative hinge angle, spring reference 0 (the chain straight); none at the pin
        body.add_joint(type=mujoco.mjtJoint.mjJNT_HINGE, axis=[0.0, 1.0, 0.0],
                       stiffness=[k if j else 0.0, 0.0, 0.0],
                       damping=[c if j else 0.0, 0.0, 0.0], springref=0.0)
        parent = body
    model = spec.compile()
    build_s = time.perf_counter() - start

    def attempt(dt: float) -> dict:
        steps = math.ceil(sc.T_END / dt - 1e-9)
        model.opt.timestep = sc.T_END / steps
        data = mujoco.MjData(model)
        data.qpos[0] = sc.ANGLE
        mujoco.mj_forward(model, data)
        start, cpu = time.perf_counter(), time.process_time()
        mujoco.mj_step(model, data, nstep=steps)
        wall, cpu_s = time.perf_counter() - start, time.process_time() - cpu
        bad = int(data.warning[mujoco.mjtWarning.mjWARN_BADQACC].number)
        phi = np.cumsum(data.qpos) if bad == 0 else np.full(LINKS, np.nan)
        return {"setting": {"integrator": integrator, "timestep": sc.T_END / steps},
                "simulate_s": wall, "cpu_s": cpu_s, "steps": steps,
                "evaluations": (4 if integrator == "RK4" else 1) * steps,
                "finished": bad == 0, "residual": 0.0, **angle_record(phi, ref)}

    info = {"build_s": build_s, "coordinates": LINKS, "constraints": 0,
            "note": "hinge stiffness and damping given as MjSpec arrays (first entry)"}
    return Prepared(info, attempt, MUJOCO_STEPS, lambda r: True)


# ---------------------------------------------------------------- Exudyn


def exudyn_chain(k: float, c: float):
    """The suite's planar Exudyn chain (``bench/peers/exudyn.py``: ``build_2d``) with a
    ``CoordinateSpringDamper`` between consecutive links' angle coordinates."""
    import exudyn as exu
    from exudyn import itemInterface as ei

    container = exu.SystemContainer()
    mbs = container.AddSystem()
    ground = mbs.AddObject(ei.ObjectGround())
    above = mbs.AddMarker(ei.MarkerBodyPosition(bodyNumber=ground, localPosition=[0.0] * 3))
    down = sc.L * np.array([np.sin(sc.ANGLE), -np.cos(sc.ANGLE)])
    nodes, angle_markers = [], []
    for j in range(LINKS):
        x, y = (j + 0.5) * down
        node = mbs.AddNode(ei.NodeRigidBody2D(referenceCoordinates=[x, y, sc.ANGLE]))
        body = mbs.AddObject(ei.ObjectRigidBody2D(mass=sc.M, inertia=sc.I_C, nodeNumber=node))
        mass = mbs.AddMarker(ei.MarkerBodyMass(bodyNumber=body))
        mbs.AddLoad(ei.LoadMassProportional(markerNumber=mass, loadVector=[0.0, -sc.G, 0.0]))
        top = mbs.AddMarker(ei.MarkerBodyPosition(bodyNumber=body,
                                                  localPosition=[0.0, sc.L / 2, 0.0]))
        mbs.AddObject(ei.ObjectJointRevolute2D(markerNumbers=[above, top]))
        above = mbs.AddMarker(ei.MarkerBodyPosition(bodyNumber=body,
                                                    localPosition=[0.0, -sc.L / 2, 0.0]))
        angle_markers.append(mbs.AddMarker(ei.MarkerNodeCoordinate(nodeNumber=node,
                                                                   coordinate=2)))
        if j:  # the relative angle's spring; both reference angles are ANGLE: offset 0
            mbs.AddObject(ei.ObjectConnectorCoordinateSpringDamper(
                markerNumbers=[angle_markers[-2], angle_markers[-1]],
                stiffness=k, damping=c, offset=0.0))
        nodes.append(node)
    mbs.Assemble()
    return container, mbs, nodes


def prepare_exudyn(k: float, c: float, ref: np.ndarray) -> Prepared:
    import exudyn as exu

    from bench.peers.exudyn import settings

    start = time.perf_counter()
    exudyn_chain(k, c)
    build_s = time.perf_counter() - start

    def attempt(h: float) -> dict:
        container, mbs, nodes = exudyn_chain(k, c)
        s = settings(h, sc.T_END)
        start, cpu = time.perf_counter(), time.process_time()
        try:
            ok = bool(mbs.SolveDynamic(s))
        except exu.SolverError:
            ok = False
        wall, cpu_s = time.perf_counter() - start, time.process_time() - cpu
        phi = np.array([mbs.GetNodeOutput(n, exu.OutputVariableType.Coordinates)[2]
                        + sc.ANGLE for n in nodes]) if ok else np.full(LINKS, np.nan)
        steps = math.ceil(sc.T_END / h - 1e-9)
        del container
        return {"setting": {"solver": "generalized-alpha", "spectralRadius": 0.95,
                            "step": sc.T_END / steps}, "simulate_s": wall, "cpu_s": cpu_s,
                "steps": steps, "evaluations": steps, "finished": ok, "residual": 0.0,
                **angle_record(phi, ref)}

    info = {"build_s": build_s, "coordinates": 3 * LINKS, "constraints": 2 * LINKS,
            "evaluations_note": "time steps (each a Newton solve)"}
    return Prepared(info, attempt, EXUDYN_STEPS, lambda r: True)


def prepare(tool: str, k: float) -> Prepared:
    ref = reference_angles(k)
    c = sc.damping_for(k, n=LINKS)["c"]
    if tool.startswith("dalembert-"):
        return prepare_dalembert(tool.split("-", 1)[1], k, c, ref)
    if tool.startswith("mujoco-"):
        return prepare_mujoco(tool.split("-", 1)[1], k, c, ref)
    if tool == "exudyn-GA":
        return prepare_exudyn(k, c, ref)
    raise ValueError(f"unknown tool {tool!r}; known: {TOOLS}")


# ---------------------------------------------------------------- harness


def serve(tool: str, k: float, cap: float) -> dict:
    """One (tool, k): both targets bisected (half the cap each at most), then timed."""
    with tempfile.TemporaryDirectory(prefix="dalembert-bench-") as cache:
        os.environ["DALEMBERT_CACHE_DIR"] = cache
        prepared = prepare(tool, k)
        start = time.perf_counter()  # the cap counts from here: the build is apart
        out: dict = {"tool": tool, "k": k, **prepared.info, "targets": {}}
        settings = list(prepared.settings)
        for target in TARGETS:
            left = cap - (time.perf_counter() - start)
            if left <= 0:
                out["targets"][f"{target:g}"] = {"status": "cap spent before this target"}
                print("@@record " + json.dumps(out), flush=True)
                continue
            def accept(r: dict, t: float = target) -> bool:
                return bool(r.get("finished")) and r["angle_error"] <= t

            record = bisect(prepared._replace(accept=accept, settings=settings),
                            budget=left * (0.5 if target == TARGETS[0] else 0.85))
            if record["accepted"]:  # the finer target's ladder starts from this setting
                settings = [s for s in settings if s <= record["setting_value"]] or settings
            record.pop("met_target", None)
            record["status"] = "ok" if record["accepted"] else "no setting met the target"
            if record["accepted"]:
                rounds = []
                for _ in range(rounds_for(record["simulate_s"])):
                    if time.perf_counter() - start > cap:
                        break
                    again = prepared.attempt(record["setting_value"])
                    rounds.append({"simulate_s": again["simulate_s"], "cpu_s": again["cpu_s"]})
                record["rounds"] = rounds
                if rounds:
                    record["simulate_s"] = min(r["simulate_s"] for r in rounds)
                    record["cpu_s"] = min(r["cpu_s"] for r in rounds)
            out["targets"][f"{target:g}"] = record
            out["wall_s"] = time.perf_counter() - start
            # each target's record as soon as it is known: a run killed at the cap keeps it
            print("@@record " + json.dumps(out), flush=True)
        return out


def run_one(tool: str, k: float, cap: float) -> dict:
    """:func:`serve` in a fresh process, killed at ``cap`` seconds."""
    cmd = [sys.executable, str(Path(__file__).resolve()), "--one", tool, str(k),
           "--cap", str(cap), "--n", str(LINKS)]
    env = {**os.environ, "PYTHONWARNINGS": "ignore", **SINGLE_THREAD}
    start = time.perf_counter()
    status = "ran"
    try:
        done = subprocess.run(cmd, capture_output=True, text=True, timeout=1.2 * cap + 120, env=env)
        stdout, stderr = done.stdout, done.stderr
    except subprocess.TimeoutExpired as exc:
        status = f"killed at the {cap:g} s cap"
        stdout, stderr = (x.decode() if isinstance(x, bytes) else x or ""
                          for x in (exc.stdout, exc.stderr))
    lines = [ln for ln in stdout.splitlines() if ln.startswith("@@record ")]
    if not lines:
        if status != "ran":
            return {"tool": tool, "k": k, "status": f"did not finish in {cap:g} s"}
        tail = (stderr.strip().splitlines() or ["no output"])[-1]
        return {"tool": tool, "k": k, "status": f"error: {tail[:300]}",
                "elapsed_s": time.perf_counter() - start}
    return {**json.loads(lines[-1][len("@@record "):]), "status": status}


def cell(record: dict, target: float) -> str:
    got = record.get("targets", {}).get(f"{target:g}")
    if got is None:
        return record.get("status", "-") if record.get("status") != "ran" else "-"
    if got.get("status") != "ok":
        return got.get("status", "-")
    setting = got["setting"]
    knob = (f"rtol {setting['rtol']:.3g}" if "rtol" in setting else
            f"h {setting.get('timestep', setting.get('step')):.3g}")
    counts = ", ".join(f"{key} {got[key]}" for key in ("n_steps", "nfev", "njev", "nlu", "steps")
                       if key in got)
    return f"{got['cpu_s']:.3g} s ({knob}; {counts})"


def table(records: list[dict]) -> str:
    lines = ["| tool | k | CPU s at 1e-3 rad | CPU s at 1e-6 rad |", "|---|---|---|---|"]
    for r in records:
        lines.append(f"| {r['tool']} | {r['k']:g} | {cell(r, 1e-3)} | {cell(r, 1e-6)} |")
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--k", type=float, nargs="+", default=list(sc.STIFFNESSES))
    parser.add_argument("--tools", nargs="+", choices=TOOLS, default=TOOLS)
    parser.add_argument("--cap", type=float, default=90.0,
                        help="seconds per (tool, k), bisections and timing rounds")
    parser.add_argument("--n", type=int, default=sc.N, help="links of the chain")
    parser.add_argument("--out", type=Path, default=HERE / "results" / "stiff.json")
    parser.add_argument("--one", nargs=2, metavar=("TOOL", "K"), help=argparse.SUPPRESS)
    args = parser.parse_args()
    global LINKS
    LINKS = args.n
    if args.one:
        serve(args.one[0], float(args.one[1]), args.cap)
        return
    for k in args.k:  # the references first, outside the tools' caps
        reference_angles(k)
    started = time.time()
    records = []
    for k in args.k:
        for tool in args.tools:
            record = run_one(tool, k, args.cap)
            records.append(record)
            print(f"k={k:g} {tool}: 1e-3 {cell(record, 1e-3)} | 1e-6 {cell(record, 1e-6)}",
                  flush=True)
            args.out.parent.mkdir(parents=True, exist_ok=True)
            args.out.write_text(json.dumps(
                {"workload": __doc__.split("\n\n")[1].replace("\n", " "), "links": LINKS,
                 "cap_s": args.cap,
                 "targets_rad": list(TARGETS), "machine": machine(),
                 "started": time.strftime("%Y-%m-%d %H:%M:%S", time.localtime(started)),
                 "elapsed_s": time.time() - started,
                 "damping": {f"{k:g}": sc.damping_for(k, n=LINKS) for k in args.k},
                 "records": records}, indent=1) + "\n")
    print(table(records))


if __name__ == "__main__":
    main()
