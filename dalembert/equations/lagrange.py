"""Lagrange's equations with multipliers, in the one sign convention of dalembert.

From ``d/dt(dL/dqdot) - dL/dq = Q + A^T lambda`` with ``A qdot + b = 0``:

    M(q, t) qddot = f(q, qdot, t) + A(q, t)^T lambda
    A(q, t) qddot = c(q, qdot, t)

``M = d2L/dqdot2``, ``f = dL/dq - (d/dq dL/dqdot) qdot - d/dt dL/dqdot + Q`` and
``c = -(d/dq (A qdot + b)) qdot - d/dt (A qdot + b)``, the constraints
differentiated once more. ``A^T lambda`` is the generalized constraint force.
Nothing is inverted symbolically: ``M`` and the KKT matrix are solved numerically.
"""

from __future__ import annotations

from dataclasses import dataclass

import sympy as sp

from ..errors import ModelError
from ..model.coordinates import Coordinates, t
from ..model.model import Model
from .chain_rule import Differentiator
from .printing import equations_latex, equations_text
from .sparse import SparseEntries, dense, gradient, nonzero_entries, rate


@dataclass(frozen=True)
class Equations:
    """The constrained equations of motion of a model (SymPy matrices, plain symbols).

    ``M qdd = f + A^T lambda`` and ``A qdd = c``; ``A qd + b = 0`` is the
    velocity-level constraint. ``q``, ``qd``, ``qdd`` and ``multipliers`` are the
    symbols the matrices are written in.
    """

    model: Model
    M: sp.Matrix
    f: sp.Matrix
    A: sp.Matrix
    b: sp.Matrix
    c: sp.Matrix
    multipliers: tuple[sp.Symbol, ...]

    @property
    def q(self) -> tuple[sp.Symbol, ...]:
        return self.model.coords.q

    @property
    def qd(self) -> tuple[sp.Symbol, ...]:
        return self.model.coords.qd

    @property
    def qdd(self) -> tuple[sp.Symbol, ...]:
        return self.model.coords.qdd

    def latex(self) -> str:
        """The equations as a LaTeX ``aligned`` block, velocities as dotted symbols."""
        return equations_latex(self)

    def _repr_latex_(self) -> str:
        return f"$\\displaystyle {self.latex()}$"

    def __str__(self) -> str:
        return equations_text(self)


def derive_equations(model: Model) -> Equations:
    """Derive ``M``, ``f``, ``A``, ``b`` and ``c`` from a model.

    Every derivative is taken term by term and only by the symbols a term
    contains (:mod:`dalembert.equations.sparse`), so the cost grows with the
    size of the Lagrangian and the constraints, not with ``n^2``; a subexpression
    met again (a momentum's part in its rate) is differentiated once
    (:mod:`dalembert.equations.chain_rule`).

    >>> from dalembert import System, coordinates
    >>> x, = coordinates("x")
    >>> m, k = sp.symbols("m k")
    >>> eqs = derive_equations(System([x], kinetic=m / 2 * x.diff()**2,
    ...                               potential=k / 2 * x**2).model)
    >>> eqs.M, eqs.f
    (Matrix([[m]]), Matrix([[-k*x]]))
    """
    coords = model.coords
    n = coords.n
    # one for all: the momenta's parts recur in M, in f and in their rates
    d = Differentiator()
    M, f = _dynamics(model, d)
    _require_quadratic(M, model)
    cons = model.constraints
    c = _constraint_rates(cons.A, cons.b, coords, d)
    lam = tuple(sp.Symbol(f"lambda_{i + 1}") for i in range(cons.m))
    return Equations(model, dense(M, n, n), sp.Matrix(n, 1, f), cons.A, cons.b, c, lam)


def _dynamics(model: Model, d: Differentiator) -> tuple[SparseEntries, list[sp.Expr]]:
    """``M`` (nonzero entries) and ``f`` from ``p = dL/dqd``, row by row."""
    coords = model.coords
    q, qd = coords.q, coords.qd
    momenta = gradient(model.lagrangian, qd, d)
    forces = gradient(model.lagrangian, q, d)
    M: SparseEntries = {}
    f = []
    for j in range(coords.n):
        p = momenta.get(j, sp.S.Zero)
        M.update({(j, k): e for k, e in gradient(p, qd, d).items()})
        convective, explicit = rate(p, q, qd, t, d)
        f.append(forces.get(j, sp.S.Zero) - convective - explicit + model.Q[j])
    return M, f


def _constraint_rates(A: sp.Matrix, b: sp.Matrix, coords: Coordinates,
                      d: Differentiator) -> sp.Matrix:
    """``c = -(d/dq (A qd + b)) qd - d/dt (A qd + b)``, each row from its own symbols."""
    rows: dict[int, list[sp.Expr]] = {i: [] for i in range(A.rows)}
    for (i, j), a in nonzero_entries(A).items():
        rows[i].append(a * coords.qd[j])
    c = []
    for i, products in rows.items():
        g = sp.Add(*products) + b[i]
        convective, explicit = rate(g, coords.q, coords.qd, t, d)
        c.append(-(convective + explicit))
    return sp.Matrix(A.rows, 1, c)


def _require_quadratic(M: SparseEntries, model: Model) -> None:
    coords = model.coords
    velocities = set(coords.qd)
    for (i, j), entry in M.items():
        if entry.free_symbols & velocities:
            raise ModelError(
                "the kinetic energy is not quadratic in the velocities: its second "
                f"derivative by {coords.names[i]}_dot and {coords.names[j]}_dot is {entry}, "
                "which still depends on velocities"
            )
