"""Generalized coordinates: from user symbols to plain internal symbols.

Users write models with SymPy ``dynamicsymbols`` (``x(t)`` with derivatives
``x'(t)``), or with plain names. Internally every expression is rewritten in plain
symbols ``q``, ``qd`` (velocity) and ``qdd`` (acceleration) and the time symbol
``t``; differentiating with respect to plain symbols is much faster than with
respect to ``Derivative`` objects, and the generated code needs plain arguments.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass

import sympy as sp
from sympy.physics.vector import dynamicsymbols

from ..errors import ModelError
from .expressions import listed, sympify_checked

#: The time symbol, the same one ``dynamicsymbols`` uses.
t: sp.Symbol = dynamicsymbols._t


def coordinates(names: str) -> tuple[sp.Function, ...]:
    """Create coordinates as SymPy dynamic symbols (functions of time ``t``).

    >>> x, y = coordinates("x y")
    >>> x.diff(t)
    Derivative(x(t), t)
    """
    created = dynamicsymbols(names)
    return tuple(created) if isinstance(created, (list, tuple)) else (created,)


@dataclass(frozen=True)
class Coordinates:
    """The ordered generalized coordinates of a model and their plain symbols.

    ``q``, ``qd`` and ``qdd`` are plain SymPy symbols standing for the position,
    velocity and acceleration of each coordinate; ``user_forms`` maps the user's
    own objects (``x(t)``, ``x'(t)``, or plain symbols) onto them.
    """

    names: tuple[str, ...]
    q: tuple[sp.Symbol, ...]
    qd: tuple[sp.Symbol, ...]
    qdd: tuple[sp.Symbol, ...]
    user_forms: tuple[tuple[sp.Expr, sp.Symbol], ...]
    #: ``(name, what it stands for, how to write it)`` for time and each coordinate,
    #: velocity and acceleration: a symbol of that name that is not ``allowed`` is
    #: refused, never taken for the coordinate or made a parameter of the same name.
    reserved: tuple[tuple[str, str, str], ...] = ()
    #: The plain symbols users may write: time, and the coordinates (with their
    #: velocities and accelerations) they gave as symbols or names.
    allowed: frozenset[sp.Symbol] = frozenset()

    @property
    def n(self) -> int:
        return len(self.names)

    def index(self, key: object) -> int:
        """Position of a coordinate given as its name, user symbol, or plain symbol."""
        name = key_name(key)
        if name in self.names:
            return self.names.index(name)
        raise ModelError(
            f"unknown coordinate {name!r}; the coordinates are {', '.join(self.names)}"
        )

    def to_plain(self, expr: object, what: str) -> sp.Expr:
        """Rewrite ``expr`` in plain symbols; ``what`` names it in error messages."""
        given = sympify_checked(expr, what)
        self._reject_lookalikes(given, what)
        plain = given.xreplace(dict(self.user_forms))
        _reject_leftover_functions(plain, what)
        accelerations = plain.free_symbols.intersection(self.qdd)
        if accelerations:
            name = self.names[self.qdd.index(min(accelerations, key=self.qdd.index))]
            raise ModelError(f"{what} contains the acceleration of {name!r}; "
                             "model expressions may hold positions and velocities only")
        return plain

    def _reject_lookalikes(self, expr: sp.Expr, what: str) -> None:
        """A symbol named like a coordinate, a velocity or time that is not that one.

        ``Symbol("x")`` next to the coordinate ``x(t)`` would silently be the
        coordinate; ``Symbol("t", positive=True)`` or ``Symbol("x", real=True)`` a
        parameter sharing the name of time or of a coordinate.
        """
        reserved = {name: (meaning, form) for name, meaning, form in self.reserved}
        for s in sorted(expr.free_symbols - self.allowed, key=str):
            if getattr(s, "name", None) not in reserved:
                continue
            meaning, form = reserved[s.name]
            kind = ("a plain symbol" if s == sp.Symbol(s.name)
                    else f"a symbol with assumptions ({_assumptions(s)})")
            raise ModelError(
                f"{what} contains {kind} named {s.name!r}, the name of {meaning}, but it is "
                f"another symbol: it would silently stand for {meaning} or become a "
                f"parameter of the same name. Write {form} for {meaning}, or give the "
                "parameter another name"
            )


def _assumptions(s: sp.Symbol) -> str:
    """The assumptions a symbol was created with (``positive=True``)."""
    given = getattr(s, "_assumptions_orig", None) or s.assumptions0
    return ", ".join(f"{k}={v}" for k, v in sorted(given.items()) if k != "commutative") \
        or type(s).__name__


def key_name(key: object) -> str:
    """The coordinate or parameter name a user key refers to."""
    if isinstance(key, str):
        return key.strip()
    if isinstance(key, sp.Derivative):
        return key_name(key.expr)
    if isinstance(key, sp.Symbol):
        return key.name
    if isinstance(key, sp.Function) or (isinstance(key, sp.Expr) and key.is_Function):
        return key.func.__name__
    raise ModelError(f"{key!r} is not a coordinate or parameter name")


def build_coordinates(
    coords: Iterable[object], velocities: Sequence[object] | None = None
) -> Coordinates:
    """Normalize user coordinates (dynamic symbols, plain symbols, or names).

    With plain symbols or names, velocities are the symbols named ``<name>_dot``
    unless ``velocities`` gives them explicitly.

    >>> x, y = coordinates("x y")
    >>> c = build_coordinates([x, y])
    >>> c.names, c.to_plain(x.diff(t)**2 + y, "T")
    (('x', 'y'), x_dot**2 + y)
    """
    if isinstance(coords, str):
        coords = coords.replace(",", " ").split()
    coords = listed(coords, "coordinates", "coordinates (dynamicsymbols, symbols or names)")
    if not coords:
        raise ModelError("a System needs at least one coordinate")
    names = tuple(key_name(c) for c in coords)
    _reject_duplicates(names)
    if "t" in names:
        raise ModelError("a coordinate cannot be named 't': t is time (dalembert.t); "
                         "rename the coordinate")
    if velocities is not None:
        velocities = listed(velocities, "velocities", "velocity symbols or names")
        if len(velocities) != len(names):
            raise ModelError(f"{len(velocities)} velocities given for {len(names)} coordinates")
    q = tuple(sp.Symbol(n) for n in names)
    qd = tuple(
        sp.Symbol(key_name(velocities[i])) if velocities is not None else sp.Symbol(f"{n}_dot")
        for i, n in enumerate(names)
    )
    qdd = tuple(sp.Symbol(f"{n}_ddot") for n in names)
    _reject_clashes(q, qd, qdd)
    forms: list[tuple[sp.Expr, sp.Symbol]] = []
    reserved: list[tuple[str, str, str]] = [("t", "time", "dalembert.t (Symbol('t'))")]
    allowed: set[sp.Symbol] = {t}
    for k, (given, name, qi, qdi, qddi) in enumerate(zip(coords, names, q, qd, qdd)):
        fn = sp.Function(name)(t)
        forms += [(fn.diff(t, 2), qddi), (fn.diff(t), qdi), (fn, qi)]
        # The user's own symbols, with whatever assumptions they carry, are the coordinate.
        for user, plain in ((given, qi), (None if velocities is None else velocities[k], qdi)):
            if isinstance(user, sp.Symbol) and user != plain:
                forms.append((user, plain))
                allowed.add(user)
        function = isinstance(given, sp.Expr) and not isinstance(given, sp.Symbol)
        forms_q = ((f"{fn} (from dalembert.coordinates)", f"{fn}.diff(t)") if function else
                   ("the symbol given in coordinates", f"the velocity symbol {qdi.name}"))
        reserved += [(qi.name, f"the coordinate {name!r}", forms_q[0]),
                     (qdi.name, f"the velocity of {name!r}", forms_q[1]),
                     (qddi.name, f"the acceleration of {name!r}", f"{fn}.diff(t, 2)")]
        if not function:  # given as a symbol or a name: its plain symbols are its forms
            allowed |= {qi, qdi, qddi}
    return Coordinates(names, q, qd, qdd, tuple(forms), tuple(reserved), frozenset(allowed))


def _reject_duplicates(names: tuple[str, ...]) -> None:
    seen: set[str] = set()
    for name in names:
        if name in seen:
            raise ModelError(f"coordinate {name!r} is listed twice")
        seen.add(name)


def _reject_clashes(*groups: tuple[sp.Symbol, ...]) -> None:
    """A coordinate called ``x_dot`` next to ``x`` would be x's velocity too."""
    seen: set[str] = set()
    for s in (s for group in groups for s in group):
        if s.name in seen:
            raise ModelError(
                f"the name {s.name!r} is both a coordinate and a velocity (or acceleration) "
                "symbol; rename the coordinate or pass distinct velocities="
            )
        seen.add(s.name)


def _reject_leftover_functions(expr: sp.Expr, what: str) -> None:
    """Functions of time that are not coordinates cannot be simulated."""
    for fn in expr.atoms(sp.Derivative):
        raise ModelError(
            f"{what} contains {fn}, a derivative that is not a coordinate velocity "
            "(only first derivatives of coordinates may appear in T, V, forces, constraints)"
        )
    for fn in expr.atoms(sp.core.function.AppliedUndef):
        raise ModelError(
            f"{what} depends on {fn}, which is not one of the coordinates; "
            "list it as a coordinate, or write it as an explicit function of t"
        )
