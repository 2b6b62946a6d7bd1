"""What an import keeps beside the :class:`~dalembert.multibody.Multibody`: the shapes to
draw, which MuJoCo bodies each dalembert body holds, and MuJoCo's compiled model.

Plain data, for a viewer or a drawing to read (``mb.imported.shapes``), with every pose
in the dalembert body's frame: its origin at the body's mass center, its axes those of
the MuJoCo body frame (so a dalembert body's Euler parameters are MuJoCo's ``xquat``
of that body, up to sign).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..types import FloatArray


@dataclass(frozen=True)
class Shape:
    """One geom of the model, for drawing.

    Attributes
    ----------
    body
        The dalembert body it moves with (``"ground"`` for the world's).
    kind
        MuJoCo's geom type: ``"sphere"``, ``"capsule"``, ``"ellipsoid"``,
        ``"cylinder"``, ``"box"``, ``"plane"``, ``"mesh"``...
    size
        MuJoCo's three size numbers (radius, half-length, half-sides: see MuJoCo's
        ``geom/size``).
    position, quaternion
        Its frame in the body's frame (quaternion ``w, x, y, z``).
    rgba
        Its colour.
    name
        Its name in the model (``""`` if none).
    mesh
        The mesh's vertices ``(k, 3)`` and triangles ``(m, 3)`` in the geom's frame (a
        mesh geom), else ``None``.

    Examples
    --------
    >>> Shape("link", "sphere", (0.1, 0, 0), (0, 0, 0), (1, 0, 0, 0), (1, 0, 0, 1)).kind
    'sphere'
    """

    body: str
    kind: str
    size: tuple[float, float, float]
    position: tuple[float, float, float]
    quaternion: tuple[float, float, float, float]
    rgba: tuple[float, float, float, float]
    name: str = ""
    mesh: tuple[FloatArray, FloatArray] | None = field(default=None, compare=False)


@dataclass(frozen=True)
class ImportedBody:
    """A dalembert body and the MuJoCo bodies welded into it.

    Attributes
    ----------
    name
        The dalembert body's name.
    mujoco_id, mujoco_name
        The MuJoCo body whose frame it has (the root of the welded group).
    members
        The names of the MuJoCo bodies it holds (itself and those attached to it without
        a joint), in model order.
    origin
        The MuJoCo body frame's origin in the dalembert body frame (minus the mass
        center's position in the MuJoCo body frame).

    Examples
    --------
    >>> ImportedBody("arm", 1, "arm", ("arm",), (0.0, 0.0, -0.25)).origin
    (0.0, 0.0, -0.25)
    """

    name: str
    mujoco_id: int
    mujoco_name: str
    members: tuple[str, ...]
    origin: tuple[float, float, float]


@dataclass(frozen=True)
class ImportedModel:
    """What :func:`~dalembert.multibody.from_mjcf` and
    :func:`~dalembert.multibody.from_urdf` read, beside the mechanism.

    Attributes
    ----------
    source
        The file's path, or "the MJCF string".
    bodies
        The moving bodies, by dalembert name.
    joints
        The dalembert joint made of each MuJoCo joint, by MuJoCo name.
    shapes
        Every geom, for drawing (:class:`Shape`).
    unsupported
        The features of the file that the mechanism leaves out (also warned of, once).
    model
        MuJoCo's compiled ``MjModel`` (for :func:`~dalembert.multibody.mujoco_state`).

    Examples
    --------
    >>> ImportedModel("the MJCF string", {}, {}, (), (), None).source
    'the MJCF string'
    """

    source: str
    bodies: dict[str, ImportedBody]
    joints: dict[str, str]
    shapes: tuple[Shape, ...]
    unsupported: tuple[str, ...]
    model: Any = field(repr=False, compare=False)

    def body_origins(self, name: str, x: FloatArray, R: FloatArray) -> FloatArray:
        """The MuJoCo body frame's origin (MuJoCo's ``xpos``) from the dalembert body's
        mass centers ``x (k, 3)`` and rotations ``R (k, 3, 3)``.

        Parameters
        ----------
        name
            The dalembert body's name.
        x, R
            Its poses (e.g. from :func:`~dalembert.multibody.point_positions`'s
            bodies, or the coordinates).

        Examples
        --------
        >>> imported = ImportedModel("s", {"arm": ImportedBody("arm", 1, "arm", ("arm",),
        ...     (0.0, 0.0, 0.5))}, {}, (), (), None)
        >>> imported.body_origins("arm", np.zeros((1, 3)), np.eye(3)[None]).tolist()
        [[0.0, 0.0, 0.5]]
        """
        origin = np.asarray(self.bodies[name].origin, dtype=float)
        return np.asarray(x, dtype=float) + np.asarray(R, dtype=float) @ origin
