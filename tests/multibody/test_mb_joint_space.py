"""Joint positions and velocities against answers computed apart from them.

- A 3D double pendulum (rigid bodies in Euler parameters, hinges about y): its angles
  by hand, ``atan2`` of the links' centers, unwrapped over several turns.
- The slider-crank: the crank angle, the rod's angle from the closed-form position
  analysis, the piston's travel against ``x_B(theta)``.
- A ball joint between two rigid bodies: the relative rotation ``R_a^T R_b`` from the
  bodies' quaternions by SciPy's ``Rotation``.
- Velocities against central differences of the positions (and of the rotations).
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from dalembert.errors import ModelError
from dalembert.examples import slider_crank
from dalembert.multibody import chain, joint_jacobian, joint_positions, joint_velocities

L = 1.0


def _about_y(phi: float) -> np.ndarray:
    return Rotation.from_rotvec([0.0, phi, 0.0]).as_matrix()


@pytest.fixture(scope="module")
def pendulum():
    mb = chain(2, L, 1.0, 0.05, joint="revolute")
    phi1, phi2 = 0.4, -0.3  # absolute link angles about y
    axis1, axis2 = (np.array([np.sin(p), 0.0, np.cos(p)]) for p in (phi1, phi2))
    c1 = -L / 2 * axis1
    c2 = -L * axis1 - L / 2 * axis2
    q0, qd0 = mb.initial_state(
        positions={"link1": c1, "link2": c2},
        orientations={"link1": _about_y(phi1), "link2": _about_y(phi2)},
        velocities={"link1": np.cross([0, 9.0, 0], c1),
                    "link2": np.cross([0, 9.0, 0], c2)},
        angular_velocities={"link1": (0, 9.0, 0), "link2": (0, 9.0, 0)})
    h = 1e-4  # central differences at a few instants
    centers = np.linspace(0.2, 2.8, 6) + 0.0021  # between the grid's points
    times = np.sort(np.concatenate([centers - h, centers, centers + h,
                                    np.linspace(0.0, 3.0, 601)]))
    traj = mb.simulate((0.0, 3.0), q0, qd0, t_eval=times)
    return mb, traj, h, np.searchsorted(times, centers)


def _hand_angles(traj) -> tuple[np.ndarray, np.ndarray]:
    x1, z1, x2, z2 = (traj[n] for n in ("link1_x", "link1_z", "link2_x", "link2_z"))
    phi1 = np.unwrap(np.arctan2(-x1, -z1))
    phi2 = np.unwrap(np.arctan2(-(x2 - 2 * x1), -(z2 - 2 * z1)))
    return phi1, phi2


def test_double_pendulum_angles_by_hand(pendulum):
    mb, traj, *_ = pendulum
    angles = joint_positions(mb, traj)
    assert angles.names == ("joint1", "joint2")
    phi1, phi2 = _hand_angles(traj)
    assert abs(phi1[-1] - phi1[0]) > 2 * np.pi  # it goes over the top: unwrapping matters
    assert np.abs(angles["joint1"] - phi1).max() < 1e-12  # measured 2.5e-14 after 3 s
    relative = angles["joint2"] - (phi2 - phi1)
    assert np.abs(relative - 2 * np.pi * np.round(relative[0] / (2 * np.pi))).max() < 1e-12


def test_velocities_are_the_rates_of_the_positions(pendulum):
    mb, traj, h, at = pendulum
    angles = joint_positions(mb, traj).array
    rates = joint_velocities(mb, traj).array
    differences = (angles[at + 1] - angles[at - 1]) / (2 * h)
    # the differences' own error is ~h^2 |theta'''| / 6: measured 3.7e-7 relative
    assert np.abs(differences - rates[at]).max() < 1e-5 * np.abs(rates).max()


def test_jacobian_maps_rates_to_joint_velocities(pendulum):
    mb, traj, *_ = pendulum
    for i in (0, 50, 500):
        names, J = joint_jacobian(mb, traj.q[i])
        single = joint_velocities(mb, traj.q[i], traj.qd[i])
        assert names == single.names
        np.testing.assert_allclose(J @ traj.qd[i], single.array, atol=1e-12)


def test_slider_crank_against_the_closed_form():
    mb = slider_crank.build_multibody()
    traj = mb.simulate((0.0, 2.0), **slider_crank.INITIAL, t_eval=np.linspace(0, 2, 201))
    coords = joint_positions(mb, traj)
    assert coords.names == ("J1", "J2", "J3", "guide")
    theta = traj["crank_theta"]
    phi, rate, _ = slider_crank.rod_kinematics(theta, traj["crank_theta_dot"], 0.0)

    def wrapped(a: np.ndarray) -> float:
        return float(np.abs(np.angle(np.exp(1j * a))).max())

    assert wrapped(coords["J1"] - theta) < 1e-12
    assert wrapped(coords["J2"] - (phi - theta)) < 1e-9  # measured 7.1e-15
    assert wrapped(coords["J3"] + phi) < 1e-9
    assert np.abs(coords["guide"] - slider_crank.piston_position(coords["J1"])).max() < 1e-9
    speeds = joint_velocities(mb, traj)
    assert np.abs(speeds["J2"] - (rate - traj["crank_theta_dot"])).max() < 1e-9
    assert np.abs(speeds["guide"] - traj["piston_x_dot"]).max() < 1e-12


@pytest.fixture(scope="module")
def balls():
    mb = chain(2, L, 1.0, 0.05)  # spherical joints, default frames on both sides
    rng = np.random.default_rng(3)
    b = rng.normal(size=(2, 4))
    b /= np.linalg.norm(b, axis=1)[:, None]
    bd = rng.normal(size=(2, 4))
    names = mb.system.coordinate_names
    q = dict.fromkeys(names, 0.0)
    qd = dict.fromkeys(names, 0.0)
    for k in range(2):
        for i in range(4):
            q[f"link{k + 1}_b{i}"] = b[k, i]
            qd[f"link{k + 1}_b{i}"] = bd[k, i]
    return mb, q, qd, b, bd


def _scipy_rotation(b: np.ndarray) -> Rotation:
    return Rotation.from_quat([b[1], b[2], b[3], b[0]])  # SciPy: scalar last


def test_ball_joint_rotation_against_the_quaternions(balls):
    mb, q, _, b, _ = balls
    relative = _scipy_rotation(b[0]).inv() * _scipy_rotation(b[1])
    vector = joint_positions(mb, q)
    assert vector.names[3:] == ("joint2.rx", "joint2.ry", "joint2.rz")
    np.testing.assert_allclose(vector.array[3:], relative.as_rotvec(), atol=1e-12)
    np.testing.assert_allclose(vector.array[:3], _scipy_rotation(b[0]).as_rotvec(), atol=1e-12)
    quaternion = joint_positions(mb, q, rotations="quaternion", joints=["joint2"])
    x, y, z, w = relative.as_quat()
    expected = np.array([w, x, y, z]) * np.sign(w)
    np.testing.assert_allclose(quaternion.array, expected, atol=1e-12)
    assert quaternion.names == ("joint2.qw", "joint2.qx", "joint2.qy", "joint2.qz")


def test_ball_joint_angular_velocity_against_differences(balls):
    mb, q, qd, b, bd = balls
    h = 1e-6

    def relative(s: float) -> np.ndarray:
        moved = [(b[k] + s * bd[k]) / np.linalg.norm(b[k] + s * bd[k]) for k in range(2)]
        return (_scipy_rotation(moved[0]).inv() * _scipy_rotation(moved[1])).as_matrix()

    rate = (relative(h) - relative(-h)) / (2 * h)
    skew = rate @ relative(0.0).T  # [w]x, w in the parent's frame
    expected = np.array([skew[2, 1], skew[0, 2], skew[1, 0]])
    w = joint_velocities(mb, q, qd, joints=["joint2"])
    assert w.names == ("joint2.wx", "joint2.wy", "joint2.wz")
    assert np.abs(w.array - expected).max() < 1e-8 * np.abs(expected).max()
    _, J = joint_jacobian(mb, q, joints=["joint2"])
    qd_ = np.array([qd[n] for n in mb.system.coordinate_names])
    np.testing.assert_allclose(J @ qd_, w.array, atol=1e-12)


def test_bad_joint_names_are_named():
    mb = slider_crank.build_multibody()
    with pytest.raises(KeyError, match="no joint 'J9'; the joints are J1, J2, J3, guide"):
        joint_positions(mb, slider_crank.INITIAL["q0"], joints=["J9"])
    with pytest.raises(ValueError, match="rotations must be"):
        joint_positions(mb, slider_crank.INITIAL["q0"], rotations="euler")  # type: ignore[arg-type]
    with pytest.raises(KeyError, match="no joint coordinate 'J4'"):
        joint_positions(mb, slider_crank.INITIAL["q0"])["J4"]


def test_a_joint_without_coordinates_is_refused():
    from dalembert.multibody import Distance, Ground, Multibody, Particle

    bob = Particle("bob", 1.0)
    mb = Multibody([bob], [Distance("rod", Ground(), bob, 1.0)])
    assert joint_positions(mb, {"bob_z": -1.0}).names == ()
    with pytest.raises(ModelError, match="joint 'rod' \\(Distance\\) has no joint coordinates"):
        joint_positions(mb, {"bob_z": -1.0}, joints=["rod"])


def test_free_joint_travel_and_rotation_against_differences():
    """A free joint between two turning bodies: the travel in the parent's frame and the
    relative rotation from SciPy's rotations of the bodies' quaternions, the rates by
    central differences along a straight line in the coordinates."""
    from dalembert.multibody import Free, Multibody, RigidBody

    a, b = RigidBody("a", 1.0, (1, 2, 3)), RigidBody("b", 2.0, (1, 1, 1))
    pa, pb = np.array([0.3, -0.2, 0.1]), np.array([0.0, 0.5, -0.4])
    mb = Multibody([a, b], [Free("float", a, b, pa, pb)])
    rng = np.random.default_rng(7)
    q, qd = rng.normal(size=14), rng.normal(size=14)
    for s in (slice(3, 7), slice(10, 14)):
        q[s] /= np.linalg.norm(q[s])

    def measured(q_: np.ndarray) -> tuple[np.ndarray, Rotation]:
        Ra = _scipy_rotation(q_[3:7] / np.linalg.norm(q_[3:7]))
        Rb = _scipy_rotation(q_[10:14] / np.linalg.norm(q_[10:14]))
        d = q_[7:10] + Rb.apply(pb) - q_[:3] - Ra.apply(pa)
        return Ra.inv().apply(d), Ra.inv() * Rb

    travel, relative = measured(q)
    values = joint_positions(mb, q)
    assert values.names == tuple(f"float.{c}" for c in ("x", "y", "z", "rx", "ry", "rz"))
    np.testing.assert_allclose(values.array[:3], travel, atol=1e-12)
    np.testing.assert_allclose(values.array[3:], relative.as_rotvec(), atol=1e-12)
    h = 1e-6
    (t_plus, r_plus), (t_minus, r_minus) = measured(q + h * qd), measured(q - h * qd)
    rate = (t_plus - t_minus) / (2 * h)
    spin = (r_plus.as_matrix() - r_minus.as_matrix()) / (2 * h) @ relative.as_matrix().T
    w = np.array([spin[2, 1], spin[0, 2], spin[1, 0]])
    speeds = joint_velocities(mb, q, qd)
    assert speeds.names[:3] == ("float.x", "float.y", "float.z")
    assert speeds.names[3:] == ("float.wx", "float.wy", "float.wz")
    assert np.abs(speeds.array - np.concatenate([rate, w])).max() < 1e-8
    _, J = joint_jacobian(mb, q)
    np.testing.assert_allclose(J @ qd, speeds.array, atol=1e-12)
