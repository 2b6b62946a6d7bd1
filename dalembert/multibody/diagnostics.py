"""Checks of a multibody model that name the joint and body at fault.

Joint points in the wrong frame. A joint point on a rigid body is given in that
body's frame, relative to its mass center. Two checks catch a world-frame point
given by mistake:

- at construction (:func:`check_joint_points`): a point farther from the mass
  center than ``FAR_FACTOR`` (10) times the body's largest radius of gyration
  ``sqrt(I_max / m)`` raises a :class:`JointPointWarning`. A warning, not an
  error: a heavy small ball on a long massless rod is legitimate (a
  :class:`~dalembert.multibody.Particle` models it better);
- at the initial state (:func:`check_initial_joint_points`, called by
  ``Multibody.initial_state``): a joint whose points do not meet at the given
  poses, but would if one point were read as a world point, raises a
  :class:`JointPointWarning` giving the body-frame point to use instead.

Immobility. Dependent constraints are legitimate (a closed loop of hinges), so a
count of equations decides nothing; :func:`check_mobility` measures
``rank(A)`` at the initial state and, when it leaves no degree of freedom,
raises a :class:`~dalembert.ConstraintError` naming every joint, its rows and
which of them depend on the others (the rank and the dependent rows are those of
:func:`dalembert.numerics.rank.constraint_rank`, as in the solver).
"""

from __future__ import annotations

import warnings
from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING, Any

import numpy as np

from ..errors import ConstraintError, JointPointWarning, user_stacklevel
from ..model.values import CoordinateValues, coordinate_values
from ..numerics.rank import constraint_rank
from .bodies import Body, TurningBody
from .joints import Fixed, Joint, Revolute, Spherical, Universal
from .parametric import is_symbolic
from .types import FloatArray

if TYPE_CHECKING:
    from .builder import Multibody

#: A body-frame joint point farther than this many radii of gyration is suspicious.
FAR_FACTOR = 10.0
#: Joints whose two points must coincide (the frame check at the initial state applies).
_COINCIDENT = (Spherical, Universal, Revolute, Fixed)


def radius_of_gyration(body: TurningBody) -> float:
    """``sqrt(I_max / m)``: the body's size as seen by its inertia.

    Parameters
    ----------
    body
        A rigid or planar body.

    Examples
    --------
    >>> from dalembert.multibody import RigidBody
    >>> radius_of_gyration(RigidBody("b", 2.0, (0.02, 0.08, 0.08)))
    0.2
    """
    return float(np.sqrt(np.linalg.eigvalsh(body.inertia)[-1] / body.mass))


def check_joint_points(joint: Joint) -> None:
    """Warn when a body-frame joint point is implausibly far from the mass center.

    Parameters
    ----------
    joint
        The joint whose points are checked (``Multibody`` checks every joint).

    Examples
    --------
    A hinge point 5 m from the center of a 10 cm box, given in world coordinates
    by mistake:

    >>> import warnings
    >>> from dalembert.multibody import Ground, Revolute, RigidBody
    >>> box = RigidBody("box", 1.0, (0.002, 0.002, 0.002))
    >>> with warnings.catch_warnings(record=True) as caught:
    ...     warnings.simplefilter("always")
    ...     check_joint_points(Revolute("hinge", Ground(), box, (5, 0, 0), (5, 0, 0)))
    >>> [type(w.message).__name__ for w in caught]
    ['JointPointWarning']
    """
    for side, body, point in (("a", joint.body_a, joint.point_a),
                              ("b", joint.body_b, joint.point_b)):
        if not isinstance(body, TurningBody) or any(
                is_symbolic(v) for v in (point, body.mass, body.inertia)):
            continue  # parameters: checked on the mechanism bound to their values
        size = radius_of_gyration(body)
        dist = float(np.linalg.norm(point))
        if dist > FAR_FACTOR * size:
            warnings.warn(
                f"joint {joint.name!r}: point_{side} {tuple(point.tolist())} is {dist:.3g} from "
                f"the mass center of body {body.name!r}, {dist / size:.0f} times its radius of "
                f"gyration {size:.3g}. Joint points are in the body frame, relative to the mass "
                "center: convert a world point p with R^T (p - x). (A point mass on a long "
                "massless rod is better a Particle.)",
                JointPointWarning, stacklevel=user_stacklevel(),
            )


def body_poses(bodies: Sequence[Body], q: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Mass centers ``(k, 3)`` and rotation matrices ``(k, 3, 3)`` of ``bodies`` at one
    configuration, each kind of body at once (a kind's pose depends on its coordinates
    alone).

    Parameters
    ----------
    bodies
        The bodies of a mechanism, in order (the ground is not one).
    q
        The mechanism's coordinates, in order (each body's after the previous one's).

    Examples
    --------
    >>> from dalembert.multibody import Particle, RigidBody
    >>> x, R = body_poses([Particle("p", 1.0), RigidBody("b", 1.0, (1, 1, 1))],
    ...                   np.array([1, 2, 3, 4, 5, 6, 0, 0, 0, 1.0]))
    >>> x.tolist(), R[1].round(12).tolist()
    ([[1.0, 2.0, 3.0], [4.0, 5.0, 6.0]], [[-1.0, 0.0, 0.0], [0.0, -1.0, 0.0], [0.0, 0.0, 1.0]])
    """
    start = np.cumsum([0, *(len(b.coordinates) for b in bodies)])
    x, R = np.zeros((len(bodies), 3)), np.zeros((len(bodies), 3, 3))
    kinds: dict[type, list[int]] = {}
    for i, body in enumerate(bodies):
        kinds.setdefault(type(body), []).append(i)
    for rows in kinds.values():
        columns = start[rows][:, None] + np.arange(start[rows[0] + 1] - start[rows[0]])
        x[rows], R[rows] = bodies[rows[0]].pose(q[columns])
    return x, R


def check_initial_joint_points(mb: Multibody, q: FloatArray) -> None:
    """Warn when a joint's points do not meet at ``q`` but would with one read as world.

    Parameters
    ----------
    mb
        The mechanism.
    q
        Its coordinates, in order (:meth:`Multibody.initial_state` calls this check).

    Examples
    --------
    A link hung from the world point ``(0, 0, 1)``, its own point given as that
    world point too:

    >>> import warnings
    >>> from dalembert.multibody import Ground, Multibody, RigidBody, Spherical
    >>> link = RigidBody("link", 1.0, (0.1, 0.1, 0.01))
    >>> mb = Multibody([link], [Spherical("ball", Ground(), link, (0, 0, 1), (0, 0, 1))])
    >>> with warnings.catch_warnings(record=True) as caught:
    ...     warnings.simplefilter("always")
    ...     _ = mb.initial_state(positions={"link": (0, 0, 0.5)})
    >>> "use point_b=(0.0, 0.0, 0.5)" in str(caught[-1].message)
    True
    """
    joints = [j for j in mb.joints if isinstance(j, _COINCIDENT)]
    if not joints:
        return
    # every joint point in the world at once; the ground's pose is the identity
    x, R = body_poses(mb.bodies, q)
    row = {id(body): i for i, body in enumerate(mb.bodies)}
    x, R = np.vstack([x, np.zeros((1, 3))]), np.vstack([R, np.eye(3)[None]])
    ends = [(j.body_a, j.point_a) for j in joints] + [(j.body_b, j.point_b) for j in joints]
    at = [row.get(id(body), -1) for body, _ in ends]
    points = np.array([point for _, point in ends], dtype=float)
    world = x[at] + np.einsum("kij,kj->ki", R[at], points)
    pa, pb = world[: len(joints)], world[len(joints):]
    gap = np.linalg.norm(pb - pa, axis=1)
    scale = np.maximum(np.maximum(np.linalg.norm(pa, axis=1), np.linalg.norm(pb, axis=1)),
                       1e-3)
    for k in np.flatnonzero(gap > 1e-6 * scale):
        j = joints[k]
        for side, body, point, other in (("a", j.body_a, j.point_a, pb[k]),
                                         ("b", j.body_b, j.point_b, pa[k])):
            if (not isinstance(body, TurningBody)
                    or np.linalg.norm(point - other) > 1e-9 * scale[k]):
                continue
            i = row[id(body)]
            fixed = R[i].T @ (point - x[i])
            warnings.warn(
                f"joint {j.name!r}: its points are {gap[k]:.3g} apart at the initial state, "
                f"but point_{side} {tuple(point.tolist())} is where the joint is in world "
                f"coordinates; joint points are in the body frame of {body.name!r}: use "
                f"point_{side}={tuple(np.round(fixed, 12).tolist())}",
                JointPointWarning, stacklevel=user_stacklevel(),
            )


def check_mobility(mb: Multibody, q0: CoordinateValues, t0: float = 0.0,
                   parameters: Mapping[Any, object] | None = None,
                   cause: BaseException | None = None) -> int:
    """Degrees of freedom ``n - rank(A)`` at ``q0``; raise naming the joints when none.

    Parameters
    ----------
    mb
        The mechanism.
    q0
        The configuration: a dict by coordinate (a coordinate left out is 0) or a
        sequence in coordinate order.
    t0
        The time (for constraints that depend on it).
    parameters
        Parameter values overriding the system's.
    cause
        An exception to chain the :class:`~dalembert.ConstraintError` to.

    Returns
    -------
    int
        ``n - rank(A)``, when positive.

    Examples
    --------
    A link on a ball joint turns three ways:

    >>> from dalembert.multibody import chain
    >>> mb = chain(1, 1.0, 1.0, 0.1)
    >>> check_mobility(mb, mb.initial_state(positions={"link1": (0, 0, -0.5)})[0])
    3

    ``q0`` is read as everywhere else (:func:`dalembert.model.values.coordinate_values`):
    a name that is not a coordinate is an error, not a value silently left out:

    >>> check_mobility(mb, {"link1_z": -0.5, "link1_b0": 1.0, "link2_z": -1.5})
    Traceback (most recent call last):
    ...
    dalembert.errors.InitialConditionError: q0 names 'link2_z', which is not a coordinate ...
    """
    system = mb.system
    names = system.coordinate_names
    q = coordinate_values(q0, names, "q0")
    A, _ = system.numeric(parameters).velocity_constraint(t0, q)
    rank = constraint_rank(A, system.constraint_names, len(names))
    if rank.degrees_of_freedom > 0:
        return rank.degrees_of_freedom
    dep = set(rank.dependent_names)
    parts = []
    for j in mb.joints:
        extra = [c for c in j.constraint_names if c in dep]
        note = f"; rows {', '.join(extra)} depend on the others" if extra else ""
        parts.append(f"{j.name} ({type(j).__name__}: {j.n_equations} rows{note})")
    raise ConstraintError(
        f"the joints leave the mechanism no degree of freedom at the initial state: rank(A) "
        f"= {rank.rank} independent rows on {len(names)} coordinates of "
        f"bodies {', '.join(b.name for b in mb.bodies)} (one unit-quaternion row per rigid "
        f"body). Joints: {'; '.join(parts) or 'none'}. Remove a joint or use one with fewer "
        "equations"
    ) from cause
