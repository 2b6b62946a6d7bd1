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
