"""Contacts between bodies: unilateral constraints of a Multibody.

A contact is a gap between two bodies that acts only when closed and only by pushing
(:class:`~dalembert.Unilateral` for a hand-written System). While it is closed it is a
joint of the mechanism: a point on a plane (:class:`~.joints.PointOnPlane`, the plane
moved along its normal by a sphere's radius) or two points at a distance
(:class:`~.joints.Distance`, the sum of two spheres' radii). A run switches it on and
off (:mod:`dalembert.solvers.contact`): the Multibody with the contacts closed then is
the Multibody with these joints added after its own.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import sympy as sp

from ..errors import ModelError
from .bodies import Body
from .joints import Distance, Joint, PointOnPlane, _unit
from .types import Vector


@dataclass(frozen=True)
class Contact:
    """A contact of a Multibody: its name, its law and the joint it is while closed.

    Attributes
    ----------
    name
        Its name (messages, ``traj.multiplier(name)``).
    joint
        The bilateral joint whose equation is the gap while closed (positive while
        open).
    restitution
        Newton's coefficient in ``[0, 1]`` (or a parameter symbol), as for
        :class:`~dalembert.Unilateral`.
    rest_speed
        An impact closing slower than this is plastic (as for
        :class:`~dalembert.Unilateral`).
    """

    name: str
    joint: Joint
    restitution: float | sp.Symbol = 0.0
    rest_speed: float = 1e-6

    @property
    def bodies(self) -> tuple[Body, Body]:
        return self.joint.body_a, self.joint.body_b


def plane_contact(name: str, plane_body: Body, body: Body, *, normal: Vector = (0, 0, 1),
                  point_on_plane: Vector = (0, 0, 0), point: Vector = (0, 0, 0),
                  radius: float = 0.0, restitution: float | sp.Symbol = 0.0,
                  rest_speed: float = 1e-6) -> Contact:
    """A point of ``body`` (a sphere's centre with ``radius``) above a plane of
    ``plane_body``: the gap is the height over the plane (less the radius).

    Parameters
    ----------
    name
        The contact's name.
    plane_body, body
        The body carrying the plane (``Ground()`` for a floor) and the one touching it.
    normal
        The plane's normal in ``plane_body``'s frame, pointing to the open side.
    point_on_plane, point
        A point of the plane (``plane_body``'s frame) and the touching point or sphere
        centre (``body``'s frame).
    radius
        The sphere's radius (0: a point).
    restitution, rest_speed
        As for :class:`~dalembert.Unilateral`.

    Examples
    --------
    >>> from dalembert.multibody import Ground, Particle
    >>> floor = plane_contact("floor", Ground(), Particle("ball", 1.0), radius=0.1,
    ...                       restitution=0.5)
    >>> floor.joint.constraints()[0].expr
    ball_z(t) - 0.1
    """
    n = _unit(normal, f"contact {name!r}: the normal")
    if n.dtype == object:
        raise ModelError(f"contact {name!r}: the normal must be numbers (a contact's "
                         "geometry is not a parameter)")
    size = _length(radius, name, "radius", zero=True)
    on_plane = np.asarray(point_on_plane, dtype=float) + size * n
    return _contact(name, PointOnPlane(name, plane_body, body, n, on_plane, point),
                    restitution, rest_speed)


def sphere_contact(name: str, body_a: Body, body_b: Body, radius_a: float,
                   radius_b: float, *, point_a: Vector = (0, 0, 0),
                   point_b: Vector = (0, 0, 0), restitution: float | sp.Symbol = 0.0,
                   rest_speed: float = 1e-6) -> Contact:
    """Two spheres (centres ``point_a`` on ``body_a``, ``point_b`` on ``body_b``): the gap
    is ``|c_b - c_a|^2 - (r_a + r_b)^2``, positive while apart.

    Parameters
    ----------
    name
        The contact's name.
    body_a, body_b
        The two bodies.
    radius_a, radius_b
        The spheres' radii.
    point_a, point_b
        The centres in each body's frame.
    restitution, rest_speed
        As for :class:`~dalembert.Unilateral`.

    Examples
    --------
    >>> from dalembert.multibody import Particle
    >>> touch = sphere_contact("touch", Particle("a", 1.0), Particle("b", 1.0), 0.1, 0.1)
    >>> touch.joint.length
    0.2
    """
    total = _length(radius_a, name, "radius_a") + _length(radius_b, name, "radius_b")
    return _contact(name, Distance(name, body_a, body_b, total, point_a, point_b),
                    restitution, rest_speed)


def _contact(name: str, joint: Joint, restitution: float | sp.Symbol,
             rest_speed: float) -> Contact:
    """The contact checked: its restitution in [0, 1] (or a symbol), a positive finite
    rest speed."""
    if not isinstance(restitution, sp.Symbol) and (
            isinstance(restitution, bool) or not isinstance(restitution, (int, float))
            or not 0.0 <= restitution <= 1.0):
        raise ModelError(f"contact {name!r}: the restitution must be in [0, 1] (or a "
                         f"parameter symbol), got {restitution!r}")
    if isinstance(rest_speed, bool) or not isinstance(rest_speed, (int, float)) \
            or not 0.0 < rest_speed < math.inf:
        raise ModelError(f"contact {name!r}: the rest_speed must be a finite positive "
                         f"number, got {rest_speed!r}")
    restitution = restitution if isinstance(restitution, sp.Symbol) else float(restitution)
    return Contact(name, joint, restitution, float(rest_speed))


def _length(value: object, name: str, what: str, zero: bool = False) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) \
            or not (value >= 0.0 if zero else value > 0.0) or not math.isfinite(value):
        raise ModelError(f"contact {name!r}: the {what} must be a finite "
                         f"{'non-negative' if zero else 'positive'} number, got {value!r}")
    return float(value)
