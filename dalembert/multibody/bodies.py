"""Bodies: the fixed ``Ground``, point-mass ``Particle``, ``RigidBody`` and ``PlanarBody``.

A rigid body's coordinates are its mass-center position ``x, y, z`` (world frame)
and its Euler parameters ``b0..b3`` (see :mod:`dalembert.multibody.rotations`),
seven ``dynamicsymbols`` named ``<body>_x`` ... ``<body>_b3``. Its kinetic energy

    T = 1/2 m v.v + 1/2 w^T I w,    w = 2 E(b) bdot  (body frame)

has the 4x4 block ``4 E^T I E`` in ``bdot``, which is singular: ``E b = 0``, so
its null direction is ``b`` itself. The unit-norm constraint
``b0^2 + b1^2 + b2^2 + b3^2 - 1 = 0`` (added automatically, named
``<body>_unit_quaternion``) differentiates to ``b . bdot = 0``, which removes
exactly that direction; the KKT matrix ``[[M, A^T], [A, 0]]`` is therefore
nonsingular (``M`` is positive definite on the null space of ``A``) and the core
solves it as a whole, never inverting ``M``.

A :class:`PlanarBody` moves in the world ``x-y`` plane: ``<body>_x, <body>_y`` and
the angle ``<body>_theta`` about ``z`` (3 coordinates, constant mass matrix
``diag(m, m, I_z)``, no constraint of its own) -- the classical planar multibody
formulation, for mechanisms that stay in a plane.

Each kind of body also maps its coordinates to numbers: :meth:`Body.pose` (mass
center and rotation matrix), :meth:`Body.center_velocity`,
:meth:`Body.angular_velocity_at` (body frame) and :meth:`Body.center_torque` (the
torque about the mass center of a generalized force on its coordinates); the
outputs, drawings and checks use these, whatever the kind.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import sympy as sp
from numpy.typing import ArrayLike
from sympy.physics.vector import dynamicsymbols

from ..errors import ModelError
from ..model.constraints import Holonomic
from ..model.coordinates import t
from ..model.expressions import sympify_strict
from .parametric import Scalar, array, is_symbolic, scalar, to_sympy
from .rotations import E_matrix, dot, rotation_matrix, times_vector
from .types import ExprVector, FloatArray


def _vector(v: ExprVector, what: str) -> sp.Matrix:
    """A 3-vector as a SymPy column (numbers or expressions)."""
    try:
        comps = list(v)
    except TypeError as exc:
        raise ModelError(f"{what} must be a 3-vector, got {v!r}") from exc
    if len(comps) != 3:
        raise ModelError(f"{what} must have 3 components, got {len(comps)}")
    vals = [sympify_strict(c, what) for c in comps]
    # exact zeros (not Float(0.0)) so that their terms vanish from the equations
    return sp.Matrix([sp.S.Zero if v.is_zero else v for v in vals])


def _check_name(name: object) -> str:
    if not isinstance(name, str) or not name.isidentifier():
        raise ModelError(f"a body name must be an identifier-like string, got {name!r}")
    return name


class Body:
    """Common interface: coordinates, point positions, orientation, energy.

    The kinds of body are :class:`Ground`, :class:`Particle`, :class:`RigidBody` and
    :class:`PlanarBody`; :data:`MovingBody` and :data:`TurningBody` name the unions
    code narrows to with ``isinstance`` (what moves; what turns and has an inertia).
    """

    name: str
    mass: float
    #: The body's coordinates, SymPy ``dynamicsymbols`` (none for the ground).
    coordinates: tuple[sp.Function, ...] = ()
    #: False for a particle. Kept for existing callers; the package itself tells the
    #: kinds apart with ``isinstance`` (``TurningBody``), which a type checker follows.
    has_orientation = True

    @property
    def center(self) -> sp.Matrix:
        """World position of the mass center as SymPy expressions (a moving body's)."""
        raise NotImplementedError

    def position(self, point: ExprVector = (0, 0, 0)) -> sp.Matrix:
        """World position of a body-fixed point: ``center + R point``.

        Parameters
        ----------
        point
            The point in the body frame, relative to the mass center (3 numbers or
            SymPy expressions); the default is the mass center.

        Examples
        --------
        >>> link = PlanarBody("link", 1.0, 0.1)
        >>> link.position((0.5, 0, 0)).T
        Matrix([[link_x(t) + 0.5*cos(link_theta(t)), link_y(t) + 0.5*sin(link_theta(t)), 0]])
        """
        s = _vector(point, f"a point of body {self.name!r}")
        if all(c == 0 for c in s):
            return self.center
        return self.center + times_vector(self.rotation(), s)

    def rotation(self) -> sp.Matrix:
        """Rotation matrix body -> world as SymPy expressions."""
        raise NotImplementedError

    def kinetic_energy(self) -> sp.Expr:
        """``T`` of the body in its coordinates and their rates (SymPy)."""
        return sp.S.Zero

    def constraints(self) -> list[Holonomic]:
        """The body's own constraints (a rigid body's unit quaternion)."""
        return []

    # -- numbers: rows of coordinate values ``c`` (k, len(coordinates)) -----------------
    def pose(self, c: FloatArray) -> tuple[FloatArray, FloatArray]:
        """Mass centers ``(k, 3)`` and rotation matrices ``(k, 3, 3)`` (body -> world).

        Parameters
        ----------
        c
            Values of the body's coordinates, one row per instant ``(k, n)`` (or one
            configuration ``(n,)``), in the order of :attr:`coordinates`.

        Examples
        --------
        A rigid body at ``(1, 2, 3)`` turned a half turn about ``z``:

        >>> x, R = RigidBody("box", 1.0, (1, 1, 1)).pose(np.array([1, 2, 3, 0, 0, 0, 1.0]))
        >>> x.tolist(), R[0].round(12).tolist()
        ([[1.0, 2.0, 3.0]], [[-1.0, 0.0, 0.0], [0.0, -1.0, 0.0], [0.0, 0.0, 1.0]])
        """
        c = np.atleast_2d(c)
        return c[:, :3], np.broadcast_to(np.eye(3), (len(c), 3, 3)).copy()

    def center_velocity(self, cd: FloatArray) -> FloatArray:
        """Mass-center velocities ``(k, 3)`` (world) from the coordinate rates.

        Parameters
        ----------
        cd
            Rates of the body's coordinates, ``(k, n)`` or ``(n,)``.

        Examples
        --------
        >>> PlanarBody("link", 1.0, 0.1).center_velocity(np.array([1.0, 2.0, 5.0])).tolist()
        [[1.0, 2.0, 0.0]]
        """
        return np.atleast_2d(cd)[:, :3]

    def angular_velocity_at(self, c: FloatArray, cd: FloatArray) -> FloatArray:
        """Angular velocities ``(k, 3)`` in body components (zero for a particle).

        Parameters
        ----------
        c, cd
            Values and rates of the body's coordinates, ``(k, n)`` or ``(n,)`` each.

        Examples
        --------
        A planar body turning at 5 rad/s:

        >>> PlanarBody("link", 1.0, 0.1).angular_velocity_at(np.zeros(3), [0, 0, 5.0]).tolist()
        [[0.0, 0.0, 5.0]]
        """
        return np.zeros((len(np.atleast_2d(c)), 3))

    def center_torque(self, c: FloatArray, Q: FloatArray) -> FloatArray:
        """The torque about the mass center (world) whose virtual work on this body's
        coordinates is the generalized force ``Q``.

        Parameters
        ----------
        c
            Values of the body's coordinates, ``(k, n)`` or ``(n,)``.
        Q
            Generalized forces on those coordinates, the same shape.

        Examples
        --------
        On a rigid body at rest, ``Q_b = 2 E(b)^T tau`` on its Euler parameters comes
        back as the torque ``tau``:

        >>> from dalembert.multibody.rotations import E_matrix
        >>> body, c = RigidBody("box", 1.0, (1, 1, 1)), np.array([0, 0, 0, 1.0, 0, 0, 0])
        >>> Q = np.concatenate([np.zeros(3), 2 * E_matrix(c[3:]).T @ [0.0, 0.0, 3.0]])
        >>> body.center_torque(c, Q).tolist()
        [[0.0, 0.0, 3.0]]
        """
        return np.zeros((len(np.atleast_2d(c)), 3))

    def center_force(self, Q: FloatArray) -> FloatArray:
        """The force (world) of a generalized force ``Q`` on this body's coordinates.

        Parameters
        ----------
        Q
            Generalized forces on the body's coordinates, ``(k, n)`` or ``(n,)``.

        Examples
        --------
        >>> Particle("bob", 1.0).center_force(np.array([0.0, 0.0, -9.81])).tolist()
        [[0.0, 0.0, -9.81]]
        """
        return np.atleast_2d(Q)[:, :3]

    @property
    def constraint_names(self) -> list[str]:
        """The names of :meth:`constraints`, without building them."""
        return []

    def __repr__(self) -> str:
        return f"{type(self).__name__}({self.name!r})"


class Ground(Body):
    """The fixed world frame; its points are given in world coordinates.

    Parameters
    ----------
    name
        Its name in messages (any ``Ground`` object is the same ground).

    Examples
    --------
    >>> Ground().position((1, 2, 3)).T
    Matrix([[1, 2, 3]])
    """

    def __init__(self, name: str = "ground") -> None:
        self.name = _check_name(name)
        self.mass = 0.0

    def position(self, point: ExprVector = (0, 0, 0)) -> sp.Matrix:
        return _vector(point, f"a point of {self.name!r}")

    def rotation(self) -> sp.Matrix:
        return sp.eye(3)


class Particle(Body):
    """A point mass with coordinates ``<name>_x, <name>_y, <name>_z``.

    Parameters
    ----------
    name
        Prefix of the coordinate names.
    mass
        Positive mass: a number, or an expression of parameter symbols (see
        :mod:`dalembert.multibody.parametric`).

    Examples
    --------
    >>> p = Particle("bob", 2.0)
    >>> [str(c) for c in p.coordinates]
    ['bob_x(t)', 'bob_y(t)', 'bob_z(t)']
    """

    has_orientation = False
    PARAMETRIC = ("mass",)

    def __init__(self, name: str, mass: Scalar) -> None:
        self.name = _check_name(name)
        self.mass = scalar(mass, f"the mass of {name!r}")
        self.coordinates = tuple(dynamicsymbols(f"{name}_x {name}_y {name}_z"))
        self.check_values()

    def check_values(self) -> None:
        """Check the numeric values (all of them once parameters are bound)."""
        _positive_mass(self.mass, self.name)

    @property
    def center(self) -> sp.Matrix:
        return sp.Matrix(self.coordinates)

    def position(self, point: ExprVector = (0, 0, 0)) -> sp.Matrix:
        s = _vector(point, f"a point of particle {self.name!r}")
        if any(c != 0 for c in s):
            raise ModelError(
                f"particle {self.name!r} has no extent: its only point is (0, 0, 0), got "
                f"{tuple(s)}"
            )
        return self.center

    def rotation(self) -> sp.Matrix:
        raise ModelError(f"particle {self.name!r} has no orientation (use a RigidBody)")

    def kinetic_energy(self) -> sp.Expr:
        v = self.center.diff(t)
        return to_sympy(self.mass) / 2 * v.dot(v)


class RigidBody(Body):
    """A rigid body: mass-center position and Euler parameters (7 coordinates).

    Parameters
    ----------
    name
        Prefix of the coordinate names ``<name>_x, _y, _z, _b0.._b3``.
    mass
        Positive mass.
    inertia
        Inertia tensor about the mass center in the body frame: a symmetric
        positive-definite 3x3 matrix, or its 3 principal values. Mass and inertia
        entries may be expressions of parameter symbols (see
        :mod:`dalembert.multibody.parametric`).

    Examples
    --------
    >>> body = RigidBody("box", 1.0, (1.0, 2.0, 3.0))
    >>> [c.name for c in body.constraints()]
    ['box_unit_quaternion']
    """

    PARAMETRIC = ("mass", "inertia")

    def __init__(self, name: str, mass: Scalar, inertia: ArrayLike) -> None:
        self.name = _check_name(name)
        self.mass = scalar(mass, f"the mass of {name!r}")
        self.inertia = _inertia_array(inertia, name)
        self.coordinates = tuple(
            dynamicsymbols(" ".join(f"{name}_{c}" for c in ("x", "y", "z", "b0", "b1", "b2", "b3")))
        )
        self.check_values()

    def check_values(self) -> None:
        """Check the numeric values (all of them once parameters are bound)."""
        _positive_mass(self.mass, self.name)
        if not is_symbolic(self.inertia):
            _inertia_tensor(self.inertia, self.name)

    @property
    def center(self) -> sp.Matrix:
        return sp.Matrix(self.coordinates[:3])

    @property
    def quaternion(self) -> sp.Matrix:
        return sp.Matrix(self.coordinates[3:])

    def rotation(self) -> sp.Matrix:
        return rotation_matrix(self.quaternion)

    def angular_velocity(self) -> sp.Matrix:
        """Body-frame angular velocity ``2 E(b) bdot``."""
        return 2 * E_matrix(self.quaternion) * self.quaternion.diff(t)

    def kinetic_energy(self) -> sp.Expr:
        v = self.center.diff(t)
        w = self.angular_velocity()
        inertia = sp.Matrix(3, 3, lambda i, j: to_sympy(self.inertia[i, j]))
        rot = dot(w, times_vector(inertia, w))
        # expanded: a sum of monomials differentiates much faster than nested products
        return sp.expand(to_sympy(self.mass) / 2 * v.dot(v) + rot / 2)

    def pose(self, c: FloatArray) -> tuple[FloatArray, FloatArray]:
        c = np.atleast_2d(c)
        return c[:, :3], rotation_matrix(c[:, 3:])

    def angular_velocity_at(self, c: FloatArray, cd: FloatArray) -> FloatArray:
        b, bd = np.atleast_2d(c)[:, 3:], np.atleast_2d(cd)[:, 3:]
        return 2 * np.einsum("kij,kj->ki", E_matrix(b), bd)

    def center_torque(self, c: FloatArray, Q: FloatArray) -> FloatArray:
        # Q_b = 2 E^T tau_body, and E E^T = I: tau_body = 1/2 E Q_b
        b, Qb = np.atleast_2d(c)[:, 3:], np.atleast_2d(Q)[:, 3:]
        tau_body = 0.5 * np.einsum("kij,kj->ki", E_matrix(b), Qb)
        return np.einsum("kij,kj->ki", rotation_matrix(b), tau_body)

    def constraints(self) -> list[Holonomic]:
        b = self.quaternion
        return [Holonomic(b.dot(b) - 1, name=self.constraint_names[0])]

    @property
    def constraint_names(self) -> list[str]:
        return [f"{self.name}_unit_quaternion"]


class PlanarBody(Body):
    """A rigid body moving in the world ``x-y`` plane (3 coordinates).

    Coordinates ``<name>_x, <name>_y`` (mass center) and ``<name>_theta`` (rotation
    about ``z``, counterclockwise). Body points are given in the body frame as
    usual; their ``z`` stays constant. Joints between planar bodies (and ground)
    take their planar forms (see :mod:`dalembert.multibody.joints`); gravity must
    lie in the plane.

    Parameters
    ----------
    name
        Prefix of the coordinate names.
    mass
        Positive mass.
    inertia
        Moment of inertia about the ``z`` axis through the mass center (> 0). Both
        may be expressions of parameter symbols (see
        :mod:`dalembert.multibody.parametric`).

    Examples
    --------
    >>> link = PlanarBody("link", 1.0, 0.1)
    >>> [c.name for c in link.coordinates], link.constraints()
    (['link_x', 'link_y', 'link_theta'], [])
    """

    PARAMETRIC = ("mass", "moment")

    def __init__(self, name: str, mass: Scalar, inertia: Scalar) -> None:
        self.name = _check_name(name)
        self.mass = scalar(mass, f"the mass of {name!r}")
        if np.ndim(np.array(inertia, dtype=object)) != 0:
            raise ModelError(f"the inertia of planar body {name!r} is its moment about z, one "
                             f"number; got {inertia!r}")
        self.moment = scalar(inertia, f"the moment of inertia of planar body {name!r}")
        self.coordinates = tuple(dynamicsymbols(f"{name}_x {name}_y {name}_theta"))
        self.check_values()

    @property
    def inertia(self) -> np.ndarray:
        """The inertia tensor seen in 3D: only rotations about ``z`` are possible."""
        tensor = np.zeros((3, 3), dtype=object if is_symbolic(self.moment) else float)
        tensor[2, 2] = self.moment
        return tensor

    def check_values(self) -> None:
        """Check the numeric values (all of them once parameters are bound)."""
        _positive_mass(self.mass, self.name)
        _positive_moment(self.moment, self.name)

    @property
    def center(self) -> sp.Matrix:
        return sp.Matrix([*self.coordinates[:2], sp.S.Zero])

    @property
    def angle(self) -> sp.Function:
        return self.coordinates[2]

    def rotation(self) -> sp.Matrix:
        c, s = sp.cos(self.angle), sp.sin(self.angle)
        return sp.Matrix([[c, -s, 0], [s, c, 0], [0, 0, 1]])

    def kinetic_energy(self) -> sp.Expr:
        x, y, theta = (c.diff(t) for c in self.coordinates)
        return (to_sympy(self.mass) / 2 * (x**2 + y**2)
                + to_sympy(self.moment) / 2 * theta**2)

    def pose(self, c: FloatArray) -> tuple[FloatArray, FloatArray]:
        c = np.atleast_2d(c)
        x = np.column_stack([c[:, 0], c[:, 1], np.zeros(len(c))])
        cos, sin = np.cos(c[:, 2]), np.sin(c[:, 2])
        R = np.zeros((len(c), 3, 3))
        R[:, 0, 0], R[:, 0, 1], R[:, 1, 0], R[:, 1, 1], R[:, 2, 2] = cos, -sin, sin, cos, 1.0
        return x, R

    def center_velocity(self, cd: FloatArray) -> FloatArray:
        cd = np.atleast_2d(cd)
        return np.column_stack([cd[:, 0], cd[:, 1], np.zeros(len(cd))])

    def angular_velocity_at(self, c: FloatArray, cd: FloatArray) -> FloatArray:
        return _along_z(np.atleast_2d(cd)[:, 2])

    def center_torque(self, c: FloatArray, Q: FloatArray) -> FloatArray:
        return _along_z(np.atleast_2d(Q)[:, 2])

    def center_force(self, Q: FloatArray) -> FloatArray:
        Q = np.atleast_2d(Q)
        return np.column_stack([Q[:, 0], Q[:, 1], np.zeros(len(Q))])


#: A body that moves (not the ground): what a ``Multibody``'s ``bodies`` hold.
MovingBody = Particle | RigidBody | PlanarBody
#: A body that turns: it has an orientation, an inertia tensor and a body frame.
TurningBody = RigidBody | PlanarBody


def _along_z(values: FloatArray) -> FloatArray:
    out = np.zeros((len(values), 3))
    out[:, 2] = values
    return out


def _positive_moment(moment: Scalar, name: str) -> None:
    """A numeric moment must be positive (an expression is checked once bound)."""
    if isinstance(moment, float) and not moment > 0:
        raise ModelError(f"the moment of inertia of planar body {name!r} must be positive and "
                         f"finite, got {moment} (use a Particle for a point mass)")


def _positive_mass(mass: Scalar, name: str) -> None:
    """A numeric mass must be positive (an expression is checked once bound)."""
    if isinstance(mass, float) and not mass > 0:
        raise ModelError(f"the mass of {name!r} must be positive and finite, got {mass}")


def _inertia_array(inertia: ArrayLike, name: str) -> np.ndarray:
    """The inertia as a 3x3 array: floats, or expressions of parameters."""
    what = f"the inertia of {name!r}"
    raw = inertia.tolist() if isinstance(inertia, sp.MatrixBase) else inertia
    shape = np.shape(np.array(raw, dtype=object))
    if shape == (3,):
        values = array(raw, (3,), what)
        tensor = np.zeros((3, 3), dtype=values.dtype)
        tensor[np.diag_indices(3)] = values
        return tensor
    if shape != (3, 3):
        raise ModelError(f"the inertia of {name!r} must be a 3x3 tensor or 3 principal "
                         f"values, got shape {shape}")
    return array(raw, (3, 3), what)


#: Principal moments may miss the triangle inequality by this much (relative) before
#: the inertia is refused: rounding of moments computed as sums, a flat plate's equality.
TRIANGLE_RTOL = 1e-9
#: Below this ratio of smallest to largest principal moment the spin about that axis
#: has no digit left in the equations of motion (the KKT matrix is singular).
INERTIA_RATIO_MIN = 1e-12


def _principal(eig: FloatArray) -> str:
    """Principal moments for a message (formatted only when one is raised)."""
    return ", ".join(f"{e:.6g}" for e in eig)


def _inertia_tensor(inertia: ArrayLike, name: str) -> FloatArray:
    """The inertia tensor, checked (:func:`check_inertias`)."""
    try:
        I = np.asarray(inertia, dtype=float)
    except (TypeError, ValueError) as exc:
        raise ModelError(f"the inertia of {name!r} must be numbers, got {inertia!r}") from exc
    if I.shape == (3,):
        I = np.diag(I)
    if I.shape != (3, 3):
        raise ModelError(
            f"the inertia of {name!r} must be a 3x3 tensor or 3 principal values, got shape "
            f"{I.shape}"
        )
    check_inertias(I[None], [name])
    return I


def check_inertias(I: FloatArray, names: Sequence[str]) -> None:
    """Check inertia tensors ``(k, 3, 3)``, every one at once: finite, symmetric,
    positive definite, well enough conditioned to integrate, and the principal moments
    obeying the triangle inequality (as every real mass distribution's do). The error
    names the first body at fault.

    Parameters
    ----------
    I
        The tensors, about the mass centers in the body frames.
    names
        The bodies' names, for the message.

    Examples
    --------
    >>> check_inertias(np.array([np.eye(3), np.diag([1.0, 1.0, 3.0])]), ["a", "b"])
    Traceback (most recent call last):
    ...
    dalembert.errors.ModelError: the inertia tensor of 'b' violates the triangle ...
    """
    finite = np.asarray(np.isfinite(I).all(axis=(1, 2)))
    safe = np.where(finite[:, None, None], I, np.eye(3))  # eigvalsh refuses NaN
    asymmetry = np.abs(safe - safe.transpose(0, 2, 1))
    symmetric = np.asarray(asymmetry.max(axis=(1, 2), initial=0.0) <= 1e-12 * np.maximum(
        np.abs(safe).max(axis=(1, 2), initial=0.0), 1))
    eig = np.linalg.eigvalsh(safe)
    good = (finite & symmetric & (eig[:, 0] > 0) & (eig[:, 0] > INERTIA_RATIO_MIN * eig[:, -1])
            & ~(eig[:, 0] + eig[:, 1] < eig[:, 2] * (1 - TRIANGLE_RTOL)))
    if good.all():
        return
    k = int(np.flatnonzero(~good)[0])
    _inertia_error(I[k], asymmetry[k], eig[k], names[k], finite[k], symmetric[k])


def _inertia_error(I: FloatArray, asymmetry: FloatArray, eig: FloatArray, name: str,
                   finite: bool, symmetric: bool) -> None:
    """Raise the :class:`ModelError` of the first check ``I`` fails."""
    if not finite:
        raise ModelError(f"the inertia tensor of {name!r} must be finite:\n{I}")
    if not symmetric:
        i, j = np.unravel_index(int(np.argmax(asymmetry)), I.shape)
        raise ModelError(
            f"the inertia tensor of {name!r} must be symmetric: I[{i}, {j}] = {I[i, j]:.6g} "
            f"but I[{j}, {i}] = {I[j, i]:.6g}:\n{I}"
        )
    if eig[0] <= 0:
        raise ModelError(
            f"the inertia tensor of {name!r} is not positive definite (principal values "
            f"{_principal(eig)}); a rigid body needs inertia about every axis (use a Particle "
            "for a point mass)"
        )
    if eig[0] <= INERTIA_RATIO_MIN * eig[-1]:
        raise ModelError(
            f"the inertia tensor of {name!r} is nearly singular (principal values "
            f"{_principal(eig)}): "
            f"the smallest is {eig[0] / eig[-1]:.1e} of the largest, so the spin about that "
            "axis has almost no inertia and the equations of motion cannot determine it "
            "(ill-conditioned). Give that axis more inertia (for a thin rod a larger radius, "
            "with a ratio above 1e-8, hardly changes its swinging), or model the body "
            "without that rotation (two particles joined by a Distance joint)"
        )
    raise ModelError(
        f"the inertia tensor of {name!r} violates the triangle inequality: principal "
        f"moments {_principal(eig)}, and {eig[0]:.6g} + {eig[1]:.6g} = {eig[0] + eig[1]:.6g} < "
        f"{eig[2]:.6g}. No mass distribution has these moments (each is at most the sum "
        "of the other two; equal for a flat plate): check the values, which are about "
        "the mass center in the body frame"
    )


def check_bodies(bodies: Sequence[MovingBody]) -> None:
    """Each body's ``check_values``, the rigid bodies' inertias all at once (a bound
    mechanism checks every body it binds: one at a time, NumPy's calls on 3x3 arrays
    would cost more than the checks).

    Parameters
    ----------
    bodies
        Bodies whose values are numbers; the error is about the first at fault, as
        checking them one by one would give it.

    Examples
    --------
    >>> check_bodies([RigidBody("a", 1.0, (1, 1, 1)), Particle("p", 2.0)])
    """
    together = [b for b in bodies if isinstance(b, RigidBody)
                and type(b).check_values is RigidBody.check_values and not is_symbolic(b.inertia)]
    try:
        for rigid in together:
            _positive_mass(rigid.mass, rigid.name)
        check_inertias(np.array([b.inertia for b in together], dtype=np.float64).reshape(-1, 3, 3),
                       [b.name for b in together])
    except ModelError:
        together = []  # one by one, in order: the error of the first body at fault
    done = {id(b) for b in together}
    for body in bodies:
        if id(body) not in done:
            body.check_values()
