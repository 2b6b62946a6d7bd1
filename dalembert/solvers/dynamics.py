"""The first-order right-hand side ``y' = F(t, y)`` with ``y = [q, qd]``.

Each evaluation solves one KKT system for ``qdd``. With Baumgarte stabilization
the acceleration-level constraint ``A qdd = c`` is replaced by
``A qdd = c - 2 w (A qd + b) - w^2 psi`` (``psi`` only on holonomic rows), so a
constraint error ``e`` obeys the critically damped ``e'' + 2 w e' + w^2 e = 0``.
Gain rule: choose ``w`` a few times above the fastest motion of interest and well
below ``1 / step``; ``w = 0`` gives the raw index-1 formulation.

With dependent constraints, ``kept`` (the independent rows, measured once at the
initial state by :func:`~dalembert.solvers.kkt.constraint_rank`) makes each
evaluation solve the reduced KKT system: same cost as the full-rank path, and no
multipliers are computed, since the integrator needs ``qdd`` only.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from ..codegen.compiled import NumericModel
from .kkt import kkt_accelerations, solve_kkt


def accelerations(
    num: NumericModel, t: float, q: np.ndarray, qd: np.ndarray, baumgarte: float = 0.0,
    kept: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """``qdd`` and the multipliers ``lambda`` at one state (minimum norm if ``kept``)."""
    return solve_kkt(*_blocks(num, t, q, qd, baumgarte), kept)


def _blocks(num: NumericModel, t: float, q: np.ndarray, qd: np.ndarray, baumgarte: float):
    """``M, f, A, c`` with the Baumgarte terms added to ``c``."""
    M, f, A, c = num.kkt_blocks(t, q, qd)
    if baumgarte and num.m:
        _, b = num.velocity_constraint(t, q)
        c = c - 2.0 * baumgarte * (A @ qd + b)
        rows = list(num.holonomic_rows)
        if rows:
            c[rows] -= baumgarte**2 * num.position_constraint(t, q)
    return M, f, A, c


def first_order_rhs(
    num: NumericModel, baumgarte: float = 0.0, kept: np.ndarray | None = None
) -> Callable:
    """``F(t, y)`` for SciPy's integrators (``kept``: see the module docstring)."""
    n = num.n

    def rhs(t: float, y: np.ndarray) -> np.ndarray:
        qdd = kkt_accelerations(*_blocks(num, t, y[:n], y[n:], baumgarte), kept)
        return np.concatenate([y[n:], qdd])

    return rhs
