"""Equations of motion by virtual power (Kane's method), independent of Lagrange.

For particles of mass ``m_i`` at positions ``r_i(q, t)`` and forces ``F_k`` applied
at points ``p_k(q, t)``, with every coordinate a function of time:

    v_i = dr_i/dt,    partial velocities  dv_i/dqdot_j,    a_i = dv_i/dt
    generalized inertia force   F*_j = sum_i -m_i a_i . dv_i/dqdot_j
    generalized active force    F_j  = sum_k  F_k . dp_k'/dqdot_j

and ``F_j + F*_j = 0`` for every coordinate. ``a_i`` is linear in ``qdd``, so
``-F* = M qdd - F*|_{qdd=0}`` and the unconstrained equations are ``M qdd = f`` with
``f = F + F*|_{qdd=0}``. No Lagrangian is formed and nothing is differentiated by a
position, which is what makes this a cross-check of :mod:`dalembert.equations.lagrange`;
constraints are left out (add ``A^T lambda`` with the same ``A``).
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from typing import cast

import sympy as sp

from ..errors import ModelError
from ..model.coordinates import Coordinates, build_coordinates, t
from ..model.forces import PointForce, vector_components


def virtual_power_equations(
    particles: Sequence[tuple[object, object]],
    forces: Sequence[PointForce],
    coordinates: Iterable[object],
    velocities: Sequence[object] | None = None,
) -> tuple[sp.Matrix, sp.Matrix]:
    """Mass matrix and right-hand side of ``M qdd = f`` from the virtual power.

    Parameters
    ----------
    particles
        ``(mass, position)`` pairs; a position is a 2- or 3-vector (sequence or SymPy
        matrix) of expressions in the coordinates and possibly ``t``.
    forces
        :class:`~dalembert.PointForce` objects: every applied force, gravity and
        springs included (there is no potential energy here). A force may depend
        on positions, velocities and ``t``.
    coordinates
        The generalized coordinates, as for :class:`~dalembert.System`.
    velocities
        With plain-symbol coordinates, the velocity symbols (default ``<name>_dot``).

    Returns
    -------
    M, f
        SymPy matrices (n x n and n x 1) in the plain symbols of
        :meth:`dalembert.System.equations`: ``q`` by name and ``<name>_dot``.
        Not simplified.

    Examples
    --------
    A particle in a plane, in polar coordinates, under gravity:

    >>> import sympy as sp
    >>> from dalembert import PointForce, coordinates
    >>> r, th = coordinates("r theta")
    >>> m, g = sp.symbols("m g", positive=True)
    >>> position = [r * sp.cos(th), r * sp.sin(th)]
    >>> weight = PointForce(force=[0, -m * g], point=position)
    >>> M, f = virtual_power_equations([(m, position)], [weight], [r, th])
    >>> sp.simplify(M)
    Matrix([
    [m,      0],
    [0, m*r**2]])
    >>> list(sp.simplify(f))
    [m*(-g*sin(theta) + r*theta_dot**2), -m*r*(g*cos(theta) + 2*r_dot*theta_dot)]
    """
    coords = build_coordinates(coordinates, velocities)
    inertia = sp.zeros(coords.n, 1)
    for k, particle in enumerate(particles):
        mass, position = _unpack_particle(particle, k)
        inertia += _inertia_force(mass, position, coords, f"particles[{k}]")
    active = sp.zeros(coords.n, 1)
    for k, pf in enumerate(forces):
        if not isinstance(pf, PointForce):
            raise ModelError(f"forces[{k}] is {pf!r}; give dalembert.PointForce(force, point)")
        active += _active_force(pf, coords, pf.name or f"forces[{k}]")
    M = -inertia.jacobian(sp.Matrix(coords.qdd))
    f = active + inertia.xreplace({a: sp.S.Zero for a in coords.qdd})
    return M, f


def _inertia_force(
    mass: object, position: object, coords: Coordinates, label: str
) -> sp.Matrix:
    """``F*_j = -m a . dv/dqdot_j`` of one particle (linear in the accelerations)."""
    m = coords.to_plain(mass, f"the mass of {label}")
    v = _time_derivative(_position(position, None, coords, f"the position of {label}"), coords)
    a = _time_derivative(v, coords)
    return -m * _partial_velocities(v, coords).T * a


def _active_force(pf: PointForce, coords: Coordinates, label: str) -> sp.Matrix:
    """``F_j = F . dv/dqdot_j`` with ``v`` the velocity of the force's point."""
    F = sp.Matrix([coords.to_plain(c, f"the force of {label}")
                   for c in _components(pf.force, pf.frame, f"the force of {label}")])
    v = _time_derivative(_position(pf.point, pf.frame, coords, f"the point of {label}"), coords)
    return _partial_velocities(v, coords).T * F


def _time_derivative(expr: sp.Matrix, coords: Coordinates) -> sp.Matrix:
    """Total derivative ``d/dt`` with ``q(t)`` and ``qd(t)`` in plain symbols."""
    q, qd, qdd = (sp.Matrix(s) for s in (coords.q, coords.qd, coords.qdd))
    return expr.jacobian(q) * qd + expr.jacobian(qd) * qdd + expr.diff(t)


def _partial_velocities(v: sp.Matrix, coords: Coordinates) -> sp.Matrix:
    """Columns ``dv/dqdot_j`` (3 x n)."""
    return v.jacobian(sp.Matrix(coords.qd))


def _position(vec: object, frame: object, coords: Coordinates, what: str) -> sp.Matrix:
    r = sp.Matrix([coords.to_plain(c, what) for c in _components(vec, frame, what)])
    if any(r.has(v) for v in coords.qd):
        raise ModelError(f"{what} depends on velocities; give the position r(q, t)")
    return r


def _components(vec: object, frame: object, what: str) -> list[object]:
    """Three components; planar vectors get ``z = 0`` so 2- and 3-vectors mix."""
    comps = vector_components(vec, frame, what)
    return comps + [0] * (3 - len(comps))


def _unpack_particle(particle: object, k: int) -> tuple[object, object]:
    try:
        mass, position = cast(Sequence[object], particle)
    except (TypeError, ValueError) as exc:
        raise ModelError(f"particles[{k}] must be a (mass, position) pair, got {particle!r}") \
            from exc
    return mass, position
