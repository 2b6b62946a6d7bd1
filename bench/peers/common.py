"""The standard workload and the accuracy target shared by every peer.

An ``n``-link chain of identical uniform solid cylinders (mass ``M``, length
``L``, radius ``R``) hung from a fixed pivot at the origin, gravity ``-G z``.
Every link starts tilted ``ANGLE`` about the world ``y`` axis (all in the x-z
plane, the chain straight). The 3D (spherical) chain also starts turning as a
whole about the world ``x`` axis at ``OMEGA`` rad/s (the out-of-plane velocity);
the planar (revolute, hinge axes along ``y``) chain starts at rest, since it
cannot move out of its plane.

Energy error is ``|E(T) - E(0)| / (E(0) - E_rest)``: the drift measured against
the energy of the motion (``E_rest`` is the chain hanging at rest), so it does not
depend on where the potential is zero.
"""

from __future__ import annotations

import numpy as np

M, L, R, G = 1.0, 1.0, 0.05, 9.81
ANGLE = np.radians(30.0)
OMEGA = 0.2
T_END = 10.0
ENERGY_TARGET = 1e-6
RESIDUAL_TARGET = 1e-10
#: Principal inertia about the center: transverse (x, y) and axial (z).
I_T = M * (3 * R**2 + L**2) / 12
I_A = M * R**2 / 2


def tilt() -> np.ndarray:
    """Rotation (body -> world) of every link at the start: ``ANGLE`` about ``y``."""
    c, s = np.cos(ANGLE), np.sin(ANGLE)
    return np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])


def omega(workload: str) -> np.ndarray:
    """World angular velocity shared by all links at the start."""
    return np.array([OMEGA if workload == "spherical" else 0.0, 0.0, 0.0])


def centers(n: int) -> np.ndarray:
    """Mass centers ``(n, 3)`` at the start (link axis along its body ``-z``)."""
    down = tilt() @ np.array([0.0, 0.0, -L])
    return np.outer(np.arange(n) + 0.5, down)


def initial_energy(n: int, workload: str) -> float:
    """``T + V`` at the start, from the geometry above (V = M G z)."""
    w = omega(workload)
    c = centers(n)
    rot = tilt()
    inertia = rot @ np.diag([I_T, I_T, I_A]) @ rot.T
    v = np.cross(w, c)
    kinetic = 0.5 * M * np.sum(v**2) + 0.5 * n * w @ inertia @ w
    return float(kinetic + M * G * c[:, 2].sum())


def rest_energy(n: int) -> float:
    """``V`` of the chain hanging straight down at rest."""
    return -M * G * L * n**2 / 2


def energy_error(e0: float, e_end: float, n: int) -> float:
    """Relative energy error at the end (see the module docstring)."""
    return abs(e_end - e0) / abs(e0 - rest_energy(n))


def meets(record: dict) -> bool:
    """Whether a run reached the end of the span with the accuracy target met (a run that
    stopped early is measured only up to where it stopped: it meets nothing)."""
    return (record.get("finished", True)
            and record["energy_error"] <= ENERGY_TARGET
            and record.get("residual", 0.0) <= RESIDUAL_TARGET)


def peak_memory_mb() -> float:
    """Peak resident memory of this process so far (the suite runs one per record).

    Read from ``VmHWM`` in ``/proc/self/status``: ``ru_maxrss`` survives fork and
    exec on Linux, so a child would report its parent's peak.
    """
    from pathlib import Path

    status = Path("/proc/self/status")
    if status.exists():
        for line in status.read_text().splitlines():
            if line.startswith("VmHWM:"):
                return float(line.split()[1]) / 1024.0
    import resource

    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


def time_call(fn, min_time: float = 0.2) -> float:
    """Seconds per call of ``fn()``, averaged over enough calls to fill ``min_time``."""
    import time

    fn()
    count, start = 0, time.perf_counter()
    while True:
        fn()
        count += 1
        elapsed = time.perf_counter() - start
        if elapsed >= min_time:
            return elapsed / count


def warm_allowed(cold_s: float) -> bool:
    """Repeat the build only if the cold one took under a quarter of the run's cap
    (``BENCH_CAP`` seconds, set by the suite), so the warm build cannot use it all."""
    import os

    cap = float(os.environ.get("BENCH_CAP", "inf"))
    return cold_s < cap / 4
