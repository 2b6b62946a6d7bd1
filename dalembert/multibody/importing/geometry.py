"""The model's geoms as :class:`~.model.Shape` objects, in the dalembert body frames."""

from __future__ import annotations

from typing import Any

import numpy as np

from ..rotations import quaternion_from_matrix, rotation_matrix
from ..types import FloatArray
from .bodies import ReferencePose
from .model import Shape


def read_shapes(pose: ReferencePose) -> tuple[Shape, ...]:
    """Every geom of the model, placed in its dalembert body's frame (or the world's).

    Parameters
    ----------
    pose
        The model at its reference pose, with its dalembert bodies.
    """
    import mujoco

    model = pose.model
    shapes = []
    for g in range(model.ngeom):
        k = int(model.geom_bodyid[g])
        R = pose.xmat[k] @ rotation_matrix(np.asarray(model.geom_quat[g], dtype=float))
        quaternion = quaternion_from_matrix(pose.world_direction(k, R))
        mesh: tuple[FloatArray, FloatArray] | None = None
        m = int(model.geom_dataid[g])
        if model.geom_type[g] == mujoco.mjtGeom.mjGEOM_MESH and m >= 0:
            v0, nv = int(model.mesh_vertadr[m]), int(model.mesh_vertnum[m])
            f0, nf = int(model.mesh_faceadr[m]), int(model.mesh_facenum[m])
            mesh = (np.array(model.mesh_vert[v0:v0 + nv], dtype=float),
                    np.array(model.mesh_face[f0:f0 + nf], dtype=np.int64))
        shapes.append(Shape(
            body=pose.body_of(k).name,
            kind=mujoco.mjtGeom(int(model.geom_type[g])).name[len("mjGEOM_"):].lower(),
            size=_floats(model.geom_size[g], 3),
            position=_floats(pose.to_body(k, model.geom_pos[g]), 3),
            quaternion=_floats(quaternion, 4),
            rgba=_floats(model.geom_rgba[g], 4),
            name=model.geom(g).name,
            mesh=mesh))
    return tuple(shapes)


def _floats(values: FloatArray, n: int) -> Any:
    """The first ``n`` values as a tuple of floats."""
    return tuple(float(v) for v in np.asarray(values, dtype=float)[:n])
