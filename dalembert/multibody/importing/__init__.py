"""Importing MJCF and URDF models through MuJoCo's ``MjSpec``.

MuJoCo reads both formats, applies the defaults classes, converts the units and
computes the inertials a file leaves out; :func:`from_mjcf` and :func:`from_urdf` turn
its compiled model into a :class:`~dalembert.multibody.Multibody` in redundant
coordinates (:mod:`.bodies`, :mod:`.joints`, :mod:`.equalities`, :mod:`.actuators`),
keep the shapes for drawing (:mod:`.model`) and list what they leave out in one
warning (:mod:`.unsupported`). :func:`mujoco_state` places the mechanism at a MuJoCo
state.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

from ...errors import ModelFileError
from ..builder import Multibody
from .build import build_multibody
from .model import ImportedBody, ImportedModel, Shape
from .reading import compile_model, is_xml_text
from .state import mujoco_state


def from_mjcf(source: str | os.PathLike[str]) -> Multibody:
    """The mechanism of an MJCF model (MuJoCo's XML), from its file or its text.

    Bodies with their compiled inertials (MuJoCo's, computed from the geoms where the
    file gives no ``<inertial>``), hinge, slide, ball and free joints, ``connect`` and
    ``weld`` equalities as exact closed loops, joint springs and dampers, gravity, and
    motors as inputs named after the actuators; the geoms are kept for drawing in
    ``mb.imported.shapes``, hinge and slide ranges as joint limits (hard stops,
    :func:`~dalembert.multibody.joint_limit`). Features dalembert does not model
    (contact between geoms, tendons, ball-joint limits...) are listed in one
    :class:`~dalembert.UnsupportedModelFeatureWarning`.
    A hinge's dalembert angle is zero at the model's pose (MuJoCo's ``qpos0``);
    :func:`mujoco_state` gives the initial state at any ``qpos``, ``qvel``.

    Parameters
    ----------
    source
        A path to an ``.xml`` file, or the XML text itself (starting with ``<``).

    Raises
    ------
    ModelFileError
        MuJoCo cannot read or compile the file (its message is passed on), or it holds
        what dalembert cannot build (a moving body without mass, several joints in a
        body that are not a universal or ball joint).

    Examples
    --------
    A double pendulum of two rods on hinges about ``y``:

    >>> mb = from_mjcf('''
    ... <mujoco model="double">
    ...   <worldbody>
    ...     <body name="upper">
    ...       <joint name="shoulder" axis="0 1 0"/>
    ...       <geom type="capsule" fromto="0 0 0 0 0 -1" size="0.05"/>
    ...       <body name="lower" pos="0 0 -1">
    ...         <joint name="elbow" axis="0 1 0"/>
    ...         <geom type="capsule" fromto="0 0 0 0 0 -1" size="0.05"/>
    ...       </body>
    ...     </body>
    ...   </worldbody>
    ... </mujoco>''')
    >>> mb.system.degrees_of_freedom, [j.name for j in mb.joints]
    (2, ['shoulder', 'elbow'])
    >>> [s.kind for s in mb.imported.shapes]
    ['capsule', 'capsule']
    """
    _, model, label = compile_model(source, "MJCF")
    return build_multibody(model, label, _name(source, model))


def from_urdf(path: str | os.PathLike[str]) -> Multibody:
    """The mechanism of a URDF robot, read and compiled by MuJoCo (as :func:`from_mjcf`).

    MuJoCo joins links fixed to each other, reads the URDF inertials, and keeps the
    collision geometry (the visual meshes are dropped by MuJoCo's URDF reader);
    ``revolute`` and ``continuous`` joints are hinges, ``prismatic`` ones slides;
    their limits are joint limits.

    Parameters
    ----------
    path
        The ``.urdf`` file (meshes it names are looked up beside it).

    Raises
    ------
    ModelFileError
        As :func:`from_mjcf`.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> urdf = '''<robot name="arm">
    ...   <link name="base"/>
    ...   <link name="rod"><inertial><origin xyz="0 0 -0.5"/><mass value="1"/>
    ...     <inertia ixx="0.08" iyy="0.08" izz="0.001" ixy="0" ixz="0" iyz="0"/>
    ...   </inertial></link>
    ...   <joint name="pin" type="continuous"><parent link="base"/><child link="rod"/>
    ...     <axis xyz="0 1 0"/></joint>
    ... </robot>'''
    >>> with tempfile.TemporaryDirectory() as folder:
    ...     file = pathlib.Path(folder, "arm.urdf")
    ...     _ = file.write_text(urdf)
    ...     mb = from_urdf(file)
    >>> [b.name for b in mb.bodies], mb.bodies[0].mass
    (['rod'], 1.0)
    """
    if is_xml_text(path):
        raise ModelFileError("from_urdf reads a file: give its path (MuJoCo looks up the "
                             "meshes it names beside it)")
    _, model, label = compile_model(path, "URDF")
    return build_multibody(model, label, _name(path, model))


def _name(source: str | os.PathLike[str], model: Any) -> str:
    """The model's name (the first of MuJoCo's names), else the file's stem."""
    name = bytes(model.names).split(b"\0", 1)[0].decode()
    if name and name != "MuJoCo Model":
        return name
    return "imported model" if is_xml_text(source) else Path(source).stem


__all__ = ["ImportedBody", "ImportedModel", "Shape", "from_mjcf", "from_urdf", "mujoco_state"]
