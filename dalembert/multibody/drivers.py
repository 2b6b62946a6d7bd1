"""A joint's own coordinate: prescribed (a driver) or elastic (a joint spring).

A :class:`~dalembert.multibody.Revolute` joint's angle ``theta`` turns body ``b``'s
reference direction ``u_b`` from body ``a``'s ``u_a`` about the common axis ``w``:
with the world components of the two joint frames (``Joint.frame``),

    cos(theta) = u_a . u_b,     sin(theta) = v_a . u_b,

zero where the two reference directions coincide (``ref_a``/``ref_b``, see
:mod:`dalembert.multibody.joints`). A :class:`~dalembert.multibody.Prismatic`
joint's displacement is ``s = w_a . d``, ``d`` from point ``a`` to point ``b``.

:class:`Driver` prescribes that coordinate in time, a rheonomic constraint of one row
``<name>_1``: ``sin(theta - theta_d(t)) = 0`` (written with the two products above,
no angle is taken; it holds on the branch the mechanism is assembled on) or
``s - s_d(t) = 0``. Its derivative by the coordinate is 1 there, so the row's
multiplier is the driving torque about ``w`` (force along ``w``) that the driver
applies to body ``b`` (``-`` that on body ``a``): the classic question "what torque
drives this mechanism" is ``traj.multiplier("<name>_1")``. A driver may leave the
mechanism no degree of freedom: its motion then follows from the constraints.

:class:`JointSpring` is a torsional (revolute) or linear (prismatic) spring and
damper on that coordinate: the potential ``1/2 k (q - rest)^2`` and the generalized
force ``-c qdot dq/dq_i`` (the angle taken with ``atan2``, in ``(-pi, pi]``).
"""

from __future__ import annotations

import numpy as np
import sympy as sp
from sympy.core.function import AppliedUndef

from ..errors import ModelError
from ..model.constraints import Holonomic, Pfaffian
from ..model.coordinates import t
from ..model.expressions import sympify_strict
from .derivatives import NotPolynomial, directional_derivative
from .joints import Joint, Prismatic, Revolute
from .parametric import Scalar, parametric_symbols, scalar, to_sympy
from .rotations import dot


def joint_coordinate(joint: Joint) -> sp.Expr:
    """The joint's angle (revolute, ``atan2``) or displacement (prismatic), SymPy.

    Parameters
    ----------
    joint
        A ``Revolute`` or ``Prismatic`` joint.

    Examples
    --------
    >>> from dalembert.multibody import Ground, PlanarBody, Revolute
    >>> crank = PlanarBody("crank", 1.0, 0.1)
    >>> joint_coordinate(Revolute("pin", Ground(), crank))
    atan2(sin(crank_theta(t)), cos(crank_theta(t)))
    """
    if isinstance(joint, Revolute):
        cos_like, sin_like = _angle_terms(joint)
        return sp.atan2(sin_like, cos_like)
    if isinstance(joint, Prismatic):
        return dot(joint.frame("a")[2], joint.separation())
    raise ModelError(f"joint {joint.name!r} ({type(joint).__name__}) has no joint coordinate: "
                     "a driver or a joint spring acts on a Revolute or a Prismatic joint")


def joint_coordinate_partials(joint: Joint) -> dict[object, sp.Expr]:
    """The joint coordinate's derivatives ``dq/dq_i`` by the coordinates of the joint's
    bodies (those not identically zero), SymPy.

    A revolute angle's are written out from ``q = atan2(s, c)``:
    ``dq = (c ds - s dc) / (c^2 + s^2)``, with ``c`` and ``s`` the two products of
    :func:`joint_coordinate`, differentiated node by node in plain symbols
    (:func:`~dalembert.multibody.derivatives.directional_derivative`). The same
    numbers as SymPy's derivative of the ``atan2``, which on a 7-joint arm with a
    damper in every joint took most of the time to build the equations.

    Parameters
    ----------
    joint
        A ``Revolute`` or ``Prismatic`` joint.

    Examples
    --------
    >>> from dalembert.multibody import Ground, PlanarBody, Revolute
    >>> crank = PlanarBody("crank", 1.0, 0.1)
    >>> partials = joint_coordinate_partials(Revolute("pin", Ground(), crank))
    >>> [(str(c), sp.simplify(d)) for c, d in partials.items()]
    [('crank_theta(t)', 1)]
    """
    return _joint_coordinate_derivatives(joint, rate=False)[1]


def joint_coordinate_rate(joint: Joint) -> sp.Expr:
    """The joint coordinate's rate ``dq/dt``, SymPy: a revolute angle's
    ``(c ds/dt - s dc/dt) / (c^2 + s^2)`` (see :func:`joint_coordinate_partials`).

    Parameters
    ----------
    joint
        A ``Revolute`` or ``Prismatic`` joint.

    Examples
    --------
    >>> from dalembert.multibody import Ground, PlanarBody, Revolute
    >>> crank = PlanarBody("crank", 1.0, 0.1)
    >>> sp.simplify(joint_coordinate_rate(Revolute("pin", Ground(), crank)))
    Derivative(crank_theta(t), t)
    """
    rate, _ = _joint_coordinate_derivatives(joint, partials=False)
    assert rate is not None
    return rate


def _joint_coordinate_derivatives(joint: Joint, rate: bool = True, partials: bool = True
                                  ) -> tuple[sp.Expr | None, dict[object, sp.Expr]]:
    """``dq/dt`` (if ``rate``) and ``{coordinate: dq/dq_i}`` (if ``partials``; the nonzero
    ones) of the joint coordinate ``q`` (see :func:`joint_coordinate_partials`)."""
    coordinates = [c for body in joint.bodies for c in body.coordinates]
    q_rate: sp.Expr | None = None
    out: dict[object, sp.Expr] = {}
    if isinstance(joint, Revolute):
        plain = {c: sp.Dummy(str(c.func)) for c in coordinates}
        back = {x: c for c, x in plain.items()}
        cos_like, sin_like = (e.xreplace(plain) for e in _angle_terms(joint))
        square = cos_like**2 + sin_like**2

        def derivative(direction: dict[sp.Symbol, sp.Expr]) -> sp.Expr:
            memo: dict[sp.Expr, sp.Expr] = {}
            d_cos = directional_derivative(cos_like, direction, memo)
            d_sin = directional_derivative(sin_like, direction, memo)
            if d_cos == 0 and d_sin == 0:
                return sp.S.Zero
            return ((cos_like * d_sin - sin_like * d_cos) / square).xreplace(back)

        try:
            if rate:
                q_rate = derivative({x: c.diff(t) for c, x in plain.items()})
            for c, x in plain.items() if partials else ():
                if (d := derivative({x: sp.S.One})) != 0:
                    out[c] = d
            return q_rate, out
        except NotPolynomial:  # not sums, products and powers: SymPy's own derivative
            out = {}
    q = joint_coordinate(joint)
    out = {c: d for c in coordinates if (d := q.diff(c)) != 0} if partials else {}
    return (q.diff(t) if rate else None), out


def _angle_terms(joint: Revolute) -> tuple[sp.Expr, sp.Expr]:
    """``(u_a . u_b, v_a . u_b)``: the cosine and sine of the joint angle."""
    ua, va, _ = joint.frame("a")
    ub = joint.frame("b")[0]
    return dot(ua, ub), dot(va, ub)


def take_joint_geometry(piece: Joint, name: str, joint: Joint) -> str:
    """Give ``piece`` (a one-row joint acting on another joint's coordinate: a driver, a
    stop) the bodies and geometry of ``joint`` (which ``joint`` checked) and its own
    name; the kind of ``joint`` returned."""
    if not isinstance(name, str) or not name.isidentifier():
        raise ModelError(f"a joint name must be an identifier-like string, got {name!r}")
    vars(piece).update({k: v for k, v in vars(joint).items()
                        if k not in ("name", "n_equations")})
    piece.name = name
    return type(joint).__name__


class Driver(Joint):
    """Prescribed motion of a revolute joint's angle or a prismatic joint's displacement.

    Parameters
    ----------
    name
        The driver's name; its row is ``<name>_1``, whose multiplier is the driving
        torque (force) on ``body_b`` of the joint.
    joint
        The driven ``Revolute`` or ``Prismatic`` joint (also in the mechanism's joints).
    motion
        The angle (rad) or displacement as a SymPy expression of the time
        ``dalembert.t`` and parameters, e.g. ``omega * t``.

    Examples
    --------
    A crank turned at 2 rad/s:

    >>> from dalembert import t
    >>> from dalembert.multibody import Ground, PlanarBody, Revolute
    >>> crank = PlanarBody("crank", 1.0, 0.1)
    >>> pin = Revolute("pin", Ground(), crank)
    >>> motor = Driver("motor", pin, 2 * t)
    >>> motor.constraint_names, motor.rheonomic
    (['motor_1'], True)
    """

    n_equations = 1
    planar_rows = 1
    rheonomic = True

    def __init__(self, name: str, joint: Joint, motion: object) -> None:
        if not isinstance(joint, Revolute | Prismatic):
            raise ModelError(f"driver {name!r}: a driver moves a Revolute or Prismatic joint, "
                             f"got {joint!r}")
        expr = sympify_strict(motion, f"the motion of driver {name!r}")
        if not isinstance(expr, sp.Expr) or expr.atoms(AppliedUndef, sp.Derivative):
            raise ModelError(f"driver {name!r}: the motion must be an expression of the time "
                             f"and parameters, got {motion!r}")
        self.joint_kind = take_joint_geometry(self, name, joint)
        self.motion = expr
        #: the driven joint itself: its own rows must be in the mechanism too (a driver
        #: fixes one coordinate of the joint, not the joint)
        self.driven = joint
        self.uses_orientation = isinstance(joint, Revolute)
        self.n_equations = 1

    def parameter_symbols(self) -> set[sp.Symbol]:
        """The parameters of its geometry and of its motion."""
        return parametric_symbols(self) | {s for s in self.motion.free_symbols
                                           if isinstance(s, sp.Symbol) and s != t}

    def equations(self) -> list[sp.Expr]:
        if self.joint_kind == "Revolute":
            cos_like, sin_like = _angle_terms(self)  # type: ignore[arg-type]
            return [sin_like * sp.cos(self.motion) - cos_like * sp.sin(self.motion)]
        return [dot(self.frame("a")[2], self.separation()) - self.motion]

    planar_equations = equations

    def _check_planar(self) -> None:
        pass  # the driven joint fits the plane: it checked that

    def constraints(self) -> list[Holonomic | Pfaffian]:
        return [Holonomic(self.equations()[0], name=f"{self.name}_1")]


class JointSpring:
    """A spring and damper on a revolute joint's angle or a prismatic joint's travel.

    Parameters
    ----------
    name
        Its name.
    joint
        The ``Revolute`` (torsional spring) or ``Prismatic`` (linear spring) joint.
    stiffness
        ``k`` (N m/rad or N/m), a number >= 0 or an expression of parameters.
    damping
        ``c`` (N m s/rad or N s/m).
    rest
        The angle (rad, in ``(-pi, pi]``) or displacement at which it is relaxed.

    Examples
    --------
    A disk on a torsional spring of stiffness 4 and inertia 1 oscillates at 2 rad/s:

    >>> import numpy as np
    >>> from dalembert.multibody import Ground, Multibody, PlanarBody, Revolute
    >>> disk = PlanarBody("disk", 1.0, 1.0)
    >>> pin = Revolute("pin", Ground(), disk)
    >>> mb = Multibody([disk], [pin], joint_springs=[JointSpring("k", pin, 4.0)],
    ...                gravity=(0, 0, 0))
    >>> q0, _ = mb.initial_state(orientations={disk: 0.1})
    >>> traj = mb.simulate((0, np.pi / 4), q0, t_eval=[np.pi / 4])
    >>> round(float(traj["disk_theta"][0]), 9) + 0.0  # a quarter period: at rest angle
    0.0
    """

    PARAMETRIC = ("stiffness", "damping", "rest")
    joint: Joint

    def __init__(self, name: str, joint: Joint, stiffness: Scalar, damping: Scalar = 0.0,
                 rest: Scalar = 0.0) -> None:
        if not isinstance(joint, Revolute | Prismatic):
            raise ModelError(f"joint spring {name!r}: it acts on a Revolute or Prismatic "
                             f"joint, got {joint!r}")
        self.name, self.joint = name, joint
        self.stiffness = scalar(stiffness, f"joint spring {name!r}: stiffness")
        self.damping = scalar(damping, f"joint spring {name!r}: damping")
        self.rest = scalar(rest, f"joint spring {name!r}: rest")
        self.check_values()

    def check_values(self) -> None:
        """Check the numeric values (all of them once parameters are bound)."""
        for field in ("stiffness", "damping"):
            value = getattr(self, field)
            if isinstance(value, float) and not value >= 0:
                raise ModelError(f"joint spring {self.name!r}: {field} must be >= 0, got {value}")

    @property
    def bodies(self) -> tuple[object, object]:
        return self.joint.bodies

    def potential(self) -> sp.Expr:
        """``1/2 k (q - rest)^2`` (SymPy)."""
        q = joint_coordinate(self.joint)
        return to_sympy(self.stiffness) / 2 * (q - to_sympy(self.rest)) ** 2

    def generalized_forces(self) -> dict[object, sp.Expr]:
        """The damper's ``-c qdot dq/dq_i`` by coordinate (none without damping)."""
        if isinstance(self.damping, float) and self.damping == 0:
            return {}
        rate, partials = _joint_coordinate_derivatives(self.joint)
        return {c: -to_sympy(self.damping) * rate * d for c, d in partials.items()}


def coordinate_values(joint: Joint, poses: dict[str, tuple[np.ndarray, np.ndarray]]) -> np.ndarray:
    """The joint coordinate at every time, from the bodies' poses ``{name: (x, R)}``
    (``(k, 3)`` centers, ``(k, 3, 3)`` rotations; the ground's absent: at rest).

    Parameters
    ----------
    joint
        A ``Revolute`` or ``Prismatic`` joint (numbers, not parameters).
    poses
        Each moving body's poses, by name.
    """
    def pose(body: object) -> tuple[np.ndarray, np.ndarray]:
        name = getattr(body, "name", "")
        if name in poses:
            return poses[name]
        return np.zeros((1, 3)), np.eye(3)[None]

    (xa, Ra), (xb, Rb) = pose(joint.body_a), pose(joint.body_b)
    if isinstance(joint, Revolute):
        ua = Ra @ np.asarray(joint.ref_a, dtype=float)
        va = Ra @ np.cross(np.asarray(joint.axis_a, float), np.asarray(joint.ref_a, float))
        ub = Rb @ np.asarray(joint.ref_b, dtype=float)
        return np.arctan2(np.einsum("ki,ki->k", va, ub), np.einsum("ki,ki->k", ua, ub))
    wa = Ra @ np.asarray(joint.axis_a, dtype=float)
    d = (xb + Rb @ np.asarray(joint.point_b, float)) - (xa + Ra @ np.asarray(joint.point_a, float))
    return np.einsum("ki,ki->k", wa, d)


class Actuator:
    """A torque about a revolute joint's axis, or a force along a prismatic joint's.

    It acts on the joint's body ``b`` (and the opposite on body ``a``), through the joint
    coordinate: the generalized force ``value * dq/dq_i`` (:func:`joint_coordinate`).
    ``value`` may hold parameters, the time and the coordinates, and the mechanism's
    inputs (``Multibody(inputs=...)``): a motor driven by a controller.

    Parameters
    ----------
    name
        Its name.
    joint
        The ``Revolute`` or ``Prismatic`` joint it acts in.
    value
        The torque (N m) or force (N), a number or a SymPy expression.

    Examples
    --------
    A motor torque ``u`` on a disk's pin, given by a controller holding 2 rad/s:

    >>> import numpy as np
    >>> import sympy as sp
    >>> from dalembert.multibody import Ground, Multibody, PlanarBody, Revolute
    >>> u = sp.Symbol("u")
    >>> disk = PlanarBody("disk", 1.0, 0.5)
    >>> pin = Revolute("pin", Ground(), disk)
    >>> mb = Multibody([disk], [pin], actuators=[Actuator("motor", pin, u)], inputs=[u],
    ...                gravity=(0, 0, 0))
    >>> hold = lambda t, q, qd: 10.0 * (2.0 - qd[2])  # qd[2]: the disk's rate
    >>> traj = mb.simulate((0, 5), {}, inputs=hold, t_eval=[5.0])
    >>> round(float(traj["disk_theta_dot"][0]), 6)
    2.0
    """

    def __init__(self, name: str, joint: Joint, value: object) -> None:
        if not isinstance(joint, Revolute | Prismatic):
            raise ModelError(f"actuator {name!r}: it acts in a Revolute or Prismatic joint, "
                             f"got {joint!r}")
        expr = sympify_strict(value, f"the value of actuator {name!r}")
        if not isinstance(expr, sp.Expr):
            raise ModelError(f"actuator {name!r}: the value must be a number or a SymPy "
                             f"expression, got {value!r}")
        self.name, self.value = name, expr
        self.joint: Joint = joint

    @property
    def bodies(self) -> tuple[object, object]:
        return self.joint.bodies

    def generalized_forces(self) -> dict[object, sp.Expr]:
        """``value * dq/dq_i`` by coordinate of the joint's bodies."""
        return {c: self.value * d for c, d in joint_coordinate_partials(self.joint).items()}
