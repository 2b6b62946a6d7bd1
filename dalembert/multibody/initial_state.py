"""Initial coordinates and rates of each kind of body from its pose and motion.

:meth:`Multibody.initial_state` takes, per body, the mass-center position and
velocity (world), the orientation and the angular velocity, and turns them into
the body's coordinates: a particle's are its position; a rigid body's add the
Euler parameters (``bdot = 1/2 E(b)^T w_body``); a planar body's are ``x, y`` and
the angle about ``z``.
"""

from __future__ import annotations

import warnings
from collections.abc import Mapping, Sequence

import numpy as np

from ..errors import InitialConditionError, InitialConditionsAdjusted, user_stacklevel
from .bodies import MovingBody, PlanarBody, RigidBody
from .rotations import E_matrix, check_rotations, quaternion_from_matrix, rotation_matrix
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
    if isinstance(body, RigidBody):
        q, qd = _rigid([body], frame, [position], [orientation], [velocity],
                       [angular_velocity])
        return q[0].tolist(), qd[0].tolist()
    x = _triple(position, f"position of {body.name!r}")
    v = _triple(velocity, f"velocity of {body.name!r}")
    for what, value in (("orientation", orientation), ("angular velocity", angular_velocity)):
        if value is not None:
            raise InitialConditionError(f"{body.name!r} is a particle; it has no {what}")
    return [*x], [*v]


def bodies_state(bodies: Sequence[MovingBody], frame: Frame,
                 positions: Mapping[str, Vector], orientations: Mapping[str, Orientation],
                 velocities: Mapping[str, Vector],
                 angular_velocities: Mapping[str, Vector | float]
                 ) -> tuple[FloatArray, FloatArray]:
    """The coordinates and rates of ``bodies`` (each body's after the previous one's), as
    :func:`body_state` gives them; the rigid bodies' all at once.

    Parameters
    ----------
    bodies
        Particles, rigid bodies and planar bodies.
    frame
        ``"world"`` or ``"body"``: the components of the angular velocities.
    positions, orientations, velocities, angular_velocities
        By body name; a body left out is at the origin, unrotated, at rest.

    Examples
    --------
    Two boxes, one turning about ``z`` at 2 rad/s (``bdot_3 = 1/2 w_z``):

    >>> from dalembert.multibody import RigidBody
    >>> boxes = [RigidBody(name, 1.0, (1, 1, 1)) for name in ("a", "b")]
    >>> q, qd = bodies_state(boxes, "world", {"b": (0, 0, 1)}, {}, {}, {"a": (0, 0, 2.0)})
    >>> q.tolist(), qd.tolist()  # doctest: +NORMALIZE_WHITESPACE
    ([0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0, 1.0, 0.0, 0.0, 0.0],
     [0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0])
    """
    start = np.cumsum([0, *(len(b.coordinates) for b in bodies)])
    q, qd = np.zeros(start[-1]), np.zeros(start[-1])
    rigid = [i for i, b in enumerate(bodies) if isinstance(b, RigidBody)]
    if rigid:
        together = [b for b in bodies if isinstance(b, RigidBody)]
        names = [b.name for b in together]
        columns = start[rigid][:, None] + np.arange(7)
        q[columns], qd[columns] = _rigid(
            together, frame, [positions.get(n) for n in names],
            [orientations.get(n) for n in names], [velocities.get(n) for n in names],
            [angular_velocities.get(n) for n in names])
    done = set(rigid)
    for i, body in enumerate(bodies):
        if i not in done:
            name = body.name
            q[start[i]:start[i + 1]], qd[start[i]:start[i + 1]] = body_state(
                body, frame, positions.get(name), orientations.get(name),
                velocities.get(name), angular_velocities.get(name))
    return q, qd


def _rigid(bodies: Sequence[RigidBody], frame: Frame, positions: Sequence[Vector | None],
           orientations: Sequence[Orientation | None], velocities: Sequence[Vector | None],
           angular_velocities: Sequence[Vector | float | None]
           ) -> tuple[FloatArray, FloatArray]:
    """Rigid bodies' coordinates and rates, rows ``(k, 7)``: the checks and the
    conversions of every body at once (on 3-vectors and 3x3 matrices NumPy costs
    microseconds a call, whatever the size)."""
    names = [body.name for body in bodies]
    x = _triples(positions, "position", names)
    v = _triples(velocities, "velocity", names)
    b = np.empty((len(bodies), 4))
    b[:] = (1.0, 0.0, 0.0, 0.0)
    matrices: dict[int, FloatArray] = {}
    for i, (value, name) in enumerate(zip(orientations, names)):
        if value is None:
            continue
        arr = _numbers(value, f"orientation of {name!r}",
                       "a 3x3 rotation matrix or 4 Euler parameters")
        if arr.shape == (3, 3):
            matrices[i] = arr
        else:
            b[i] = _quaternion(value, name)
    if matrices:
        rows = list(matrices)
        b[rows] = quaternion_from_matrix(_rotations(np.array(list(matrices.values())),
                                                    [names[i] for i in rows]))
    w = _triples(angular_velocities, "angular velocity", names)
    if frame == "world":
        w = np.einsum("kji,kj->ki", rotation_matrix(b), w)  # R^T w: body components
    bd = 0.5 * np.einsum("kji,kj->ki", E_matrix(b), w)  # E^T w_body
    return np.hstack([x, b]), np.hstack([v, bd])


def _triples(values: Sequence[Vector | float | None], what: str,
             names: Sequence[str]) -> FloatArray:
    """3-vectors of the bodies ``names`` as rows (``None``: zero): all at once where they
    are valid, else the first bad one's error, as :func:`_triple` gives it."""
    try:
        arr = np.array([(0.0, 0.0, 0.0) if v is None else v for v in values], dtype=float)
        if arr.shape == (len(values), 3) and np.isfinite(arr).all():
            return arr
    except (TypeError, ValueError):
        pass
    return np.array([_triple(v, f"{what} of {name!r}") for v, name in zip(values, names)])


def _triple(value: Vector | float | None, what: str) -> FloatArray:
    if value is None:
        return np.zeros(3)
    arr = _numbers(value, what, "3 finite numbers")
    if arr.shape != (3,) or not np.all(np.isfinite(arr)):
        raise InitialConditionError(f"the {what} must be 3 finite numbers, got {value!r}")
    return arr


def _quaternion(value: Orientation, name: str) -> FloatArray:
    """Unit Euler parameters of an orientation given as 4 numbers (matrices are read
    by :func:`_rigid`, all at once)."""
    arr = _numbers(value, f"orientation of {name!r}",
                   "a 3x3 rotation matrix or 4 Euler parameters")
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
            InitialConditionsAdjusted, stacklevel=user_stacklevel(),
        )
    return arr / norm


def _rotation(R: FloatArray, name: str) -> FloatArray:
    return _rotations(R[None], [name])[0]


def _rotations(R: FloatArray, names: Sequence[str]) -> FloatArray:
    try:
        return check_rotations(R, [f"the orientation of {name!r}" for name in names])
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
    arr = _numbers(value, what, "2 or 3 finite numbers")
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
    arr = _numbers(orientation, f"orientation of planar body {name!r}",
                   "an angle about z or a 3x3 rotation matrix about z")
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
    arr = _numbers(value, what, "a number or 3 finite numbers")
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


def _numbers(value: object, what: str, expected: str) -> FloatArray:
    """``value`` as an array of floats, or an error naming the body's quantity (a value
    nested one level too deep, such as ``{"crank": {"x": 0.5}}``, is not numbers)."""
    try:
        return np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        hint = (" (a dict: give the numbers themselves, not a dict of them)"
                if isinstance(value, dict) else "")
        raise InitialConditionError(f"the {what} must be {expected}, got {value!r}{hint}"
                                    ) from None
