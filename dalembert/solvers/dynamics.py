"""The first-order right-hand side ``y' = F(t, y)`` with ``y = [q, qd]``.

Each evaluation solves one KKT system for ``qdd``. With Baumgarte stabilization
the acceleration-level constraint ``A qdd = c`` is replaced by
``A qdd = c - 2 w (A qd + b) - w^2 psi`` (``psi`` only on holonomic rows), so a
constraint error ``e`` obeys the critically damped ``e'' + 2 w e' + w^2 e = 0``.
Gain rule: choose ``w`` a few times above the fastest motion of interest and well
below ``1 / step``; ``w = 0`` gives the raw index-1 formulation.

With dependent constraints, ``kept`` (the independent rows, measured once at the
initial state by :func:`~dalembert.numerics.rank.constraint_rank`) makes each
evaluation solve the reduced KKT system: same cost as the full-rank path, and no
multipliers are computed, since the integrator needs ``qdd`` only.

Each evaluation is linear in the size of the mechanism: the generated code returns
``M`` and ``A`` on their fixed sparsity pattern and
:class:`~dalembert.solvers.kkt.sparse.KKTSolver` factors the sparse KKT matrix
(dense below a measured size, where that is faster).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from ..codegen.compiled import NumericModel
from .kkt.sparse import kkt_solver, matvec


def accelerations(
    num: NumericModel, t: float, q: np.ndarray, qd: np.ndarray, baumgarte: float = 0.0,
    kept: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """``qdd`` and the multipliers ``lambda`` at one state (minimum norm if ``kept``)."""
    return kkt_solver(num.pattern, kept).solve(*_blocks(num, t, q, qd, baumgarte))


def _blocks(num: NumericModel, t: float, q: np.ndarray, qd: np.ndarray, baumgarte: float):
    """Values of ``M``, ``f``, ``A`` (on the pattern), ``c`` with the Baumgarte terms."""
    Mv, f, Av, c = num.kkt_sparse(t, q, qd)
    if baumgarte and num.m:
        pat = num.pattern
        _, b = num.velocity_sparse(t, q)
        c = c - 2.0 * baumgarte * (matvec(pat.A_rows, pat.A_cols, Av, qd, num.m) + b)
        rows = list(num.holonomic_rows)
        if rows:
            c[rows] -= baumgarte**2 * num.position_constraint(t, q)
    return Mv, f, Av, c


def first_order_rhs(
    num: NumericModel, baumgarte: float = 0.0, kept: np.ndarray | None = None
) -> Callable:
    """``F(t, y)`` for SciPy's integrators (``kept``: see the module docstring)."""
    layout = num.layout
    solver = kkt_solver(num.pattern, kept)

    def rhs(t: float, y: np.ndarray) -> np.ndarray:
        q, qd = layout.split(y)
        qdd = solver.accelerations(*_blocks(num, t, q, qd, baumgarte))
        return layout.join(qd, qdd)

    return rhs
