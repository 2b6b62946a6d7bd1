"""The derivatives the stabilized index-2 (GGL) form adds to the KKT residuals'.

In the form of Gear, Gupta and Leimkuhler, ``y = [q, v, lambda, mu]``,

    q' = v - A_h(q, t)^T mu                    (n rows; mu: one per holonomic row)
    M(q, t) v' = f(q, v, t) + A(q, t)^T lambda  (n rows)
    0 = A(q, t) v + b(q, t)                     (m rows: the velocity level)
    0 = psi(q, t)                               (the holonomic rows: the position level)

(``A_h`` the holonomic rows of ``A = dpsi/dq``; ``mu`` is zero on the exact solution).
A Newton iteration on it needs, beyond the KKT residuals' Jacobians
(:mod:`.residual`), ``d (A qd + b)/dq`` (``m x n``) and ``d (A^T lambda)/dq``
(``n x n``, with ``lambda`` any row vector: ``mu`` placed on the holonomic rows).
Both are derived exactly, as sparse entries, each term differentiated only by the
symbols it contains (:mod:`.sparse`) and each shared subexpression once
(:mod:`.chain_rule`).
"""

from __future__ import annotations

from dataclasses import dataclass

import sympy as sp

from .chain_rule import Differentiator
from .lagrange import Equations
from .sparse import SparseEntries, jacobian_entries, nonzero_entries


@dataclass(frozen=True)
class GGLJacobianEntries:
    """The nonzero entries of ``d (A qd + b)/dq`` and ``d (A^T lam)/dq``, row-major."""

    velocity_q: SparseEntries
    force_q: SparseEntries


def ggl_jacobian_entries(eqs: Equations) -> GGLJacobianEntries:
    """The entries of ``d (A qd + b)/dq`` and ``d (A^T lam)/dq`` (see the module).

    Parameters
    ----------
    eqs
        The equations of a model (or of one part of a mechanism).

    Examples
    --------
    A particle on a circle, ``psi = x^2 + y^2 - l^2``, ``A = [2 x, 2 y]``:
    ``A qd = 2 x xd + 2 y yd`` has ``d/dq = [2 xd, 2 yd]``, and ``A^T lam = 2 lam q``
    has ``d/dq = 2 lam I``:

    >>> from dalembert.examples import cartesian_pendulum
    >>> found = ggl_jacobian_entries(cartesian_pendulum.build().equations())
    >>> found.velocity_q
    {(0, 0): 2*x_dot, (0, 1): 2*y_dot}
    >>> found.force_q
    {(0, 0): 2*lambda_1, (1, 1): 2*lambda_1}
    """
    q, qd, lam = eqs.q, eqs.qd, eqs.multipliers
    m, n = len(lam), len(q)
    velocity_terms: list[list[sp.Expr]] = [[] for _ in range(m)]
    force_terms: list[list[sp.Expr]] = [[] for _ in range(n)]
    for (k, j), a in nonzero_entries(eqs.A).items():
        velocity_terms[k].append(a * qd[j])
        force_terms[j].append(a * lam[k])
    velocity = [sp.Add(*terms) + eqs.b[k] for k, terms in enumerate(velocity_terms)]
    force = [sp.Add(*terms) for terms in force_terms]
    d = Differentiator()  # the entries of A recur in both
    return GGLJacobianEntries(jacobian_entries(velocity, q, d), jacobian_entries(force, q, d))
