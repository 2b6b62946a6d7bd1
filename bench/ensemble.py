"""Ensemble throughput: many runs of the 16-link 3D chain, serial, threads, Dask, MuJoCo.

Workload: the suite's 16-link chain of solid cylinders (1 m, r = 5 cm) on spherical
joints, each link with its own mass (``m1 .. m16`` uniform in [0.8, 1.2] kg, one
parameter per link: one build, no compile per case), tilted as a whole by an angle
uniform in [20, 40] degrees and turning at 0.2 rad/s about x (the suite's start),
10 s simulated, output at 101 times. The cases are drawn with
``dalembert.ensemble.sample(..., seed=17)``. The solver is dalembert's cheapest that
meets the suite's energy target (``|E(10) - E(0)| / (E(0) - E_rest) <= 1e-6``) on every
case of a sample of 40: for each method of ``METHODS`` the coarsest rtol that meets it,
bracketed by ``RTOLS`` and bisected to within 5% (``peers/ladder.py``), and of these the
one whose cases took the least CPU time (as MuJoCo gets its largest step that meets it,
bisected alike); the energy error of every case run is reported.

Parts (``--part``):

- ``throughput``: N cases (1000; ``--quick``: 60) as a plain loop over
  ``simulate`` (the reference), ``simulate_many`` serially, on 2 threads (and on 2
  threads keeping only the states and the energy, ``threads-2-states``: MuJoCo's
  rollout gives the states, neither multipliers nor constraint forces), on a
  Dask ``LocalCluster`` of 1 and of 2 single-threaded processes, and with MuJoCo's
  ``rollout`` (one ``MjModel`` per case with its link masses and inertias, the
  initial state of each case, both made within its time as dalembert's ensemble binds
  each case's masses and runs its ``initial_state`` within its own; 2 threads; the
  largest RK4 step at which every case of the sample meets the target, bracketed by the
  suite's ladder, 2e-2 down by factors of 2^(1/3), and bisected to within 5%). Wall and
  CPU seconds (CPU: this process's threads, and a Dask cluster's worker processes; the
  figure to trust on a loaded machine). Runs per second, the speed-up over the plain
  loop, the parallel efficiency (speed-up / workers) and the overhead per case of
  the ensemble machinery. The ways run in rounds (``--rounds``, 5): each round runs
  its share of the cases every way, in an order turned by one each round, so a
  spell of a slower machine falls on every way alike; ratios are given from the
  totals and as the median of the rounds' ratios. A cluster's start and its
  workers' first preparation of the model (import, unpack, load the shipped code)
  are timed apart: they are paid once per cluster and model. The ensemble's own
  time (wall time x workers - the cases' own) is split by the cases' timeline
  (:func:`timeline`) into what each case adds and what each call adds; the rounds
  make five calls of the cases, so each way also runs all of them in one call
  (``whole``), as one ensemble of N cases, whose own time is the target's measure.
- ``scaling``: 10, 100, 1000, 10000 cases (``--quick``: 10, 100) of 1 s simulated
  (not 10: the ensemble's own costs weigh ten times more against a case) on 2 Dask
  processes, results to a Zarr store, each size in a fresh client process: time per
  case, the client's peak memory, the store's size.

Usage: ``python bench/ensemble.py [--quick] [--part all|throughput|scaling]``
writes ``bench/results/ensemble.json`` (``--quick``: ``ensemble_quick.json``) and its
plot (``--plot`` only redraws it).
"""

from __future__ import annotations

import argparse
import copy
import json
import math
import os
import platform
import subprocess
import sys
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))  # peers/ (MuJoCo's model and ladder), however this is run
N_LINKS, L, R, G = 16, 1.0, 0.05, 9.81
OMEGA = 0.2
T_END = 10.0
ENERGY_TARGET = 1e-6
SEED = 17
#: Tolerances tried (atol = rtol / 100), as the suite's ladder, for each method.
RTOLS = (1e-3, 3e-4, 1e-4, 3e-5, 1e-5, 3e-6, 1e-6)
#: What the ``threads-2-states`` way keeps: the states, as MuJoCo's rollout gives them
#: (and the energy, for the accuracy; MuJoCo's is computed outside its time), without
#: the multipliers and constraint forces the other ways keep (MuJoCo computes neither).
STATES = ("q", "qd", "energy")
#: dalembert's explicit methods that run in C (RK23 needs ~4x DOP853's evaluations here).
METHODS = ("DOP853", "RK45")
#: Seconds simulated per case in the scaling part: a tenth of the workload's span, so
#: that 10,000 cases fit in minutes and the ensemble's own costs weigh ten times more.
SCALING_T_END = 1.0
#: One BLAS thread per process, as the suite runs every tool: the threads, processes
#: and MuJoCo's threads are the parallelism measured here (set before NumPy loads, by
#: running the script again with them).
SINGLE_THREAD = {k: "1" for k in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS",
                                  "MKL_NUM_THREADS")}


# -- the model and the cases ------------------------------------------------------------
def link_mass_chain(n: int = N_LINKS):
    """The chain with one mass parameter per link (``m1 .. mn``, default 1 kg)."""
    import sympy as sp

    from dalembert.multibody import Ground, Multibody, RigidBody, Spherical

    masses = sp.symbols(f"m1:{n + 1}", positive=True)
    links = [RigidBody(f"link{k + 1}", m, (m * (3 * R**2 + L**2) / 12,
                                           m * (3 * R**2 + L**2) / 12, m * R**2 / 2))
             for k, m in enumerate(masses)]
    joints = [Spherical(f"joint{k + 1}", parent, child, (0, 0, 0) if k == 0 else (0, 0, -L / 2),
                        (0, 0, L / 2))
              for k, (parent, child) in enumerate(zip([Ground(), *links[:-1]], links))]
    return Multibody(links, joints, gravity=(0, 0, -G), name=f"{n}-link chain",
                     parameters=dict.fromkeys(masses, 1.0))


def tilt(angle: float) -> np.ndarray:
    c, s = np.cos(angle), np.sin(angle)
    return np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])


def make_initial(mb):
    """``initial_state(case)``: the chain straight, tilted by the case's angle, turning."""
    names = [b.name for b in mb.bodies]
    w = np.array([OMEGA, 0.0, 0.0])

    def initial(case: dict) -> tuple[dict, dict]:
        rot = tilt(np.radians(case["angle"]))
        centers = np.outer(np.arange(len(names)) + 0.5, rot @ np.array([0.0, 0.0, -L]))
        return mb.initial_state(positions=dict(zip(names, centers)),
                                orientations=dict.fromkeys(names, rot),
                                velocities=dict(zip(names, np.cross(w, centers))),
                                angular_velocities=dict.fromkeys(names, w))

    return initial


def draw_cases(n: int):
    from scipy import stats

    from dalembert.ensemble import sample

    dist = {f"m{k + 1}": stats.uniform(0.8, 0.4) for k in range(N_LINKS)}
    dist["angle"] = stats.uniform(20.0, 20.0)
    return sample(dist, n, seed=SEED)


def masses(cases) -> np.ndarray:
    return cases[[f"m{k + 1}" for k in range(N_LINKS)]].to_numpy()


def rest_energy(m: np.ndarray) -> np.ndarray:
    """``V`` of each case's chain hanging straight down (link k's center at -(k-1/2) L)."""
    return -G * L * (m * (np.arange(N_LINKS) + 0.5)).sum(axis=-1)


def energy_errors(energy: np.ndarray, m: np.ndarray) -> np.ndarray:
    """The suite's relative energy error per case from ``energy`` (cases x times)."""
    return np.abs(energy[:, -1] - energy[:, 0]) / np.abs(energy[:, 0] - rest_energy(m))


def load_average() -> float:
    return os.getloadavg()[0]


def peak_memory_mb() -> float:
    for line in Path("/proc/self/status").read_text().splitlines():
        if line.startswith("VmHWM:"):
            return float(line.split()[1]) / 1024.0
    return float("nan")


# -- dalembert --------------------------------------------------------------------------
def choose_solver(mb, initial, cases) -> tuple[dict, list[dict]]:
    """``simulate``'s method, rtol and atol: for each method the coarsest rtol (within
    5%: ``peers.ladder.bisect``, bracketed by ``RTOLS``) at which every case of ``cases``
    meets the energy target, and of these the one whose cases took the least CPU time;
    every setting tried is listed."""
    from peers.ladder import Prepared, bisect

    tried, passed = [], []
    mb.system.simulate_many((0.0, T_END), cases.iloc[:2], initial_state=initial,
                            scheduler="serial", progress=False)  # untimed: loads the code
    for method in METHODS:
        def attempt(rtol: float, method: str = method) -> dict:
            solver = {"method": method, "rtol": rtol, "atol": rtol / 100}
            start = time.process_time()
            result = mb.system.simulate_many((0.0, T_END), cases, initial_state=initial,
                                             keep=("energy",), scheduler="serial",
                                             progress=False, **solver)
            cpu = time.process_time() - start
            errors = energy_errors(result.dataset["energy"].values, masses(cases))
            row = {**solver, "worst_energy_error": float(errors.max()),
                   "median_energy_error": float(np.median(errors)),
                   "nfev_mean": float(result.summary["nfev"].mean()),
                   "case_seconds": case_seconds(result), "cpu_s": cpu}
            tried.append(row)
            return {"setting": solver, "energy_error": row["worst_energy_error"],
                    "simulate_s": row["case_seconds"], "cpu_s": cpu, "row": row}

        found = bisect(Prepared({}, attempt, RTOLS,
                                lambda r: r["energy_error"] <= ENERGY_TARGET))
        if found["accepted"]:
            found["row"].update(kept=True, bracket=found["bracket"])  # marked in ``tried``
            passed.append(found["row"])
    if not passed:
        raise RuntimeError(f"no method in {METHODS} met the energy target: {tried}")
    best = min(passed, key=lambda row: row["cpu_s"])  # CPU: the work, whatever the load
    return {k: best[k] for k in ("method", "rtol", "atol")}, tried


def plain_loop(mb, initial, cases, solver: dict) -> tuple[float, float, np.ndarray]:
    """The reference: ``simulate`` in a loop, each trajectory kept (wall and CPU
    seconds, energies)."""
    t_eval = np.linspace(0.0, T_END, 101)
    kept = []
    start, cpu = time.perf_counter(), time.process_time()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # rounding-level projection of q0
        for row in cases.to_dict("records"):
            q0, qd0 = initial(row)
            kept.append(mb.system.simulate(
                (0.0, T_END), q0, qd0, parameters={k: v for k, v in row.items() if k != "angle"},
                t_eval=t_eval, **solver))
    seconds, cpu = time.perf_counter() - start, time.process_time() - cpu
    return seconds, cpu, np.array([traj.energy for traj in kept])


def cpu_seconds(client=None) -> float:
    """CPU seconds of this process so far (all its threads), plus those of ``client``'s
    worker processes when given."""
    own = time.process_time()
    return own if client is None else own + sum(client.run(time.process_time).values())


def ensemble_run(mb, initial, cases, solver: dict, **how) -> tuple[float, object]:
    """Seconds of one ``simulate_many`` call and its result; ``result.call`` holds the
    call's start and end on the clock of the cases' ``started`` (for :func:`timeline`),
    ``result.cpu_s`` the CPU seconds it took (this process and any Dask workers)."""
    cpu = cpu_seconds(how.get("client"))
    start, clock = time.perf_counter(), time.time()
    result = mb.system.simulate_many((0.0, T_END), cases, initial_state=initial,
                                     progress=False, **solver, **how)
    result.call = (clock, time.time())
    seconds = time.perf_counter() - start
    result.cpu_s = cpu_seconds(how.get("client")) - cpu
    return seconds, result


def timeline(result) -> dict:
    """Where a call's time went beside its cases, in seconds summed over the lanes that
    ran cases side by side (a worker process, or a thread of one): ``head``, from the
    call to each lane's first case (the cases read and checked, the model packed, the
    first batch sent); ``gaps``, between a lane's consecutive cases (the batches'
    hand-over and arrays, a task's overhead); ``tail``, from each lane's last case to
    the call's return (the last results received, a lane waiting for the others, the
    dataset and summary made). With the cases' own time they add up to the call's wall
    time x lanes."""
    start, end = result.call
    summary = result.summary
    began = summary["started"].map(lambda t: t.timestamp()).to_numpy()
    took = summary["seconds"].to_numpy()
    head = gaps = tail = 0.0
    for _, rows in summary.groupby("worker").indices.items():
        lanes: list[list[int]] = []  # threads of one process: cases that overlap
        for i in sorted(rows, key=lambda i: began[i]):
            free = [lane for lane in lanes if began[lane[-1]] + took[lane[-1]] <= began[i] + 1e-4]
            if free:
                max(free, key=lambda lane: began[lane[-1]]).append(i)
            else:
                lanes.append([i])
        for lane in lanes:
            first, last = began[lane], began[lane] + took[lane]
            head += first[0] - start
            gaps += float(np.sum(first[1:] - last[:-1]))
            tail += end - last[-1]
    return {"head_s": head, "gaps_s": gaps, "tail_s": tail}


def case_seconds(result) -> float:
    """The time the cases themselves took where they ran (set-up, ``simulate``, what is
    kept), summed: the rest of a run's time is the ensemble's own overhead."""
    return float(result.summary["seconds"].sum())


def local_cluster(mb, initial, solver: dict, workers: int):
    """A Dask ``LocalCluster`` of ``workers`` single-threaded processes and its client,
    each worker's first preparation of the model done (it is paid once per cluster and
    model, timed apart)."""
    import logging

    from distributed import Client, LocalCluster

    start = time.perf_counter()
    cluster = LocalCluster(n_workers=workers, threads_per_worker=1, processes=True,
                           dashboard_address=None, silence_logs=logging.ERROR)
    client = Client(cluster)
    started = time.perf_counter() - start
    warm = draw_cases(2 * workers)
    warm_s, _ = ensemble_run(mb, initial, warm, solver, client=client, batch_size=1)
    return cluster, client, {"cluster_start_s": started, "first_cases_s": warm_s,
                             "first_cases": len(warm)}


def throughput(n: int, rounds: int) -> dict:
    """Every way of running the cases, MuJoCo's rollout included, in ``rounds`` rounds:
    each round runs its share of the cases every way, in an order turned by one each
    round, so that a spell of a slower machine (frequent on shared cores) falls on
    every way alike; the ratios are taken within each round and their median reported
    beside the ratio of the totals."""
    start = time.perf_counter()
    mb = link_mass_chain()
    mb.system.compiled  # noqa: B018
    build_s = time.perf_counter() - start
    initial = make_initial(mb)
    solver, ladder = choose_solver(mb, initial, draw_cases(40))
    dt, mujoco_ladder = mujoco_step()
    cases = draw_cases(n)
    mujoco = MujocoCases(cases, dt)
    shares = np.array_split(np.arange(n), rounds)
    record: dict = {"cases": n, "rounds": rounds, **solver, "ladder": ladder,
                    "build_s": build_s, "runs": {}}
    mujoco_record = {"version": mujoco.version, "ladder": mujoco_ladder, "dt": dt}

    def loop(part):
        seconds, cpu, energies = plain_loop(mb, initial, part, solver)
        return (seconds, cpu, energy_errors(energies, masses(part))), {}

    def many(**how):
        def run(part):
            seconds, result = ensemble_run(mb, initial, part, solver, **how)
            errors = energy_errors(result.dataset["energy"].values, masses(part))
            return (seconds, result.cpu_s, errors), {"case_seconds": case_seconds(result),
                                                     **timeline(result)}
        return run

    def on_cluster(workers: int):
        def run(part):
            cluster, client, started = local_cluster(mb, initial, solver, workers)
            try:
                done, extra = many(client=client)(part)
            finally:
                client.close()
                cluster.close()
            return done, {**extra, **started}
        return run

    def rollout(part):
        cpu = time.process_time()  # the rollout's threads are this process's
        seconds, prepare, errors = mujoco.rollout(part.index.to_numpy())
        # the energies measured after the rollout are in the CPU time: ~1% of it
        return (seconds, time.process_time() - cpu, errors), {"prepare_s": prepare}

    ways = {"loop": (loop, 1), "serial": (many(scheduler="serial"), 1),
            "threads-2": (many(scheduler="threads", workers=2), 2),
            "threads-2-states": (many(scheduler="threads", workers=2, keep=STATES), 2),
            "dask-1": (on_cluster(1), 1), "dask-2": (on_cluster(2), 2),
            "mujoco-2": (rollout, 2)}
    names = list(ways)
    seconds = {k: np.zeros(rounds) for k in names}
    cpu = {k: np.zeros(rounds) for k in names}
    errors = {k: np.zeros(n) for k in names}
    extras: dict[str, dict] = {k: {} for k in names}
    for r, share in enumerate(shares):
        part = cases.iloc[share]
        for name in names[r % len(names):] + names[: r % len(names)]:
            (seconds[name][r], cpu[name][r], errors[name][share]), extra = \
                ways[name][0](part)
            for key, value in extra.items():
                extras[name][key] = extras[name].get(key, 0.0) + value
        print(f"round {r + 1}/{rounds}: " + ", ".join(
            f"{k} {len(share) / seconds[k][r]:.1f} ({len(share) / cpu[k][r]:.1f} per CPU s)"
            for k in names) + " runs/s", flush=True)
    for name in names:
        total = float(seconds[name].sum())
        record["runs"][name] = {
            "seconds": total, "runs_per_s": n / total, "workers": ways[name][1],
            "round_seconds": seconds[name].tolist(),
            "cpu_seconds": float(cpu[name].sum()), "runs_per_cpu_s": n / cpu[name].sum(),
            "round_cpu_seconds": cpu[name].tolist(),
            "speedup": float(seconds["loop"].sum() / total),
            "speedup_median_of_rounds": float(np.median(seconds["loop"] / seconds[name])),
            "worst_energy_error": float(errors[name].max()),
            "median_energy_error": float(np.median(errors[name])), **extras[name]}
        run = record["runs"][name]
        run["efficiency"] = run["speedup"] / run["workers"]
        print(f"{name}: {total:.1f} s, {n / total:.1f} runs/s; CPU {cpu[name].sum():.1f} s",
              flush=True)
    record["against_mujoco"] = {
        "dask-2": float(seconds["mujoco-2"].sum() / seconds["dask-2"].sum()),
        "dask-2_median_of_rounds": float(np.median(seconds["mujoco-2"] / seconds["dask-2"])),
        "threads-2": float(seconds["mujoco-2"].sum() / seconds["threads-2"].sum()),
        "threads-2_median_of_rounds": float(np.median(seconds["mujoco-2"]
                                                      / seconds["threads-2"])),
        # at equal outputs: the states (and the energy), as MuJoCo's rollout gives them
        "threads-2-states": float(seconds["mujoco-2"].sum()
                                  / seconds["threads-2-states"].sum()),
        "threads-2-states_median_of_rounds": float(np.median(
            seconds["mujoco-2"] / seconds["threads-2-states"])),
        # MuJoCo's rollout calls alone, without making the cases' models and states
        "threads-2_rollout_only": float((seconds["mujoco-2"].sum()
                                         - extras["mujoco-2"]["prepare_s"])
                                        / seconds["threads-2"].sum())}
    # CPU seconds: the work done, whatever the machine's load (the figure to trust on
    # shared cores); Dask's include its workers' processes
    record["against_mujoco_cpu"] = {
        name: float(cpu["mujoco-2"].sum() / cpu[name].sum())
        for name in ("loop", "serial", "threads-2", "threads-2-states", "dask-1", "dask-2")}
    record["against_mujoco_cpu"].update({
        f"{name}_median_of_rounds": float(np.median(cpu["mujoco-2"] / cpu[name]))
        for name in ("threads-2", "threads-2-states", "dask-2")})
    mujoco_record["run"] = {**record["runs"].pop("mujoco-2"), "dt": dt,
                            "steps": round(T_END / dt), "threads": 2}
    # The ensemble's own time per case (wall x workers - the cases' own time), against a
    # case's simulation: less sensitive to the machine's load than two totals' difference.
    record["overhead_per_case"] = {}
    for name in ("serial", "threads-2", "dask-1", "dask-2"):
        run = record["runs"][name]
        own = run["seconds"] * run["workers"] - run["case_seconds"]
        record["overhead_per_case"][name] = {"seconds": own / n,
                                             "of_case": own / run["case_seconds"]}
        # split: what each case adds (gaps) and what each call adds (head and tail)
        record["overhead_per_case"][name].update(
            gaps_of_case=run["gaps_s"] / run["case_seconds"],
            per_call_s=(run["head_s"] + run["tail_s"]) / rounds)
    record["overhead_per_case"]["serial_vs_loop"] = (record["runs"]["serial"]["seconds"]
                                                     / record["runs"]["loop"]["seconds"] - 1)
    # All the cases as one ensemble, one call each way: the rounds split them into
    # `rounds` calls, each paying a call's own head and tail; an ensemble pays them once.
    record["whole"] = {}
    for name in ("serial", "threads-2", "dask-1", "dask-2"):
        (seconds_, cpu_, errors_), extra = ways[name][0](cases)
        own = seconds_ * ways[name][1] - extra["case_seconds"]
        record["whole"][name] = {"seconds": seconds_, "runs_per_s": n / seconds_,
                                 "cpu_seconds": cpu_,
                                 "speedup": record["runs"]["loop"]["seconds"] / seconds_,
                                 "own_s": own, "own_of_case": own / extra["case_seconds"],
                                 "gaps_of_case": extra["gaps_s"] / extra["case_seconds"],
                                 "worst_energy_error": float(errors_.max()), **extra}
        print(f"whole, {name}: {n / seconds_:.1f} runs/s, own time "
              f"{100 * own / extra['case_seconds']:.1f}% of the cases'", flush=True)
    fastest = max(("serial", "threads-2", "dask-1", "dask-2"),
                  key=lambda name: record["runs"][name]["runs_per_s"])
    record["best"] = {"way": fastest, "speedup": record["runs"][fastest]["speedup"],
                      "speedup_median_of_rounds":
                          record["runs"][fastest]["speedup_median_of_rounds"]}
    record["preparation_s"] = preparation_seconds(mb)
    return {"throughput": record, "mujoco": mujoco_record}


def preparation_seconds(mb) -> dict:
    """A fresh process preparing the package: with an empty code cache (the shipped
    libraries installed) and, for comparison, compiling the model itself."""
    import pickle

    from dalembert.ensemble.model import package

    pack = package(mb.system)
    out = {}
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "pack.pkl"
        path.write_bytes(pickle.dumps(pack))
        script = ("import pickle, sys, time; t = time.perf_counter(); import dalembert.ensemble"
                  ".model as m; i = time.perf_counter(); p = pickle.load(open(sys.argv[1], 'rb'))"
                  "; {}; print(i - t, time.perf_counter() - i)")
        for name, action in (("shipped", "m.preparation_seconds(p)"),
                             ("compiled_there", "p = type(p)(p.token, p.system, ()); "
                                                "m.preparation_seconds(p)")):
            env = {**os.environ, "DALEMBERT_CACHE_DIR": str(Path(folder) / name)}
            done = subprocess.run([sys.executable, "-c", script.format(action), str(path)],
                                  capture_output=True, text=True, env=env, check=True)
            imported, prepared = map(float, done.stdout.split())
            out[name] = {"import_s": imported, "prepare_s": prepared}
    out["package_kb"] = pack.size / 1024
    return out


# -- MuJoCo -----------------------------------------------------------------------------
def mujoco_models(cases, dt: float):
    """One ``MjModel`` per case (its link masses and inertias) and its initial states."""
    import mujoco
    from peers.mujoco import spec

    base = spec("spherical", N_LINKS, dt).compile()
    m = masses(cases)
    models, states = [], []
    data = mujoco.MjData(base)
    size = mujoco.mj_stateSize(base, mujoco.mjtState.mjSTATE_FULLPHYSICS)
    for k, row in enumerate(cases.to_dict("records")):
        model = copy.copy(base)
        for j in range(N_LINKS):
            mass = m[k, j]
            model.body_mass[j + 1] = mass
            model.body_inertia[j + 1] = [mass * (3 * R**2 + L**2) / 12,
                                         mass * (3 * R**2 + L**2) / 12, mass * R**2 / 2]
        mujoco.mj_resetData(model, data)
        rot = tilt(np.radians(row["angle"]))
        quat = np.zeros(4)
        mujoco.mju_mat2Quat(quat, rot.ravel())
        data.qpos[:4] = quat
        data.qvel[:3] = rot.T @ np.array([OMEGA, 0.0, 0.0])  # ball joint: body frame
        state = np.empty(size)
        mujoco.mj_getState(model, data, state, mujoco.mjtState.mjSTATE_FULLPHYSICS)
        models.append(model)
        states.append(state)
    return models, np.array(states)


def mujoco_energies(models, states) -> np.ndarray:
    """``T + V`` of each model at each state (the energy flag on for this only: the
    models roll out with it off, :func:`peers.mujoco.energy`)."""
    import mujoco
    from peers.mujoco import energy

    data = mujoco.MjData(models[0])
    out = np.empty(len(models))
    for k, (model, state) in enumerate(zip(models, states)):
        mujoco.mj_setState(model, data, state, mujoco.mjtState.mjSTATE_FULLPHYSICS)
        out[k] = energy(model, data)
    return out


class MujocoCases:
    """The cases as MuJoCo models (one ``MjModel`` per case: its link masses and
    inertias) with their initial states, rolled out ``T_END / dt`` RK4 steps."""

    def __init__(self, cases, dt: float, threads: int = 2) -> None:
        import mujoco

        self.version = mujoco.__version__
        self.steps = math.ceil(T_END / dt - 1e-9)  # the span exactly, at a step <= dt
        self.cases, self.dt, self.threads = cases, T_END / self.steps, threads

    def rollout(self, rows: np.ndarray, chunk: int = 100) -> tuple[float, float, np.ndarray]:
        """Seconds of running the cases at positions ``rows``: making their models and
        initial states (as dalembert's ensemble binds each case's masses and runs its
        ``initial_state`` in its time), then the rollout calls (in chunks of ``chunk``
        cases: rollout returns every step's state); the first part's seconds alone; and
        each case's energy error (``nan`` where it diverged)."""
        import mujoco
        from mujoco import rollout

        start = time.perf_counter()
        models, initial = mujoco_models(self.cases.iloc[rows], self.dt)
        prepare = time.perf_counter() - start
        datas = [mujoco.MjData(models[0]) for _ in range(self.threads)]
        final = np.empty_like(initial)
        seconds = prepare
        with rollout.Rollout(nthread=self.threads) as runner:
            for a in range(0, len(models), chunk):
                start = time.perf_counter()
                state, _ = runner.rollout(models[a:a + chunk], datas, initial[a:a + chunk],
                                          nstep=self.steps)
                seconds += time.perf_counter() - start
                final[a:a + chunk] = state[:, -1]
        e0, e1 = mujoco_energies(models, initial), mujoco_energies(models, final)
        errors = np.abs(e1 - e0) / np.abs(e0 - rest_energy(masses(self.cases.iloc[rows])))
        return seconds, prepare, np.where(np.isfinite(errors), errors, np.nan)


def mujoco_step() -> tuple[float, list[dict]]:
    """The largest RK4 step at which every case of a sample of 40 meets the energy
    target, within 5% (``peers.ladder.bisect``, bracketed by the suite's ladder,
    peers/mujoco.py); every step tried is listed."""
    from peers.ladder import Prepared, bisect
    from peers.mujoco import STEPS

    sample = draw_cases(40)
    ladder = []

    def attempt(dt: float) -> dict:
        cases = MujocoCases(sample, dt)
        start = time.process_time()
        _, _, errors = cases.rollout(np.arange(len(sample)))
        cpu = time.process_time() - start
        worst = float(np.max(errors)) if np.all(np.isfinite(errors)) else float("inf")
        ladder.append({"dt": cases.dt, "worst_energy_error": worst,
                       "median_energy_error": float(np.median(errors)), "cpu_s": cpu})
        return {"setting": {"dt": cases.dt}, "energy_error": worst, "cpu_s": cpu}

    found = bisect(Prepared({}, attempt, STEPS, lambda r: r["energy_error"] <= ENERGY_TARGET))
    if not found["accepted"]:
        raise RuntimeError(f"no MuJoCo step met the energy target: {ladder}")
    return found["setting"]["dt"], ladder


# -- scaling ----------------------------------------------------------------------------
def scaling_one(n: int, folder: str) -> dict:
    """``n`` cases of ``SCALING_T_END`` seconds on 2 Dask processes into a Zarr store (run
    in a fresh process)."""
    import logging

    from distributed import Client, LocalCluster

    mb = link_mass_chain()
    initial = make_initial(mb)
    solver = json.loads(os.environ["BENCH_SOLVER"])
    cluster = LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                           dashboard_address=None, silence_logs=logging.ERROR)
    client = Client(cluster)
    ensemble_run(mb, initial, draw_cases(4), solver, client=client, batch_size=1)  # warm
    before = peak_memory_mb()
    store = Path(folder) / f"run{n}.zarr"
    start = time.perf_counter()
    result = mb.system.simulate_many((0.0, SCALING_T_END), draw_cases(n),
                                     initial_state=initial, client=client, store=store,
                                     keep=("q", "energy"), progress=False, **solver)
    seconds = time.perf_counter() - start
    band = result.quantile("q", [0.05, 0.5, 0.95], coordinate=f"link{N_LINKS}_x")
    client.close()
    cluster.close()
    size = sum(p.stat().st_size for p in store.rglob("*") if p.is_file())
    return {"cases": n, "t_end": SCALING_T_END, "seconds": seconds, "per_case_s": seconds / n,
            "case_seconds": float(result.summary["seconds"].sum()),
            "client_peak_mb_before": before, "client_peak_mb": peak_memory_mb(),
            "store_mb": size / 2**20, "failed": len(result.failed),
            "band_shape": list(band.shape), "load_average": load_average()}


def scaling(sizes: list[int], solver: dict) -> list[dict]:
    out = []
    with tempfile.TemporaryDirectory() as folder:
        for n in sizes:
            done = subprocess.run([sys.executable, __file__, "--scaling-one", str(n), folder],
                                  capture_output=True, text=True,
                                  env={**os.environ, "BENCH_SOLVER": json.dumps(solver)})
            if done.returncode != 0:
                raise RuntimeError(done.stderr[-2000:])
            out.append(json.loads(done.stdout.strip().splitlines()[-1]))
            print(f"scaling {n}: {out[-1]['per_case_s'] * 1e3:.1f} ms per case, client peak "
                  f"{out[-1]['client_peak_mb']:.0f} MB", flush=True)
    return out


# -- plot -------------------------------------------------------------------------------
def plot(record: dict, out: Path) -> Path:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(11, 4))
    runs = record.get("throughput", {}).get("runs", {})
    names = list(runs)
    rates = [runs[k]["runs_per_s"] for k in names]
    if "mujoco" in record:
        names.append("MuJoCo rollout (2 threads)")
        rates.append(record["mujoco"]["run"]["runs_per_s"])
    axes[0].barh(names, rates, color=["C0"] * len(runs) + ["C2"] * (len(names) - len(runs)))
    axes[0].set_xlabel("runs per second (16-link 3D chain, 10 s)")
    axes[0].invert_yaxis()
    for y, r in enumerate(rates):
        axes[0].text(r, y, f" {r:.1f}", va="center")
    scaled = record.get("scaling", [])
    if scaled:
        n = [s["cases"] for s in scaled]
        axes[1].semilogx(n, [1e3 * s["per_case_s"] for s in scaled], "o-", label="ms per case")
        axes[1].set_xlabel("cases (2 Dask processes, results to Zarr)")
        axes[1].set_ylabel("ms per case")
        twin = axes[1].twinx()
        twin.semilogx(n, [s["client_peak_mb"] for s in scaled], "s--", color="C1",
                      label="client peak memory (MB)")
        twin.semilogx(n, [s["store_mb"] for s in scaled], "^:", color="C3",
                      label="store on disk (MB)")
        twin.set_yscale("log")
        twin.set_ylabel("MB")
        lines = axes[1].get_lines() + twin.get_lines()
        axes[1].legend(lines, [ln.get_label() for ln in lines], loc="upper center")
        axes[1].set_ylim(bottom=0)
    fig.tight_layout()
    fig.savefig(out, dpi=110)
    return out


def main() -> None:
    if any(os.environ.get(k) != v for k, v in SINGLE_THREAD.items()):
        os.execve(sys.executable, [sys.executable, __file__, *sys.argv[1:]],
                  {**os.environ, **SINGLE_THREAD})
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true")
    parser.add_argument("--part", default="all",
                        choices=["all", "throughput", "scaling"])
    parser.add_argument("--rounds", type=int, default=5,
                        help="throughput: rounds over the ways of running (default 5)")
    parser.add_argument("--cases", type=int,
                        help="throughput: this many cases (default 1000; quick 60)")
    parser.add_argument("--plot", action="store_true", help="only redraw the plot")
    parser.add_argument("--sizes", type=int, nargs="+", help="scaling: these case counts")
    parser.add_argument("--scaling-one", nargs=2, help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.scaling_one:
        print(json.dumps(scaling_one(int(args.scaling_one[0]), args.scaling_one[1])))
        return
    out = HERE / "results" / ("ensemble_quick.json" if args.quick else "ensemble.json")
    record = json.loads(out.read_text()) if out.exists() else {}
    if not args.plot:
        n = args.cases or (60 if args.quick else 1000)
        record.setdefault("machine", {}).update(cpus=os.cpu_count(),
                                                python=platform.python_version())
        if args.part in ("all", "throughput"):
            record.update(throughput(n, 2 if args.quick else args.rounds))
            out.write_text(json.dumps(record, indent=1))  # each part as it is done
        if args.part in ("all", "scaling"):
            record["scaling"] = scaling(args.sizes or ([10, 100] if args.quick else
                                                       [10, 100, 1000, 10000]),
                                        {"method": "DOP853", **{  # older records: DOP853
                                            k: v for k, v in record["throughput"].items()
                                            if k in ("method", "rtol", "atol")}})
            out.write_text(json.dumps(record, indent=1))
    print(f"wrote {out} and {plot(record, out.with_suffix('.png'))}")


if __name__ == "__main__":
    main()
