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

from ..errors import DoubleCountingWarning, ModelError
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
    """Warn when a term of ``Q_j`` equals a term of ``-dV/dq_j``.

    That is the classic mistake of putting gravity (or a spring) both in the
    potential energy and again among the applied forces.
    """
    state = (*coords.q, *coords.qd)
    for j, q in enumerate(coords.q):
        if Q[j] == 0 or not V.has(q):
            continue
        conservative = set(sp.Add.make_args(sp.expand(-V.diff(q)))) - {sp.S.Zero}
        # Q's own terms, and its state-independent part expanded (a constant weight m*g
        # hidden in a product); expanding all of Q can take long for damper forces.
        constant = Q[j].as_independent(*state, as_Add=True)[0]
        applied = set(sp.Add.make_args(Q[j])) | set(sp.Add.make_args(sp.expand(constant)))
        repeated = conservative & applied
        for term in repeated:
            warnings.warn(
                f"the generalized force on {coords.names[j]!r} contains {term}, which is "
                f"already -dV/d{coords.names[j]} from the potential energy: a conservative "
                "force (gravity?) counted twice. Keep it in V only; Q holds "
                "non-conservative forces.",
                DoubleCountingWarning,
                stacklevel=4,
            )
