"""Holonomic and Pfaffian constraints.

A holonomic constraint ``psi(q, t) = 0`` is differentiated once into Pfaffian
form ``A(q, t) qdot + b(q, t) = 0`` with ``A = dpsi/dq`` and ``b = dpsi/dt``; a
Pfaffian (possibly nonholonomic) constraint is given in that form directly.
Both kinds then share one constraint matrix ``A`` whose rows keep the user's order.
"""

from __future__ import annotations

from dataclasses import dataclass

import sympy as sp

from ..errors import ConstraintError
from .coordinates import Coordinates, t
from .expressions import listed


@dataclass(frozen=True)
class Holonomic:
    """A holonomic constraint ``expr(q, t) = 0`` (time may appear: rheonomic).

    >>> import sympy as sp
    >>> x, y, l = sp.symbols("x y l")
    >>> Holonomic(x**2 + y**2 - l**2, name="string")
    Holonomic(-l**2 + x**2 + y**2 = 0, name='string')
    """

    expr: object
    name: str | None = None

    def __repr__(self) -> str:
        return f"Holonomic({self.expr} = 0, name={self.name!r})"


@dataclass(frozen=True)
class Pfaffian:
    """A constraint linear in the velocities, ``A(q, t) qdot + b(q, t) = 0``.

    >>> import sympy as sp
    >>> xd, yd, th = sp.symbols("x_dot y_dot theta")
    >>> Pfaffian(-sp.sin(th) * xd + sp.cos(th) * yd, name="blade")
    Pfaffian(-x_dot*sin(theta) + y_dot*cos(theta) = 0, name='blade')
    """

    expr: object
    name: str | None = None

    def __repr__(self) -> str:
        return f"Pfaffian({self.expr} = 0, name={self.name!r})"


@dataclass(frozen=True)
class ConstraintSet:
    """All constraints of a model in plain symbols, rows in the user's order.

    ``A`` (m x n) and ``b`` (m) give the velocity-level form ``A qd + b = 0``;
    ``psi`` holds the position-level expressions of the holonomic rows listed in
    ``holonomic_rows``.
    """

    names: tuple[str, ...]
    kinds: tuple[str, ...]
    exprs: tuple[sp.Expr, ...]
    A: sp.Matrix
    b: sp.Matrix
    holonomic_rows: tuple[int, ...]

    @property
    def m(self) -> int:
        return len(self.names)

    @property
    def psi(self) -> sp.Matrix:
        rows = [self.exprs[i] for i in self.holonomic_rows]
        return sp.Matrix(len(rows), 1, rows)

    def describe(self, i: int) -> str:
        """A human-readable label of constraint ``i`` for messages."""
        return f"constraint {self.names[i]!r} ({self.kinds[i]}: {self.exprs[i]} = 0)"


def build_constraints(constraints: object, coords: Coordinates) -> ConstraintSet:
    """Check each constraint and assemble the Pfaffian matrices ``A`` and ``b``."""
    if isinstance(constraints, (Holonomic, Pfaffian)):
        constraints = [constraints]
    items = listed(constraints or (), "constraints",
                   "dalembert.Holonomic(expr) or dalembert.Pfaffian(expr)", ConstraintError)
    names, kinds, exprs, rows_A, rows_b, holonomic = [], [], [], [], [], []
    for i, c in enumerate(items):
        if not isinstance(c, (Holonomic, Pfaffian)):
            raise ConstraintError(
                f"constraint {i} is {c!r}; wrap it as dalembert.Holonomic(expr) "
                "or dalembert.Pfaffian(expr)"
            )
        kind = "holonomic" if isinstance(c, Holonomic) else "Pfaffian"
        if c.name is not None and not isinstance(c.name, str):
            raise ConstraintError(f"the name of constraint {i} must be a string, got {c.name!r}")
        name = c.name or f"{kind}_{i}"
        expr = coords.to_plain(c.expr, f"constraint {name!r}")
        if isinstance(c, Holonomic):
            row_A, row_b = _differentiate_holonomic(expr, name, coords)
            holonomic.append(i)
        else:
            row_A, row_b = _split_pfaffian(expr, name, coords)
        names.append(name)
        kinds.append(kind)
        exprs.append(expr)
        rows_A.append(row_A)
        rows_b.append(row_b)
    if len(set(names)) != len(names):
        dup = next(n for n in names if names.count(n) > 1)
        raise ConstraintError(f"two constraints are named {dup!r}; give them distinct names")
    A = sp.Matrix(rows_A) if rows_A else sp.zeros(0, coords.n)
    return ConstraintSet(
        tuple(names),
        tuple(kinds),
        tuple(exprs),
        A,
        sp.Matrix(len(rows_b), 1, rows_b),
        tuple(holonomic),
    )


def _differentiate_holonomic(
    expr: sp.Expr, name: str, coords: Coordinates
) -> tuple[list[sp.Expr], sp.Expr]:
    free = expr.free_symbols
    if free.intersection(coords.qd):
        raise ConstraintError(
            f"holonomic constraint {name!r} contains velocities: {expr}; "
            "a constraint linear in velocities is dalembert.Pfaffian(expr)"
        )
    if not free.intersection(coords.q):
        raise ConstraintError(
            f"holonomic constraint {name!r} does not involve any coordinate: {expr} = 0"
        )
    # Only the coordinates present are differentiated by: the row is sparse.
    return [expr.diff(q) if q in free else sp.S.Zero for q in coords.q], _d(expr, t, free)


def _split_pfaffian(
    expr: sp.Expr, name: str, coords: Coordinates
) -> tuple[list[sp.Expr], sp.Expr]:
    free = expr.free_symbols
    row = [expr.diff(v) if v in free else sp.S.Zero for v in coords.qd]
    velocities = set(coords.qd)
    if any(entry.free_symbols & velocities for entry in row if entry != 0):
        term = _first_nonlinear_term(expr, coords.qd)
        raise ConstraintError(
            f"Pfaffian constraint {name!r} is not linear in the velocities: the term "
            f"{term} is not of the form a(q, t) * velocity"
        )
    if all(entry == 0 for entry in row):
        raise ConstraintError(
            f"Pfaffian constraint {name!r} contains no velocity: {expr} = 0; "
            "a constraint on positions only is dalembert.Holonomic(expr)"
        )
    b = expr.xreplace({v: 0 for v in coords.qd})
    return row, b


def _d(expr: sp.Expr, v: sp.Symbol, free: set[sp.Symbol]) -> sp.Expr:
    return expr.diff(v) if v in free else sp.S.Zero


def _first_nonlinear_term(expr: sp.Expr, velocities: tuple[sp.Symbol, ...]) -> sp.Expr:
    for term in sp.Add.make_args(sp.expand(expr)):
        poly = term.as_poly(*velocities)
        if poly is None or poly.total_degree() > 1:
            return term
    return expr
