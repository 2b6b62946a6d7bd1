"""A validated symbolic model: coordinates, Lagrangian, forces and constraints."""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from functools import cached_property
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
    #: Input symbols: values given during a simulation (forces, controllers).
    inputs: tuple[sp.Symbol, ...] = ()

    @property
    def has_energy(self) -> bool:
        return self.kinetic is not None and self.potential is not None

    @cached_property  # asked at every run's end (an ensemble's cases)
    def conserves_energy(self) -> bool:
        """Whether ``T + V`` stays constant along every motion, so that a change of it
        is an integration error: the energies given (not a Lagrangian alone), no applied
        generalized force, point force or input, no time in ``T``, ``V`` or the
        constraints, every velocity constraint homogeneous (``A qd = 0``: its forces do
        no work), and ``T`` quadratic in the velocities (a part linear in them or free
        of them, as in a rotating frame, makes the Jacobi integral, not ``T + V``, the
        constant).

        Examples
        --------
        >>> from dalembert.model.coordinates import coordinates
        >>> (x,) = coordinates("x")
        >>> spring = build_model([x], kinetic=x.diff() ** 2 / 2, potential=x**2 / 2)
        >>> damped = build_model([x], kinetic=x.diff() ** 2 / 2, potential=x**2 / 2,
        ...                      generalized_forces=[-x.diff()])
        >>> spring.conserves_energy, damped.conserves_energy
        (True, False)
        """
        if self.kinetic is None or self.potential is None or self.inputs:
            return False
        if not self.Q.is_zero_matrix or t in self.lagrangian.free_symbols:
            return False
        cons = self.constraints
        if any(t in sp.sympify(e).free_symbols for e in cons.exprs) or \
                not cons.b.is_zero_matrix:
            return False
        rest = dict.fromkeys(self.coords.qd, sp.S.Zero)
        T = self.kinetic
        return T.xreplace(rest) == 0 and all(T.diff(v).xreplace(rest) == 0
                                            for v in self.coords.qd)


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
    inputs: Sequence[object] = (),
) -> Model:
    """Check the user's model and rewrite it in plain symbols (see :func:`check_inputs`
    for where inputs may appear)."""
    if not isinstance(name, str):
        raise ModelError(f"name must be a string, got {name!r}")
    coords = build_coordinates(coordinates, velocities)
    T, V, L = _energies(kinetic, potential, lagrangian, coords)
    Q = _generalized_forces(generalized_forces, forces, coords)
    # given L only, its velocity-free part -L(q, 0, t) holds the potential energy
    warn_double_counting(Q, V if V is not None
                         else -L.xreplace(dict.fromkeys(coords.qd, sp.S.Zero)), coords)
    # m >= n is allowed: dependent constraints (closed loops) can still leave freedom.
    # Whether the independent ones leave any depends on the state, so it is judged
    # numerically at the initial state (dalembert.solvers.initialization).
    cons = build_constraints(constraints, coords)
    given = check_inputs(inputs, coords, L, cons)
    params = tuple(s for s in _parameters(coords, L, Q, cons) if s not in set(given))
    return Model(coords, L, T, V, Q, cons, params, name, given)


def check_inputs(inputs: Sequence[object], coords: Coordinates, L: sp.Expr,
                 cons: ConstraintSet) -> tuple[sp.Symbol, ...]:
    """The input symbols, checked: distinct plain symbols, neither a coordinate nor the
    time, and only in the applied forces (an input in the energies or the constraints
    would need its time derivatives, which a sampled or tabulated input does not have:
    a prescribed motion is a constraint in ``t``, or a ``multibody.Driver``).

    Parameters
    ----------
    inputs
        The declared input symbols.
    coords, L, cons
        The model's coordinates, Lagrangian and constraints.

    Examples
    --------
    >>> from dalembert.model.coordinates import build_coordinates, coordinates
    >>> from dalembert.model.constraints import build_constraints
    >>> coords = build_coordinates(coordinates("x"))
    >>> check_inputs([sp.Symbol("u")], coords, sp.S.Zero, build_constraints((), coords))
    (u,)
    """
    if isinstance(inputs, (str, sp.Basic)) or not isinstance(inputs, Sequence):
        raise ModelError(f"inputs must be a list of SymPy symbols, got {inputs!r}")
    out: list[sp.Symbol] = []
    taken = {t, *coords.q, *coords.qd}
    for u in inputs:
        if not isinstance(u, sp.Symbol) or isinstance(u, sp.Dummy):
            raise ModelError(f"an input must be a SymPy Symbol, got {u!r}")
        if u in taken or u.name == "t" or u.name in coords.names:
            raise ModelError(f"the input {u.name!r} is named like the time or a coordinate; "
                             "give it another name")
        if u in out:
            raise ModelError(f"the input {u.name!r} is declared twice")
        where = ("the Lagrangian (T or V)" if u in L.free_symbols else
                 next((f"constraint {name!r}" for name, e in
                       [*zip(cons.names, cons.exprs),
                        *((g.name, g.gap) for g in cons.unilateral)]
                       if u in sp.sympify(e).free_symbols), None))
        if where is not None:
            raise ModelError(
                f"the input {u.name!r} appears in {where}; inputs may appear in the applied "
                "forces only (an input in the energies or the constraints would need its "
                "time derivatives): prescribe a motion with a constraint in dalembert.t, or "
                "a multibody Driver")
        out.append(u)
    return tuple(out)


def build_part_model(
    coordinates: Iterable[object],
    *,
    kinetic: object = 0,
    potential: object = 0,
    constraints: object = (),
    generalized_forces: Mapping[Any, object] | Sequence[object] | None = None,
    forces: Sequence[PointForce] = (),
    name: str = "part",
    inputs: Sequence[object] = (),
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
    given = check_inputs(inputs, coords, T - V, cons)
    params = tuple(s for s in _parameters(coords, T - V, Q, cons) if s not in set(given))
    return Model(coords, T - V, T, V, Q, cons, params, name, given)


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
    exprs = [L, *Q, *cons.exprs, *(u.gap for u in cons.unilateral),
             *(sp.sympify(u.restitution) for u in cons.unilateral),
             *(e for u in cons.unilateral for e, _, _ in u.tangents)]
    free = set().union(*(e.free_symbols for e in exprs))
    free -= {t, *coords.q, *coords.qd}
    return tuple(sorted(free, key=lambda s: s.name))
