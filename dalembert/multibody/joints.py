"""Joints between two bodies (or a body and ``Ground``) as holonomic constraints.

Each side of a joint has a point (body frame; world frame on ``Ground``) and a
joint frame ``(u, v, w)``: ``w`` is the joint ``axis``, ``u`` the reference
direction ``ref`` (perpendicular to ``w``; by default the coordinate axis least
aligned with ``w``, made perpendicular) and ``v = w x u``. With ``d`` the vector
from point ``a`` to point ``b`` and all vectors in world components:

============  =====  ===========================================================
joint         rows   equations
============  =====  ===========================================================
Spherical     3      ``d = 0``
Universal     4      ``d = 0``, ``w_a . w_b = 0`` (cross axes)
Revolute      5      ``d = 0``, ``u_a . w_b = 0``, ``v_a . w_b = 0``
Prismatic     5      ``u_a . w_b = v_a . w_b = u_a . v_b = 0``, ``u_a . d = v_a . d = 0``
Fixed         6      ``d = 0``, ``u_a . w_b = v_a . w_b = u_a . v_b = 0``
Distance      1      ``d . d - length^2 = 0`` (massless rod)
PointOnPlane  1      ``n_a . d = 0`` (point ``b`` on the plane through ``a``)
Free          0      none (names a free motion, which joint coordinates measure)
============  =====  ===========================================================

``Prismatic`` and ``Fixed`` lock the two joint frames parallel, so give each
side's ``axis``/``ref`` as they are when the bodies are assembled.

Between planar bodies (:class:`~dalembert.multibody.PlanarBody`, or one and
``Ground``) the rows that hold identically in the plane are left out, so the
constraints stay independent:

============  =====  ===========================================================
planar        rows   equations (``d``: in-plane components; axes in world)
============  =====  ===========================================================
Spherical     2      ``d = 0`` (a pin)
Revolute      2      ``d = 0``; the axes must be along ``z``
Fixed         3      ``d = 0``, ``u_a . v_b = 0``; the axes must be along ``z``
Prismatic     2      ``n_a . w_b = 0``, ``n_a . d = 0`` with ``n_a = z x w_a``; the
                     sliding axes must lie in the plane
Distance      1      as in 3D
PointOnPlane  1      as in 3D (a point on a line); the normal must lie in the plane
============  =====  ===========================================================

``Universal`` has no planar form. The rows of
joint ``J`` are the constraints ``J_1, J_2, ...``. Every joint's equations are
invariant under a common rigid motion of both bodies, so its constraint forces
on ``a`` and ``b`` are equal and opposite (see
:func:`dalembert.multibody.outputs.joint_reactions`).
"""

from __future__ import annotations

from typing import Literal

import numpy as np
import sympy as sp

from ..errors import ModelError
from ..model.constraints import Holonomic, Pfaffian
from .bodies import Body, Ground, Particle, PlanarBody
from .parametric import (
    Scalar,
    array,
    is_symbolic,
    parametric_symbols,
    scalar,
    sympy_vector,
    to_sympy,
)
from .rotations import dot, times_vector
from .types import Vector

#: A joint's two sides: body ``a`` and body ``b``.
Side = Literal["a", "b"]


def _unit(v: object, what: str) -> np.ndarray:
    """A direction made unit: 3 numbers, or expressions of parameters (normalized in
    the expressions, checked once bound)."""
    arr = array(v, (3,), what)
    if is_symbolic(arr):
        norm = sp.sqrt(sum(to_sympy(c) ** 2 for c in arr))
        return np.array([to_sympy(c) / norm for c in arr], dtype=object)
    norm = np.linalg.norm(arr)
    if norm == 0:
        raise ModelError(f"{what} is the zero vector; give a direction")
    return arr / norm


def _perpendicular(w: np.ndarray, ref: object, what: str) -> np.ndarray:
    """``ref`` made perpendicular to ``w`` (default: the axis least aligned with ``w``;
    an axis with parameters needs its reference given, which can then hold some too)."""
    if ref is None:
        if is_symbolic(w):
            raise ModelError(f"{what}: a joint axis written with parameters needs its "
                             "reference direction too (ref_a / ref_b: perpendicular to it, "
                             "where the joint's angle is zero)")
        ref = np.eye(3)[int(np.argmin(np.abs(w)))]
    u = _unit(ref, what)
    if is_symbolic(u) or is_symbolic(w):
        along = sum(to_sympy(a) * to_sympy(b) for a, b in zip(u, w))
        u = np.array([to_sympy(a) - along * to_sympy(b) for a, b in zip(u, w)], dtype=object)
        return _unit(u, what)
    u = u - u.dot(w) * w
    if np.linalg.norm(u) < 1e-8:
        raise ModelError(f"{what} is parallel to the joint axis; give a perpendicular direction")
    return u / np.linalg.norm(u)


def _point(p: object, what: str) -> np.ndarray:
    """A point: 3 numbers, or expressions of parameters (see :mod:`.parametric`)."""
    return array(p, (3,), what)


def _sym(v: np.ndarray) -> sp.Matrix:
    return sympy_vector(v)


class Joint:
    """Base class: two bodies, a point and a joint frame on each.

    Parameters
    ----------
    name
        Constraint names are ``<name>_1``, ``<name>_2``, ...
    body_a, body_b
        The joined bodies; either may be a :class:`~dalembert.multibody.Ground`.
    point_a, point_b
        The joint point on each body, in that body's frame.
    axis_a, axis_b
        Joint axis on each body (body frame); ``axis_b`` defaults to ``axis_a``.
    ref_a, ref_b
        Reference directions perpendicular to the axes (see the module docstring).

    Examples
    --------
    A joint kind is a subclass with its equations; every joint checks its points and
    axes and names its rows:

    >>> from dalembert.multibody import Ground, Particle
    >>> class OnSphere(Joint):  # point b on the sphere of radius 2 about point a
    ...     n_equations, uses_orientation = 1, False
    ...     def equations(self):
    ...         d = self.separation()
    ...         return [d.dot(d) - 4]
    >>> OnSphere("shell", Ground(), Particle("p", 1.0)).constraints()[0].expr
    p_x(t)**2 + p_y(t)**2 + p_z(t)**2 - 4
    """

    #: The number of equations (rows) of the joint.
    n_equations = 0
    #: The attributes that may be parameters (:mod:`.parametric`).
    PARAMETRIC: tuple[str, ...] = ("point_a", "point_b", "axis_a", "axis_b", "ref_a", "ref_b")
    #: Whether the joint constrains its bodies' orientations (then no particle may join).
    uses_orientation = True
    #: Rows between planar bodies (``None``: no planar form).
    planar_rows: int | None = None
    body_a: Body
    body_b: Body

    def __init__(
        self,
        name: str,
        body_a: Body,
        body_b: Body,
        point_a: Vector = (0, 0, 0),
        point_b: Vector = (0, 0, 0),
        axis_a: Vector = (0, 0, 1),
        axis_b: Vector | None = None,
        ref_a: Vector | None = None,
        ref_b: Vector | None = None,
    ) -> None:
        if not isinstance(name, str) or not name.isidentifier():
            raise ModelError(f"a joint name must be an identifier-like string, got {name!r}")
        self.name = name
        for label, body in (("body_a", body_a), ("body_b", body_b)):
            if not isinstance(body, Body):
                raise ModelError(f"joint {name!r}: {label} is {body!r}, not a body")
        if body_a is body_b:
            raise ModelError(f"joint {name!r} joins body {body_a.name!r} to itself")
        self.body_a, self.body_b = body_a, body_b
        self.point_a = _point(point_a, f"joint {name!r}: point_a")
        self.point_b = _point(point_b, f"joint {name!r}: point_b")
        self.axis_a = _unit(axis_a, f"joint {name!r}: axis_a")
        self.axis_b = _unit(self.axis_a if axis_b is None else axis_b,
                            f"joint {name!r}: axis_b")
        self.ref_a = _perpendicular(self.axis_a, ref_a, f"joint {name!r}: ref_a")
        self.ref_b = _perpendicular(self.axis_b, ref_b, f"joint {name!r}: ref_b")
        self._check_bodies()
        self._check_planar()

    @property
    def bodies(self) -> tuple[Body, Body]:
        """``(body_a, body_b)``."""
        return self.body_a, self.body_b

    def parameter_symbols(self) -> set[sp.Symbol]:
        """The parameter symbols of its geometry (:mod:`.parametric`)."""
        return parametric_symbols(self)

    def _check_bodies(self) -> None:
        if not self.uses_orientation:
            return
        for body in self.bodies:
            if isinstance(body, Particle):
                raise ModelError(
                    f"joint {self.name!r} ({type(self).__name__}) constrains the orientation "
                    f"of {body.name!r}, but a particle has none; use a RigidBody"
                )

    @property
    def planar(self) -> bool:
        """Both sides planar bodies or ground (at least one planar body)."""
        kinds = [type(b) for b in self.bodies]
        return PlanarBody in kinds and all(k in (PlanarBody, Ground) for k in kinds)

    def _check_planar(self) -> None:
        """Use the planar rows between planar bodies, after checking the axes fit."""
        if not self.planar:
            return
        if self.planar_rows is None:
            raise ModelError(
                f"joint {self.name!r} ({type(self).__name__}) has no planar form; between "
                "planar bodies use Revolute, Prismatic, Fixed, Distance or PointOnPlane")
        self._check_planar_axes()
        self.n_equations = self.planar_rows

    def _check_planar_axes(self) -> None:
        pass

    def _planar_axes(self, normal: bool, why: str) -> None:
        """Both axes along z, the plane's normal (``normal``), or in the x-y plane."""
        where = "be along z, the plane's normal" if normal else "lie in the x-y plane"
        for side, axis in (("a", self.axis_a), ("b", self.axis_b)):
            if is_symbolic(axis):
                raise ModelError(
                    f"joint {self.name!r} ({type(self).__name__}) between planar bodies: "
                    f"axis_{side} must be numbers that {where} ({why}), not parameters")
            off = abs(abs(axis[2]) - 1.0) if normal else abs(axis[2])
            if off > 1e-12:
                raise ModelError(
                    f"joint {self.name!r} ({type(self).__name__}) between planar bodies: "
                    f"axis_{side} {tuple(axis.tolist())} must {where} ({why})")

    # -- geometry in world components ------------------------------------------------
    def separation(self) -> sp.Matrix:
        """``d``: from point ``a`` to point ``b``."""
        return self.body_b.position(self.point_b) - self.body_a.position(self.point_a)

    def frame(self, side: Side) -> tuple[sp.Matrix, sp.Matrix, sp.Matrix]:
        """World components of ``(u, v, w)`` on side ``"a"`` or ``"b"``.

        Parameters
        ----------
        side
            ``"a"`` or ``"b"``.

        Examples
        --------
        On the ground the frame is the given one: the axis ``w`` along ``z``, the
        reference ``u`` by default the world axis least aligned with it:

        >>> from dalembert.multibody import Ground, RigidBody
        >>> hinge = Revolute("hinge", Ground(), RigidBody("door", 1.0, (1, 1, 1)))
        >>> [[float(c) for c in e] for e in hinge.frame("a")]
        [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]
        """
        body = self.body_a if side == "a" else self.body_b
        w = self.axis_a if side == "a" else self.axis_b
        u = self.ref_a if side == "a" else self.ref_b
        R = body.rotation()
        v = [w[1] * u[2] - w[2] * u[1], w[2] * u[0] - w[0] * u[2], w[0] * u[1] - w[1] * u[0]]
        return tuple(times_vector(R, _sym(np.asarray(e))) for e in (u, v, w))

    def _orientation_lock(self) -> list[sp.Expr]:
        ua, va, _ = self.frame("a")
        _, vb, wb = self.frame("b")
        return [dot(ua, wb), dot(va, wb), dot(ua, vb)]

    # -- constraints -----------------------------------------------------------------
    def equations(self) -> list[sp.Expr]:
        """The joint's equations ``psi = 0`` (``n_equations`` of them, SymPy)."""
        raise NotImplementedError

    def planar_equations(self) -> list[sp.Expr]:
        """The equations between planar bodies (``planar_rows`` of them)."""
        raise NotImplementedError

    def constraints(self) -> list[Holonomic | Pfaffian]:
        """The joint's equations as named ``Holonomic`` constraints ``<name>_<k>``."""
        eqs = self.planar_equations() if self.planar else self.equations()
        return [Holonomic(e, name=f"{self.name}_{k + 1}") for k, e in enumerate(eqs)]

    @property
    def constraint_names(self) -> list[str]:
        """``<name>_1 .. <name>_n``, without building the constraints."""
        return [f"{self.name}_{k + 1}" for k in range(self.n_equations)]

    def __repr__(self) -> str:
        return (f"{type(self).__name__}({self.name!r}, {self.body_a.name!r}, "
                f"{self.body_b.name!r})")


class Spherical(Joint):
    """Ball joint: the two points coincide (3 equations).

    Parameters
    ----------
    name
        The joint's name; its rows are ``<name>_1``, ``<name>_2``, ...
    body_a, body_b
        The joined bodies (either may be a :class:`~dalembert.multibody.Ground`).
    point_a, point_b
        The joint point on each body, in that body's frame relative to its center.

    Examples
    --------
    >>> from dalembert.multibody import Ground, Particle
    >>> len(Spherical("ball", Ground(), Particle("p", 1.0)).constraints())
    3
    """

    n_equations = 3
    planar_rows = 2
    uses_orientation = False

    def equations(self) -> list[sp.Expr]:
        return list(self.separation())

    def planar_equations(self) -> list[sp.Expr]:
        return list(self.separation()[:2])


class Universal(Joint):
    """Cardan joint: points coincide and the two axes stay perpendicular (4).

    Parameters
    ----------
    name
        The joint's name; its rows are ``<name>_1``, ``<name>_2``, ...
    body_a, body_b
        The joined bodies (either may be a :class:`~dalembert.multibody.Ground`).
    point_a, point_b
        The joint point on each body, in that body's frame relative to its center.
    axis_a, axis_b
        The two cross axes, each in its body's frame (default ``x`` and ``y``).

    Examples
    --------
    >>> from dalembert.multibody import Ground, RigidBody
    >>> shaft = RigidBody("shaft", 1.0, (0.1, 0.1, 0.02))
    >>> Universal("u", Ground(), shaft).constraint_names
    ['u_1', 'u_2', 'u_3', 'u_4']
    """

    n_equations = 4

    def __init__(self, name: str, body_a: Body, body_b: Body, point_a: Vector = (0, 0, 0),
                 point_b: Vector = (0, 0, 0), axis_a: Vector = (1, 0, 0),
                 axis_b: Vector = (0, 1, 0)) -> None:
        super().__init__(name, body_a, body_b, point_a, point_b, axis_a, axis_b)

    def equations(self) -> list[sp.Expr]:
        wa = self.frame("a")[2]
        wb = self.frame("b")[2]
        return [*self.separation(), dot(wa, wb)]


class Revolute(Joint):
    """Hinge: points coincide, axes stay parallel (5 equations).

    Parameters
    ----------
    name
        The joint's name; its rows are ``<name>_1``, ``<name>_2``, ...
    body_a, body_b
        The joined bodies (either may be a :class:`~dalembert.multibody.Ground`).
    point_a, point_b
        The joint point on each body, in that body's frame relative to its center.
    axis_a, axis_b
        The hinge axis in each body's frame (``axis_b`` defaults to ``axis_a``).

    Examples
    --------
    A door on a vertical hinge keeps one degree of freedom (6 coordinates and the
    quaternion's norm give 7; 5 hinge rows leave 1 turning about ``z``):

    >>> from dalembert.multibody import Ground, Multibody, RigidBody
    >>> door = RigidBody("door", 10.0, (1.0, 1.2, 0.3))
    >>> hinge = Revolute("hinge", Ground(), door, (0, 0, 0), (-0.5, 0, 0))
    >>> system = Multibody([door], [hinge]).system
    >>> len(system.coordinate_names) - len(system.constraint_names)
    1
    """

    n_equations = 5
    planar_rows = 2

    def equations(self) -> list[sp.Expr]:
        ua, va, _ = self.frame("a")
        wb = self.frame("b")[2]
        return [*self.separation(), dot(ua, wb), dot(va, wb)]

    def _check_planar_axes(self) -> None:
        self._planar_axes(True, "a hinge in the plane turns about its normal")

    def planar_equations(self) -> list[sp.Expr]:
        return list(self.separation()[:2])


class Prismatic(Joint):
    """Slider: frames locked parallel, point ``b`` moves along the axis of ``a`` (5).

    Parameters
    ----------
    name
        The joint's name; its rows are ``<name>_1``, ``<name>_2``, ...
    body_a, body_b
        The joined bodies (either may be a :class:`~dalembert.multibody.Ground`).
    point_a, point_b
        The joint point on each body, in that body's frame relative to its center.
    axis_a
        The sliding direction in the frame of ``body_a``.

    Examples
    --------
    >>> from dalembert.multibody import Ground, RigidBody
    >>> piston = RigidBody("piston", 1.0, (0.1, 0.1, 0.1))
    >>> len(Prismatic("guide", Ground(), piston, axis_a=(1, 0, 0)).constraints())
    5
    """

    n_equations = 5
    planar_rows = 2

    def equations(self) -> list[sp.Expr]:
        ua, va, _ = self.frame("a")
        d = self.separation()
        return [*self._orientation_lock(), dot(ua, d), dot(va, d)]

    def _check_planar_axes(self) -> None:
        self._planar_axes(False, "the slider moves in the plane")

    def planar_equations(self) -> list[sp.Expr]:
        wa, wb = self.frame("a")[2], self.frame("b")[2]
        normal = sp.Matrix([-wa[1], wa[0], 0])  # z x w_a
        return [dot(normal, wb), dot(normal, self.separation())]


class Fixed(Joint):
    """Weld: points coincide and frames locked parallel (6 equations).

    Parameters
    ----------
    name
        The joint's name; its rows are ``<name>_1``, ``<name>_2``, ...
    body_a, body_b
        The joined bodies (either may be a :class:`~dalembert.multibody.Ground`).
    point_a, point_b
        The joint point on each body, in that body's frame relative to its center.

    Examples
    --------
    >>> from dalembert.multibody import Ground, RigidBody
    >>> plate = RigidBody("plate", 1.0, (0.1, 0.1, 0.2))
    >>> len(Fixed("weld", Ground(), plate).constraints())
    6
    """

    n_equations = 6
    planar_rows = 3

    def equations(self) -> list[sp.Expr]:
        return [*self.separation(), *self._orientation_lock()]

    def _check_planar_axes(self) -> None:
        self._planar_axes(True, "a weld in the plane keeps the angle about its normal")

    def planar_equations(self) -> list[sp.Expr]:
        ua, vb = self.frame("a")[0], self.frame("b")[1]
        return [*self.separation()[:2], dot(ua, vb)]


class Distance(Joint):
    """Massless rod of length ``length`` between the two points (1 equation).

    Parameters
    ----------
    name, body_a, body_b
        As for every joint (see :class:`Spherical`).
    length
        The rod's length, a positive number.
    point_a, point_b
        The rod's ends on each body, in that body's frame.

    Examples
    --------
    A particle on a rod of length 2 from the origin is a spherical pendulum:

    >>> from dalembert.multibody import Ground, Particle
    >>> rod = Distance("rod", Ground(), Particle("bob", 1.0), 2.0)
    >>> rod.constraints()[0].expr
    bob_x(t)**2 + bob_y(t)**2 + bob_z(t)**2 - 4.0
    """

    n_equations = 1
    planar_rows = 1
    uses_orientation = False

    PARAMETRIC = ("point_a", "point_b", "axis_a", "axis_b", "ref_a", "ref_b", "length")

    def __init__(self, name: str, body_a: Body, body_b: Body, length: Scalar,
                 point_a: Vector = (0, 0, 0), point_b: Vector = (0, 0, 0)) -> None:
        self.length = scalar(length, f"joint {name!r}: the length")
        super().__init__(name, body_a, body_b, point_a, point_b)
        self.check_values()

    def check_values(self) -> None:
        """Check the numeric values (all of them once parameters are bound)."""
        if isinstance(self.length, float) and not self.length > 0:
            raise ModelError(f"joint {self.name!r}: the length must be positive, got "
                             f"{self.length}")

    def equations(self) -> list[sp.Expr]:
        d = self.separation()
        return [dot(d, d) - to_sympy(self.length) ** 2]

    planar_equations = equations


class PointOnPlane(Joint):
    """Point ``b`` stays on the plane through point ``a`` with normal ``normal`` (1).

    Parameters
    ----------
    name, body_a, body_b
        As for every joint (see :class:`Spherical`); ``body_a`` carries the plane.
    normal
        The plane's normal in the frame of ``body_a``.
    point_a, point_b
        A point of the plane on ``body_a`` and the constrained point on ``body_b``.

    Examples
    --------
    >>> from dalembert.multibody import Ground, Particle
    >>> floor = PointOnPlane("floor", Ground(), Particle("p", 1.0), normal=(0, 0, 1))
    >>> floor.constraints()[0].expr
    p_z(t)
    """

    n_equations = 1
    planar_rows = 1

    def __init__(self, name: str, body_a: Body, body_b: Body, normal: Vector = (0, 0, 1),
                 point_a: Vector = (0, 0, 0), point_b: Vector = (0, 0, 0)) -> None:
        super().__init__(name, body_a, body_b, point_a, point_b, axis_a=normal)

    def _check_bodies(self) -> None:
        if isinstance(self.body_a, Particle):
            raise ModelError(f"joint {self.name!r}: the plane's body {self.body_a.name!r} is "
                             "a particle, which has no orientation")

    def _check_planar_axes(self) -> None:
        self._planar_axes(False, "in the plane the point moves on a line")

    def equations(self) -> list[sp.Expr]:
        n = self.frame("a")[2]
        return [dot(n, self.separation())]

    planar_equations = equations


class Free(Joint):
    """No constraint: body ``b`` moves freely relative to body ``a`` (0 equations).

    It constrains nothing; it names a free motion (a floating base, MJCF's ``free``
    joint) so that :func:`~dalembert.multibody.joint_positions` measures it: the travel
    of point ``b`` from point ``a`` and the rotation of ``b``'s joint frame, both in
    ``a``'s joint frame (see :mod:`~dalembert.multibody.joint_space`).

    Parameters
    ----------
    name, body_a, body_b
        As for every joint (see :class:`Spherical`); ``body_a`` is usually the ground.
    point_a, point_b
        The points whose separation is measured, each in its body's frame.

    Examples
    --------
    >>> from dalembert.multibody import Ground, RigidBody
    >>> Free("base", Ground(), RigidBody("torso", 10.0, (1, 1, 1))).constraints()
    []
    """

    n_equations = 0
    planar_rows = 0

    def __init__(self, name: str, body_a: Body, body_b: Body, point_a: Vector = (0, 0, 0),
                 point_b: Vector = (0, 0, 0)) -> None:
        super().__init__(name, body_a, body_b, point_a, point_b)

    def equations(self) -> list[sp.Expr]:
        return []

    planar_equations = equations
