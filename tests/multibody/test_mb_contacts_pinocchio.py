"""A Multibody contact's impact against Pinocchio's ``impulseDynamics`` (a test oracle).

The rod of ``test_mb_contacts.py`` (a quaternion rigid body falling tilted, its lower
end striking a floor) built in Pinocchio as a free-flyer body; the contact Jacobian is
the floor normal's row of the end point's Jacobian. Pinocchio's velocities after the
impact and its impulse must equal dalembert's (its free-flyer velocity is in the body
frame: compared in the world frame).
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from dalembert.multibody import Ground, Multibody, RigidBody, plane_contact
from dalembert.multibody.rotations import G_matrix

g = 9.81


@pytest.mark.parametrize("e", [0.0, 0.6, 1.0])
def test_rod_impact_matches_pinocchio(e):
    m, L, theta, h = 2.0, 1.5, 0.4, 0.3
    inertia = np.diag([1e-3, m * L**2 / 12, m * L**2 / 12])
    rod = RigidBody("rod", m, inertia)
    end = plane_contact("end", Ground(), rod, point=(-L / 2, 0, 0), restitution=e)
    mb = Multibody([rod], contacts=[end], gravity=(0, 0, -g))
    c, s = np.cos(theta), np.sin(theta)
    R = np.array([[c, 0, -s], [0, 1, 0], [s, 0, c]])
    centre = np.array([0.0, 0.0, h + L / 2 * s])
    traj = mb.simulate((0.0, np.sqrt(2 * h / g) + 1e-3),
                       *mb.initial_state(positions={"rod": centre}, orientations={"rod": R}))
    impact = traj.contacts.impacts[0]
    names = traj.coordinate_names
    before, after = (dict(zip(names, v)) for v in (impact.qd_before, impact.qd_after))
    b = np.array([dict(zip(names, traj.q[0]))[f"rod_b{k}"] for k in range(4)])
    linear = np.array([after[f"rod_{a}"] for a in "xyz"])
    angular = 2 * G_matrix(b) @ np.array([after[f"rod_b{k}"] for k in range(4)])

    # Pinocchio: one free-flyer body, the end point as a frame; the state at the impact
    model = pin.Model()
    joint = model.addJoint(0, pin.JointModelFreeFlyer(), pin.SE3.Identity(), "rod")
    model.appendBodyToJoint(joint, pin.Inertia(m, np.zeros(3), inertia), pin.SE3.Identity())
    frame = model.addFrame(pin.Frame("end", joint, 0, pin.SE3(np.eye(3), np.array(
        [-L / 2, 0.0, 0.0])), pin.FrameType.OP_FRAME))
    data = model.createData()
    centre_now = np.array([dict(zip(names, traj.q[0]))[f"rod_{a}"] for a in "xyz"])
    centre_now[2] -= h  # it fell h without turning
    q = np.concatenate([centre_now, pin.Quaternion(R).coeffs()])
    v_world = np.array([before[f"rod_{a}"] for a in "xyz"])
    v = np.concatenate([R.T @ v_world, np.zeros(3)])  # body-frame velocity
    pin.computeJointJacobians(model, data, q)
    pin.framesForwardKinematics(model, data, q)
    J = pin.getFrameJacobian(model, data, frame, pin.ReferenceFrame.LOCAL_WORLD_ALIGNED)
    dq_after = pin.impulseDynamics(model, data, q, v, J[2:3], e, 0.0)
    assert abs(data.oMf[frame].translation[2]) < 1e-12  # the end is on the floor
    assert np.abs(R @ dq_after[:3] - linear).max() < 1e-10
    assert np.abs(R @ dq_after[3:] - angular).max() < 1e-10
    assert abs(data.impulse_c[0] - impact.impulses[0]) < 1e-10
