"""Contacts between bodies and joint limits: unilateral constraints of a Multibody.

A contact is a gap between two bodies that acts only when closed and only by pushing
(:class:`~dalembert.Unilateral` for a hand-written System). While it is closed it is a
joint of the mechanism: a point on a plane (:class:`~.joints.PointOnPlane`, the plane
moved along its normal by a sphere's radius), two points at a distance
(:class:`~.joints.Distance`, the sum of two spheres' radii), a disk's rim on a plane
(:class:`DiskOnPlane`) or a joint at the end of its range (:class:`JointStop`). A run
switches it on and off (:mod:`dalembert.solvers.contact`): the Multibody with the
contacts closed then is the Multibody with these joints added after its own.

Coulomb friction (``friction=mu``) acts along the contact's sliding velocity: the
velocity of the material point of ``body_b`` at the contact relative to that of
``body_a`` at the same place, in the plane tangent to the contact (:class:`Sliding`).
In the event-driven contact mode a closed contact sticks, its sliding velocity held by
these rows (:class:`Sliding`) while its force stays in the cone of radius ``mu`` times
the normal one, or slides, its friction a load against the sliding velocity
(:class:`SlidingFriction`); the time-stepping mode keeps each friction impulse in that
cone.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import sympy as sp

from ..errors import ModelError
from ..model.constraints import Holonomic, Pfaffian
from ..model.coordinates import t
from .bodies import Body, Ground, Particle, PlanarBody, RigidBody
from .drivers import _angle_terms, take_joint_geometry
from .joints import Distance, Joint, PointOnPlane, Prismatic, Revolute, _unit
from .rotations import G_matrix, dot
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
    friction
        Coulomb's coefficient ``mu >= 0`` (0: frictionless).
    sliding
        The joint whose Pfaffian rows are the sliding velocities at the contact
        (:class:`Sliding`), ``None`` for a contact without friction (a joint limit).
    """

    name: str
    joint: Joint
    restitution: float | sp.Symbol = 0.0
    rest_speed: float = 1e-6
    friction: float = 0.0
    sliding: Sliding | None = None

    @property
    def bodies(self) -> tuple[Body, Body]:
        return self.joint.body_a, self.joint.body_b

    @property
    def tangents(self) -> tuple[sp.Expr, ...]:
        """The sliding velocities at the contact (none without friction), as for
        :class:`~dalembert.Unilateral`: one per row of :attr:`sliding`."""
        if self.friction == 0 or self.sliding is None:
            return ()
        return tuple(self.sliding.planar_equations() if self.sliding.planar
                     else self.sliding.equations())


def plane_contact(name: str, plane_body: Body, body: Body, *, normal: Vector = (0, 0, 1),
                  point_on_plane: Vector = (0, 0, 0), point: Vector = (0, 0, 0),
                  radius: float = 0.0, restitution: float | sp.Symbol = 0.0,
                  rest_speed: float = 1e-6, friction: float = 0.0) -> Contact:
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
    friction
        Coulomb's coefficient ``mu >= 0`` (0: frictionless), along the sliding velocity
        of the touching point (the sphere's lowest point) over the plane: two
        directions of the plane, one (in the plane of motion) between planar bodies.
        ``math.inf`` is a rough contact (never sliding).

    Examples
    --------
    >>> from dalembert.multibody import Ground, Particle
    >>> floor = plane_contact("floor", Ground(), Particle("ball", 1.0), radius=0.1,
    ...                       restitution=0.5)
    >>> floor.joint.constraints()[0].expr
    ball_z(t) - 0.1
    >>> rough = plane_contact("floor", Ground(), Particle("ball", 1.0), friction=0.3)
    >>> rough.tangents
    (Derivative(ball_x(t), t), Derivative(ball_y(t), t))
    """
    n = _unit(normal, f"contact {name!r}: the normal")
    if n.dtype == object:
        raise ModelError(f"contact {name!r}: the normal must be numbers (a contact's "
                         "geometry is not a parameter)")
    size = _length(radius, name, "radius", zero=True)
    on_plane = np.asarray(point_on_plane, dtype=float) + size * n
    joint = PointOnPlane(name, plane_body, body, n, on_plane, point)
    return _contact(name, joint, restitution, rest_speed, friction,
                    lambda: Sliding(name, "plane", plane_body, body, normal=n,
                                    point_b=point, radius=size, ref_a=joint.ref_a))


def sphere_contact(name: str, body_a: Body, body_b: Body, radius_a: float,
                   radius_b: float, *, point_a: Vector = (0, 0, 0),
                   point_b: Vector = (0, 0, 0), restitution: float | sp.Symbol = 0.0,
                   rest_speed: float = 1e-6, friction: float = 0.0) -> Contact:
    """Two spheres (centres ``point_a`` on ``body_a``, ``point_b`` on ``body_b``): the gap
    is ``|c_b - c_a|^2 - (r_a + r_b)^2``, positive while apart; with friction
    ``|c_b - c_a| - (r_a + r_b)`` (:class:`SphereGap`), whose multiplier is the normal
    force that bounds the friction.

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
    friction
        Coulomb's coefficient ``mu >= 0`` (0: frictionless), along the sliding velocity
        at the point of contact: in space its three world components projected on the
        tangent plane (no two fixed directions stay tangent to a sphere everywhere),
        between planar bodies its component in the plane of motion; ``math.inf`` is a
        rough contact (never sliding). In space the three rows are of rank 2: a
        sticking or rough contact holds them as dependent rows, which the run
        solves with the independent ones.

    Examples
    --------
    >>> from dalembert.multibody import Particle
    >>> touch = sphere_contact("touch", Particle("a", 1.0), Particle("b", 1.0), 0.1, 0.1)
    >>> touch.joint.length
    0.2
    >>> rough = sphere_contact("touch", Particle("a", 1.0), Particle("b", 1.0), 0.1, 0.1,
    ...                        friction=0.5)
    >>> len(rough.tangents)
    3
    """
    size_a = _length(radius_a, name, "radius_a")
    total = size_a + _length(radius_b, name, "radius_b")
    # with friction the gap is a distance: the cone's radius is mu times the gap's
    # multiplier, which is then the normal force (the squared form's is that over 2|d|)
    rough = not isinstance(friction, bool) and isinstance(friction, (int, float)) \
        and friction > 0
    joint = (SphereGap if rough else Distance)(name, body_a, body_b, total, point_a, point_b)
    return _contact(name, joint, restitution, rest_speed, friction,
                    lambda: Sliding(name, "sphere", body_a, body_b, point_a=point_a,
                                    point_b=point_b, radius=size_a))


def disk_contact(name: str, plane_body: Body, disk_body: Body, radius: float, *,
                 axis: Vector = (0, 0, 1), point: Vector = (0, 0, 0),
                 normal: Vector = (0, 0, 1), point_on_plane: Vector = (0, 0, 0),
                 restitution: float | sp.Symbol = 0.0, rest_speed: float = 1e-6,
                 friction: float = 0.0) -> Contact:
    """The rim of a thin disk of ``disk_body`` above a plane of ``plane_body``: the gap
    is the height of the rim's lowest point, ``n.(c - p0) - r sqrt(1 - (n.a)^2)``
    (:class:`DiskOnPlane`; ``c`` the disk's centre, ``a`` its unit axis, ``n`` the
    plane's normal, all in world components).

    The gap is smooth while the disk is not flat. A disk lying flat on the plane
    (``a`` along ``n``) is outside the contact's domain: every rim point is then lowest
    and the gap's row is ``0/0``, not finite. A run in which it lands flat ends there as
    failed, naming the contact, with what it computed (falling flat far from the plane
    is fine). Keep the disk off flat (or model a coin that may lie flat by contacts at
    points of its rim).

    Parameters
    ----------
    name
        The contact's name.
    plane_body, disk_body
        The body carrying the plane (``Ground()`` for a floor) and the disk's body (a
        ``RigidBody``, or a ``PlanarBody`` whose disk turns in the plane).
    radius
        The disk's radius.
    axis, point
        The disk's axis and its centre in ``disk_body``'s frame.
    normal, point_on_plane
        The plane's normal (pointing to the open side) and a point of it, in
        ``plane_body``'s frame.
    restitution, rest_speed
        As for :class:`~dalembert.Unilateral`.
    friction
        Coulomb's coefficient ``mu >= 0`` (0: frictionless), along the sliding velocity
        of the rim's lowest point over the plane (two directions of the plane; one
        between planar bodies). ``math.inf`` is a rough contact (never sliding).

    Examples
    --------
    A wheel (axis body ``y``) over the floor: upright, its gap is its centre's height
    less the radius.

    >>> from dalembert.multibody import Ground, RigidBody
    >>> wheel = RigidBody("wheel", 1.0, (0.25, 0.5, 0.25))
    >>> rim = disk_contact("rim", Ground(), wheel, 0.5, axis=(0, 1, 0), friction=0.8)
    >>> upright = {c: v for c, v in zip(wheel.coordinates, (0, 0, 0.7, 1, 0, 0, 0))}
    >>> round(float(rim.joint.equations()[0].subs(upright)), 12)
    0.2
    >>> len(rim.tangents)
    2
    """
    n = _unit(normal, f"contact {name!r}: the normal")
    a = _unit(axis, f"contact {name!r}: the disk's axis")
    if n.dtype == object or a.dtype == object:
        raise ModelError(f"contact {name!r}: the normal and the axis must be numbers (a "
                         "contact's geometry is not a parameter)")
    if not isinstance(disk_body, RigidBody | PlanarBody):
        raise ModelError(f"contact {name!r}: the disk's body must be a RigidBody (or a "
                         f"PlanarBody), got {disk_body!r}; a particle has no axis")
    size = _length(radius, name, "radius")
    joint = DiskOnPlane(name, plane_body, disk_body, size, n, a, point_on_plane, point)
    return _contact(name, joint, restitution, rest_speed, friction,
                    lambda: Sliding(name, "disk", plane_body, disk_body, normal=n,
                                    point_b=point, radius=size, axis_b=a,
                                    ref_a=joint.ref_a))


def _contact(name: str, joint: Joint, restitution: float | sp.Symbol,
             rest_speed: float, friction: object = 0.0,
             sliding: Callable[[], Sliding] | None = None) -> Contact:
    """The contact checked: its restitution in [0, 1] (or a symbol), a positive finite
    rest speed, a friction coefficient >= 0 or ``math.inf`` (rough) (its sliding rows
    made if > 0)."""
    if not isinstance(restitution, sp.Symbol) and (
            isinstance(restitution, bool) or not isinstance(restitution, (int, float))
            or not 0.0 <= restitution <= 1.0):
        raise ModelError(f"contact {name!r}: the restitution must be in [0, 1] (or a "
                         f"parameter symbol), got {restitution!r}")
    if isinstance(rest_speed, bool) or not isinstance(rest_speed, (int, float)) \
            or not 0.0 < rest_speed < math.inf:
        raise ModelError(f"contact {name!r}: the rest_speed must be a finite positive "
                         f"number, got {rest_speed!r}")
    if isinstance(friction, bool) or not isinstance(friction, (int, float)) \
            or not 0.0 <= friction <= math.inf:
        raise ModelError(f"contact {name!r}: the friction must be a number >= 0 "
                         f"(Coulomb's coefficient, or math.inf: rough, never sliding; a "
                         f"contact's law is not a parameter), got {friction!r}")
    restitution = restitution if isinstance(restitution, sp.Symbol) else float(restitution)
    rows = sliding() if friction > 0 and sliding is not None else None
    return Contact(name, joint, restitution, float(rest_speed), float(friction), rows)


def _length(value: object, name: str, what: str, zero: bool = False) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) \
            or not (value >= 0.0 if zero else value > 0.0) or not math.isfinite(value):
        raise ModelError(f"contact {name!r}: the {what} must be a finite "
                         f"{'non-negative' if zero else 'positive'} number, got {value!r}")
    return float(value)


class DiskOnPlane(Joint):
    """The rim of a thin disk on ``body_b`` on a plane of ``body_a`` (1 equation): the
    height of the rim's lowest point over the plane, ``n.(c - p0) - r sqrt(1 - (n.a)^2)``
    (``n`` the plane's normal, ``p0`` a point of it, ``c`` the disk's centre, ``a`` its
    unit axis, world components). Not smooth where the disk lies flat (``a`` along
    ``n``): see :func:`disk_contact`.

    Parameters
    ----------
    name
        Its name.
    body_a, body_b
        The plane's body and the disk's.
    radius
        The disk's radius.
    normal, axis
        The plane's normal (``body_a``'s frame) and the disk's axis (``body_b``'s).
    point_a, point_b
        A point of the plane and the disk's centre, each in its body's frame.

    Examples
    --------
    >>> from dalembert.multibody import Ground, RigidBody
    >>> disk = DiskOnPlane("rim", Ground(), RigidBody("d", 1.0, (1, 2, 1)), 0.5,
    ...                    axis=(0, 1, 0))
    >>> disk.constraint_names
    ['rim_1']
    """

    n_equations = 1
    planar_rows = 1

    def __init__(self, name: str, body_a: Body, body_b: Body, radius: float,
                 normal: Vector = (0, 0, 1), axis: Vector = (0, 0, 1),
                 point_a: Vector = (0, 0, 0), point_b: Vector = (0, 0, 0)) -> None:
        self.radius = float(radius)
        super().__init__(name, body_a, body_b, point_a, point_b, axis_a=normal, axis_b=axis)

    def _check_planar_axes(self) -> None:
        if abs(float(self.axis_a[2])) > 1e-12:
            raise ModelError(f"contact {self.name!r} between planar bodies: the plane's "
                             f"normal {tuple(self.axis_a.tolist())} must lie in the x-y "
                             "plane (in the plane the disk rolls on a line)")

    def equations(self) -> list[sp.Expr]:
        n, a = self.frame("a")[2], self.frame("b")[2]
        centre = self.body_b.position(self.point_b)
        height = dot(n, centre - self.body_a.position(self.point_a))
        return [height - self.radius * sp.sqrt(1 - dot(n, a) ** 2)]

    planar_equations = equations


class SphereGap(Distance):
    """Two points at a distance ``length`` as a distance, ``|d| - length`` (1 equation):
    its multiplier is the force along ``d`` (:class:`~.joints.Distance`'s squared form
    has it over ``2 |d|``), as friction's cone needs.

    Parameters
    ----------
    name, body_a, body_b, length, point_a, point_b
        As for :class:`~.joints.Distance`.

    Examples
    --------
    >>> from dalembert.multibody import Ground, Particle
    >>> SphereGap("touch", Ground(), Particle("p", 1.0), 2.0).constraints()[0].expr
    sqrt(p_x(t)**2 + p_y(t)**2 + p_z(t)**2) - 2.0
    """

    def equations(self) -> list[sp.Expr]:
        d = self.separation()
        return [sp.sqrt(dot(d, d)) - self.length]

    planar_equations = equations


class Sliding(Joint):
    """The sliding velocity at a contact: the velocity of ``body_b``'s material point
    at the contact point less ``body_a``'s there, along directions tangent to the
    contact (Pfaffian rows ``<name>_1, ...``, :attr:`Contact.sliding`). The
    time-stepping contact mode reads them for friction, never enforcing them; a rough
    contact's (``friction=math.inf``) are enforced while it is closed.

    The contact point and the directions, by ``kind``:

    - ``"plane"``: the point (sphere centre ``c``) less ``radius`` along the plane's
      normal ``n``; the plane's two directions ``u``, ``v = n x u`` (``ref_a``), turning
      with ``body_a``;
    - ``"disk"``: the rim's lowest point ``c - r (n - (n.a) a) / sqrt(1 - (n.a)^2)``; the
      plane's directions;
    - ``"sphere"``: ``c_a + r_a d / |d|`` (``d = c_b - c_a``); the sliding velocity's
      three world components less its part along ``d`` (of rank 2).

    Between planar bodies one row: the component along ``z x n``, in the plane.

    Parameters
    ----------
    name
        The contact's name (the rows are ``<name>_friction_1, ...``).
    kind
        ``"plane"``, ``"disk"`` or ``"sphere"``.
    body_a, body_b
        The contact's bodies (the plane's first).
    normal
        The plane's normal (``body_a``'s frame).
    point_a, point_b
        Sphere ``a``'s centre (``"sphere"``); sphere or disk centre, or touching point,
        on ``body_b``.
    radius
        The sphere's or disk's radius (``"sphere"``: sphere ``a``'s).
    axis_b
        The disk's axis (``body_b``'s frame).
    ref_a
        The plane's first direction (``body_a``'s frame).

    Examples
    --------
    >>> from dalembert.multibody import Ground, Particle
    >>> Sliding("floor", "plane", Ground(), Particle("p", 1.0)).constraint_names
    ['floor_friction_1', 'floor_friction_2']
    """

    planar_rows = 1
    uses_orientation = False

    def __init__(self, name: str, kind: str, body_a: Body, body_b: Body, *,
                 normal: Vector = (0, 0, 1), point_a: Vector = (0, 0, 0),
                 point_b: Vector = (0, 0, 0), radius: float = 0.0,
                 axis_b: Vector = (0, 0, 1), ref_a: Vector | None = None) -> None:
        if kind not in ("plane", "disk", "sphere"):
            raise ModelError(f"contact {name!r}: no sliding velocity for a {kind!r} contact")
        self.kind = kind
        self.radius = float(radius)
        self.n_equations = 3 if kind == "sphere" else 2
        super().__init__(f"{name}_friction", body_a, body_b, point_a, point_b,
                         axis_a=normal, axis_b=axis_b, ref_a=ref_a)

    def _check_bodies(self) -> None:
        pass  # the contact's own joint checked them

    def _check_planar_axes(self) -> None:
        pass  # the contact's own joint checked them

    def contact_point(self) -> tuple[sp.Matrix, sp.Matrix]:
        """The contact point and the normal (world components, SymPy)."""
        r = self.radius
        if self.kind == "sphere":
            centre = self.body_a.position(self.point_a)
            d = self.body_b.position(self.point_b) - centre
            n = d / sp.sqrt(dot(d, d))
            return centre + r * n, n
        n = self.frame("a")[2]
        centre = self.body_b.position(self.point_b)
        if self.kind == "plane":
            return centre - r * n, n
        a = self.frame("b")[2]
        along = dot(n, a)
        return centre - r * (n - along * a) / sp.sqrt(1 - along**2), n

    def equations(self) -> list[sp.Expr]:
        point, n = self.contact_point()
        slip = _material_velocity(self.body_b, point) - _material_velocity(self.body_a, point)
        if self.planar:
            across = sp.Matrix([-n[1], n[0], 0])  # z x n, in the plane of motion
            if self.kind == "sphere":  # n may lean out of the plane (centres at two z)
                across = across / sp.sqrt(n[0] ** 2 + n[1] ** 2)
            return [dot(across, slip)]
        if self.kind == "sphere":
            return list(slip - n * dot(n, slip))
        u, v, _ = self.frame("a")
        return [dot(u, slip), dot(v, slip)]

    planar_equations = equations

    def constraints(self) -> list[Holonomic | Pfaffian]:
        return [Pfaffian(e, name=name) for e, name in
                zip(self.equations(), self.constraint_names)]


def _material_velocity(body: Body, point: sp.Matrix) -> sp.Matrix:
    """The velocity of ``body``'s material point at the world point ``point``:
    ``x' + w x (point - x)`` (0 on the ground; a particle does not turn)."""
    if isinstance(body, Ground):
        return sp.zeros(3, 1)
    centre = body.center
    velocity = centre.diff(t)
    if isinstance(body, RigidBody):
        spin = 2 * G_matrix(body.quaternion) * body.quaternion.diff(t)  # world frame
    elif isinstance(body, PlanarBody):
        spin = sp.Matrix([0, 0, body.angle.diff(t)])
    else:
        assert isinstance(body, Particle)
        return velocity
    return velocity + spin.cross(point - centre)


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


@dataclass(frozen=True)
class SlidingFriction:
    """The friction forces of a sliding contact as loads: each sliding velocity's force
    ``F_k`` (an input symbol) on the two bodies' material points at the contact, whose
    generalized force is ``F_k`` times the sliding velocity's coefficients of the
    coordinates' rates (the virtual power of the pair of forces).

    Attributes
    ----------
    contact
        The contact.
    forces
        One input symbol per sliding velocity (:attr:`Contact.tangents`).

    Examples
    --------
    >>> ball = Particle("ball", 1.0)
    >>> floor = plane_contact("floor", Ground(), ball, friction=0.3)
    >>> F = sp.symbols("F1 F2")
    >>> SlidingFriction(floor, F).generalized_forces()
    {ball_x(t): F1, ball_y(t): F2}
    """

    contact: Contact
    forces: tuple[sp.Symbol, ...]

    def generalized_forces(self) -> dict[object, sp.Expr]:
        Q: dict[object, sp.Expr] = {}
        coordinates = [c for body in self.contact.bodies if not isinstance(body, Ground)
                       for c in body.coordinates]
        for force, velocity in zip(self.forces, self.contact.tangents):
            for c in coordinates:
                weight = velocity.diff(c.diff(t))  # the velocity is linear in the rates
                if weight != 0:
                    Q[c] = Q.get(c, sp.S.Zero) + force * weight
        return Q
