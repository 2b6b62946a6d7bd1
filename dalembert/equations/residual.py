"""The Jacobians of the KKT residuals by the positions and the velocities.

With the accelerations ``qdd`` and the multipliers ``lambda`` as unknowns of their
own (an implicit integrator's stage equations), the equations of motion are the
residuals

    r1 = M(q, t) qdd - f(q, qd, t) - A(q, t)^T lambda    (n rows)
    r2 = A(q, t) qdd - c(q, qd, t)                        (m rows)

and a Newton iteration on them needs ``d r1/dq``, ``d r1/dqd``, ``d r2/dq`` and
``d r2/dqd`` (``d r1/dqdd = M``, ``d r1/dlambda = -A^T`` and ``d r2/dqdd = A`` are
the KKT blocks already generated). Each is derived exactly, as sparse entries in
``qdd`` and ``lambda`` (their symbols are ``coords.qdd`` and the equations'
``multipliers``), each term differentiated only by the symbols it contains
(:mod:`.sparse`), and every subexpression the residuals share (a spring's length in
each of its force's rows, an entry of ``M`` in ``d r1/dq`` by every coordinate it
holds) differentiated once by each variable (:mod:`.chain_rule`).
"""

from __future__ import annotations

from dataclasses import dataclass

import sympy as sp

from .chain_rule import Differentiator
from .lagrange import Equations
from .sparse import SparseEntries, jacobian_entries, nonzero_entries


@dataclass(frozen=True)
class ResidualJacobianEntries:
    """The nonzero entries of the residuals' Jacobians (see the module), row-major."""

    r1_q: SparseEntries
    r1_qd: SparseEntries
    r2_q: SparseEntries
    r2_qd: SparseEntries


def residuals(eqs: Equations) -> tuple[list[sp.Expr], list[sp.Expr]]:
    """``(r1, r2)``: the KKT residuals of ``eqs`` in ``qdd`` and the multipliers.

    Parameters
    ----------
    eqs
        The equations of a model (or of one part of a mechanism).

    Examples
    --------
    >>> from dalembert.examples import cartesian_pendulum
    >>> r1, r2 = residuals(cartesian_pendulum.build().equations())
    >>> r1[0], r2[0]
    (-2*lambda_1*x + m*x_ddot, 2*x*x_ddot + 2*x_dot**2 + 2*y*y_ddot + 2*y_dot**2)
    """
    qdd, lam = eqs.qdd, eqs.multipliers
    n, m = len(qdd), len(lam)
    r1_terms: list[list[sp.Expr]] = [[] for _ in range(n)]
    r2_terms: list[list[sp.Expr]] = [[] for _ in range(m)]
    for (i, j), e in nonzero_entries(eqs.M).items():
        r1_terms[i].append(e * qdd[j])
    for (k, j), a in nonzero_entries(eqs.A).items():
        r1_terms[j].append(-a * lam[k])
        r2_terms[k].append(a * qdd[j])
    r1 = [sp.Add(*terms) - eqs.f[i] for i, terms in enumerate(r1_terms)]
    r2 = [sp.Add(*terms) - eqs.c[k] for k, terms in enumerate(r2_terms)]
    return r1, r2


def residual_jacobian_entries(eqs: Equations) -> ResidualJacobianEntries:
    """The entries of ``d r1/dq``, ``d r1/dqd``, ``d r2/dq`` and ``d r2/dqd``.

    Parameters
    ----------
    eqs
        The equations of a model (or of one part of a mechanism).

    Examples
    --------
    A particle on a circle, ``x^2 + y^2 = l^2``: ``r1 = m qdd - 2 lambda q`` (plus
    gravity in ``f``), so ``d r1/dq = -2 lambda I``; ``r2 = 2 x xdd + 2 y ydd + 2 (xd^2 +
    yd^2)``, so ``d r2/dq = [2 xdd, 2 ydd]`` and ``d r2/dqd = [4 xd, 4 yd]``:

    >>> from dalembert.examples import cartesian_pendulum
    >>> found = residual_jacobian_entries(cartesian_pendulum.build().equations())
    >>> found.r1_q, found.r1_qd
    ({(0, 0): -2*lambda_1, (1, 1): -2*lambda_1}, {})
    >>> found.r2_q, found.r2_qd
    ({(0, 0): 2*x_ddot, (0, 1): 2*y_ddot}, {(0, 0): 4*x_dot, (0, 1): 4*y_dot})
    """
    q, qd = eqs.q, eqs.qd
    r1, r2 = residuals(eqs)
    d = Differentiator()
    return ResidualJacobianEntries(jacobian_entries(r1, q, d), jacobian_entries(r1, qd, d),
                                   jacobian_entries(r2, q, d), jacobian_entries(r2, qd, d))
