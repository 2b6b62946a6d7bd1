"""Contacts between bodies and joint limits: unilateral constraints of a Multibody.

A contact is a gap between two bodies that acts only when closed and only by pushing
(:class:`~dalembert.Unilateral` for a hand-written System). While it is closed it is a
joint of the mechanism: a point on a plane (:class:`~.joints.PointOnPlane`, the plane
moved along its normal by a sphere's radius), two points at a distance
(:class:`~.joints.Distance`, the sum of two spheres' radii), or a joint at the end of
its range (:class:`JointStop`). A run switches it on and off
(:mod:`dalembert.solvers.contact`): the Multibody with the contacts closed then is the
Multibody with these joints added after its own.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import sympy as sp

from ..errors import ModelError
from ..model.constraints import Holonomic, Pfaffian
from .bodies import Body
from .drivers import _angle_terms, take_joint_geometry
from .joints import Distance, Joint, PointOnPlane, Prismatic, Revolute, _unit
from .rotations import dot
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
    #: Coulomb friction (not yet for a Multibody's contacts: 0).
    friction: float = 0.0

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


class JointStop(Joint):
    """The range of a revolute joint's angle or a prismatic joint's travel as one gap,
    positive inside the range, 0 at either end (1 equation while closed).

    Revolute, the range ``[lower, upper]`` (less than a turn) about its middle ``m``
    and half-width ``w``: ``cos(theta - m) - cos(w)``, smooth at both ends and blind to
    whole turns. Prismatic: ``w^2 - (d - m)^2``.

    Parameters
    ----------
    name
        Its name.
    joint
        The ``Revolute`` or ``Prismatic`` joint it limits (in the mechanism's joints).
    lower, upper
        The range's ends (rad or length), ``lower < upper``.
    """

    n_equations = 1
    planar_rows = 1

    def __init__(self, name: str, joint: Joint, lower: float, upper: float) -> None:
        if not isinstance(joint, Revolute | Prismatic):
            raise ModelError(f"joint limit {name!r}: a limit bounds a Revolute or Prismatic "
                             f"joint, got {joint!r}")
        for what, value in (("lower", lower), ("upper", upper)):
            if isinstance(value, bool) or not isinstance(value, (int, float)) \
                    or not math.isfinite(value):
                raise ModelError(f"joint limit {name!r}: {what} must be a finite number, "
                                 f"got {value!r}")
        turn = isinstance(joint, Revolute)
        if not lower < upper or (turn and upper - lower >= 2 * math.pi):
            raise ModelError(f"joint limit {name!r}: the range [{lower}, {upper}] must have "
                             f"lower < upper{' and span less than a turn' if turn else ''}")
        self.joint_kind = take_joint_geometry(self, name, joint)
        self.limited = joint
        self.middle, self.half = (lower + upper) / 2, (upper - lower) / 2
        self.uses_orientation = turn
        self.n_equations = 1

    def equations(self) -> list[sp.Expr]:
        m, w = self.middle, self.half
        if self.joint_kind == "Revolute":
            cos_like, sin_like = _angle_terms(self)  # type: ignore[arg-type]
            return [cos_like * math.cos(m) + sin_like * math.sin(m) - math.cos(w)]
        travel = dot(self.frame("a")[2], self.separation())
        return [w**2 - (travel - m) ** 2]

    planar_equations = equations

    def _check_planar(self) -> None:
        pass  # the limited joint fits the plane: it checked that

    def constraints(self) -> list[Holonomic | Pfaffian]:
        return [Holonomic(self.equations()[0], name=f"{self.name}_1")]


def joint_limit(name: str, joint: Joint, lower: float, upper: float, *,
                restitution: float | sp.Symbol = 0.0, rest_speed: float = 1e-6) -> Contact:
    """A revolute joint's angle or a prismatic joint's travel kept in ``[lower, upper]``
    by a stop at each end (:class:`JointStop`): a unilateral constraint.

    Parameters
    ----------
    name
        The limit's name.
    joint
        The ``Revolute`` or ``Prismatic`` joint (in the mechanism's joints).
    lower, upper
        The range (rad for a revolute joint, less than a turn; length for a prismatic).
    restitution, rest_speed
        As for :class:`~dalembert.Unilateral`.

    Examples
    --------
    >>> from dalembert.multibody import Ground, RigidBody, Revolute
    >>> link = RigidBody("link", 1.0, (0.1, 0.1, 0.1))
    >>> hinge = Revolute("hinge", Ground(), link, axis_a=(0, 1, 0), axis_b=(0, 1, 0))
    >>> joint_limit("stop", hinge, -0.5, 0.5).joint.half
    0.5
    """
    return _contact(name, JointStop(name, joint, lower, upper), restitution, rest_speed)
