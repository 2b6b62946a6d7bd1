"""``Rolling``: a thin disk or a sphere rolling without slipping on a fixed plane.

The plane passes through the world point ``point`` with unit normal ``n``; ``t1``
and ``t2 = n x t1`` span it. The contact point sits at ``rho`` from the body's
center ``x``:

- sphere of radius ``r``: ``rho = -r n``;
- thin disk (wheel) of radius ``r`` with the body-fixed axis ``a`` (world
  components ``a = R(b) a_body``): ``rho = -r (n - (n.a) a) / s`` with
  ``s = sqrt(1 - (n.a)^2)``, the point of the rim lowest along ``n``.

Rolling without slipping means the material point at the contact is at rest,
``v + w x rho = 0`` (``w = 2 G(b) bdot``, world). Its three components are split:

=========  ==========  ====================================================
row        kind        equation
=========  ==========  ====================================================
``J_1``    holonomic   contact height ``n.(x - point) - h = 0``, ``h = r`` (sphere)
                       or ``r s`` (disk)
``J_2``    Pfaffian    ``t1 . (v + w x rho) = 0``
``J_3``    Pfaffian    ``t2 . (v + w x rho) = 0``
=========  ==========  ====================================================

Why this split keeps the system well posed: the normal component of the contact
velocity is exactly the time derivative of the height row (the contact point is
the lowest point of the body, so the envelope theorem removes the motion of the
point along the rim), so writing it as a holonomic row loses nothing and lets the
projection keep the body on the plane; the two tangential rows are genuinely
nonholonomic. All three involve ``bdot`` only through ``w = 2 G(b) bdot``, and
``G b = 0``, so they never contain the quaternion's own direction ``b``: with the
unit-norm row ``b . bdot = 0`` the constraint rows stay independent and the KKT
matrix is regular. The disk's ``s`` vanishes when it lies flat (``a`` parallel to
``n``), where the contact point is not defined: keep the disk off flat.

Each row's coefficients on the center's velocity are ``n``, ``t1``, ``t2``, so the
multipliers are the components of the contact force on the body,
``F = lambda_1 n + lambda_2 t1 + lambda_3 t2``, acting at the contact point
(:func:`dalembert.multibody.outputs.joint_reactions` reports it there).
"""

from __future__ import annotations

import numpy as np
import sympy as sp

from ..errors import ModelError
from ..model.constraints import Holonomic, Pfaffian
from ..model.coordinates import t
from .bodies import Ground, RigidBody
from .joints import Joint, _sym
from .parametric import scalar, to_sympy
from .rotations import G_matrix
from .types import FloatArray, Vector


class Rolling(Joint):
    """Rolling without slipping of a sphere or a thin disk on a fixed plane (3 rows).

    Parameters
    ----------
    name
        Constraint names ``<name>_1`` (contact height), ``<name>_2``, ``<name>_3``
        (tangential, Pfaffian).
    body
        The rolling :class:`~dalembert.multibody.RigidBody`.
    radius
        The sphere's or the disk's radius.
    axis
        The disk's axis in the body frame; ``None`` (default) for a sphere.
    normal, point
        The plane's unit normal and a point on it (world); default ``z = 0``.
    tangent
        ``t1``, a direction in the plane (default: the world axis least aligned
        with ``normal``, made perpendicular).
    ground
        The :class:`~dalembert.multibody.Ground` the plane belongs to (its side
        ``a``; default a new one).

    Examples
    --------
    >>> from dalembert.multibody import RigidBody
    >>> coin = RigidBody("coin", 1.0, (0.25, 0.5, 0.25))
    >>> [type(c).__name__ for c in Rolling("roll", coin, 1.0, axis=(0, 1, 0)).constraints()]
    ['Holonomic', 'Pfaffian', 'Pfaffian']
    """

    n_equations = 3
    #: The plane (its side ``a``) and the rolling body (side ``b``).
    body_a: Ground
    body_b: RigidBody

    def __init__(self, name: str, body: RigidBody, radius: float, axis: Vector | None = None,
                 normal: Vector = (0, 0, 1), point: Vector = (0, 0, 0),
                 tangent: Vector | None = None, ground: Ground | None = None) -> None:
        if not isinstance(body, RigidBody):
            raise ModelError(f"joint {name!r} (Rolling): the rolling body must be a RigidBody, "
                             f"got {body!r}; a particle has no rotation to roll with")
        self.radius = scalar(radius, f"joint {name!r} (Rolling): the radius")
        self.is_disk = axis is not None
        super().__init__(name, ground or Ground(), body, point_a=point, axis_a=normal,
                         axis_b=normal if axis is None else axis, ref_a=tangent)
        self.check_values()

    PARAMETRIC = ("point_a", "radius")  # its normal and axis are numbers

    def check_values(self) -> None:
        """Check the numeric values (all of them once parameters are bound)."""
        if isinstance(self.radius, float) and not self.radius > 0:
            raise ModelError(f"joint {self.name!r} (Rolling): the radius must be positive, "
                             f"got {self.radius}")

    @property
    def normal(self) -> FloatArray:
        """The plane's unit normal ``n`` (world)."""
        return self.axis_a

    @property
    def tangents(self) -> tuple[FloatArray, FloatArray]:
        """``t1`` and ``t2 = n x t1``, spanning the plane (world)."""
        return self.ref_a, np.cross(self.axis_a, self.ref_a)

    # -- symbolic ----------------------------------------------------------------------
    def _arm_and_height(self) -> tuple[sp.Matrix, sp.Expr]:
        """``rho`` (center -> contact, world) and the center's height ``h`` above the plane."""
        n, r = _sym(self.normal), to_sympy(self.radius)
        if not self.is_disk:
            return -r * n, r
        a = self.body_b.rotation() * _sym(self.axis_b)
        na = n.dot(a)
        s = sp.sqrt(1 - na**2)
        return -r * (n - na * a) / s, r * s

    def equations(self) -> list[sp.Expr]:
        body = self.body_b
        n = _sym(self.normal)
        rho, h = self._arm_and_height()
        w = 2 * G_matrix(body.quaternion) * body.quaternion.diff(t)
        slip = body.center.diff(t) + w.cross(rho)
        height = n.dot(body.center - _sym(self.point_a)) - h
        return [height, *(_sym(e).dot(slip) for e in self.tangents)]

    def constraints(self) -> list[Holonomic | Pfaffian]:
        height, slip1, slip2 = self.equations()
        return [Holonomic(height, name=f"{self.name}_1"), Pfaffian(slip1, name=f"{self.name}_2"),
                Pfaffian(slip2, name=f"{self.name}_3")]

    # -- numeric -----------------------------------------------------------------------
    def contact_points(self, x: FloatArray, R: FloatArray) -> FloatArray:
        """World contact points for centers ``x`` ``(k, 3)`` and rotations ``R`` ``(k, 3, 3)``.

        Parameters
        ----------
        x, R
            The body's poses, as :meth:`~dalembert.multibody.Body.pose` gives them.

        Examples
        --------
        A wheel of radius 0.5 (axis body ``y``) leaning 30 degrees about ``x``, its
        center at height ``r cos 30``, touches the table ``r sin 30`` to the side:

        >>> from dalembert.multibody import RigidBody
        >>> from dalembert.multibody.rotations import elementary_rotation
        >>> wheel = Rolling("roll", RigidBody("w", 1.0, (1, 2, 1)), 0.5, axis=(0, 1, 0))
        >>> R = elementary_rotation("x", np.pi / 6)
        >>> P = wheel.contact_points(np.array([[0, 0, 0.5 * np.cos(np.pi / 6)]]), R[None])
        >>> (P.round(12) + 0.0).tolist()
        [[0.0, 0.25, 0.0]]
        """
        n = self.normal
        if not self.is_disk:
            return x - self.radius * n
        a = R @ self.axis_b
        lateral = n - (a @ n)[:, None] * a
        return x - self.radius * lateral / np.linalg.norm(lateral, axis=1)[:, None]

    def __repr__(self) -> str:
        kind = "disk" if self.is_disk else "sphere"
        return f"Rolling({self.name!r}, {self.body_b.name!r}, {kind}, r={self.radius})"
