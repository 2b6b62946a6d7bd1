"""MuJoCo bodies -> dalembert rigid bodies, from the compiled model at its reference pose.

A MuJoCo body without a joint is welded to its parent: it and its jointless
descendants become one dalembert body (MuJoCo's ``body_weldid`` groups them), with their
masses, mass centers and inertias combined (parallel axes); those welded to the world
are part of the ground. Each dalembert body's frame has its origin at the group's
mass center and the axes of the group's root MuJoCo body frame, so every point given
in a MuJoCo body frame is moved to it here.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from typing import Any

import numpy as np

from ...errors import ModelError, ModelFileError
from ..bodies import Body, Ground, RigidBody
from ..types import FloatArray
from .model import ImportedBody

#: Below this a MuJoCo body's compiled mass counts as none (MuJoCo's own ``mjMINVAL``).
MIN_MASS = 1e-15


def body_label(model: Any, k: int) -> str:
    """MuJoCo body ``k``'s name for messages (``body<k>`` if it has none).

    Examples
    --------
    >>> import mujoco
    >>> body_label(mujoco.MjModel.from_xml_string("<mujoco/>"), 0)
    'world'
    """
    return model.body(k).name or f"body{k}"


def identifier(name: str, fallback: str, taken: set[str]) -> str:
    """``name`` as a Python identifier not in ``taken`` (then added to it).

    Parameters
    ----------
    name
        The name in the model (may be empty, or hold ``-``, ``.``, spaces).
    fallback
        The name to use when ``name`` is empty.
    taken
        The names already given.

    Examples
    --------
    >>> taken = set()
    >>> [identifier(name, "b", taken) for name in ("link-1", "link_1", "")]
    ['link_1', 'link_1_2', 'b']
    """
    base = re.sub(r"\W", "_", name) or fallback
    if not base.isidentifier():
        base = "_" + base
    out, k = base, 2
    while out in taken:
        out, k = f"{base}_{k}", k + 1
    taken.add(out)
    return out


@dataclass
class ReferencePose:
    """The compiled model at its reference pose ``qpos0``: every MuJoCo body's frame and
    the dalembert bodies made of them."""

    model: Any
    label: str
    xpos: FloatArray
    xmat: FloatArray
    #: The group (root body id) of every MuJoCo body; 0 for the world's.
    group: FloatArray
    #: The dalembert body of every group root (``Ground`` for 0).
    bodies: dict[int, Body]
    #: The moving ones, in model order.
    moving: list[RigidBody]
    #: Each group's mass center (world) and frame (its root's orientation).
    center: dict[int, FloatArray]
    imported: dict[str, ImportedBody]

    def to_body(self, k: int, point: FloatArray) -> FloatArray:
        """A point given in MuJoCo body ``k``'s frame, in its dalembert body's frame."""
        world = self.xpos[k] + self.xmat[k] @ np.asarray(point, dtype=float)
        return self.world_point(k, world)

    def world_point(self, k: int, world: FloatArray) -> FloatArray:
        """A world point (at the reference pose) in body ``k``'s dalembert frame."""
        g = int(self.group[k])
        if g == 0:
            return np.asarray(world, dtype=float)
        return self.xmat[g].T @ (world - self.center[g])

    def to_body_direction(self, k: int, direction: FloatArray) -> FloatArray:
        """A direction given in MuJoCo body ``k``'s frame, in its dalembert body's frame."""
        world = self.xmat[k] @ np.asarray(direction, dtype=float)
        return self.world_direction(k, world)

    def world_direction(self, k: int, world: FloatArray) -> FloatArray:
        """A world direction (at the reference pose) in body ``k``'s dalembert frame."""
        g = int(self.group[k])
        return np.asarray(world, dtype=float) if g == 0 else self.xmat[g].T @ world

    def body_of(self, k: int) -> Body:
        """The dalembert body (or the ground) MuJoCo body ``k`` belongs to."""
        return self.bodies[int(self.group[k])]


def reference_pose(model: Any, label: str) -> ReferencePose:
    """The dalembert bodies of ``model``, built at its reference pose.

    Parameters
    ----------
    model
        MuJoCo's compiled ``MjModel``.
    label
        The source, for messages.

    Raises
    ------
    ModelFileError
        A moving body group without mass, or with an inertia dalembert refuses.
    """
    import mujoco

    data = mujoco.MjData(model)
    mujoco.mj_kinematics(model, data)
    xpos, xmat = data.xpos.copy(), data.xmat.reshape(-1, 3, 3).copy()
    xipos, ximat = data.xipos.copy(), data.ximat.reshape(-1, 3, 3).copy()
    group = np.asarray(model.body_weldid, dtype=int).copy()
    # a mocap body is moved by the user, not simulated: it and what is welded to it are
    # held fixed, with the ground (listed in the warning)
    mocap = np.flatnonzero(np.asarray(model.body_mocapid) >= 0)
    group[np.isin(group, mocap)] = 0
    taken = {"ground"}
    bodies: dict[int, Body] = {0: Ground()}
    moving: list[RigidBody] = []
    center: dict[int, FloatArray] = {}
    imported: dict[str, ImportedBody] = {}
    for root in sorted({int(g) for g in group if g != 0}):
        members = [k for k in range(model.nbody) if group[k] == root]
        masses = np.array([model.body_mass[k] for k in members])
        mass = float(masses.sum())
        mujoco_name = model.body(root).name
        name = identifier(mujoco_name, f"body{root}", taken)
        if not mass > MIN_MASS:
            raise ModelFileError(
                f"{label}: body {name!r} moves but has no mass (in dalembert's absolute "
                "coordinates every moving body needs its own mass and inertia): give it an "
                "<inertial>")
        c = (masses[:, None] * xipos[members]).sum(axis=0) / mass
        inertia_world = np.zeros((3, 3))
        for k, m in zip(members, masses):
            principal = ximat[k] @ np.diag(model.body_inertia[k]) @ ximat[k].T
            r = xipos[k] - c
            inertia_world += principal + m * (r @ r * np.eye(3) - np.outer(r, r))
        R = xmat[root]
        inertia = R.T @ inertia_world @ R
        try:
            bodies[root] = body = RigidBody(name, mass, (inertia + inertia.T) / 2)
        except ModelError as exc:
            raise ModelFileError(f"{label}: body {name!r}: {exc}") from None
        center[root] = c
        moving.append(body)
        imported[name] = ImportedBody(
            name, root, mujoco_name, tuple(model.body(k).name for k in members),
            _triple(R.T @ (xpos[root] - c)))
    return ReferencePose(model, label, xpos, xmat, group, bodies, moving, center, imported)


def _triple(v: FloatArray) -> tuple[float, float, float]:
    return float(v[0]), float(v[1]), float(v[2])
