"""Non-conservative forces and their generalized forces.

Forces enter Lagrange's equations as generalized forces ``Q_j``. They may be given
per coordinate, or as physical forces acting at points; a force ``F`` at a point
with position ``r(q, t)`` contributes ``Q_j = F . dr/dq_j`` (virtual work, with
``dr/dq_j = dv/dqdot_j`` the partial velocity). Conservative forces belong in the
potential energy ``V`` only: repeating one in ``Q`` counts it twice, and
:func:`warn_double_counting` says so.
"""

from __future__ import annotations

import warnings
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any, cast

import sympy as sp

from ..errors import DoubleCountingWarning, ModelError, user_stacklevel
from .coordinates import Coordinates
from .expressions import listed


@dataclass(frozen=True)
class PointForce:
    """A force applied at a point, both given as 3-vectors in one inertial frame.

    ``force`` and ``point`` are sequences (or SymPy matrices) of components; the
    point's position depends on the coordinates and possibly time, the force on
    positions, velocities and time. With SymPy ``Vector`` objects, pass ``frame``
    to read their components.

    >>> import sympy as sp
    >>> x, y, c = sp.symbols("x y c")
    >>> PointForce(force=[-c, 0, 0], point=[x, y, 0], name="drag")
    PointForce(name='drag')
    """

    force: object
    point: object
    frame: object | None = None
    name: str | None = None

    def __repr__(self) -> str:
        return f"PointForce(name={self.name!r})"


def generalized_forces(
    per_coordinate: Mapping[Any, object] | Sequence[object] | None,
    point_forces: Sequence[PointForce],
    coords: Coordinates,
) -> sp.Matrix:
    """Total generalized force vector ``Q`` (n x 1) in plain symbols."""
    Q = _per_coordinate_forces(per_coordinate, coords)
    for k, pf in enumerate(point_forces):
        if not isinstance(pf, PointForce):
            raise ModelError(f"forces[{k}] is {pf!r}; give dalembert.PointForce(force, point)")
        Q += _virtual_work(pf, pf.name or f"forces[{k}]", coords)
    return Q


def _per_coordinate_forces(
    given: Mapping[Any, object] | Sequence[object] | None, coords: Coordinates
) -> sp.Matrix:
    Q = sp.zeros(coords.n, 1)
    if given is None:
        return Q
    if isinstance(given, Mapping):
        items = [(coords.index(key), value) for key, value in given.items()]
    else:
        given = listed(given, "generalized_forces",
                       "forces, one per coordinate (or a dict by coordinate)")
        if len(given) != coords.n:
            raise ModelError(
                f"generalized_forces has {len(given)} entries for {coords.n} coordinates "
                f"({', '.join(coords.names)}); give one per coordinate or a dict"
            )
        items = list(enumerate(given))
    for j, value in items:
        Q[j] += coords.to_plain(value, f"generalized force on {coords.names[j]!r}")
    return Q


def _virtual_work(pf: PointForce, label: str, coords: Coordinates) -> sp.Matrix:
    force = vector_components(pf.force, pf.frame, f"the force of {label}")
    point = vector_components(pf.point, pf.frame, f"the point of {label}")
    F = sp.Matrix([coords.to_plain(c, f"force of {label}") for c in force])
    r = sp.Matrix([coords.to_plain(c, f"point of {label}") for c in point])
    if any(r.has(v) for v in coords.qd):
        raise ModelError(f"the point of {label} depends on velocities; give its position r(q, t)")
    partials = r.jacobian(sp.Matrix(coords.q))
    return partials.T * F


def vector_components(vec: object, frame: object | None, what: str) -> list[object]:
    """The 2 or 3 components of a vector given as a sequence, matrix or SymPy ``Vector``.

    ``what`` names the vector in error messages (``"the force of drag"``).

    >>> vector_components(sp.Matrix([1, 2]), None, "the force")
    [1, 2]
    """
    if hasattr(vec, "to_matrix"):
        if frame is None:
            raise ModelError(f"{what} is a SymPy Vector; pass frame= to read its components")
        vec = vec.to_matrix(frame)
    if isinstance(vec, (str, bytes)):
        raise ModelError(f"{what} must be a vector of components, got the string {vec!r}")
    try:
        comps = list(cast(Iterable[object], vec))
    except TypeError as exc:
        raise ModelError(f"{what} must be a vector of components, got {vec!r}") from exc
    if len(comps) not in (2, 3):
        raise ModelError(f"{what} has {len(comps)} components; give 2 or 3")
    return comps


def warn_double_counting(Q: sp.Matrix, V: sp.Expr, coords: Coordinates) -> None:
    """Warn when ``Q_j`` holds a term of ``-dV/dq_j``, both expanded.

    That is the classic mistake of putting gravity (or a spring) both in the
    potential energy and again among the applied forces. A conservative force does
    not depend on the velocities, so the part of ``Q_j`` that remains at zero
    velocities is compared, expanded: a weight hidden in a product with a damper
    (``-m (g + c y')``) or written with a float (``-1.0 g m``) is found, and a damper
    alone (zero at rest) never is. Terms agree when their symbolic factors are equal
    and their numeric coefficients agree to rounding.

    Parameters
    ----------
    Q
        The generalized forces (n x 1), in plain symbols.
    V
        The potential energy (for a model given by its Lagrangian ``L``, ``-L`` at
        zero velocities).
    coords
        The model's coordinates.

    Examples
    --------
    >>> import warnings
    >>> from dalembert.model.coordinates import build_coordinates, coordinates
    >>> coords = build_coordinates(coordinates("y"))
    >>> y, yd = coords.q[0], coords.qd[0]
    >>> m, g, c = sp.symbols("m g c")
    >>> with warnings.catch_warnings(record=True) as caught:
    ...     warnings.simplefilter("always")
    ...     warn_double_counting(sp.Matrix([-m * (g + c * yd)]), m * g * y, coords)
    >>> [type(w.message).__name__ for w in caught]
    ['DoubleCountingWarning']
    """
    rest = dict.fromkeys(coords.qd, sp.S.Zero)
    # a potential's terms in an angle taken with atan2 (a joint spring's 1/2 k (q - r)^2)
    # are left out: no weight or spring force given twice is written so, and expanding
    # their derivatives took minutes for an arm with two joint springs and a motor
    V = sp.Add(*(term for term in sp.Add.make_args(V) if not term.has(sp.atan2)))
    for j, q in enumerate(coords.q):
        if Q[j] == 0 or not V.has(q):
            continue
        # a damper's force vanishes at rest before anything is expanded (expanding all
        # of a damper's force can take long)
        static = Q[j].xreplace(rest)
        if static == 0:
            continue
        conservative = _terms(-V.diff(q))
        repeated = [term for key, (coeff, term) in _terms(static).items()
                    if key in conservative and _same_number(coeff, conservative[key][0])]
        if repeated:
            listing = ", ".join(str(term) for term in repeated)
            warnings.warn(
                f"the generalized force on {coords.names[j]!r} contains {listing}, which "
                f"{'is' if len(repeated) == 1 else 'are'} already in "
                f"-dV/d{coords.names[j]} from the potential energy: a conservative "
                "force (gravity?) counted twice. Keep it in V only; Q holds "
                "non-conservative forces.",
                DoubleCountingWarning,
                stacklevel=user_stacklevel(),
            )


def _terms(expr: sp.Expr) -> dict[sp.Expr, tuple[sp.Expr, sp.Expr]]:
    """The terms of ``expr`` expanded, by their symbolic factor: ``(coefficient, term)``."""
    out: dict[sp.Expr, tuple[sp.Expr, sp.Expr]] = {}
    for term in sp.Add.make_args(sp.expand(expr)):
        coeff, factor = term.as_coeff_Mul()
        out[factor] = (coeff, term)  # a constant (factor 1): a weight given as a number
    return out


def _same_number(a: sp.Expr, b: sp.Expr) -> bool:
    """Numeric coefficients equal to rounding (``-1.0`` and ``-1``)."""
    x, y = float(a), float(b)
    return abs(x - y) <= 1e-12 * max(abs(x), abs(y))
