"""MJCF joint ranges imported as joint limits (``multibody/importing/limits.py``).

References: a compound pendulum read from MJCF, released from rest, swings onto the
stop at the end of its hinge's range: it arrives with the rate the energy gives,
``w^2 = 2 m g d (cos(stop) - cos(theta0)) / I_hinge`` (angles from the hanging
position; the mass, centre and inertia read from MuJoCo's compiled model), stops there
(plastic) and never passes it; the range is in MuJoCo's own angle (``qpos``, the
joint's ``ref`` where the file's pose is).
"""

from __future__ import annotations

import warnings

import mujoco
import numpy as np

from dalembert import UnsupportedModelFeatureWarning
from dalembert.multibody import from_mjcf, joint_positions, joint_velocities, mujoco_state

XML = """<mujoco>
  <compiler angle="radian"/>
  <option gravity="0 0 -9.81"/>
  <worldbody>
    <body name="link" pos="0 0 1">
      <joint name="hinge" axis="0 1 0" ref="0.2" range="-0.3 0.9" limited="true"/>
      <geom type="capsule" fromto="0 0 0 0 0 -0.5" size="0.05" mass="2"/>
    </body>
  </worldbody>
</mujoco>"""


def test_a_pendulum_stops_on_its_hinge_range():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UnsupportedModelFeatureWarning)  # its contact
        mb = from_mjcf(XML)
    model = mujoco.MjModel.from_xml_string(XML)
    hanging, stop, theta0 = 0.2, -0.3, 0.8  # qpos: ref (the file's pose), the stop, release
    q0, qd0 = mujoco_state(mb, [theta0], [0.0])
    traj = mb.simulate((0.0, 2.0), q0, qd0)
    assert traj.success, traj.message
    angle = joint_positions(mb, traj, joints=["hinge"]).array[:, 0]
    qpos = angle + hanging  # dalembert's angle is 0 at the file's pose, where qpos = ref
    assert abs(qpos[0] - theta0) < 1e-12
    assert qpos.min() >= stop - 1e-10  # never past the stop
    first = traj.contacts.impacts[0]
    names = traj.coordinate_names
    at = next(s for s in traj.contacts.switches if s.t == first.t)
    rate = joint_velocities(mb, dict(zip(names, at.q)), dict(zip(names, first.qd_before)),
                            joints=["hinge"]).array[0]
    # the compound pendulum: mass m, centre d below the hinge, inertia about the hinge
    m, d = float(model.body_mass[1]), float(np.linalg.norm(model.body_ipos[1]))
    inertia = float(np.max(model.body_inertia[1])) + m * d**2  # across the capsule
    expected = np.sqrt(2 * m * 9.81 * d * (np.cos(stop - hanging) - np.cos(theta0 - hanging))
                       / inertia)
    assert abs(rate + expected) < 1e-9
    after = joint_velocities(mb, dict(zip(names, at.q)), dict(zip(names, first.qd_after)),
                             joints=["hinge"]).array[0]
    assert abs(after) < 1e-12  # plastic: stopped on the stop, then swings back
    assert abs(qpos[np.searchsorted(traj.t, first.t)] - stop) < 1e-12
