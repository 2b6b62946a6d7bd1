"""Trajectories the viewer's tests draw."""

from __future__ import annotations

import numpy as np

from dalembert.multibody import chain
from dalembert.trajectory import Trajectory

LINK = 0.05


def swinging_chain(n: int, t_end: float, points: int) -> tuple[Trajectory, object]:
    """An ``n``-link chain swinging as one rigid pendulum: ``theta(t) = 0.5 sin(2 pi t / 3)``
    about ``y`` (every joint holds exactly), with multipliers of one so that every joint
    has a force to draw.

    A page's size depends on its frames, bodies and joints, not on the dynamics, so
    this motion stands in for a 10 s simulation of 256 links (about 50 s to run)."""
    mb = chain(n, LINK, 0.1, 0.005)
    t = np.linspace(0.0, t_end, points)
    theta = 0.5 * np.sin(2 * np.pi * t / 3)
    k = len(t)
    q = np.zeros((k, 7 * n))
    for i in range(n):
        depth = (i + 0.5) * LINK
        q[:, 7 * i] = -depth * np.sin(theta)          # R_y(theta) (0, 0, -depth)
        q[:, 7 * i + 2] = -depth * np.cos(theta)
        q[:, 7 * i + 3] = np.cos(theta / 2)           # the quaternion of R_y(theta)
        q[:, 7 * i + 5] = np.sin(theta / 2)
    m = len(mb.system.constraint_names)
    zeros = np.zeros(k)
    traj = Trajectory(t=t, q=q, qd=np.zeros_like(q), qdd=np.zeros_like(q),
                      multipliers=np.ones((k, m)), constraint_forces=np.zeros_like(q),
                      kinetic_energy=zeros, potential_energy=zeros, jacobi_integral=zeros,
                      position_residual=zeros, velocity_residual=zeros,
                      coordinate_names=mb.system.coordinate_names,
                      constraint_names=mb.system.constraint_names)
    return traj, mb


#: An MJCF model with one geom of every kind the viewer draws, on bodies whose frames
#: are not at their mass centers (explicit inertials off the origin and turned), a body
#: welded to its parent (no joint), a free body, and geoms on the world (a plane, not
#: drawn, and a box).
GEOMS_MJCF = """
<mujoco model="geoms">
  <asset><mesh name="wedge" vertex="0 0 0  0.2 0 0  0 0.1 0  0 0 0.3"/></asset>
  <worldbody>
    <geom name="floor" type="plane" size="2 2 0.1" pos="0 0 -2"/>
    <geom name="stand" type="box" size="0.1 0.1 0.02" pos="0 0 0.05" euler="0 0 30"/>
    <body name="base" pos="0.1 0 0" euler="0 10 20">
      <joint name="swivel" axis="0 0 1"/>
      <inertial pos="0.2 0.05 -0.1" quat="0.9 0.1 0.3 0.2" mass="2"
                diaginertia="0.04 0.03 0.02"/>
      <geom name="plate" type="box" size="0.3 0.05 0.02" pos="0.25 0 0" euler="10 20 30"/>
      <geom name="rod" type="capsule" fromto="0.5 0 0 0.5 0.1 -0.6" size="0.03"/>
      <body name="arm" pos="0.5 0.1 -0.6" euler="30 0 0">
        <joint name="shoulder" type="ball"/>
        <geom name="drum" type="cylinder" fromto="0 0 0 0.4 0 -0.2" size="0.05" mass="1"/>
        <geom name="egg" type="ellipsoid" size="0.05 0.08 0.12" pos="0.4 0 -0.2"
              euler="0 45 10" mass="0.5"/>
        <body name="hand" pos="0.4 0 -0.3" euler="0 0 60">
          <geom name="knob" type="sphere" size="0.04" pos="0 0.05 0"/>
          <geom name="wedge" type="mesh" mesh="wedge" pos="0 0 -0.1" euler="20 0 0"/>
        </body>
      </body>
    </body>
    <body name="puck" pos="1 1 0.5" euler="10 0 0">
      <freejoint name="loose"/>
      <geom name="tile" type="box" size="0.1 0.2 0.03" pos="0.05 0 0" euler="0 0 15"/>
    </body>
  </worldbody>
</mujoco>
"""


def posed_run(mb, qpos: list[np.ndarray]) -> Trajectory:
    """A trajectory of an imported mechanism through MuJoCo's joint positions ``qpos``
    (one frame each, a second apart), at rest; multipliers of zero."""
    from dalembert.multibody import mujoco_state

    names = mb.system.coordinate_names
    q = np.array([[mujoco_state(mb, p)[0][name] for name in names] for p in qpos])
    k = len(q)
    zeros = np.zeros(k)
    return Trajectory(t=np.arange(k, dtype=float), q=q, qd=np.zeros_like(q),
                      qdd=np.zeros_like(q),
                      multipliers=np.zeros((k, len(mb.system.constraint_names))),
                      constraint_forces=np.zeros_like(q), kinetic_energy=zeros,
                      potential_energy=zeros, jacobi_integral=zeros,
                      position_residual=zeros, velocity_residual=zeros,
                      coordinate_names=names, constraint_names=mb.system.constraint_names)


def geoms_qpos(model, seed: int) -> np.ndarray:
    """A MuJoCo configuration of :data:`GEOMS_MJCF` away from its reference pose: the
    swivel's angle, the ball's unit quaternion, the free body's position and quaternion."""
    rng = np.random.default_rng(seed)
    qpos = np.array(model.qpos0, dtype=float)
    qpos[0] = rng.uniform(-2, 2)
    ball = rng.normal(size=4)
    qpos[1:5] = ball / np.linalg.norm(ball)
    qpos[5:8] = rng.uniform(-1, 1, 3)
    free = rng.normal(size=4)
    qpos[8:12] = free / np.linalg.norm(free)
    return qpos
