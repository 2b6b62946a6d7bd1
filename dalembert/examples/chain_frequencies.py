"""A parameter study: the natural frequencies of a hanging chain against its link length.

A planar chain of ``N_LINKS`` uniform rods (:func:`~dalembert.multibody.chain`,
planar revolute) built once with a symbolic link length ``l``; every length of the
study is a new parameter value, not a new build. For each, the equilibrium (hanging
straight) and the small oscillations about it (``System.linearize``) give the
natural frequencies; the simulation swings the chain in its first mode at a small
amplitude (at ``l = 1``).

Independent answer: the chain linearized by hand in absolute link angles. Rod ``i``'s
center moves ``l sum_{k<i} theta_k + l/2 theta_i``, its height gives the potential
``m g l (sum_{k<i} theta_k^2 / 2 + theta_i^2 / 4)``, so

    M = m l^2 (sum_i a_i a_i^T) + I_t Id,    K = m g l diag(N - k - 1/2),

with ``a_i`` the lever arms and ``I_t = m (3 r^2 + l^2) / 12``; the frequencies are
the square roots of the eigenvalues of ``M^-1 K``. The first mode's motion is then
``theta(t) = A cos(omega_1 t) v_1`` to first order in the amplitude.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import sympy as sp

from ..multibody import chain, multibody_of
from ..system import System
from ..trajectory import Trajectory

TITLE = "Parameter study: a hanging chain's natural frequencies against its link length"
N_LINKS, MASS, RADIUS, G = 3, 1.0, 0.05, 9.81
LENGTH = sp.Symbol("l", positive=True)
LENGTHS = np.linspace(0.5, 2.0, 7)
AMPLITUDE = 1e-4  # rad: small enough for the linear motion (errors ~ amplitude^2)
T_END = 6.0


def build() -> System:
    """The chain with its link length ``l`` a parameter (default 1 m).

    >>> build().parameters
    (l,)
    """
    mb = chain(N_LINKS, LENGTH, MASS, RADIUS, joint="revolute", planar=True)
    mb.defaults = {LENGTH: 1.0}
    return mb.system


def hand_modes(length: float) -> tuple[np.ndarray, np.ndarray]:
    """``(omega, shapes)`` of the hand linearization (see module), ascending; the
    shapes are columns of absolute link angles."""
    transverse = MASS * (3 * RADIUS**2 + length**2) / 12
    M = transverse * np.eye(N_LINKS)
    for i in range(N_LINKS):
        arm = np.zeros(N_LINKS)
        arm[:i], arm[i] = length, length / 2
        M += MASS * np.outer(arm, arm)
    K = np.diag([MASS * G * length * (N_LINKS - k - 0.5) for k in range(N_LINKS)])
    values, vectors = np.linalg.eig(np.linalg.solve(M, K))
    order = np.argsort(values.real)
    return np.sqrt(values.real[order]), vectors.real[:, order]


def _first_mode_state(length: float = 1.0) -> dict[str, dict[str, float]]:
    """The chain displaced by ``AMPLITUDE`` times its first mode, at rest."""
    shape = hand_modes(length)[1][:, 0]
    angles = AMPLITUDE * shape / np.abs(shape).max()
    q0: dict[str, float] = {}
    joint = np.zeros(2)
    for k, angle in enumerate(angles):
        down = np.array([np.sin(angle), -np.cos(angle)])  # along the link, from its top
        center = joint + length / 2 * down
        # the link's body y axis points up along it: its angle is the tilt itself
        q0 |= {f"link{k + 1}_x": center[0], f"link{k + 1}_y": center[1],
               f"link{k + 1}_theta": angle}
        joint = joint + length * down
    return {"q0": q0, "qd0": {}}


INITIAL = _first_mode_state()


def study(system: System, lengths: np.ndarray = LENGTHS) -> np.ndarray:
    """The natural frequencies (rows: lengths) from ``linearize`` at each length."""
    rows = []
    for length in lengths:
        guess: dict[str, float] = {}
        for k in range(N_LINKS):
            guess |= {f"link{k + 1}_y": -(k + 0.5) * length + 0.01, f"link{k + 1}_theta": 0.02}
        rest = system.equilibrium(guess, parameters={LENGTH: length})
        rows.append(np.sort(system.linearize(rest).natural_frequencies.real))
    return np.array(rows)


def checks(system: System, traj: Trajectory) -> dict[str, float]:
    """Frequencies of the study against the hand linearization; the first mode's
    motion against ``A cos(omega_1 t)``; residuals."""
    found = study(system)
    expected = np.array([hand_modes(length)[0] for length in LENGTHS])
    omega = hand_modes(1.0)[0][0]
    start = traj["link1_theta"][0]
    linear = start * np.cos(omega * traj.t)
    return {
        "natural frequency relative error (hand linearization)": float(
            np.abs(found / expected - 1).max()),
        "first-mode motion error relative to the amplitude": float(
            np.abs(traj["link1_theta"] - linear).max() / abs(start)),
        "max position residual": float(traj.position_residual.max()),
    }


def plots(system: System, traj: Trajectory, out: Path) -> list[Path]:
    """``frequencies.png``: each mode's frequency against the link length, log-log."""
    from matplotlib.figure import Figure

    found = study(system)
    fig = Figure(figsize=(7.0, 4.2), dpi=100)
    ax = fig.add_subplot()
    for k in range(N_LINKS):
        ax.loglog(LENGTHS, found[:, k] / (2 * np.pi), "o-", label=f"mode {k + 1}")
    ax.loglog(LENGTHS, 0.8 * found[0, 0] / (2 * np.pi) * np.sqrt(LENGTHS[0] / LENGTHS), ":",
              color="gray", label="slope -1/2")
    ax.set_xlabel("link length l (m)")
    ax.set_ylabel("natural frequency (Hz)")
    ax.set_title(f"{multibody_of(system).name}: frequencies against the link length")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(loc="best", fontsize="small")
    path = Path(out) / "frequencies.png"
    fig.savefig(path)
    return [path]
