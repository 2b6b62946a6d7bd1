"""The geoms of an imported model (``mb.imported.shapes``) as the viewer's shapes.

An imported mechanism keeps its model file's geoms (:class:`~dalembert.multibody.
importing.Shape`), each posed in its dalembert body's frame: origin at the body's mass
center, axes those of the MuJoCo body frame, the same frame the scene's poses move. They
become the viewer's three primitives:

- a ``box`` its box (MuJoCo's sizes are half-sides);
- a ``sphere`` its sphere, an ``ellipsoid`` a sphere scaled by its three radii
  (``radii``) and turned by the geom's rotation;
- a ``cylinder`` a cylinder along the geom's ``z`` (MuJoCo's size: radius, half-length),
  a ``capsule`` that cylinder and a sphere at each end;
- a ``mesh`` the box bounding its vertices in the geom's frame (the viewer draws no
  meshes).

Planes, height fields and SDF geoms are not drawn (a plane is infinite: the floor
would hide the mechanism), nor a geom MuJoCo makes invisible (alpha 0). A moving body
left with no geom to draw keeps the viewer's default shapes.
"""

from __future__ import annotations

from collections.abc import Iterable
from typing import Any

import numpy as np
from scipy.spatial.transform import Rotation

from ...multibody.importing.model import Shape

#: MuJoCo geom types with no picture here.
NOT_DRAWN = ("plane", "hfield", "sdf")


def geom_shapes(shape: Shape) -> list[dict[str, Any]]:
    """One geom as the viewer's shape dicts (without the ``body`` key), in its body's
    frame; none for a geom not drawn.

    Parameters
    ----------
    shape
        The geom, from ``mb.imported.shapes``.

    Examples
    --------
    A capsule of radius 0.1 and half-length 0.5 along the body's ``x`` (the geom's
    ``z`` turned a quarter about ``y``), centered 0.2 above the mass center:

    >>> c = np.sqrt(0.5)
    >>> capsule = Shape("arm", "capsule", (0.1, 0.5, 0.0), (0.0, 0.0, 0.2),
    ...                 (c, 0.0, c, 0.0), (1, 1, 1, 1))
    >>> [(s["kind"], np.round(s.get("from", s.get("center")), 12).tolist())
    ...  for s in geom_shapes(capsule)]
    [('cylinder', [-0.5, 0.0, 0.2]), ('sphere', [-0.5, 0.0, 0.2]), ('sphere', [0.5, 0.0, 0.2])]
    """
    if shape.kind in NOT_DRAWN or shape.rgba[3] <= 0:
        return []
    center = np.asarray(shape.position, dtype=float)
    w, x, y, z = shape.quaternion
    turn = Rotation.from_quat([x, y, z, w])
    rotation = turn.as_quat().tolist()
    size = np.asarray(shape.size, dtype=float)
    if shape.kind == "sphere":
        return [{"kind": "sphere", "center": center.tolist(), "radius": float(size[0])}]
    if shape.kind == "ellipsoid":
        return [{"kind": "sphere", "center": center.tolist(), "radius": float(size.max()),
                 "radii": size.tolist(), "rotation": rotation}]
    if shape.kind == "box":
        return [{"kind": "box", "center": center.tolist(), "size": (2 * size).tolist(),
                 "rotation": rotation}]
    if shape.kind in ("cylinder", "capsule"):
        half = turn.apply([0.0, 0.0, float(size[1])])
        ends = [(center - half).tolist(), (center + half).tolist()]
        out = [{"kind": "cylinder", "from": ends[0], "to": ends[1], "radius": float(size[0])}]
        if shape.kind == "capsule":
            out += [{"kind": "sphere", "center": end, "radius": float(size[0])} for end in ends]
        return out
    if shape.kind == "mesh" and shape.mesh is not None and len(shape.mesh[0]):
        vertices = np.asarray(shape.mesh[0], dtype=float)
        lo, hi = vertices.min(axis=0), vertices.max(axis=0)
        return [{"kind": "box", "center": (center + turn.apply((lo + hi) / 2)).tolist(),
                 "size": np.maximum(hi - lo, 1e-9).tolist(), "rotation": rotation}]
    return []


def imported_shapes(shapes: Iterable[Shape],
                    body_index: dict[str, int]) -> dict[int, list[dict[str, Any]]]:
    """The drawable geoms of an imported model by body index (-1: the ground's).

    Parameters
    ----------
    shapes
        ``mb.imported.shapes``.
    body_index
        The scene's index of each moving body, by name; a geom on another body (the
        world's) goes to the ground.

    Examples
    --------
    >>> ball = Shape("bob", "sphere", (0.1, 0.0, 0.0), (0.0, 0.0, 0.0), (1, 0, 0, 0),
    ...              (1, 0, 0, 1))
    >>> floor = Shape("ground", "plane", (0.0, 0.0, 0.1), (0.0, 0.0, 0.0), (1, 0, 0, 0),
    ...               (1, 1, 1, 1))
    >>> imported_shapes([ball, floor], {"bob": 0})
    {0: [{'kind': 'sphere', 'center': [0.0, 0.0, 0.0], 'radius': 0.1, 'body': 0}]}
    """
    out: dict[int, list[dict[str, Any]]] = {}
    for shape in shapes:
        index = body_index.get(shape.body, -1)
        drawn = [{**s, "body": index} for s in geom_shapes(shape)]
        if drawn:
            out.setdefault(index, []).extend(drawn)
    return out
