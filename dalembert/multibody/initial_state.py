"""Initial coordinates and rates of each kind of body from its pose and motion.

:meth:`Multibody.initial_state` takes, per body, the mass-center position and
velocity (world), the orientation and the angular velocity, and turns them into
the body's coordinates: a particle's are its position; a rigid body's add the
Euler parameters (``bdot = 1/2 E(b)^T w_body``); a planar body's are ``x, y`` and
the angle about ``z``.
"""

from __future__ import annotations

import warnings

import numpy as np

from ..errors import InitialConditionError, InitialConditionsAdjusted
from .bodies import MovingBody, PlanarBody, RigidBody
from .rotations import E_matrix, check_rotation, quaternion_from_matrix, rotation_matrix
from .types import FloatArray, Frame, Orientation, Vector

Values = tuple[list[float], list[float]]


def body_state(body: MovingBody, frame: Frame, position: Vector | None = None,
               orientation: Orientation | None = None, velocity: Vector | None = None,
               angular_velocity: Vector | float | None = None) -> Values:
    """``(coordinates, rates)`` of ``body``; ``None`` means at the origin, unrotated, at
    rest.

    Parameters
    ----------
    body
        A particle, rigid body or planar body.
    frame
        ``"world"`` or ``"body"``: the components of ``angular_velocity``.
    position, velocity
        The mass center's (world; 2 numbers for a planar body).
    orientation
        A rotation matrix or Euler parameters; a planar body's angle about ``z``.
    angular_velocity
        3 components; a planar body's ``w_z``.

    Examples
    --------
    A planar body: ``x, y`` and the angle, their rates:

    >>> from dalembert.multibody import PlanarBody
    >>> q, qd = body_state(PlanarBody("link", 1.0, 0.1), "world", (1, 2), 0.5, (0, 3), 4.0)
    >>> [float(v) for v in q], [float(v) for v in qd]
    ([1.0, 2.0, 0.5], [0.0, 3.0, 4.0])
    """
    if isinstance(body, PlanarBody):
        return _planar(body, position, orientation, velocity, angular_velocity)
    x = _triple(position, f"position of {body.name!r}")
    v = _triple(velocity, f"velocity of {body.name!r}")
    if not isinstance(body, RigidBody):
        for what, value in (("orientation", orientation), ("angular velocity",
                                                           angular_velocity)):
            if value is not None:
                raise InitialConditionError(f"{body.name!r} is a particle; it has no {what}")
        return [*x], [*v]
    b = np.array([1.0, 0.0, 0.0, 0.0]) if orientation is None else _quaternion(orientation,
                                                                                 body.name)
    w = _triple(angular_velocity, f"angular velocity of {body.name!r}")
    if frame == "world":
        w = rotation_matrix(b).T @ w
    return [*x, *b], [*v, *(0.5 * E_matrix(b).T @ w)]


def _triple(value: Vector | float | None, what: str) -> FloatArray:
    if value is None:
        return np.zeros(3)
    arr = np.asarray(value, dtype=float)
    if arr.shape != (3,) or not np.all(np.isfinite(arr)):
        raise InitialConditionError(f"the {what} must be 3 finite numbers, got {value!r}")
    return arr


def _quaternion(value: Orientation, name: str) -> FloatArray:
    """Euler parameters of an orientation given as a matrix or a quaternion."""
    arr = np.asarray(value, dtype=float)
    if arr.shape == (3, 3):
        return quaternion_from_matrix(_rotation(arr, name))
    if arr.shape != (4,) or not np.all(np.isfinite(arr)):
        raise InitialConditionError(
            f"the orientation of {name!r} must be a 3x3 rotation matrix or 4 Euler "
            f"parameters, got {value!r}"
        )
    norm = np.linalg.norm(arr)
    if norm == 0:
        raise InitialConditionError(f"the quaternion of {name!r} is zero; it has no direction")
    if abs(norm - 1.0) > 1e-12:
        warnings.warn(
            f"the quaternion of {name!r} had norm {norm:.12g}; normalized to "
            f"{np.array2string(arr / norm, precision=12)}",
            InitialConditionsAdjusted, stacklevel=4,
        )
    return arr / norm


def _rotation(R: FloatArray, name: str) -> FloatArray:
    try:
        return check_rotation(R, f"the orientation of {name!r}")
    except ValueError as exc:
        raise InitialConditionError(str(exc)) from exc


def _planar(body: PlanarBody, position: Vector | None, orientation: Orientation | None,
            velocity: Vector | None, angular_velocity: Vector | float | None) -> Values:
    x = _in_plane(position, f"position of {body.name!r}")
    v = _in_plane(velocity, f"velocity of {body.name!r}")
    theta = _angle(orientation, body.name)
    w = _about_z(angular_velocity, f"angular velocity of {body.name!r}")
    return [*x, theta], [*v, w]


def _in_plane(value: Vector | None, what: str) -> FloatArray:
    """``(x, y)`` of a vector given as 2 numbers or 3 with ``z = 0``."""
    if value is None:
        return np.zeros(2)
    arr = np.asarray(value, dtype=float)
    if arr.shape not in ((2,), (3,)) or not np.all(np.isfinite(arr)):
        raise InitialConditionError(f"the {what} must be 2 or 3 finite numbers, got {value!r}")
    if arr.shape == (3,) and arr[2] != 0:
        raise InitialConditionError(
            f"the {what} has z = {arr[2]:g}, but a planar body moves in the x-y plane (z = 0)")
    return arr[:2]


def _angle(orientation: Orientation | None, name: str) -> float:
    """The angle about ``z`` of a number or a rotation matrix about ``z``."""
    if orientation is None:
        return 0.0
    arr = np.asarray(orientation, dtype=float)
    if arr.shape == ():
        if not np.isfinite(arr):
            raise InitialConditionError(f"the angle of {name!r} must be finite, got {arr}")
        return float(arr)
    if arr.shape != (3, 3):
        raise InitialConditionError(
            f"the orientation of planar body {name!r} must be an angle about z or a 3x3 "
            f"rotation matrix about z, got {orientation!r}")
    R = _rotation(arr, name)
    if abs(R[2, 2] - 1.0) > 1e-9:
        raise InitialConditionError(
            f"the orientation of planar body {name!r} is not a rotation about z (its z axis "
            f"goes to {np.round(R[:, 2], 9).tolist()}); a planar body turns in the x-y plane")
    return float(np.arctan2(R[1, 0], R[0, 0]))


def _about_z(value: Vector | float | None, what: str) -> float:
    """``w_z`` of an angular velocity given as a number or ``(0, 0, w_z)``."""
    if value is None:
        return 0.0
    arr = np.asarray(value, dtype=float)
    if arr.shape == () and np.isfinite(arr):
        return float(arr)
    if arr.shape != (3,) or not np.all(np.isfinite(arr)):
        raise InitialConditionError(f"the {what} must be a number or 3 finite numbers, got "
                                    f"{value!r}")
    if arr[0] != 0 or arr[1] != 0:
        raise InitialConditionError(
            f"the {what} {arr.tolist()} has x or y components, but a planar body turns "
            "about z only")
    return float(arr[2])
