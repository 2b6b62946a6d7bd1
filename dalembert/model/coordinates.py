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
        plain = sympify_checked(expr, what).xreplace(dict(self.user_forms))
        _reject_leftover_functions(plain, what)
        accelerations = plain.free_symbols.intersection(self.qdd)
        if accelerations:
            name = self.names[self.qdd.index(min(accelerations, key=self.qdd.index))]
            raise ModelError(f"{what} contains the acceleration of {name!r}; "
                             "model expressions may hold positions and velocities only")
        return plain


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


def sympify_checked(expr: object, what: str) -> sp.Expr:
    """``sympy.sympify`` with an error that says which input could not be read."""
    try:
        result = sp.sympify(expr)
    except (sp.SympifyError, TypeError) as exc:
        raise ModelError(f"{what} is not a SymPy expression: {expr!r}") from exc
    if not isinstance(result, sp.Expr):
        raise ModelError(f"{what} must be a scalar SymPy expression, got {type(result).__name__}")
    return result


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
    coords = list(coords)
    if not coords:
        raise ModelError("a System needs at least one coordinate")
    names = tuple(key_name(c) for c in coords)
    _reject_duplicates(names)
    if velocities is not None and len(velocities) != len(names):
        raise ModelError(f"{len(velocities)} velocities given for {len(names)} coordinates")
    q = tuple(sp.Symbol(n) for n in names)
    qd = tuple(
        sp.Symbol(key_name(velocities[i])) if velocities is not None else sp.Symbol(f"{n}_dot")
        for i, n in enumerate(names)
    )
    qdd = tuple(sp.Symbol(f"{n}_ddot") for n in names)
    _reject_clashes(q, qd, qdd)
    forms: list[tuple[sp.Expr, sp.Symbol]] = []
    for name, qi, qdi, qddi in zip(names, q, qd, qdd):
        fn = sp.Function(name)(t)
        forms += [(fn.diff(t, 2), qddi), (fn.diff(t), qdi), (fn, qi)]
    return Coordinates(names, q, qd, qdd, tuple(forms))


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
