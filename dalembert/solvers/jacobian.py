"""The exact Jacobian of the constrained first-order system, for implicit solvers.

The right-hand side ``y' = F(t, y)``, ``y = [q, qd]``, is ``[qd, qdd]`` with ``qdd``
(and the multipliers ``lambda``) from the KKT system

    r1 = M(q) qdd - f(q, qd) - A(q)^T lambda = 0,      r2 = A(q) qdd - c(q, qd) = 0.

Differentiating both by ``z`` (``q`` or ``qd``) at the solution,

    [ M  A^T ] [ d qdd / dz      ]     [ d r1 / dz ]
    [ A   0  ] [ -d lambda / dz  ] = - [ d r2 / dz ],

the same KKT matrix as the solve itself, with the residuals' partial derivatives
(generated exactly from the symbolic model: the registry's ``residual_jacobians``) as
``2 n`` right-hand sides through one factorization. So

    dF/dy = [[0, I], [d qdd/dq, d qdd/dqd]]

costs one KKT factorization and its solves, where a forward difference costs ``2 n``
more evaluations of ``F`` and carries their rounding (about ``sqrt(eps)`` relative).
With dependent constraints the kept rows are solved for, as in the dynamics; the
multipliers of the others are zero.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from ..codegen.compiled import NumericModel, ResidualJacobians
from .kkt.sparse import kkt_solver


def first_order_jacobian(num: NumericModel, kept: np.ndarray | None = None
                         ) -> Callable[[float, np.ndarray], np.ndarray]:
    """``jac(t, y)``: the exact ``dF/dy`` (dense, ``2n x 2n``) of the first-order system
    without Baumgarte's terms (see :mod:`dalembert.solvers.jacobian`).

    The inputs are read as they stand in ``num``'s parameter vector: an input computed
    from the state at each evaluation contributes no derivative here.

    Parameters
    ----------
    num
        The compiled equations bound to parameter values.
    kept
        The constraint rows solved for (``None``: all).

    Examples
    --------
    The Cartesian pendulum (``l = 1``, ``g = 9.81``) at rest at the angle ``theta`` from
    the bottom: the tangential acceleration ``-g sin(theta)`` changes along the circle
    as ``-g cos(theta)``.

    >>> from dalembert.examples import cartesian_pendulum
    >>> num = cartesian_pendulum.build().numeric()
    >>> theta = 0.3
    >>> y = np.array([np.sin(theta), -np.cos(theta), 0.0, 0.0])
    >>> J = first_order_jacobian(num)(0.0, y)
    >>> tangent = np.array([np.cos(theta), np.sin(theta)])
    >>> bool(np.isclose(tangent @ J[2:, :2] @ tangent, -9.81 * np.cos(theta)))
    True
    """
    n = num.n
    layout = num.layout
    rows = np.arange(num.m) if kept is None else np.asarray(kept, dtype=np.intp)
    top = np.hstack([np.zeros((n, n)), np.eye(n)])

    def jac(t: float, y: np.ndarray) -> np.ndarray:
        q, qd = layout.split(y)
        found, solve, _, _ = residual_jacobians_at(num, kept, t, q, qd)
        r1_q, r1_qd, r2_q, r2_qd = found.dense()
        partial = np.vstack([np.hstack([r1_q, r1_qd]), np.hstack([r2_q, r2_qd])[rows]])
        return np.vstack([top, -solve(partial)[:n]])

    return jac


def residual_jacobians_at(num: NumericModel, kept: np.ndarray | None, t: float,
                          q: np.ndarray, qd: np.ndarray
                          ) -> tuple[ResidualJacobians, Callable[[np.ndarray], np.ndarray],
                                     np.ndarray, np.ndarray]:
    """The KKT residuals' Jacobians at the solution ``(qdd, lambda)`` of the KKT system
    at ``(t, q, qd)``, the solve of that KKT matrix (on the kept rows), and the values
    of ``M`` and ``A`` it was made from.

    Parameters
    ----------
    num
        The compiled equations bound to parameter values.
    kept
        The constraint rows solved for (``None``: all).
    t, q, qd
        The state.

    Examples
    --------
    The Cartesian pendulum at rest, hanging: the rod pulls ``m g``, ``lambda = g / 2``
    (``A = [2 x, 2 y]``), so ``d r1/dq = -2 lambda I``:

    >>> from dalembert.examples import cartesian_pendulum
    >>> num = cartesian_pendulum.build().numeric()
    >>> found, *_ = residual_jacobians_at(num, None, 0.0, np.array([0.0, -1.0]), np.zeros(2))
    >>> found.r1_q.dense()
    array([[9.81, 0.  ],
           [0.  , 9.81]])
    """
    n, m = num.n, num.m
    rows = np.arange(m) if kept is None else np.asarray(kept, dtype=np.intp)
    Mv, f, Av, c = num.kkt_sparse(t, q, qd)
    solve = kkt_solver(num.pattern, kept).factor(Mv, Av)
    x = solve(np.concatenate([f, c[rows]]))
    lam = np.zeros(m)
    lam[rows] = -x[n:]
    return num.residual_jacobians(t, q, qd, x[:n], lam), solve, Mv, Av
