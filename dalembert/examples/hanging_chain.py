"""A hanging chain: 20 point masses joined by 21 rigid rods, pinned at both ends.

Coordinates ``x1, y1, ..., x20, y20`` (``y`` up), one holonomic constraint per rod:
``rod1`` ties mass 1 to the left pin at ``(0, 0)``, ``rod21`` ties mass 20 to the
right pin at ``(s, 0)`` and the others join neighbours. The span ``s`` is shorter
than the total length ``21 a``, so the rods and the ground form a closed loop:
40 coordinates, 21 constraints, 19 degrees of freedom. At rest it hangs in a
discrete catenary; the support reactions (the pins' pull on the chain through
the end rods) then carry the whole weight ``20 m g``.

``INITIAL`` is the equilibrium shape of the chain under gravity plus a small
sideways load (5 % of the weight, a gust of wind), released from rest when the
wind stops: a small swing about the catenary that conserves ``T + V``.
"""

from __future__ import annotations

import itertools

import numpy as np
import scipy.optimize
import sympy as sp

from ..model.constraints import Holonomic
from ..model.coordinates import coordinates
from ..system import System
from ..trajectory import Trajectory

TITLE = "Hanging chain: 20 masses on 21 rigid rods pinned at both ends (a closed loop)"
N_MASSES = 20
m, g, a, s = sp.symbols("m g a s", positive=True)
XS = coordinates(" ".join(f"x{i}" for i in range(1, N_MASSES + 1)))
YS = coordinates(" ".join(f"y{i}" for i in range(1, N_MASSES + 1)))
NAMES = tuple(name for i in range(1, N_MASSES + 1) for name in (f"x{i}", f"y{i}"))
#: Default parameters: mass of each particle, gravity, rod length, span (total length 2.1).
DEFAULTS = {"m": 0.1, "g": 9.81, "a": 0.1, "s": 1.5}
WIND = 0.05  # sideways load of the initial shape, as a fraction of each weight


def build(m_value: float = DEFAULTS["m"], g_value: float = DEFAULTS["g"],
          a_value: float = DEFAULTS["a"], s_value: float = DEFAULTS["s"]) -> System:
    """The chain (pins at ``(0, 0)`` and ``(s, 0)``, ``y`` up).

    >>> chain = build()
    >>> len(chain.coordinate_names), len(chain.constraint_names), chain.degrees_of_freedom
    (40, 21, 19)
    """
    zero = sp.Integer(0)
    nodes = [(zero, zero), *zip(XS, YS), (s, zero)]
    rods = [
        Holonomic((x_b - x_a) ** 2 + (y_b - y_a) ** 2 - a**2, name=f"rod{k + 1}")
        for k, ((x_a, y_a), (x_b, y_b)) in enumerate(itertools.pairwise(nodes))
    ]
    return System(
        [c for pair in zip(XS, YS) for c in pair],
        kinetic=m / 2 * sum(x.diff() ** 2 + y.diff() ** 2 for x, y in zip(XS, YS)),
        potential=m * g * sum(YS),
        constraints=rods,
        parameters={m: m_value, g: g_value, a: a_value, s: s_value},
        name="hanging chain",
    )


def loaded_shape(load: np.ndarray, a_value: float = DEFAULTS["a"],
                 s_value: float = DEFAULTS["s"]) -> np.ndarray:
    """Equilibrium positions (coordinate order) under the same force ``load`` on each mass.

    Force balance at mass ``j`` makes the rod forces ``c_k = c_0 - k load``
    (``k = 0..20``) with each rod along its force, ``u_k = c_k / |c_k|``; the two
    components of ``c_0`` are found from the closure ``a sum u_k = (s, 0)``.

    >>> q = loaded_shape(np.array([0.0, -1.0]))
    >>> bool(abs(q[0] - (1.5 - q[-2])) < 1e-12)  # symmetric under a vertical load
    True
    """
    load = np.asarray(load, dtype=float)
    k = np.arange(N_MASSES + 1)[:, None]

    def directions(c0: np.ndarray) -> np.ndarray:
        c = c0 - k * load
        return c / np.linalg.norm(c, axis=1, keepdims=True)

    def closure(c0: np.ndarray) -> np.ndarray:
        return a_value * directions(c0).sum(axis=0) - [s_value, 0.0]

    weight = N_MASSES * np.linalg.norm(load)
    c0 = scipy.optimize.fsolve(closure, [weight / 2, -weight / 2], xtol=1e-14)
    points = a_value * np.cumsum(directions(c0), axis=0)[:-1]
    return points.ravel()


def _sag_guess(depth: float = 0.5) -> dict[str, float]:
    u = np.arange(1, N_MASSES + 1) / (N_MASSES + 1)
    values = np.column_stack([DEFAULTS["s"] * u, -4 * depth * u * (1 - u)]).ravel()
    return dict(zip(NAMES, (float(v) for v in values)))


#: A parabolic sag (not on the rods: equilibrium() projects it).
EQUILIBRIUM_GUESS = _sag_guess()
INITIAL = {
    "q0": dict(zip(NAMES, (float(v) for v in loaded_shape(np.array([WIND, -1.0]))))),
    "qd0": dict.fromkeys(NAMES, 0.0),
}
T_END = 2.0


def positions(q: np.ndarray) -> np.ndarray:
    """The masses' positions ``(20, 2)`` from ``q`` in coordinate order."""
    return np.asarray(q, dtype=float).reshape(N_MASSES, 2)


def draw(system: System, q: np.ndarray) -> list[np.ndarray]:
    """The chain as one polyline, left pin -> masses -> right pin.

    >>> line = draw(build(), loaded_shape(np.array([0.0, -1.0])))[0]
    >>> line.shape, line[-1].tolist()
    ((22, 2), [1.5, 0.0])
    """
    span = system.parameter_values["s"]
    return [np.vstack([[0.0, 0.0], positions(q), [span, 0.0]])]


def support_reactions(system: System, q: np.ndarray,
                      multipliers: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Forces of the left and right pins on the chain, through the end rods.

    The rod constraint ``psi = |r - pin|^2 - a^2`` exerts ``lambda dpsi/dr =
    2 lambda (r - pin)`` on its mass; a massless rod passes the same force on from
    the pin.
    """
    r = positions(q)
    names = system.constraint_names
    lam = np.asarray(multipliers, dtype=float)
    left = 2 * lam[names.index("rod1")] * r[0]
    right = 2 * lam[names.index(f"rod{N_MASSES + 1}")] * (r[-1] - [system.parameter_values["s"], 0])
    return left, right


def checks(system: System, traj: Trajectory) -> dict[str, float]:
    """Energy conservation and constraint residuals."""
    e = traj.energy
    return {
        "relative energy error": float(np.abs(e - e[0]).max() / abs(e[0])),
        "max position residual": float(traj.position_residual.max()),
        "max velocity residual": float(traj.velocity_residual.max()),
    }
