"""Applied loads: forces at body points, torques on bodies, spring-dampers.

Forces become :class:`dalembert.PointForce` (generalized force by virtual work,
``Q = (dr/dq)^T F``). A torque on a rigid body does the virtual work
``tau . dtheta`` with ``dtheta_body = 2 E(b) db``, so its generalized force on the
Euler parameters is ``2 E(b)^T tau_body = 2 G(b)^T tau_world`` (nothing on the
position coordinates); on a planar body it is ``tau_z`` on the angle. A spring's
elastic force is conservative and goes into the potential ``1/2 k (L - L0)^2``;
its damper ``-c Ldot`` along the spring is a pair of opposite point forces. Loads
may depend on the coordinates (as the bodies' ``dynamicsymbols``), their time
derivatives and the time ``dalembert.t``.
"""

from __future__ import annotations

from typing import get_args

import sympy as sp

from ..errors import ModelError
from ..model.coordinates import t
from ..model.forces import PointForce
from .bodies import Body, Particle, PlanarBody, TurningBody, _vector
from .joints import _point
from .parametric import Scalar, scalar, to_sympy
from .rotations import E_matrix, G_matrix
from .types import ExprVector, Frame, Vector

FRAMES: tuple[Frame, ...] = get_args(Frame)


def _frame(frame: Frame, what: str) -> Frame:
    if frame not in FRAMES:
        raise ModelError(f"{what}: frame must be 'world' or 'body', got {frame!r}")
    return frame


class Force:
    """A force on ``body`` at the body-fixed ``point`` (body frame).

    Parameters
    ----------
    body
        The body pushed.
    force
        3 components: numbers or SymPy expressions in the coordinates (the bodies'
        ``dynamicsymbols``), their rates and the time ``dalembert.t``.
    point
        Where it acts, in the body frame (default the mass center).
    frame
        ``"world"`` (default): world components; ``"body"``: body components (a
        follower force that turns with the body).
    name
        Its name (default ``force_on_<body>``).

    Examples
    --------
    A push of 2 N along ``x`` on a particle:

    >>> from dalembert.multibody import Multibody, Particle
    >>> p = Particle("p", 1.0)
    >>> mb = Multibody([p], forces=[Force(p, (2.0, 0, 0))], gravity=(0, 0, 0))
    >>> traj = mb.simulate((0, 1), *mb.initial_state(), t_eval=[1.0])
    >>> round(float(traj["p_x"][0]), 9)   # a t^2 / 2 with a = 2
    1.0
    """

    PARAMETRIC = ("point",)

    def __init__(self, body: Body, force: ExprVector, point: Vector = (0, 0, 0),
                 frame: Frame = "world", name: str | None = None) -> None:
        self.body = body
        self.name = name or f"force_on_{getattr(body, 'name', '?')}"
        self.force = _vector(force, f"{self.name}: force")
        self.point = _point(point, f"{self.name}: point")
        self.frame = _frame(frame, self.name)
        if frame == "body" and isinstance(body, Particle):
            raise ModelError(f"{self.name}: {body.name!r} is a particle, it has no body frame")

    def point_force(self) -> PointForce:
        """The force as a :class:`~dalembert.PointForce` (world components)."""
        F = self.force if self.frame == "world" else self.body.rotation() * self.force
        return PointForce(force=list(F), point=list(self.body.position(self.point)),
                          name=self.name)


class Torque:
    """A torque on a rigid or planar body, in world (``frame="world"``) or body components.

    On a :class:`~dalembert.multibody.PlanarBody` only ``tau_z`` does work (the
    body cannot turn about ``x`` or ``y``), so the torque must be along ``z``.

    Parameters
    ----------
    body
        A :class:`~dalembert.multibody.RigidBody` or
        :class:`~dalembert.multibody.PlanarBody`.
    torque
        3 components: numbers or SymPy expressions (as for :class:`Force`).
    frame
        ``"world"`` (default) or ``"body"`` components.
    name
        Its name (default ``torque_on_<body>``).

    Examples
    --------
    A torque of 3 N m about ``z`` spins up a planar body of moment 0.5 at 6 rad/s^2:

    >>> from dalembert.multibody import Multibody, PlanarBody
    >>> disk = PlanarBody("disk", 1.0, 0.5)
    >>> mb = Multibody([disk], torques=[Torque(disk, (0, 0, 3.0))], gravity=(0, 0, 0))
    >>> traj = mb.simulate((0, 1), *mb.initial_state(), t_eval=[1.0])
    >>> round(float(traj["disk_theta_dot"][0]), 9)
    6.0
    """

    def __init__(self, body: TurningBody, torque: ExprVector, frame: Frame = "world",
                 name: str | None = None) -> None:
        self.name = name or f"torque_on_{getattr(body, 'name', '?')}"
        if not isinstance(body, TurningBody):
            raise ModelError(f"{self.name}: a torque needs a RigidBody or PlanarBody, got "
                             f"{body!r}")
        self.body = body
        self.torque = _vector(torque, f"{self.name}: torque")
        self.frame = _frame(frame, self.name)
        if isinstance(body, PlanarBody) and any(c != 0 for c in self.torque[:2]):
            raise ModelError(f"{self.name}: planar body {body.name!r} turns about z only; give "
                             f"the torque as (0, 0, tau_z), got {tuple(self.torque)}")

    def generalized_forces(self) -> dict[object, sp.Expr]:
        """``{b_k: Q_k}`` with ``Q = 2 E^T tau_body`` (or ``2 G^T tau_world``); a planar
        body's ``{theta: tau_z}`` (world and body ``z`` are the same axis).

        Examples
        --------
        >>> from dalembert.multibody import PlanarBody
        >>> Torque(PlanarBody("disk", 1.0, 0.5), (0, 0, 3)).generalized_forces()
        {disk_theta(t): 3}
        """
        if isinstance(self.body, PlanarBody):
            return {self.body.angle: self.torque[2]}
        b = self.body.quaternion
        P = E_matrix(b) if self.frame == "body" else G_matrix(b)
        Q = 2 * P.T * self.torque
        return dict(zip(self.body.coordinates[3:], Q))


class SpringDamper:
    """Linear spring (stiffness ``k``, rest length ``rest_length``) and damper ``c``
    between ``point_a`` on ``body_a`` and ``point_b`` on ``body_b`` (body frames).

    Parameters
    ----------
    name
        Its name (damper forces ``<name>_damper_a``, ``<name>_damper_b``).
    body_a, body_b
        The bodies joined; either may be a :class:`~dalembert.multibody.Ground`.
    stiffness, rest_length, damping
        ``k``, ``L0`` and ``c``, each finite and ``>= 0``.
    point_a, point_b
        The ends, each in its body's frame.

    Examples
    --------
    A mass of 1 on a spring of stiffness 4 swings at ``omega = 2``: at a quarter
    period it passes the rest position at ``omega`` times the amplitude:

    >>> import numpy as np
    >>> from dalembert.multibody import Ground, Multibody, Particle
    >>> p = Particle("p", 1.0)
    >>> mb = Multibody([p], springs=[SpringDamper("k", Ground(), p, 4.0)], gravity=(0, 0, 0))
    >>> traj = mb.simulate((0, np.pi / 4), *mb.initial_state(positions={p: (0.1, 0, 0)}),
    ...                    t_eval=[np.pi / 4])
    >>> round(float(traj["p_x"][0]), 9), round(float(traj["p_x_dot"][0]), 9)
    (0.0, -0.2)
    """

    PARAMETRIC = ("stiffness", "rest_length", "damping", "point_a", "point_b")

    def __init__(self, name: str, body_a: Body, body_b: Body, stiffness: Scalar,
                 rest_length: Scalar = 0.0, damping: Scalar = 0.0,
                 point_a: Vector = (0, 0, 0), point_b: Vector = (0, 0, 0)) -> None:
        self.name = name
        self.body_a, self.body_b = body_a, body_b
        self.stiffness = _nonnegative(stiffness, f"spring {name!r}: stiffness")
        self.rest_length = _nonnegative(rest_length, f"spring {name!r}: rest_length")
        self.damping = _nonnegative(damping, f"spring {name!r}: damping")
        self.point_a = _point(point_a, f"spring {name!r}: point_a")
        self.point_b = _point(point_b, f"spring {name!r}: point_b")

    def check_values(self) -> None:
        """Check the numeric values (all of them once parameters are bound)."""
        for field in ("stiffness", "rest_length", "damping"):
            _nonnegative(getattr(self, field), f"spring {self.name!r}: {field}")

    @property
    def bodies(self) -> tuple[Body, Body]:
        """``(body_a, body_b)``."""
        return self.body_a, self.body_b

    def _geometry(self) -> tuple[sp.Matrix, sp.Matrix, sp.Matrix, sp.Expr]:
        ra = self.body_a.position(self.point_a)
        rb = self.body_b.position(self.point_b)
        d = rb - ra
        return ra, rb, d, sp.sqrt(d.dot(d))

    def potential(self) -> sp.Expr:
        """The elastic energy ``1/2 k (L - L0)^2`` (SymPy)."""
        *_, L = self._geometry()
        if self.rest_length == 0:
            # (L - 0)^2 = d.d: no square root, smooth through L = 0
            d = self._geometry()[2]
            return to_sympy(self.stiffness) / 2 * d.dot(d)
        return to_sympy(self.stiffness) / 2 * (L - to_sympy(self.rest_length)) ** 2

    def point_forces(self) -> list[PointForce]:
        """The damper's two opposite forces (none without damping)."""
        if self.damping == 0:
            return []
        ra, rb, d, _ = self._geometry()
        # c Ldot along the unit vector, written as c (d.ddot) d / L^2 (one sqrt less)
        F_b = -to_sympy(self.damping) * d.dot(d.diff(t)) / d.dot(d) * d
        return [PointForce(force=list(F_b), point=list(rb), name=f"{self.name}_damper_b"),
                PointForce(force=list(-F_b), point=list(ra), name=f"{self.name}_damper_a")]


def _nonnegative(value: Scalar, what: str) -> Scalar:
    """A number >= 0, or an expression of parameters (checked once bound)."""
    v = scalar(value, what)
    if isinstance(v, float) and not v >= 0:
        raise ModelError(f"{what} must be finite and >= 0, got {v}")
    return v
