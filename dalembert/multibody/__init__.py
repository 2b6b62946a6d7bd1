"""Multibody systems in redundant coordinates: rigid bodies with Euler parameters.

Every body carries its full pose (particles ``x, y, z``; rigid bodies also the
Euler parameters ``b0..b3``; planar bodies ``x, y, theta``) and joints become
named holonomic constraints, so :class:`Multibody` builds an ordinary
:class:`dalembert.System`, whose numeric code is assembled from one kernel per
kind of body and joint (:mod:`~dalembert.multibody.parts`). See
:mod:`~dalembert.multibody.rotations` for the quaternion convention,
:mod:`~dalembert.multibody.bodies` for why the singular rotational mass block is
harmless, :mod:`~dalembert.multibody.joints` for the joint equations,
:mod:`~dalembert.multibody.rolling` for rolling contact,
:mod:`~dalembert.multibody.outputs` for reactions, momenta and energy, and
:mod:`~dalembert.multibody.joint_space` / :mod:`~dalembert.multibody.joint_control` for
joint angles, actuator torques and linearizations in joint coordinates.
"""

from .bodies import Body, Ground, Particle, PlanarBody, RigidBody
from .builder import Multibody, chain, multibody_of, ring, ring_state
from .contacts import (
    Contact,
    DiskOnPlane,
    JointStop,
    Sliding,
    disk_contact,
    joint_limit,
    plane_contact,
    sphere_contact,
)
from .diagnostics import JointPointWarning, check_mobility
from .drivers import Actuator, Driver, JointSpring
from .importing import from_mjcf, from_urdf, mujoco_state
from .joint_control import JointEfforts, inverse_dynamics, linearize_joints
from .joint_space import JointValues, joint_jacobian, joint_positions, joint_velocities
from .joints import (
    Distance,
    Fixed,
    Free,
    Joint,
    PointOnPlane,
    Prismatic,
    Revolute,
    Spherical,
    Universal,
)
from .loads import Force, SpringDamper, Torque
from .outputs import (
    JointReaction,
    angular_momentum,
    angular_velocities,
    energy,
    euler_angles,
    joint_reactions,
    kinetic_energy,
    linear_momentum,
    point_positions,
    potential_energy,
    rotation_matrices,
)
from .rolling import Rolling
from .rotations import (
    E_matrix,
    G_matrix,
    euler_from_matrix,
    matrix_from_euler,
    quaternion_from_matrix,
    rotation_matrix,
)

__all__ = [
    "Actuator",
    "Body",
    "Contact",
    "DiskOnPlane",
    "Distance",
    "Driver",
    "E_matrix",
    "Fixed",
    "Force",
    "Free",
    "G_matrix",
    "Ground",
    "Joint",
    "JointEfforts",
    "JointPointWarning",
    "JointReaction",
    "JointSpring",
    "JointStop",
    "JointValues",
    "Multibody",
    "Particle",
    "PlanarBody",
    "PointOnPlane",
    "Prismatic",
    "Revolute",
    "RigidBody",
    "Rolling",
    "Sliding",
    "Spherical",
    "SpringDamper",
    "Torque",
    "Universal",
    "angular_momentum",
    "angular_velocities",
    "chain",
    "check_mobility",
    "disk_contact",
    "energy",
    "euler_angles",
    "euler_from_matrix",
    "from_mjcf",
    "from_urdf",
    "inverse_dynamics",
    "joint_jacobian",
    "joint_limit",
    "joint_positions",
    "joint_reactions",
    "joint_velocities",
    "kinetic_energy",
    "linear_momentum",
    "linearize_joints",
    "matrix_from_euler",
    "mujoco_state",
    "multibody_of",
    "plane_contact",
    "point_positions",
    "potential_energy",
    "quaternion_from_matrix",
    "ring",
    "ring_state",
    "rotation_matrices",
    "rotation_matrix",
    "sphere_contact",
]
