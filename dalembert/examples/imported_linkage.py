"""A spatial linkage read from MJCF: an arm whose loop is closed by a ``connect``.

The mechanism is written for MuJoCo (the string :data:`MJCF` below) and imported with
:func:`dalembert.multibody.from_mjcf`: a ``crank`` on a hinge about the vertical ``z``,
a ``coupler`` hanging from its tip on a ball joint, and a ``rocker`` on its own hinge
about ``y``; the ``connect`` equality ``closure`` ties the coupler's far end to the
rocker's tip (an RSSR linkage: revolute, spherical, spherical, revolute). MuJoCo holds
such a loop softly; dalembert makes it a spherical joint held to rounding. Degrees of
freedom: 1 + 3 + 1 - 3 = 2 (the linkage's one and the coupler's spin about its own
axis). A motor (``motor``, gear 1) drives the crank with the constant torque
:data:`TORQUE`, an input.

Independent checks: the work of the motor is the only change of ``T + V``, so
``T + V - TORQUE * (crank angle - its start)`` stays constant (the angle read from the
crank's Euler parameters, not from the model); the loop's two anchors, computed from
the bodies' poses, stay together.
"""

from __future__ import annotations

import numpy as np

from ..multibody.builder import Multibody
from ..multibody.importing import from_mjcf, mujoco_state
from ..multibody.outputs import energy
from ..system import System
from ..trajectory import Trajectory

TITLE = "Imported MJCF linkage: a crank, coupler and rocker closed by a connect equality"
TORQUE = 0.4  # N m, the motor's
T_END = 5.0

MJCF = """
<mujoco model="rssr linkage">
  <option gravity="0 0 -9.81"><flag contact="disable"/></option>
  <worldbody>
    <body name="crank">
      <joint name="crank_pin" axis="0 0 1"/>
      <geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.03"/>
      <body name="coupler" pos="0.3 0 0">
        <joint name="crank_ball" type="ball"/>
        <geom type="capsule" fromto="0 0 0 0 0.9 0.3" size="0.02"/>
      </body>
    </body>
    <body name="rocker" pos="0 0.9 -0.2">
      <joint name="rocker_pin" axis="0 1 0"/>
      <geom type="capsule" fromto="0 0 0 0.3 0 0.5" size="0.03"/>
    </body>
  </worldbody>
  <equality>
    <connect name="closure" body1="coupler" body2="rocker" anchor="0 0.9 0.3"/>
  </equality>
  <actuator>
    <motor name="motor" joint="crank_pin" gear="1"/>
  </actuator>
</mujoco>
"""


def build_multibody() -> Multibody:
    """The linkage, imported.

    >>> mb = build_multibody()
    >>> [type(j).__name__ for j in mb.joints], [u.name for u in mb.inputs]
    (['Revolute', 'Spherical', 'Revolute', 'Spherical'], ['motor'])
    """
    return from_mjcf(MJCF)


def build() -> System:
    """The linkage's ``System`` (21 coordinates)."""
    return build_multibody().system


def initial_state() -> dict[str, object]:
    """At the file's pose (MuJoCo's ``qpos0``), at rest, the motor's torque on.

    >>> sorted(initial_state())
    ['inputs', 'q0', 'qd0']
    """
    q0, qd0 = mujoco_state(build_multibody())
    return {"q0": q0, "qd0": qd0, "inputs": {"motor": TORQUE}}


INITIAL = initial_state()


def _crank_angle(traj: Trajectory) -> np.ndarray:
    """The crank's turn about ``z`` from its Euler parameters (``b1 = b2 = 0``)."""
    return np.unwrap(2 * np.arctan2(traj["crank_b3"], traj["crank_b0"]))


def checks(system: System, traj: Trajectory) -> dict[str, float]:
    """The energy balance with the motor's work, and the loop's closure (m)."""
    from ..multibody.builder import multibody_of
    from ..multibody.rotations import rotation_matrix

    mb = multibody_of(system)
    e = energy(mb, traj) - TORQUE * (_crank_angle(traj) - _crank_angle(traj)[0])
    closure = next(j for j in mb.joints if j.name == "closure")
    ends = []
    for body, point in ((closure.body_a, closure.point_a), (closure.body_b, closure.point_b)):
        x = np.column_stack([traj[f"{body.name}_{c}"] for c in "xyz"])
        R = rotation_matrix(np.column_stack([traj[f"{body.name}_b{i}"] for i in range(4)]))
        ends.append(x + R @ np.asarray(point, dtype=float))
    return {
        "relative energy balance error": float(np.abs(e - e[0]).max() / np.abs(e).max()),
        "max loop opening (m)": float(np.linalg.norm(ends[0] - ends[1], axis=1).max()),
        "max position residual": float(traj.position_residual.max()),
    }
