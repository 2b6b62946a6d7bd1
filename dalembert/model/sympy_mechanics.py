"""Models from ``sympy.physics.mechanics``: a ``LagrangesMethod`` read as a System's inputs.

A ``LagrangesMethod(L, qs, forcelist, frame=N, hol_coneqs=..., nonhol_coneqs=...)``
holds what a dalembert model needs: the Lagrangian in ``dynamicsymbols``, the
coordinates, the holonomic constraints (kept at position level, so the positions
are projected onto them), the nonholonomic ones (``A qd + b = 0``) and the applied
loads, which become generalized forces through their partial velocities,
``Q_i = sum_k d v_k / d qd_i . F_k`` (torques through the angular velocities), as
SymPy forms them.

Signs: dalembert writes ``M qdd = f + A^T lambda``. SymPy's numeric route,
``mass_matrix_full`` times ``[qd, qdd, lambda]`` equal to ``forcing_full``, has the
same multipliers (its rows read ``M qdd + lam_coeffs^T lambda = forcing`` with
``lam_coeffs = -A``). Its symbolic ``eom`` carries them with the opposite sign
(``eom = 0`` holds with ``-lambda``): compare with ``-lambda`` there. The
constraint forces ``A^T lambda`` are the same physical forces.

``KanesMethod`` is refused with a message: its equations come in generalized
speeds, not in a Lagrangian.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import sympy as sp

from ..errors import ModelError
from .constraints import Holonomic, Pfaffian

#: The attributes of ``LagrangesMethod`` read here that SymPy does not document.
PRIVATE_NAMES = ("_L", "_hol_coneqs")


@dataclass(frozen=True)
class LagrangianInputs:
    """What :class:`~dalembert.System` is built from, read off a ``LagrangesMethod``."""

    coordinates: tuple[sp.Expr, ...]
    lagrangian: sp.Expr
    constraints: tuple[Holonomic | Pfaffian, ...]
    generalized_forces: tuple[sp.Expr, ...]


def is_sympy_method(value: object) -> bool:
    """Whether ``value`` is a ``LagrangesMethod`` or ``KanesMethod`` (without importing
    SymPy's mechanics unless it was)."""
    return type(value).__name__ in ("LagrangesMethod", "KanesMethod") and \
        type(value).__module__.startswith("sympy.physics.mechanics")


def from_lagranges_method(method: Any) -> LagrangianInputs:
    """The inputs of a System equivalent to ``method`` (see module docstring).

    Parameters
    ----------
    method
        A ``sympy.physics.mechanics.LagrangesMethod``.

    Raises
    ------
    ModelError
        ``method`` is a ``KanesMethod`` or something else, or its forces need a frame
        it was not given.

    Examples
    --------
    >>> from sympy.physics.mechanics import LagrangesMethod, dynamicsymbols
    >>> x = dynamicsymbols("x")
    >>> k = sp.Symbol("k")
    >>> inputs = from_lagranges_method(LagrangesMethod(x.diff()**2 / 2 - k * x**2 / 2, [x]))
    >>> inputs.coordinates, inputs.constraints
    ((x(t),), ())
    """
    kind = type(method).__name__
    if kind == "KanesMethod":
        raise ModelError(
            "a KanesMethod gives equations in generalized speeds, not a Lagrangian: build "
            "a LagrangesMethod of the same system (Lagrangian(N, *bodies) and the same "
            "forcelist) and pass that, or write T, V and the constraints for System directly")
    if kind != "LagrangesMethod":
        raise ModelError(f"expected a sympy.physics.mechanics.LagrangesMethod, got {kind}")
    from sympy.physics.mechanics import dynamicsymbols

    coordinates = tuple(method.q)
    qd = [q.diff(dynamicsymbols._t) for q in coordinates]
    # SymPy keeps these two only privately (PRIVATE_NAMES; a test checks they exist)
    lagrangian = sp.sympify(method._L[0])
    holonomic = list(method._hol_coneqs)
    velocity_level = list(method.coneqs)[len(holonomic):]  # the nonholonomic rows
    constraints: list[Holonomic | Pfaffian] = [
        Holonomic(expr, name=f"holonomic_{k + 1}") for k, expr in enumerate(holonomic)]
    constraints += [Pfaffian(expr, name=f"nonholonomic_{k + 1}")
                    for k, expr in enumerate(velocity_level)]
    forces = _generalized_forces(method, qd)
    return LagrangianInputs(coordinates, lagrangian, tuple(constraints), forces)


def _generalized_forces(method: Any, qd: list[sp.Expr]) -> tuple[sp.Expr, ...]:
    """``Q_i = sum_k d v_k/d qd_i . F_k + d w_k/d qd_i . T_k`` over the forcelist."""
    from sympy.physics.vector import Point, ReferenceFrame

    loads = list(method.forcelist or [])
    Q = [sp.S.Zero] * len(qd)
    if not loads:
        return tuple(Q)
    frame = getattr(method, "inertial", None)
    if frame is None:
        raise ModelError("the LagrangesMethod has loads but no frame: pass frame=N (the "
                         "inertial frame) when creating it")
    for where, load in loads:
        if isinstance(where, Point):
            velocity = where.vel(frame)
        elif isinstance(where, ReferenceFrame):
            velocity = where.ang_vel_in(frame)
        else:
            raise ModelError(f"a load acts on {where!r}: expected a Point or a ReferenceFrame")
        for i, v in enumerate(qd):
            Q[i] += velocity.diff(v, frame).dot(load)
    return tuple(sp.simplify(q) if q != 0 else q for q in Q)
