"""The derivatives statics needs, beside ``M``, ``f``, ``A`` and ``c``.

At rest (``qd = 0``) the equilibrium equations are ``f(q, 0, t) + A^T lambda = 0``,
``psi(q, t) = 0`` and, for a Pfaffian row whose ``b`` is not identically zero,
``b_k(q, t) = 0``. Newton's method on them, the constrained stiffness and the small
oscillations need, as sparse entries:

- ``stiffness``: ``d f_i(q, 0, t) / d q_j`` (``K = -(stiffness + curvature . lambda)``);
- ``curvature``: ``d A_kj / d q_i``, keyed ``(k, j, i)``, so that
  ``d (A^T lambda)_j / d q_i = sum_k lambda_k d A_kj / d q_i`` (for a holonomic row
  ``A_k = d psi_k / dq``, and this is ``lambda_k`` times the Hessian of ``psi_k``);
- ``damping``: ``-d f_i / d qd_j`` at ``qd = 0`` (linear damping, gyroscopic terms);
- ``rest``: ``d b_k / d q_j`` of the Pfaffian rows in ``rest_rows``.

Each derivative is taken only by the symbols its expression contains
(:mod:`.sparse`), as for the equations of motion.
"""

from __future__ import annotations

from dataclasses import dataclass

import sympy as sp

from .lagrange import Equations
from .sparse import SparseEntries, gradient, nonzero_entries

#: Nonzero entries of a three-index array, keyed ``(k, j, i)``.
SparseEntries3 = dict[tuple[int, int, int], sp.Expr]


@dataclass(frozen=True)
class StaticEntries:
    """Sparse symbolic derivatives of one model's equations at rest (see module)."""

    stiffness: SparseEntries
    curvature: SparseEntries3
    damping: SparseEntries
    rest: SparseEntries
    rest_rows: tuple[int, ...]


def static_entries(eqs: Equations) -> StaticEntries:
    """The entries of ``eqs`` that statics needs.

    Parameters
    ----------
    eqs
        The equations of motion of a model (or of one part of a mechanism).

    Examples
    --------
    >>> from dalembert.examples import cartesian_pendulum
    >>> entries = static_entries(cartesian_pendulum.build().equations())
    >>> entries.stiffness, entries.curvature, entries.rest_rows
    ({}, {(0, 0, 0): 2, (0, 1, 1): 2}, ())
    """
    q, qd = eqs.q, eqs.qd
    at_rest = {v: sp.S.Zero for v in qd}
    stiffness: SparseEntries = {}
    damping: SparseEntries = {}
    for i, f_i in enumerate(eqs.f):
        if f_i == 0:
            continue
        f0 = f_i.xreplace(at_rest)
        stiffness.update({(i, j): d for j, d in gradient(f0, q).items()})
        for j, d in gradient(f_i, qd).items():
            value = d.xreplace(at_rest)
            if value != 0:
                damping[(i, j)] = -value
    curvature: SparseEntries3 = {}
    for (k, j), a in nonzero_entries(eqs.A).items():
        curvature.update({(k, j, i): d for i, d in gradient(a, q).items()})
    holonomic = set(eqs.model.constraints.holonomic_rows)
    rest_rows = tuple(k for k, b in enumerate(eqs.b)
                      if k not in holonomic and b != 0 and sp.simplify(b) != 0)
    rest: SparseEntries = {}
    for k in rest_rows:
        rest.update({(k, j): d for j, d in gradient(eqs.b[k], q).items()})
    return StaticEntries(stiffness, dict(sorted(curvature.items())), damping, rest, rest_rows)
