"""Small models and case functions shared by the ensemble tests.

Module-level functions, so that Dask workers can import them (or receive them by
value) like any user's functions.
"""

from __future__ import annotations

import os
import time
from pathlib import Path

import numpy as np
import sympy as sp

from dalembert import System, coordinates
from dalembert.examples import load
from dalembert.multibody import Multibody, chain, multibody_of, point_positions

G = 9.81
#: Small swing amplitude of the period-law cases (rad).
THETA0 = 1e-3


def pendulum() -> System:
    """The gallery's Cartesian pendulum: parameters m, g, l."""
    return load("pendulum").build()


def released(case: dict[str, float]) -> tuple[dict[str, float], None]:
    """The pendulum released from rest at angle ``theta`` (rod length ``l``)."""
    l, theta = case["l"], case.get("theta", 0.5)
    return {"x": l * np.sin(theta), "y": -l * np.cos(theta)}, None


def released_slowly(case: dict[str, float]) -> tuple[dict[str, float], None]:
    """:func:`released`, a tenth of a second later (cases still running when a test
    interrupts the ensemble)."""
    time.sleep(0.1)
    return released(case)


def through_bottom(case: dict[str, float]) -> tuple[dict[str, float], dict[str, float]]:
    """The pendulum at the bottom, moving so that it swings to ``THETA0``."""
    l = case["l"]
    speed = np.sqrt(2 * G * l * (1 - np.cos(THETA0)))
    return {"x": 0.0, "y": -l}, {"x": speed}


def blow_up() -> System:
    """A particle on a line pushed by ``k / (tc - t)^2``: the force grows without bound
    as ``t -> tc``, so an integration through ``tc`` fails there."""
    (x,) = coordinates("x")
    tc, k = sp.symbols("tc k", positive=True)
    from dalembert import t

    return System([x], kinetic=x.diff() ** 2 / 2, generalized_forces={x: k / (tc - t) ** 2},
                  parameters={"tc": 10.0, "k": 1.0}, name="blow-up")


def small_chain() -> Multibody:
    """A 3-link spherical chain with a symbolic link mass ``m``."""
    return chain(3, 1.0, sp.Symbol("m", positive=True), 0.05)


def tilted_state(mb: Multibody, angle: float) -> tuple[dict, dict]:
    """The chain straight, tilted by ``angle`` about ``y``, turning at 0.3 rad/s about x."""
    c, s = np.cos(angle), np.sin(angle)
    rot = np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])
    names = [b.name for b in mb.bodies]
    centers = np.outer(np.arange(len(names)) + 0.5, rot @ np.array([0.0, 0.0, -1.0]))
    w = np.array([0.3, 0.0, 0.0])
    return mb.initial_state(positions=dict(zip(names, centers)),
                            orientations=dict.fromkeys(names, rot),
                            velocities={k: np.cross(w, ck) for k, ck in zip(names, centers)},
                            angular_velocities=dict.fromkeys(names, w))


def tip_z(system: System, traj) -> np.ndarray:
    """The height of the chain's free end."""
    mb = multibody_of(system)
    last = mb.bodies[-1].name
    return point_positions(mb, traj, last, (0.0, 0.0, -0.5))[:, 2]


def kill_once(marker: str):
    """An initial_state that ends its worker process the first time it runs there
    (a worker dying mid-run), and makes the released pendulum's state after that."""

    def initial(case: dict[str, float]):
        path = Path(marker)
        if case.get("victim", 0.0) == 1.0 and not path.exists():
            path.write_text("killed")
            os._exit(1)
        return released(case)

    return initial


def kill_always(case: dict[str, float]):
    """An initial_state that ends its worker process for the case marked ``victim``."""
    if case.get("victim", 0.0) == 1.0:
        os._exit(1)
    return released(case)


def pushed_bead() -> System:
    """A bead of mass ``m`` on the line ``x = y``, pushed by the inputs ``u`` (along x)
    and ``v`` (along y). With ``A = [1, -1]``: ``m x'' = u + lambda``, ``m y'' = v -
    lambda``, ``x'' = y''``, so ``x'' = (u + v) / (2 m)`` and ``lambda = (v - u) / 2``."""
    from dalembert import Holonomic

    x, y = coordinates("x y")
    u, v, m = sp.symbols("u v m")
    return System([x, y], kinetic=m / 2 * (x.diff() ** 2 + y.diff() ** 2),
                  constraints=[Holonomic(x - y, name="line")],
                  generalized_forces={x: u, y: v}, inputs=[u, v], parameters={m: 2.0})


def ramp(t: float) -> float:
    """The input ``v = t``."""
    return t


def brake(t: float, q: np.ndarray, qd: np.ndarray) -> float:
    """A feedback input ``v = -3 x' - x``."""
    return -3.0 * qd[0] - q[0]


def damper(case: dict[str, float]) -> dict:
    """``case_inputs``: the bead braked along y by ``v = -c y'`` with the case's ``c``."""
    c = case["c"]
    return {"v": lambda t, q, qd: -c * qd[1]}


def spin() -> None:
    """A function of the user's that never returns."""
    while True:
        pass


def spinning_damper(case: dict[str, float]) -> dict:
    """``case_inputs``: :func:`damper`, whose controller never returns from t = 0.5 on in
    the case marked ``victim``."""
    c, victim = case["c"], case.get("victim", 0.0) == 1.0

    def v(t, q, qd):
        if victim and t > 0.5:
            spin()
        return -c * qd[1]

    return {"v": v}


def spinning_initial_state(case: dict[str, float]):
    """``initial_state``: :func:`released`, never returning for the case marked
    ``victim``."""
    if case.get("victim", 0.0) == 1.0:
        spin()
    return released(case)


def spinning_output(system: System, traj) -> np.ndarray:
    """An output (the height ``y``) that never returns for a pendulum longer than 1.2."""
    if traj.parameters.get("l", 1.0) > 1.2:
        spin()
    return traj["y"]


def spinning_crossing(t: float, q: np.ndarray, qd: np.ndarray) -> float:
    """An event (the bob passing under the pivot) that never returns from t = 0.3 on for
    a pendulum longer than 1.2 (its length read from the state: x^2 + y^2 = l^2)."""
    if t > 0.3 and np.hypot(q[0], q[1]) > 1.2:
        spin()
    return q[0]
