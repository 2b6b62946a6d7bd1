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
from sympy.physics.vector import dynamicsymbols

from ..errors import ModelError
from ..model.constraints import Holonomic
from ..model.coordinates import t
from ..model.expressions import sympify_strict
from .rotations import E_matrix, dot, rotation_matrix, times_vector


def _vector(v: object, what: str) -> sp.Matrix:
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
    """Common interface: coordinates, point positions, orientation, energy."""

    name: str
    mass: float
    coordinates: tuple[sp.Function, ...] = ()
    has_orientation = True

    def position(self, point: object = (0, 0, 0)) -> sp.Matrix:
        """World position of a body-fixed point (given in the body frame):
        ``center + R point`` for a body with an orientation."""
        s = _vector(point, f"a point of body {self.name!r}")
        if all(c == 0 for c in s):
            return self.center
        return self.center + times_vector(self.rotation(), s)

    def rotation(self) -> sp.Matrix:
        """Rotation matrix body -> world as SymPy expressions."""
        raise NotImplementedError

    def kinetic_energy(self) -> sp.Expr:
        return sp.S.Zero

    def constraints(self) -> list[Holonomic]:
        return []

    # -- numbers: rows of coordinate values ``c`` (k, len(coordinates)) -----------------
    def pose(self, c: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Mass centers ``(k, 3)`` and rotation matrices ``(k, 3, 3)`` (body -> world)."""
        c = np.atleast_2d(c)
        return c[:, :3], np.broadcast_to(np.eye(3), (len(c), 3, 3)).copy()

    def center_velocity(self, cd: np.ndarray) -> np.ndarray:
        """Mass-center velocities ``(k, 3)`` (world) from the coordinate rates."""
        return np.atleast_2d(cd)[:, :3]

    def angular_velocity_at(self, c: np.ndarray, cd: np.ndarray) -> np.ndarray:
        """Angular velocities ``(k, 3)`` in body components."""
        return np.zeros((len(np.atleast_2d(c)), 3))

    def center_torque(self, c: np.ndarray, Q: np.ndarray) -> np.ndarray:
        """The torque about the mass center (world) whose virtual work on this body's
        coordinates is the generalized force ``Q`` (k, len(coordinates))."""
        return np.zeros((len(np.atleast_2d(c)), 3))

    def center_force(self, Q: np.ndarray) -> np.ndarray:
        """The force (world) of a generalized force ``Q`` on this body's coordinates."""
        return np.atleast_2d(Q)[:, :3]

    @property
    def constraint_names(self) -> list[str]:
        return []

    def __repr__(self) -> str:
        return f"{type(self).__name__}({self.name!r})"


class Ground(Body):
    """The fixed world frame; its points are given in world coordinates.

    >>> Ground().position((1, 2, 3)).T
    Matrix([[1, 2, 3]])
    """

    def __init__(self, name: str = "ground") -> None:
        self.name = _check_name(name)
        self.mass = 0.0

    def position(self, point: object = (0, 0, 0)) -> sp.Matrix:
        return _vector(point, f"a point of {self.name!r}")

    def rotation(self) -> sp.Matrix:
        return sp.eye(3)


class Particle(Body):
    """A point mass with coordinates ``<name>_x, <name>_y, <name>_z``.

    >>> p = Particle("bob", 2.0)
    >>> [str(c) for c in p.coordinates]
    ['bob_x(t)', 'bob_y(t)', 'bob_z(t)']
    """

    has_orientation = False

    def __init__(self, name: str, mass: float) -> None:
        self.name = _check_name(name)
        self.mass = _positive_mass(mass, name)
        self.coordinates = tuple(dynamicsymbols(f"{name}_x {name}_y {name}_z"))

    @property
    def center(self) -> sp.Matrix:
        return sp.Matrix(self.coordinates)

    def position(self, point: object = (0, 0, 0)) -> sp.Matrix:
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
        return _number(self.mass) / 2 * v.dot(v)


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
        positive-definite 3x3 matrix, or its 3 principal values.

    >>> body = RigidBody("box", 1.0, (1.0, 2.0, 3.0))
    >>> [c.name for c in body.constraints()]
    ['box_unit_quaternion']
    """

    def __init__(self, name: str, mass: float, inertia: object) -> None:
        self.name = _check_name(name)
        self.mass = _positive_mass(mass, name)
        self.inertia = _inertia_tensor(inertia, name)
        self.coordinates = tuple(
            dynamicsymbols(" ".join(f"{name}_{c}" for c in ("x", "y", "z", "b0", "b1", "b2", "b3")))
        )

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
        inertia = sp.Matrix(3, 3, lambda i, j: _number(self.inertia[i, j]))
        rot = dot(w, times_vector(inertia, w))
        # expanded: a sum of monomials differentiates much faster than nested products
        return sp.expand(_number(self.mass) / 2 * v.dot(v) + rot / 2)

    def pose(self, c: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        c = np.atleast_2d(c)
        return c[:, :3], rotation_matrix(c[:, 3:])

    def angular_velocity_at(self, c: np.ndarray, cd: np.ndarray) -> np.ndarray:
        b, bd = np.atleast_2d(c)[:, 3:], np.atleast_2d(cd)[:, 3:]
        return 2 * np.einsum("kij,kj->ki", E_matrix(b), bd)

    def center_torque(self, c: np.ndarray, Q: np.ndarray) -> np.ndarray:
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
        Moment of inertia about the ``z`` axis through the mass center (> 0).

    >>> link = PlanarBody("link", 1.0, 0.1)
    >>> [c.name for c in link.coordinates], link.constraints()
    (['link_x', 'link_y', 'link_theta'], [])
    """

    def __init__(self, name: str, mass: float, inertia: float) -> None:
        self.name = _check_name(name)
        self.mass = _positive_mass(mass, name)
        self.moment = _positive_moment(inertia, name)
        #: The inertia tensor seen in 3D: only rotations about ``z`` are possible.
        self.inertia = np.diag([0.0, 0.0, self.moment])
        self.coordinates = tuple(dynamicsymbols(f"{name}_x {name}_y {name}_theta"))

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
        return (_number(self.mass) / 2 * (x**2 + y**2)
                + _number(self.moment) / 2 * theta**2)

    def pose(self, c: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        c = np.atleast_2d(c)
        x = np.column_stack([c[:, 0], c[:, 1], np.zeros(len(c))])
        cos, sin = np.cos(c[:, 2]), np.sin(c[:, 2])
        R = np.zeros((len(c), 3, 3))
        R[:, 0, 0], R[:, 0, 1], R[:, 1, 0], R[:, 1, 1], R[:, 2, 2] = cos, -sin, sin, cos, 1.0
        return x, R

    def center_velocity(self, cd: np.ndarray) -> np.ndarray:
        cd = np.atleast_2d(cd)
        return np.column_stack([cd[:, 0], cd[:, 1], np.zeros(len(cd))])

    def angular_velocity_at(self, c: np.ndarray, cd: np.ndarray) -> np.ndarray:
        return _along_z(np.atleast_2d(cd)[:, 2])

    def center_torque(self, c: np.ndarray, Q: np.ndarray) -> np.ndarray:
        return _along_z(np.atleast_2d(Q)[:, 2])

    def center_force(self, Q: np.ndarray) -> np.ndarray:
        Q = np.atleast_2d(Q)
        return np.column_stack([Q[:, 0], Q[:, 1], np.zeros(len(Q))])


def _along_z(values: np.ndarray) -> np.ndarray:
    out = np.zeros((len(values), 3))
    out[:, 2] = values
    return out


def _positive_moment(value: object, name: str) -> float:
    try:
        moment = float(value)
    except (TypeError, ValueError) as exc:
        raise ModelError(f"the inertia of planar body {name!r} is its moment about z, one "
                         f"number; got {value!r}") from exc
    if not (np.isfinite(moment) and moment > 0):
        raise ModelError(f"the moment of inertia of planar body {name!r} must be positive and "
                         f"finite, got {moment} (use a Particle for a point mass)")
    return moment


def _number(value: float) -> sp.Expr:
    """A float as a SymPy number; exact zero stays exact so its terms vanish."""
    return sp.S.Zero if value == 0 else sp.Float(value)


def _positive_mass(mass: object, name: str) -> float:
    try:
        value = float(mass)
    except (TypeError, ValueError) as exc:
        raise ModelError(f"the mass of {name!r} must be a number, got {mass!r}") from exc
    if not (np.isfinite(value) and value > 0):
        raise ModelError(f"the mass of {name!r} must be positive and finite, got {value}")
    return value


#: Principal moments may miss the triangle inequality by this much (relative) before
#: the inertia is refused: rounding of moments computed as sums, a flat plate's equality.
TRIANGLE_RTOL = 1e-9
#: Below this ratio of smallest to largest principal moment the spin about that axis
#: has no digit left in the equations of motion (the KKT matrix is singular).
INERTIA_RATIO_MIN = 1e-12


def _inertia_tensor(inertia: object, name: str) -> np.ndarray:
    """The inertia tensor, checked: finite, symmetric, positive definite, well enough
    conditioned to integrate, and the principal moments obeying the triangle
    inequality (as every real mass distribution's do)."""
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
    if not np.all(np.isfinite(I)):
        raise ModelError(f"the inertia tensor of {name!r} must be finite:\n{I}")
    asymmetry = np.abs(I - I.T)
    if asymmetry.max() > 1e-12 * max(np.abs(I).max(), 1):
        i, j = np.unravel_index(int(np.argmax(asymmetry)), I.shape)
        raise ModelError(
            f"the inertia tensor of {name!r} must be symmetric: I[{i}, {j}] = {I[i, j]:.6g} "
            f"but I[{j}, {i}] = {I[j, i]:.6g}:\n{I}"
        )
    eig = np.linalg.eigvalsh(I)
    values = ", ".join(f"{e:.6g}" for e in eig)
    if eig[0] <= 0:
        raise ModelError(
            f"the inertia tensor of {name!r} is not positive definite (principal values "
            f"{values}); a rigid body needs inertia about every axis (use a Particle for a "
            "point mass)"
        )
    if eig[0] <= INERTIA_RATIO_MIN * eig[-1]:
        raise ModelError(
            f"the inertia tensor of {name!r} is nearly singular (principal values {values}): "
            f"the smallest is {eig[0] / eig[-1]:.1e} of the largest, so the spin about that "
            "axis has almost no inertia and the equations of motion cannot determine it "
            "(ill-conditioned). Give that axis more inertia (for a thin rod a larger radius, "
            "with a ratio above 1e-8, hardly changes its swinging), or model the body "
            "without that rotation (two particles joined by a Distance joint)"
        )
    if eig[0] + eig[1] < eig[2] * (1 - TRIANGLE_RTOL):
        raise ModelError(
            f"the inertia tensor of {name!r} violates the triangle inequality: principal "
            f"moments {values}, and {eig[0]:.6g} + {eig[1]:.6g} = {eig[0] + eig[1]:.6g} < "
            f"{eig[2]:.6g}. No mass distribution has these moments (each is at most the sum "
            "of the other two; equal for a flat plate): check the values, which are about "
            "the mass center in the body frame"
        )
    return I


def body_names(bodies: Sequence[Body]) -> list[str]:
    return [b.name for b in bodies]
