"""Planar bodies (x, y, theta) and the planar forms of the joints.

Each check is against something derived separately: a compound pendulum in its
angle, the same chain built from 3D bodies, Freudenstein's closed form of the
four-bar, uniform acceleration on an incline, Newton-Euler for a free body.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from dalembert.errors import InitialConditionError, ModelError
from dalembert.examples import four_bar
from dalembert.multibody import (
    Distance,
    Fixed,
    Force,
    Ground,
    Multibody,
    PlanarBody,
    PointOnPlane,
    Prismatic,
    Revolute,
    RigidBody,
    Spherical,
    Torque,
    Universal,
    angular_momentum,
    chain,
    energy,
    joint_reactions,
    kinetic_energy,
)

G = 9.81
TIGHT = {"rtol": 1e-10, "atol": 1e-12}


def _pendulum(m=2.0, length=1.5, inertia=0.5, theta0=0.9):
    """A link pinned to ground at its top end, released from ``theta0`` (from hanging)."""
    link = PlanarBody("link", m, inertia)
    pin = Revolute("pin", Ground(), link, (0, 0, 0), (0, length / 2, 0))
    mb = Multibody([link], [pin], gravity=(0, -G, 0))
    center = length / 2 * np.array([np.sin(theta0), -np.cos(theta0)])
    return mb, mb.initial_state(positions={"link": center}, orientations={"link": theta0})


def test_compound_pendulum_matches_its_angle_equation_and_pin_force():
    m, length, inertia, theta0 = 2.0, 1.5, 0.5, 0.9
    mb, (q0, qd0) = _pendulum(m, length, inertia, theta0)
    assert mb.system.constraint_names == ("pin_1", "pin_2")
    t_eval = np.linspace(0, 3, 31)
    traj = mb.simulate((0, 3), q0, qd0, t_eval=t_eval, **TIGHT)
    r, J = length / 2, inertia + m * (length / 2) ** 2

    def minimal(t, y):
        return [y[1], -m * G * r * np.sin(y[0]) / J]

    ref = solve_ivp(minimal, (0, 3), [theta0, 0.0], t_eval=t_eval, rtol=1e-12, atol=1e-12)
    th, w = ref.y
    np.testing.assert_allclose(traj["link_theta"], th, atol=1e-8)
    # pin force on the link: m a_center - m g, with a_center from the angle
    alpha = -m * G * r * np.sin(th) / J
    a = r * np.column_stack([alpha * np.cos(th) - w**2 * np.sin(th),
                             alpha * np.sin(th) + w**2 * np.cos(th)])
    expected = m * a - m * np.array([0.0, -G])
    force = joint_reactions(mb, traj)["pin"]["link"].force_world
    np.testing.assert_allclose(force[:, :2], expected, atol=1e-7)
    np.testing.assert_array_equal(force[:, 2], 0.0)


def test_planar_chain_matches_the_chain_of_3d_bodies():
    # 3D chain: hangs in x-z, hinges about y; planar: x-y, pins about z. Same physics
    # with (x, z) of the one as (x, y) of the other (a tilt of +a about y moves the
    # 3D link's lower end to -x; the planar angle a moves it to +x, so angles flip).
    n, a = 3, np.radians(30)
    spatial = chain(n, 1.0, 1.0, 0.05, joint="revolute")
    planar = chain(n, 1.0, 1.0, 0.05, joint="revolute", planar=True)
    assert len(planar.system.coordinate_names) == 3 * n
    assert len(planar.system.constraint_names) == 2 * n
    names = [f"link{k + 1}" for k in range(n)]
    c, s = np.cos(a), np.sin(a)
    R = np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])
    centers = np.outer(np.arange(n) + 0.5, [-s, -c])
    q3, qd3 = spatial.initial_state(
        positions={k: (x, 0.0, z) for k, (x, z) in zip(names, centers)},
        orientations=dict.fromkeys(names, R))
    q2, qd2 = planar.initial_state(positions=dict(zip(names, centers)),
                                   orientations=dict.fromkeys(names, -a))
    t_eval = np.linspace(0, 2, 5)
    t3 = spatial.simulate((0, 2), q3, qd3, t_eval=t_eval, **TIGHT)
    t2 = planar.simulate((0, 2), q2, qd2, t_eval=t_eval, **TIGHT)
    for k in names:
        np.testing.assert_allclose(t2[f"{k}_x"], t3[f"{k}_x"], atol=1e-7)
        np.testing.assert_allclose(t2[f"{k}_y"], t3[f"{k}_z"], atol=1e-7)
    np.testing.assert_allclose(energy(planar, t2), energy(spatial, t3), atol=1e-7)


def _planar_four_bar():
    a, b, c, d = four_bar.LENGTHS
    bodies = [PlanarBody(name, four_bar.DENSITY * L, four_bar.DENSITY * L**3 / 12)
              for name, L in zip(four_bar.LINKS, (a, b, c))]
    crank, coupler, rocker = bodies
    joints = [
        Revolute("J1", Ground(), crank, (0, 0, 0), (-a / 2, 0, 0)),
        Revolute("J2", crank, coupler, (a / 2, 0, 0), (-b / 2, 0, 0)),
        Revolute("J3", coupler, rocker, (b / 2, 0, 0), (c / 2, 0, 0)),
        Revolute("J4", rocker, Ground(), (-c / 2, 0, 0), (d, 0, 0)),
    ]
    return Multibody(bodies, joints, gravity=(0, -G, 0))


def test_planar_four_bar_has_independent_rows_and_follows_freudenstein():
    mb = _planar_four_bar()
    a, b, c, d = four_bar.LENGTHS
    th = four_bar.link_angles(four_bar.THETA2_0)
    w = four_bar.link_rates(th, four_bar.OMEGA2_0)
    # link k from its first joint point along its angle; centers at the middle
    starts = [np.zeros(2), a * np.array([np.cos(th[0]), np.sin(th[0])]), np.array([d, 0.0])]
    lengths = (a, b, c)
    pos, vel = {}, {}
    for name, p, L, ang in zip(four_bar.LINKS, starts, lengths, th):
        pos[name] = p + L / 2 * np.array([np.cos(ang), np.sin(ang)])
    # velocities of the centers from the rates (start points: O2, A, O4)
    vA = a * w[0] * np.array([-np.sin(th[0]), np.cos(th[0])])
    for name, v0, L, ang, rate in zip(four_bar.LINKS, (np.zeros(2), vA, np.zeros(2)), lengths,
                                      th, w):
        vel[name] = v0 + L / 2 * rate * np.array([-np.sin(ang), np.cos(ang)])
    q0, qd0 = mb.initial_state(positions=pos, velocities=vel,
                               orientations=dict(zip(four_bar.LINKS, th)),
                               angular_velocities=dict(zip(four_bar.LINKS, w)))
    assert mb.system.degrees_of_freedom == 1
    traj = mb.simulate((0, 2), q0, qd0, t_eval=np.linspace(0, 2, 41), **TIGHT)
    assert traj.success
    gap = traj["rocker_theta"] - four_bar.freudenstein(traj["crank_theta"])
    np.testing.assert_allclose(np.angle(np.exp(1j * gap)), 0.0, atol=1e-8)
    e = energy(mb, traj)
    assert abs(e[-1] - e[0]) < 1e-8 * abs(e[0])


def test_prismatic_slide_on_an_incline_accelerates_at_g_sin_alpha():
    alpha = np.radians(25)
    axis = (np.cos(alpha), np.sin(alpha), 0.0)
    block = PlanarBody("block", 3.0, 0.2)
    rail = Prismatic("rail", Ground(), block, axis_a=axis, axis_b=(1, 0, 0))
    mb = Multibody([block], [rail], gravity=(0, -G, 0))
    assert len(mb.system.constraint_names) == 2
    q0, qd0 = mb.initial_state(orientations={"block": alpha})
    t = np.linspace(0, 1.5, 7)
    traj = mb.simulate((0, 1.5), q0, qd0, t_eval=t, **TIGHT)
    s = -0.5 * G * np.sin(alpha) * t**2  # distance along the rail
    np.testing.assert_allclose(traj["block_x"], s * np.cos(alpha), atol=1e-9)
    np.testing.assert_allclose(traj["block_y"], s * np.sin(alpha), atol=1e-9)
    np.testing.assert_allclose(traj["block_theta"], alpha, atol=1e-10)


def test_welded_pair_swings_as_one_compound_pendulum():
    upper, lower = PlanarBody("upper", 1.0, 0.1), PlanarBody("lower", 2.0, 0.3)
    joints = [Revolute("pin", Ground(), upper, (0, 0, 0), (0, 0.5, 0)),
              Fixed("weld", upper, lower, (0, -0.5, 0), (0, 0.25, 0))]
    mb = Multibody([upper, lower], joints, gravity=(0, -G, 0))
    assert mb.system.degrees_of_freedom == 1
    th0 = 0.6
    e = np.array([np.sin(th0), -np.cos(th0)])
    q0, qd0 = mb.initial_state(positions={"upper": 0.5 * e, "lower": 1.25 * e},
                               orientations={"upper": th0, "lower": th0})
    t_eval = np.linspace(0, 2, 11)
    traj = mb.simulate((0, 2), q0, qd0, t_eval=t_eval, **TIGHT)
    J = 0.1 + 1.0 * 0.5**2 + 0.3 + 2.0 * 1.25**2  # about the pin
    mgr = G * (1.0 * 0.5 + 2.0 * 1.25)
    ref = solve_ivp(lambda t, y: [y[1], -mgr * np.sin(y[0]) / J], (0, 2), [th0, 0.0],
                    t_eval=t_eval, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(traj["upper_theta"], ref.y[0], atol=1e-8)
    np.testing.assert_allclose(traj["lower_theta"], ref.y[0], atol=1e-8)


def test_free_body_under_torque_and_offset_force_follows_newton_euler():
    body = PlanarBody("body", 2.0, 0.5)
    mb = Multibody([body], gravity=(0, 0, 0),
                   forces=[Force(body, (0, 3.0, 0), point=(0.4, 0, 0))],
                   torques=[Torque(body, (0, 0, 1.0))])
    q0, qd0 = mb.initial_state()
    t = 0.3
    traj = mb.simulate((0, t), q0, qd0, t_eval=[t], **TIGHT)
    # the follower arm turns: solve theta'' = (tau + r x F) / I numerically, 1 dof
    ref = solve_ivp(lambda s, y: [y[1], (1.0 + 0.4 * np.cos(y[0]) * 3.0) / 0.5], (0, t),
                    [0.0, 0.0], rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(traj["body_theta"][-1], ref.y[0, -1], atol=1e-9)
    np.testing.assert_allclose(traj["body_y"][-1], 0.5 * 3.0 / 2.0 * t**2, atol=1e-9)
    H = angular_momentum(mb, traj)
    np.testing.assert_allclose(H[:, 2], 0.5 * traj["body_theta_dot"], atol=1e-12)
    T = kinetic_energy(mb, traj)
    v2 = traj["body_x_dot"] ** 2 + traj["body_y_dot"] ** 2
    np.testing.assert_allclose(T, 0.5 * 2.0 * v2 + 0.5 * 0.5 * traj["body_theta_dot"] ** 2)


def test_native_and_python_loops_agree_on_the_planar_chain():
    mb = chain(5, 1.0, 1.0, 0.05, joint="revolute", planar=True)
    names = [b.name for b in mb.bodies]
    centers = np.outer(np.arange(5) + 0.5, [0.5, -np.sqrt(0.75)])
    q0, qd0 = mb.initial_state(positions=dict(zip(names, centers)),
                               orientations=dict.fromkeys(names, np.pi / 6))
    runs = [mb.simulate((0, 2), q0, qd0, t_eval=np.linspace(0, 2, 9), backend=backend,
                        rtol=1e-8, atol=1e-10) for backend in ("c", "python")]
    np.testing.assert_allclose(runs[0].q, runs[1].q, atol=1e-9)
    np.testing.assert_allclose(runs[0].multipliers, runs[1].multipliers, rtol=1e-8, atol=1e-8)


def test_initial_state_takes_angles_matrices_and_2_vectors():
    mb, _ = _pendulum()
    c, s = np.cos(0.3), np.sin(0.3)
    Rz = np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])
    q_angle, _ = mb.initial_state(orientations={"link": 0.3}, angular_velocities={"link": 2.0})
    q_matrix, qd = mb.initial_state(orientations={"link": Rz},
                                    angular_velocities={"link": (0, 0, 2.0)},
                                    velocities={"link": (1.0, 2.0)})
    assert q_matrix["link_theta"] == pytest.approx(q_angle["link_theta"])
    assert (qd["link_theta"], qd["link_x"], qd["link_y"]) == (2.0, 1.0, 2.0)


@pytest.mark.parametrize("make, match", [
    (lambda b: Universal("u", Ground(), b), "no planar form"),
    (lambda b: Revolute("r", Ground(), b, axis_a=(0, 1, 0)), "must be along z"),
    (lambda b: Fixed("f", Ground(), b, axis_a=(1, 0, 0)), "must be along z"),
    (lambda b: Prismatic("p", Ground(), b, axis_a=(0, 0, 1)), "must lie in the x-y plane"),
    (lambda b: PointOnPlane("pp", Ground(), b), "must lie in the x-y plane"),
    (lambda b: Torque(b, (1.0, 0, 0)), "turns about z only"),
])
def test_joints_and_loads_without_a_planar_meaning_are_refused(make, match):
    with pytest.raises(ModelError, match=match):
        make(PlanarBody("b", 1.0, 0.1))


def test_planar_forms_apply_only_between_planar_bodies():
    body, rigid = PlanarBody("b", 1.0, 0.1), RigidBody("r", 1.0, (1, 1, 1))
    assert len(Spherical("s", Ground(), body).constraints()) == 2
    assert len(Distance("d", Ground(), body, 1.0).constraints()) == 1
    assert len(Revolute("mixed", rigid, body).constraints()) == 5  # 3D rows


def test_gravity_out_of_the_plane_and_bad_initial_states_are_refused():
    body = PlanarBody("b", 1.0, 0.1)
    with pytest.raises(ModelError, match=r"gravity=\(0, -9\.81, 0\)"):
        Multibody([body])  # the default gravity is along -z
    mb = Multibody([body], gravity=(0, -G, 0))
    with pytest.raises(InitialConditionError, match="x-y plane"):
        mb.initial_state(positions={"b": (0, 0, 1.0)})
    tilted = np.array([[1.0, 0, 0], [0, 0, -1], [0, 1, 0]])
    with pytest.raises(InitialConditionError, match="not a rotation about z"):
        mb.initial_state(orientations={"b": tilted})
    with pytest.raises(InitialConditionError, match="turns about z only"):
        mb.initial_state(angular_velocities={"b": (1.0, 0, 0)})
    with pytest.raises(ModelError, match="moment about z"):
        PlanarBody("c", 1.0, (1, 2, 3))
