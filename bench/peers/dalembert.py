"""dalembert: the chain in redundant coordinates.

The 3D (spherical) chain has 7 coordinates per link (center + Euler parameters)
and 4 constraints; the planar (revolute) chain is made of planar bodies (``x, y,
theta`` per link, in the x-y plane with gravity along -y) joined by 2-row pins,
as planar multibody codes (and Exudyn's 2D bodies) model it.

Build = ``chain(...)`` + derivation + code generation (``system.compiled``: one
link and two joint kinds derived and compiled, whatever ``n``). Cold = the model's
code not in the cache (a fresh ``DALEMBERT_CACHE_DIR``); warm = the same build
again in the same process, the compiled library found on disk. The C loop (the
sources in ``dalembert/solvers/native``) does not depend on the model and is compiled
once per machine, as an extension module would be at installation: it is timed first,
apart, as ``runtime_build_s``. The simulation is ``Multibody.simulate`` with its defaults
(DOP853 under PI step-size control, projection; the loop in C, see
``dalembert.solvers.native``), tolerances tightened from loose until the target is
met and then bisected to within 5% (``ladder.bisect``). One evaluation = one right-hand
side ``[qd, qdd]`` at the initial state (KKT blocks and their solve), from Python,
with the solver set up once as in a simulation.
"""

from __future__ import annotations

import os
import tempfile
import time
import warnings

import numpy as np

from .common import (
    ANGLE,
    T_END,
    centers,
    energy_error,
    meets,
    omega,
    tilt,
    time_call,
    warm_allowed,
)
from .ladder import Prepared, bisect

TOOL = "dalembert"
#: DOP853 relative tolerances tried in turn (atol = rtol / 100) to bracket the coarsest
#: one meeting the target, which ``ladder.bisect`` then narrows to 5%.
RTOLS = (1e-1, 3e-2, 1e-2, 3e-3, 1e-3, 3e-4, 1e-4, 3e-5, 1e-5, 3e-6, 1e-6, 1e-7, 1e-8, 1e-10,
         1e-12)


def versions() -> dict:
    import scipy
    import sympy

    import dalembert

    return {"dalembert": dalembert.__version__, "sympy": sympy.__version__,
            "numpy": np.__version__, "scipy": scipy.__version__}


def build(workload: str, n: int):
    from dalembert.multibody import chain

    start = time.perf_counter()
    mb = chain(n, 1.0, 1.0, 0.05, joint=workload, planar=workload == "revolute")
    mb.system.compiled  # derive and generate code now  # noqa: B018
    return mb, time.perf_counter() - start


def build_runtime() -> float:
    """Seconds to compile the model-independent C loop (once per machine, like an
    extension module built at installation; recorded apart from the model's build)."""
    from dalembert.solvers.native.library import runtime

    start = time.perf_counter()
    runtime()
    return time.perf_counter() - start


def initial_state(mb, workload: str, n: int):
    names = [b.name for b in mb.bodies]
    rot, w, c = tilt(), omega(workload), centers(n)
    if workload == "revolute":  # the x-z plane of the 3D chain is the x-y plane here
        return mb.initial_state(positions=dict(zip(names, c[:, [0, 2]])),
                                orientations=dict.fromkeys(names, -ANGLE))
    return mb.initial_state(
        positions=dict(zip(names, c)), orientations=dict.fromkeys(names, rot),
        velocities={k: np.cross(w, ck) for k, ck in zip(names, c)},
        angular_velocities=dict.fromkeys(names, w),
    )


def run(workload: str, n: int) -> dict:
    """The measured record: :func:`prepare`, then the bisection of the rtol."""
    with tempfile.TemporaryDirectory(prefix="dalembert-bench-") as cache:
        os.environ["DALEMBERT_CACHE_DIR"] = cache  # the first build is cold
        prepared = prepare(workload, n)
        return {**bisect(prepared), **prepared.info}


def prepare(workload: str, n: int) -> Prepared:
    """The model built (cold, then warm) and ``attempt(rtol)``; the code cache is
    ``DALEMBERT_CACHE_DIR`` (:func:`run` and the suite make it a fresh one)."""
    runtime_s = build_runtime()
    mb, cold = build(workload, n)
    warm = build(workload, n)[1] if warm_allowed(cold) else None
    q0, qd0 = initial_state(mb, workload, n)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # rounding-level projection of q0
        plan = mb.system.plan((0.0, T_END), q0, qd0, method="DOP853")  # as a run
    y = plan.y0
    rhs = plan.start().rhs
    eval_s = time_call(lambda: rhs(0.0, y))

    def attempt(rtol: float) -> dict:
        start, cpu = time.perf_counter(), time.process_time()
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # rounding-level projection of q0
            traj = mb.simulate((0.0, T_END), q0, qd0, method="DOP853", rtol=rtol,
                               atol=rtol / 100, t_eval=np.linspace(0.0, T_END, 101))
        simulate_s, cpu_s = time.perf_counter() - start, time.process_time() - cpu
        return {
            "setting": {"method": "DOP853", "rtol": rtol, "atol": rtol / 100,
                        "step_control": "PI", "stabilization": "projection",
                        "loop": "C" if plan.loop == "c" else "Python"},
            "simulate_s": simulate_s, "cpu_s": cpu_s, "evaluations": int(traj.stats["nfev"]),
            "energy_error": energy_error(traj.energy[0], traj.energy[-1], n),
            "initial_energy": float(traj.energy[0]),
            "residual": float(traj.position_residual.max()),
            "velocity_residual": float(traj.velocity_residual.max()),
            "finished": traj.status == "finished" if isinstance(traj.status, str)
            else bool(traj.status == 0),
        }

    coords = len(mb.system.coordinate_names)
    info = dict(build_s=cold, build_warm_s=warm, eval_s=eval_s, coordinates=coords,
                  constraints=len(mb.system.constraint_names), runtime_build_s=runtime_s,
                  build_note="cold: the model's code not cached (the C loop, which does "
                             "not depend on the model, compiled before: runtime_build_s, once "
                             "per machine); warm: rebuilt in the same process, the compiled "
                             "library loaded from the disk cache")
    return Prepared(info, attempt, RTOLS, meets)
