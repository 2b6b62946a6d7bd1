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
from ..model.coordinates import t
from ..model.model import Model
from .printing import equations_latex, equations_text


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
    """Derive ``M``, ``f``, ``A``, ``b`` and ``c`` from a model."""
    coords = model.coords
    q, qd = sp.Matrix(coords.q), sp.Matrix(coords.qd)
    momenta = sp.Matrix([model.lagrangian]).jacobian(qd).T
    M = momenta.jacobian(qd)
    _require_quadratic(M, model)
    f = (
        sp.Matrix([model.lagrangian]).jacobian(q).T
        - momenta.jacobian(q) * qd
        - momenta.diff(t)
        + model.Q
    )
    cons = model.constraints
    g = cons.A * qd + cons.b
    c = -(g.jacobian(q) * qd + g.diff(t)) if cons.m else sp.zeros(0, 1)
    lam = tuple(sp.Symbol(f"lambda_{i + 1}") for i in range(cons.m))
    return Equations(model, M, f, cons.A, cons.b, c, lam)


def _require_quadratic(M: sp.Matrix, model: Model) -> None:
    coords = model.coords
    for (i, j), entry in zip(_indices(M), M):
        if any(entry.has(v) for v in coords.qd):
            raise ModelError(
                "the kinetic energy is not quadratic in the velocities: its second "
                f"derivative by {coords.names[i]}_dot and {coords.names[j]}_dot is {entry}, "
                "which still depends on velocities"
            )


def _indices(M: sp.Matrix) -> list[tuple[int, int]]:
    return [(i, j) for i in range(M.rows) for j in range(M.cols)]
