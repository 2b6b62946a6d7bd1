"""An arm read from MJCF whose elbow is driven through a parallelogram closed by a
``connect``.

The mechanism is written for MuJoCo (the string :data:`MJCF` below) and imported with
:func:`dalembert.multibody.from_mjcf`. A ``turret`` turns about the vertical ``z``; on
it the ``upper_arm`` swings about ``y`` at the shoulder, and the ``forearm`` about ``y``
at the elbow. As in palletizing robots, the forearm is not driven at the elbow: a short
``crank`` on the shoulder axis and a ``tie_rod`` (on a ball joint at the crank's tip)
form a parallelogram with the upper arm and the forearm's rear lever, and the
``connect`` equality ``closure`` ties the rod's far end to that lever. MuJoCo holds such
a loop softly; dalembert makes it a spherical joint held to rounding. Degrees of
freedom: 4 hinges + 3 (the ball) - 3 (the connect) = 4: the turret, the shoulder, the
parallelogram (the elbow) and the rod's spin about its own axis. Springs at the
shoulder and the crank (MuJoCo's joint ``stiffness``) hold the arm up against gravity;
a motor (``turret_motor``, gear 1) turns the turret with the constant torque
:data:`TORQUE`, an input, and the arm swings out as it turns.

Independent checks: the work of the motor is the only change of ``T + V`` (gravity and
the springs in ``V``), so ``T + V - TORQUE * (turret angle - its start)`` stays constant
(the angle read from the turret's Euler parameters, not from the model); the loop's
two anchors, computed from the bodies' poses, stay together.
"""

from __future__ import annotations

import numpy as np

from ..multibody.builder import Multibody
from ..multibody.importing import from_mjcf, mujoco_state
from ..multibody.outputs import energy
from ..system import System
from ..trajectory import Trajectory

TITLE = ("Imported MJCF arm: a turret, an upper arm and a forearm driven through a "
         "parallelogram closed by a connect equality")
TORQUE = 0.3  # N m, the turret motor's
T_END = 5.0

MJCF = """
<mujoco model="parallelogram arm">
  <option gravity="0 0 -9.81"><flag contact="disable"/></option>
  <worldbody>
    <geom name="base" type="cylinder" fromto="0 0 -0.05 0 0 0" size="0.12"/>
    <body name="turret">
      <joint name="turret_pin" axis="0 0 1"/>
      <geom type="cylinder" fromto="0 0 0 0 0 0.2" size="0.08"/>
      <geom type="box" pos="0 0 0.2" size="0.06 0.1 0.04"/>
      <body name="upper_arm" pos="0 0 0.2">
        <joint name="shoulder" axis="0 1 0" stiffness="60"/>
        <geom type="capsule" fromto="0 0 0 0.1 0 0.5" size="0.035"/>
        <body name="forearm" pos="0.1 0 0.5">
          <joint name="elbow" axis="0 1 0"/>
          <geom type="capsule" fromto="0 0 0 0.6 0 0" size="0.03"/>
          <geom type="cylinder" fromto="0 0 0 0 -0.06 0" size="0.03"/>
          <geom type="capsule" fromto="0 -0.06 0 -0.15 -0.06 0" size="0.02"/>
          <geom type="box" pos="0.63 0 0" size="0.03 0.06 0.04"/>
        </body>
      </body>
      <body name="crank" pos="0 -0.06 0.2">
        <joint name="crank_pin" axis="0 1 0" stiffness="20"/>
        <geom type="capsule" fromto="0 0 0 -0.15 0 0" size="0.025"/>
        <body name="tie_rod" pos="-0.15 0 0">
          <joint name="rod_ball" type="ball"/>
          <geom type="capsule" fromto="0 0 0 0.1 0 0.5" size="0.015"/>
        </body>
      </body>
    </body>
  </worldbody>
  <equality>
    <connect name="closure" body1="tie_rod" body2="forearm" anchor="0.1 0 0.5"/>
  </equality>
  <actuator>
    <motor name="turret_motor" joint="turret_pin" gear="1"/>
  </actuator>
</mujoco>
"""


def build_multibody() -> Multibody:
    """The arm, imported.

    >>> mb = build_multibody()
    >>> [type(j).__name__ for j in mb.joints], [u.name for u in mb.inputs]
    (['Revolute', 'Revolute', 'Revolute', 'Revolute', 'Spherical', 'Spherical'], ['turret_motor'])
    """
    return from_mjcf(MJCF)


def build() -> System:
    """The arm's ``System`` (35 coordinates)."""
    return build_multibody().system


def initial_state() -> dict[str, object]:
    """At the file's pose (MuJoCo's ``qpos0``), at rest, the motor's torque on.

    >>> sorted(initial_state())
    ['inputs', 'q0', 'qd0']
    """
    q0, qd0 = mujoco_state(build_multibody())
    return {"q0": q0, "qd0": qd0, "inputs": {"turret_motor": TORQUE}}


INITIAL = initial_state()


def _turret_angle(traj: Trajectory) -> np.ndarray:
    """The turret's turn about ``z`` from its Euler parameters (``b1 = b2 = 0``)."""
    return np.unwrap(2 * np.arctan2(traj["turret_b3"], traj["turret_b0"]))


def checks(system: System, traj: Trajectory) -> dict[str, float]:
    """The energy balance with the motor's work, and the loop's closure (m)."""
    from ..multibody.builder import multibody_of
    from ..multibody.rotations import rotation_matrix

    mb = multibody_of(system)
    e = energy(mb, traj) - TORQUE * (_turret_angle(traj) - _turret_angle(traj)[0])
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
