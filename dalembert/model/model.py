"""A validated symbolic model: coordinates, Lagrangian, forces and constraints."""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any, cast

import sympy as sp

from ..errors import ModelError
from .constraints import ConstraintSet, build_constraints
from .coordinates import Coordinates, build_coordinates, t
from .expressions import listed
from .forces import PointForce, generalized_forces, warn_double_counting


@dataclass(frozen=True)
class Model:
    """Everything the equations of motion are derived from, in plain symbols.

    ``kinetic`` and ``potential`` are ``None`` when the user gave only a
    Lagrangian; ``Q`` is the total non-conservative generalized force.
    """

    coords: Coordinates
    lagrangian: sp.Expr
    kinetic: sp.Expr | None
    potential: sp.Expr | None
    Q: sp.Matrix
    constraints: ConstraintSet
    parameters: tuple[sp.Symbol, ...]
    name: str

    @property
    def has_energy(self) -> bool:
        return self.kinetic is not None and self.potential is not None


def build_model(
    coordinates: Iterable[object],
    *,
    kinetic: object = None,
    potential: object = None,
    lagrangian: object = None,
    constraints: object = (),
    generalized_forces: Mapping[Any, object] | Sequence[object] | None = None,
    forces: Sequence[PointForce] = (),
    velocities: Sequence[object] | None = None,
    name: str = "system",
) -> Model:
    """Check the user's model and rewrite it in plain symbols."""
    if not isinstance(name, str):
        raise ModelError(f"name must be a string, got {name!r}")
    coords = build_coordinates(coordinates, velocities)
    T, V, L = _energies(kinetic, potential, lagrangian, coords)
    Q = _generalized_forces(generalized_forces, forces, coords)
    if V is not None:
        warn_double_counting(Q, V, coords)
    # m >= n is allowed: dependent constraints (closed loops) can still leave freedom.
    # Whether the independent ones leave any depends on the state, so it is judged
    # numerically at the initial state (dalembert.solvers.initialization).
    cons = build_constraints(constraints, coords)
    params = _parameters(coords, L, Q, cons)
    return Model(coords, L, T, V, Q, cons, params, name)


def build_part_model(
    coordinates: Iterable[object],
    *,
    kinetic: object = 0,
    potential: object = 0,
    constraints: object = (),
    generalized_forces: Mapping[Any, object] | Sequence[object] | None = None,
    forces: Sequence[PointForce] = (),
    name: str = "part",
) -> Model:
    """A piece of a larger model (one body, one joint, the loads) in its own coordinates.

    Unlike :func:`build_model` the energies may be zero: a joint is constraints only.
    The equations of the whole are the sum of its parts' (the Lagrangian is a sum,
    each constraint belongs to one part).

    >>> from dalembert.model.coordinates import coordinates
    >>> x, y = coordinates("x y")
    >>> from dalembert.model.constraints import Holonomic
    >>> build_part_model([x, y], constraints=[Holonomic(x - y)]).constraints.m
    1
    """
    coords = build_coordinates(coordinates)
    T = coords.to_plain(kinetic, f"the kinetic energy of {name}")
    V = coords.to_plain(potential, f"the potential energy of {name}")
    Q = _generalized_forces(generalized_forces, forces, coords)
    cons = build_constraints(constraints, coords)
    params = _parameters(coords, T - V, Q, cons)
    return Model(coords, T - V, T, V, Q, cons, params, name)


def _energies(
    kinetic: object, potential: object, lagrangian: object, coords: Coordinates
) -> tuple[sp.Expr | None, sp.Expr | None, sp.Expr]:
    if lagrangian is not None and (kinetic is not None or potential is not None):
        raise ModelError("give either lagrangian=L or kinetic=T (and potential=V), not both")
    if lagrangian is not None:
        L = coords.to_plain(lagrangian, "the Lagrangian")
        _require_velocities(L, "the Lagrangian", coords)
        return None, None, L
    if kinetic is None:
        raise ModelError("a System needs kinetic=T (with potential=V) or lagrangian=L")
    T = coords.to_plain(kinetic, "the kinetic energy")
    _require_velocities(T, "the kinetic energy", coords)
    V = coords.to_plain(0 if potential is None else potential, "the potential energy")
    for v, n in zip(coords.qd, coords.names):
        if V.has(v):
            raise ModelError(
                f"the potential energy depends on the velocity of {n!r}; velocity-dependent "
                "forces go in generalized_forces or forces"
            )
    return T, V, T - V


def _require_velocities(expr: sp.Expr, what: str, coords: Coordinates) -> None:
    if not any(expr.has(v) for v in coords.qd):
        raise ModelError(f"{what} contains no velocity: {expr}")


def _generalized_forces(
    per_coordinate: Mapping[Any, object] | Sequence[object] | None,
    forces: Sequence[PointForce], coords: Coordinates
) -> sp.Matrix:
    if isinstance(forces, PointForce):
        forces = [forces]
    points = listed(forces or (), "forces", "dalembert.PointForce(force, point)")
    # each item is checked to be a PointForce where it is read
    return generalized_forces(per_coordinate, cast(list[PointForce], points), coords)


def _parameters(
    coords: Coordinates, L: sp.Expr, Q: sp.Matrix, cons: ConstraintSet
) -> tuple[sp.Symbol, ...]:
    exprs = [L, *Q, *cons.exprs]
    free = set().union(*(e.free_symbols for e in exprs))
    free -= {t, *coords.q, *coords.qd}
    return tuple(sorted(free, key=lambda s: s.name))
