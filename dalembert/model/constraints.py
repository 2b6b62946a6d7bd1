"""Holonomic, Pfaffian and unilateral constraints.

A holonomic constraint ``psi(q, t) = 0`` is differentiated once into Pfaffian
form ``A(q, t) qdot + b(q, t) = 0`` with ``A = dpsi/dq`` and ``b = dpsi/dt``; a
Pfaffian (possibly nonholonomic) constraint is given in that form directly.
Both kinds then share one constraint matrix ``A`` whose rows keep the user's order.

A unilateral constraint ``g(q, t) >= 0`` (a contact, a string that can go slack) is
kept apart (:attr:`ConstraintSet.unilateral`): it is a row only while it is closed, and
a run decides when (:mod:`dalembert.solvers.contact`). :func:`with_gaps` gives the
constraint set in which some gaps are closed, as holonomic rows after the others.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, replace
from typing import Protocol

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
class Unilateral:
    """A unilateral constraint ``gap(q, t) >= 0``: it acts only when closed, and only by
    pushing (its multiplier ``lambda >= 0``, the force ``A^T lambda`` opening the gap).

    Parameters
    ----------
    gap
        ``g(q, t)``, positive while open (a height above a floor; ``l - |r|`` for a
        string of length ``l``, slack while positive).
    name
        Its name (messages, ``traj.multiplier(name)``).
    restitution
        Newton's coefficient ``e`` in ``[0, 1]``: at an impact the gap's rate after is
        ``-e`` times the rate before (0: plastic, it stays closed; 1: elastic). A SymPy
        symbol makes it a parameter of the model (a sweep over it runs one model).
    rest_speed
        An impact closing slower than this (in the gap's units per second) is plastic
        whatever ``e``: the contact then stays closed (a bouncing ball comes to rest
        instead of bouncing infinitely often; the energy it loses is in the impacts'
        record). Default ``1e-6``.
    friction
        Coulomb's coefficient ``mu >= 0`` (0: frictionless), or ``math.inf``: a rough
        contact, which never slides. With it, ``tangents``.
    tangents
        The sliding velocities at the contact, each linear in the velocities (one in
        the plane, two in space): for a disk of radius ``r`` on a floor,
        ``x.diff() + r * theta.diff()``, the contact point's velocity along the floor.
        The friction force acts along them, at most ``mu`` times the normal force,
        opposing the sliding (or holding the contact still: sticking). A finite
        ``mu`` runs in the time-stepping contact mode; a rough contact in the
        event-driven mode, where its sliding velocities are held at 0 while it is
        closed (at an impact too: it grips where it lands), by a force as large as
        that takes.

    Examples
    --------
    >>> import sympy as sp
    >>> y = sp.Symbol("y")
    >>> Unilateral(y, name="floor", restitution=0.8)
    Unilateral(y >= 0, name='floor', restitution=0.8)
    """

    gap: object
    name: str | None = None
    restitution: float | sp.Symbol = 0.0
    rest_speed: float = 1e-6
    friction: float = 0.0
    tangents: Sequence[object] = ()

    def __repr__(self) -> str:
        return f"Unilateral({self.gap} >= 0, name={self.name!r}, restitution={self.restitution})"


@dataclass(frozen=True)
class UnilateralRow:
    """A checked :class:`Unilateral`: its name, its gap in plain symbols, its ``A`` row
    and ``b`` (``g' = A qd + b``), its restitution and rest speed."""

    name: str
    gap: sp.Expr
    A: tuple[sp.Expr, ...]
    b: sp.Expr
    restitution: float | sp.Symbol
    rest_speed: float
    #: Coulomb's coefficient and the sliding velocities ``(expression, A, b)``
    #: (velocity = ``A qd + b``), one per tangent direction.
    friction: float = 0.0
    tangents: tuple[tuple[sp.Expr, tuple[sp.Expr, ...], sp.Expr], ...] = ()


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
    #: The unilateral constraints, apart from the rows (see the module docstring).
    unilateral: tuple[UnilateralRow, ...] = ()

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
    if isinstance(constraints, (Holonomic, Pfaffian, Unilateral)):
        constraints = [constraints]
    items = listed(constraints or (), "constraints",
                   "dalembert.Holonomic(expr), dalembert.Pfaffian(expr) or "
                   "dalembert.Unilateral(gap)", ConstraintError)
    names, kinds, exprs, rows_A, rows_b, holonomic = [], [], [], [], [], []
    unilateral: list[UnilateralRow] = []
    for i, c in enumerate(items):
        if isinstance(c, Unilateral):
            unilateral.append(_unilateral_row(c, i, coords))
            continue
        if not isinstance(c, (Holonomic, Pfaffian)):
            raise ConstraintError(
                f"constraint {i} is {c!r}; wrap it as dalembert.Holonomic(expr), "
                "dalembert.Pfaffian(expr) or dalembert.Unilateral(gap)"
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
    every = names + [u.name for u in unilateral]
    if len(set(every)) != len(every):
        dup = next(n for n in every if every.count(n) > 1)
        raise ConstraintError(f"two constraints are named {dup!r}; give them distinct names")
    A = sp.Matrix(rows_A) if rows_A else sp.zeros(0, coords.n)
    return ConstraintSet(
        tuple(names),
        tuple(kinds),
        tuple(exprs),
        A,
        sp.Matrix(len(rows_b), 1, rows_b),
        tuple(holonomic),
        tuple(unilateral),
    )


@dataclass(frozen=True)
class ClosedGaps:
    """Which unilateral constraints hold as rows of a model, and how their friction
    acts there (indices into ``ConstraintSet.unilateral``, each in increasing order).

    Attributes
    ----------
    closed
        The gaps closed: holonomic rows after the bilateral ones.
    held
        Closed gaps whose sliding velocities are rows too, after the gaps (kind
        ``"friction"``): a rough contact's or a sticking one's, held at 0 while it is
        closed; in the time-stepping mode's model every frictional gap's, never
        enforced there (its ``A`` rows are read).
    sliding
        Closed gaps sliding with Coulomb friction: their friction force along each
        sliding velocity is an input of the model (:func:`friction_inputs`), which the
        run sets to ``-mu`` times the normal force along the sliding direction.

    Examples
    --------
    >>> ClosedGaps((0, 2), held=(2,))
    ClosedGaps(closed=(0, 2), held=(2,), sliding=())
    """

    closed: tuple[int, ...]
    held: tuple[int, ...] = ()
    sliding: tuple[int, ...] = ()


class WithTangents(Protocol):
    """A contact with sliding velocities (a :class:`UnilateralRow`, a Multibody's
    contact)."""

    @property
    def name(self) -> str: ...

    @property
    def tangents(self) -> Sequence[object]: ...


def friction_inputs(rows: Sequence[WithTangents], sliding: Iterable[int]
                    ) -> tuple[sp.Symbol, ...]:
    """The input symbols of the friction forces of the ``sliding`` contacts, one per
    sliding velocity (``<name>_friction_force_<k>``), in order.

    Examples
    --------
    >>> floor = UnilateralRow("floor", sp.Symbol("y"), (), 0, 0.0, 1e-6, 0.3,
    ...                       ((sp.Symbol("x"), (1,), 0),))
    >>> friction_inputs([floor], [0])
    (floor_friction_force_1,)
    """
    return tuple(sp.Symbol(friction_force_name(rows[i].name, k))
                 for i in sliding for k in range(len(rows[i].tangents)))


def friction_force_name(contact: str, k: int) -> str:
    """The name of the input that is contact ``contact``'s friction force along its
    sliding velocity ``k`` (from 0) while it slides.

    Examples
    --------
    >>> friction_force_name("floor", 0)
    'floor_friction_force_1'
    """
    return f"{contact}_friction_force_{k + 1}"


def with_gaps(cons: ConstraintSet, which: ClosedGaps) -> ConstraintSet:
    """The constraint set with the unilateral constraints ``which.closed`` as holonomic
    rows after the others (kind ``"unilateral"``), then the sliding velocities of the
    ``which.held`` ones (kind ``"friction"``, named ``<name>_friction_<k>``), and no
    unilateral constraint left apart: the equations while those gaps are closed.

    Parameters
    ----------
    cons
        A constraint set with unilateral constraints.
    which
        Which of them are closed and which hold their sliding velocities
        (:class:`ClosedGaps`; its ``sliding`` gaps add no row).

    Examples
    --------
    >>> from dalembert.model.coordinates import build_coordinates, coordinates
    >>> x, y = coordinates("x y")
    >>> cons = build_constraints([Unilateral(y, name="floor")], build_coordinates([x, y]))
    >>> closed = with_gaps(cons, ClosedGaps((0,)))
    >>> cons.m, closed.names, closed.holonomic_rows
    (0, ('floor',), (0,))
    """
    rows = [cons.unilateral[i] for i in which.closed]
    m = cons.m
    extra = [(u.name, "unilateral", u.gap, u.A, u.b) for u in rows]
    extra += [(f"{u.name}_friction_{k + 1}", "friction", expr, A_row, b)
              for i in which.held for u in (cons.unilateral[i],) if u.friction > 0
              for k, (expr, A_row, b) in enumerate(u.tangents)]
    A = cons.A.col_join(sp.Matrix([list(e[3]) for e in extra])) if extra else cons.A
    return replace(
        cons, names=cons.names + tuple(e[0] for e in extra),
        kinds=cons.kinds + tuple(e[1] for e in extra),
        exprs=cons.exprs + tuple(e[2] for e in extra), A=A,
        b=cons.b.col_join(sp.Matrix(len(extra), 1, [e[4] for e in extra])),
        holonomic_rows=cons.holonomic_rows + tuple(range(m, m + len(rows))), unilateral=())


def _unilateral_row(c: Unilateral, i: int, coords: Coordinates) -> UnilateralRow:
    """A unilateral constraint checked: its name, numbers and gap (a holonomic row)."""
    if c.name is not None and not isinstance(c.name, str):
        raise ConstraintError(f"the name of constraint {i} must be a string, got {c.name!r}")
    name = c.name or f"unilateral_{i}"
    symbolic = isinstance(c.restitution, sp.Symbol)
    checked = [("rest_speed", c.rest_speed, 0.0, math.inf)]
    if not symbolic:
        checked.insert(0, ("restitution", c.restitution, 0.0, 1.0))
    for what, value, low, high in checked:
        if isinstance(value, bool) or not isinstance(value, (int, float)) \
                or not low <= value < math.inf or value > high \
                or (what == "rest_speed" and value <= 0):
            span = "in [0, 1]" if what == "restitution" else "a finite positive number"
            raise ConstraintError(
                f"the {what} of unilateral constraint {name!r} must be {span}, got {value!r}")
    gap = coords.to_plain(c.gap, f"constraint {name!r}")
    row, b = _differentiate_holonomic(gap, name, coords)
    restitution = c.restitution if symbolic else float(c.restitution)
    friction = c.friction
    if isinstance(friction, bool) or not isinstance(friction, (int, float)) \
            or not 0.0 <= friction <= math.inf:
        raise ConstraintError(f"the friction of unilateral constraint {name!r} must be a "
                              f"number >= 0 (math.inf: rough, never sliding), got "
                              f"{friction!r}")
    tangents = listed(c.tangents, f"the tangents of unilateral constraint {name!r}",
                      "velocity expressions", ConstraintError)
    if friction > 0 and not tangents:
        raise ConstraintError(f"unilateral constraint {name!r} has friction but no "
                              "tangents: give the sliding velocities at the contact "
                              "(tangents=[...], linear in the velocities)")
    plain = [coords.to_plain(v, f"a tangent of constraint {name!r}") for v in tangents]
    rows = tuple((v, tuple(a), b_t) for v, (a, b_t) in (
        (v, _split_pfaffian(v, f"{name} (tangent {k + 1})", coords))
        for k, v in enumerate(plain)))
    return UnilateralRow(name, gap, tuple(row), b, restitution, float(c.rest_speed),
                         float(friction), rows)


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
