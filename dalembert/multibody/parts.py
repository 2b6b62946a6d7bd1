"""A :class:`~dalembert.multibody.Multibody` as parts: each kind of body and joint derived once.

The equations of a mechanism in absolute coordinates are sums over its pieces:
the kinetic and gravitational energy of each body involve only its own
coordinates, the equations of each joint only its two bodies'. Bodies with the
same mass and inertia have the same equations in their own coordinates, and so
do joints of one type with the same geometry between the same kinds of bodies
(a joint's equations are kinematic: they depend on whether each side is ground,
a particle or a rigid body, not on masses). Each such kind is derived once, on
template bodies, and placed at every instance (:class:`~dalembert.codegen.assembly.Part`):
building a chain of a thousand equal links derives one body and two joints. A
joint's constraints are differentiated on their expression trees
(:mod:`~dalembert.multibody.derivatives`), which keeps them factored.

Loads (forces, torques, springs) may depend on any coordinates and the time, so
they form one part written in the coordinates they actually use.
"""

from __future__ import annotations

import copy
import dataclasses
from collections.abc import Callable, Hashable, Sequence
from typing import TYPE_CHECKING, TypeVar

import numpy as np
import sympy as sp
from numpy.typing import NDArray
from sympy.core.function import AppliedUndef

from ..codegen.assembly import Part
from ..equations.lagrange import Equations, derive_equations
from ..model.constraints import ConstraintSet, Holonomic, Pfaffian
from ..model.coordinates import Coordinates, t
from ..model.forces import warn_double_counting
from ..model.model import Model, build_part_model
from .bodies import Body, Ground, MovingBody, Particle, PlanarBody, RigidBody
from .derivatives import NotPolynomial, holonomic_rates
from .joints import Joint
from .parametric import sympy_vector, to_sympy
from .rotations import E_matrix, times_vector

if TYPE_CHECKING:
    from .builder import Multibody

#: Global indices (of coordinates or constraint rows).
Indices = NDArray[np.intp]
_T = TypeVar("_T")


def gravity_potential(body: Body, gravity: np.ndarray) -> sp.Expr:
    """``-m g . x`` of the body's mass center (exact zeros drop out).

    Parameters
    ----------
    body
        A moving body.
    gravity
        The field, world components (numbers or expressions of parameters).

    Examples
    --------
    >>> from dalembert.multibody import Particle
    >>> gravity_potential(Particle("p", 2.0), np.array([0.0, 0.0, -9.81]))
    19.62*p_z(t)
    >>> gravity_potential(Particle("p", sp.Symbol("m")), np.array([0, 0, -sp.Symbol("g")]))
    g*m*p_z(t)
    """
    return -to_sympy(body.mass) * sympy_vector(np.asarray(gravity)).dot(body.center)


def multibody_parts(mb: Multibody) -> list[Part]:
    """The parts of ``mb`` (a Multibody): bodies, then joints, then loads.

    Global coordinates and constraint rows are in the order of ``mb.coordinates``
    and ``mb.constraints()``: bodies' rows (unit quaternions) first, then joints'.

    Parameters
    ----------
    mb
        The mechanism.

    Examples
    --------
    Three equal links on ball joints: one body part placed three times, one part
    for the ground joint and one for the two joints between links:

    >>> from dalembert.multibody import chain
    >>> [part.instances for part in multibody_parts(chain(3, 1.0, 1.0, 0.1))]
    [3, 1, 2]
    """
    offsets = _consecutive(mb.bodies, lambda b: len(b.coordinates))
    rows = _consecutive([*mb.bodies, *mb.joints], lambda o: len(o.constraint_names))
    parts = _body_parts(mb.bodies, mb.gravity, offsets, rows)
    parts += _joint_parts(mb.joints, offsets, rows)
    loads = _load_part(mb, offsets)
    return parts + ([loads] if loads is not None else [])


def _consecutive(items: Sequence[_T], size: Callable[[_T], int]) -> dict[int, Indices]:
    """Consecutive global indices, ``size(item)`` of them per item, keyed by ``id(item)``."""
    out: dict[int, Indices] = {}
    start = 0
    for item in items:
        k = size(item)
        out[id(item)] = np.arange(start, start + k)
        start += k
    return out


def _grouped(items: Sequence[_T], signature: Callable[[_T], Hashable]) -> list[list[_T]]:
    """Items with equal ``signature(item)`` together, in order of first appearance."""
    groups: dict[Hashable, list[_T]] = {}
    for item in items:
        groups.setdefault(signature(item), []).append(item)
    return list(groups.values())


class _Localized:
    """Parametric values with each expression replaced by a local symbol ``_p0, _p1...``.

    ``signature`` keeps the numbers and marks the expressions, so pieces that differ
    only in their parameter values share it (and one kernel); ``values`` are the
    local stand-ins, ``exprs`` what instance by instance they stand for.
    """

    def __init__(self, values: Sequence[object]) -> None:
        self.symbols: list[sp.Symbol] = []
        self.exprs: list[sp.Expr] = []
        self.values = [self._local(v) for v in values]
        self.signature = tuple(_freeze(v) for v in self.values)

    def _local(self, value: object) -> object:
        if isinstance(value, np.ndarray) and value.dtype == object:
            out = np.empty(value.shape, dtype=object)
            for i, v in np.ndenumerate(value):
                out[i] = self._local(v)
            return out
        if isinstance(value, sp.Basic) and value.free_symbols:
            symbol = sp.Symbol(f"_p{len(self.symbols)}")
            self.symbols.append(symbol)
            self.exprs.append(value)
            return symbol
        return value


def _localized_part(members: Sequence[object], localized: Sequence[_Localized],
                    equations: Equations, coordinates: np.ndarray, rows: np.ndarray) -> Part:
    """The part of a group of pieces, its kernel's parameters the template's locals."""
    local = tuple(localized[0].symbols)
    # the model's own parameters in what was not localized (a driver's motion)
    shared = tuple(sorted((s for s in equations.model.parameters if s not in set(local)),
                          key=lambda s: s.name))
    values = np.empty((len(members), len(local) + len(shared)), dtype=object)
    for k, instance in enumerate(localized):
        values[k, :] = [*instance.exprs, *shared]
    return Part(equations, coordinates, rows, local + shared, values)


def _body_fields(body: MovingBody, gravity: np.ndarray) -> list[object]:
    fields = [body.mass, gravity]
    if isinstance(body, RigidBody):
        fields.append(body.inertia)
    if isinstance(body, PlanarBody):
        fields.append(body.moment)
    return fields


def _body_parts(bodies: Sequence[MovingBody], gravity: np.ndarray,
                offsets: dict[int, Indices], rows: dict[int, Indices]) -> list[Part]:
    local = {id(b): _Localized(_body_fields(b, gravity)) for b in bodies}
    parts = []
    for members in _grouped(bodies, lambda b: (type(b), local[id(b)].signature)):
        first = local[id(members[0])]
        template = _template_body(members[0], "body", first.values)
        model = build_part_model(
            template.coordinates, kinetic=template.kinetic_energy(),
            potential=gravity_potential(template, np.asarray(first.values[1])),
            constraints=template.constraints(), name=f"body {members[0].name}",
        )
        equations = derive_equations(model)
        if isinstance(template, RigidBody):
            equations = _compact_rotation(equations, template)
        parts.append(_localized_part(
            members, [local[id(b)] for b in members], equations,
            np.array([offsets[id(b)] for b in members]), np.array([rows[id(b)] for b in members])))
    return parts


def _compact_rotation(equations: Equations, body: RigidBody) -> Equations:
    """A rigid body's equations with the Euler parameters' rows of ``f`` written
    through the angular velocity: ``f_b = -4 E(bdot)^T J w``, ``w = 2 E(b) bdot``.

    Lagrange's ``f_b = dT/db - (dp/db) bdot`` comes out of the derivation as an
    expanded cubic polynomial (some 60 products per row, evaluated at every step).
    ``E(a) c = -E(c) a`` for any two 4-vectors, so ``dw/db = -2 E(bdot)``,
    ``dT/db = -2 E(bdot)^T J w`` and ``(dp/db) bdot = 2 E(bdot)^T J w``, which add up
    to the form above (no unit norm assumed). It is used only where it equals the
    derived row (:func:`_same_polynomial`), else the derived row is kept.
    """
    q, qd = equations.q, equations.qd
    b, bd = sp.Matrix(q[3:7]), sp.Matrix(qd[3:7])
    inertia = sp.Matrix(3, 3, lambda i, j: to_sympy(body.inertia[i, j]))
    momentum = times_vector(inertia, E_matrix(b) * bd)  # J w / 2
    compact = -8 * (E_matrix(bd).T * momentum)
    f = sp.Matrix(equations.f)
    for k in range(4):
        if _same_polynomial(f[3 + k], compact[k]):
            f[3 + k] = compact[k]
    return dataclasses.replace(equations, f=f)


#: Numeric coefficients (a body's inertia given as floats) round differently in two
#: equal forms: their expanded difference is this small against the largest.
ROUNDING = 1e-12


def _same_polynomial(a: sp.Expr, b: sp.Expr) -> bool:
    """Whether two polynomials are equal: their expanded difference is zero, or, with
    floating-point coefficients, under ``ROUNDING`` of the largest of ``a``'s."""
    difference = sp.expand(a - b)
    if difference == 0:
        return True
    left = sp.expand(a).as_coefficients_dict().values()
    rest = difference.as_coefficients_dict().values()
    if not all(c.is_Number for c in (*left, *rest)):
        return False
    return max(abs(float(c)) for c in rest) <= ROUNDING * max(abs(float(c)) for c in left)


def _template_body(body: Body, name: str, fields: Sequence[object] | None = None) -> Body:
    """A body of the same kind with coordinates ``<name>_x ...`` (ground is itself): with
    ``fields`` (``[mass, gravity, inertia or moment]``, localized), the equations of
    ``body``; without, unit inertia (a joint's equations are kinematic)."""
    if isinstance(body, Ground):
        return body
    mass = fields[0] if fields else 1.0
    if isinstance(body, RigidBody):
        return RigidBody(name, mass, np.asarray(fields[2]) if fields else np.ones(3))
    if isinstance(body, PlanarBody):
        return PlanarBody(name, mass, fields[2] if fields else 1.0)
    if isinstance(body, Particle):
        return Particle(name, mass)
    raise TypeError(f"no template for {body!r}")


def _joint_parts(joints: Sequence[Joint], offsets: dict[int, Indices],
                 rows: dict[int, Indices]) -> list[Part]:
    local = {id(j): _Localized([getattr(j, f) for f in j.PARAMETRIC]) for j in joints}
    parts = []
    for members in _grouped(joints, lambda j: (_signature(j), local[id(j)].signature)):
        first = local[id(members[0])]
        template = copy.copy(members[0])
        for field, value in zip(template.PARAMETRIC, first.values):
            setattr(template, field, value)
        template.body_a = _template_body(template.body_a, "a")
        template.body_b = _template_body(template.body_b, "b")
        coords = [*template.body_a.coordinates, *template.body_b.coordinates]
        equations = _constraint_equations(coords, template.constraints(),
                                          f"joint {members[0].name}")
        places = np.array([_joint_coordinates(j, offsets) for j in members])
        parts.append(_localized_part(members, [local[id(j)] for j in members], equations,
                                     places, np.array([rows[id(j)] for j in members])))
    return parts


def _constraint_equations(coordinates: Sequence[sp.Function],
                          constraints: Sequence[Holonomic | Pfaffian], name: str) -> Equations:
    """What :func:`derive_equations` gives a part that is constraints only (a joint).

    Holonomic constraints without time that are polynomials (also in the sines and
    cosines of planar angles: every joint but rolling) are differentiated on their
    expression trees (:func:`~.derivatives.holonomic_rates`):
    the same polynomials, factored, several times faster to derive and compile.
    Any other constraint, and any constraint to report an error about, takes the
    general route.
    """
    model = build_part_model(coordinates, name=name)
    try:
        equations = _polynomial_equations(model, constraints)
    except NotPolynomial:
        equations = None
    if equations is not None:
        return equations
    return derive_equations(build_part_model(coordinates, constraints=constraints, name=name))


def _polynomial_equations(model: Model,
                          constraints: Sequence[Holonomic | Pfaffian]) -> Equations | None:
    """``model`` (coordinates only) with ``constraints`` and their derivatives, or ``None``
    when they need the general route."""
    coords = model.coords
    if not all(isinstance(c, Holonomic) for c in constraints):
        return None
    exprs = [coords.to_plain(c.expr, f"constraint {c.name!r}") for c in constraints]
    if not all(_scleronomic(e, coords) for e in exprs):
        return None
    A, rates = holonomic_rates(exprs, coords.q, coords.qd)
    n, m = coords.n, len(exprs)
    b = sp.zeros(m, 1)
    names = tuple(c.name or f"holonomic_{i}" for i, c in enumerate(constraints))
    others = set().union(*(e.free_symbols for e in exprs)) - set(coords.q)
    model = dataclasses.replace(
        model, constraints=ConstraintSet(names, ("holonomic",) * m, tuple(exprs), A, b,
                                         tuple(range(m))),
        parameters=tuple(sorted(others, key=lambda s: s.name)))
    multipliers = tuple(sp.Symbol(f"lambda_{i + 1}") for i in range(m))
    return Equations(model, sp.zeros(n, n), sp.zeros(n, 1), A, b, rates, multipliers)


def _scleronomic(expr: sp.Expr, coords: Coordinates) -> bool:
    """Involves coordinates, but neither velocities nor the time."""
    free = expr.free_symbols
    return bool(free & set(coords.q)) and not free & {t, *coords.qd}


def _joint_coordinates(joint: Joint, offsets: dict[int, Indices]) -> Indices:
    return np.concatenate([offsets.get(id(b), np.zeros(0, dtype=np.intp))
                           for b in joint.bodies]).astype(np.intp)


def _signature(joint: Joint) -> Hashable:
    """What a joint's equations depend on besides its parametric values: its type, the
    rest of its geometry and the kinds of its bodies."""
    parametric = set(joint.PARAMETRIC)
    items = tuple((k, _freeze(v)) for k, v in sorted(vars(joint).items())
                  if k != "name" and k not in parametric)
    return type(joint), items


def _freeze(value: object) -> object:
    if isinstance(value, Body):
        return ("body", type(value).__name__)
    if isinstance(value, np.ndarray):
        return ("array", value.shape, tuple(value.ravel().tolist()))
    if isinstance(value, (sp.Basic, sp.MatrixBase)):
        return ("sympy", sp.srepr(value))
    try:
        hash(value)
    except TypeError:
        return ("repr", repr(value))
    return value


def _load_part(mb: Multibody, offsets: dict[int, Indices]) -> Part | None:
    """Forces, torques and springs as one part in the coordinates they involve."""
    if not (mb.forces or mb.torques or mb.springs or mb.joint_springs or mb.actuators
            or mb.sliding_friction):
        return None
    potential = sp.Add(*(s.potential() for s in mb.springs),
                       *(s.potential() for s in mb.joint_springs))
    generalized = mb.generalized_forces()
    point_forces = mb.point_forces()
    # a generalized force involves the coordinate it acts on even when constant (a
    # constant torque on a planar body's angle)
    used = set(generalized) | _coordinates_in(
        mb.bodies, [potential, *generalized.values(),
                    *(sp.Matrix([pf.force, pf.point]) for pf in point_forces)])
    coords = [c for body in mb.bodies for c in body.coordinates if c in used]
    index = {c: i for body in mb.bodies
             for c, i in zip(body.coordinates, offsets[id(body)])}
    model = build_part_model(coords, potential=potential, generalized_forces=generalized,
                             forces=point_forces, name="loads", inputs=mb.inputs)
    _warn_double_counting(mb, model, used)
    symbols = (*model.parameters, *model.inputs)  # the inputs' values follow the parameters'
    return Part(derive_equations(model), np.array([[index[c] for c in coords]], dtype=np.intp),
                np.zeros((1, 0)), symbols, np.array([symbols], dtype=object))


def _coordinates_in(bodies: Sequence[Body], exprs: Sequence[object]) -> set[sp.Function]:
    every = {c for body in bodies for c in body.coordinates}
    found: set[sp.Function] = set()
    for e in exprs:
        found |= sp.sympify(e).atoms(AppliedUndef) & every
    return found


def _warn_double_counting(mb: Multibody, loads: Model, used: set[sp.Function]) -> None:
    """Gravity (in the bodies' potential) given again as an applied force."""
    every = sp.Add(*(gravity_potential(b, mb.gravity) for b in mb.bodies))
    # only the terms in the loads' coordinates (each is -m g_k x_k of one coordinate)
    gravity = sp.Add(*(term for term in sp.Add.make_args(every)
                       if term.atoms(AppliedUndef) <= used))
    V = loads.potential + loads.coords.to_plain(gravity, "the gravitational potential")
    warn_double_counting(loads.Q, V, loads.coords)
