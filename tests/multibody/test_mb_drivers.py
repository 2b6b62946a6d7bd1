"""Drivers (prescribed joint motion) and joint springs, against closed forms.

References: the slider-crank's minimal model (its closed-form kinematics in the
crank angle, differentiated by SymPy) and the power balance ``tau omega = d(T + V)/dt``
for the motor torque; Newton's law for a driven slider; the damped harmonic
oscillator for a disk on a torsional spring and a block on a linear one.
"""

from __future__ import annotations

import numpy as np
import pytest
import sympy as sp

from dalembert import ModelError
from dalembert import t as time
from dalembert.examples import slider_crank
from dalembert.multibody import (
    Driver,
    Ground,
    JointSpring,
    Multibody,
    PlanarBody,
    Prismatic,
    Revolute,
    Spherical,
    joint_reactions,
    potential_energy,
)

THETA0, OMEGA = np.pi / 3, 5.0


def driven_crank(omega=OMEGA):
    mb = slider_crank.build_multibody()
    j1 = mb.joint("J1")
    return Multibody(mb.bodies, [*mb.joints, Driver("motor", j1, THETA0 + omega * time)],
                     gravity=mb.gravity, name="driven slider-crank")


def motor_torque_closed_form():
    """tau(t) = d(T + V)/dt / omega along theta = THETA0 + omega t (minimal model)."""
    a, b, e = slider_crank.GEOMETRY
    t = sp.Symbol("t")
    th = THETA0 + OMEGA * t
    phi = sp.asin((e - a * sp.sin(th)) / b)
    A = sp.Matrix([a * sp.cos(th), a * sp.sin(th)])
    B = A + b * sp.Matrix([sp.cos(phi), sp.sin(phi)])
    masses = [slider_crank.DENSITY * a, slider_crank.DENSITY * b, slider_crank.PISTON_MASS]
    moments = [slider_crank.DENSITY * a**3 / 12, slider_crank.DENSITY * b**3 / 12]
    centers = [A / 2, (A + B) / 2, B]
    T = sum(m / 2 * c.diff(t).dot(c.diff(t)) for m, c in zip(masses, centers))
    T += moments[0] / 2 * OMEGA**2 + moments[1] / 2 * phi.diff(t) ** 2
    V = sum(m * slider_crank.G * c[1] for m, c in zip(masses, centers))
    return sp.lambdify(t, (T + V).diff(t) / OMEGA)


@pytest.fixture(scope="module")
def crank_run():
    mb = driven_crank()
    start = slider_crank.initial_state(THETA0, OMEGA)
    times = np.linspace(0.0, 2.0, 81)
    return mb, mb.simulate((0.0, 2.0), start["q0"], start["qd0"], t_eval=times)


def test_the_driver_leaves_no_freedom_and_turns_the_crank(crank_run):
    mb, traj = crank_run
    assert mb.system.consistent_initial_state(traj.q[0], traj.qd[0]).degrees_of_freedom == 0
    np.testing.assert_allclose(traj["crank_theta"], THETA0 + OMEGA * traj.t, atol=1e-10)
    x_b = slider_crank.piston_position(THETA0 + OMEGA * traj.t)
    np.testing.assert_allclose(traj["piston_x"], x_b, atol=1e-10)


def test_the_motor_multiplier_is_the_driving_torque(crank_run):
    mb, traj = crank_run
    tau = motor_torque_closed_form()
    expected = np.array([tau(t) for t in traj.t])
    assert np.abs(traj.multiplier("motor_1") - expected).max() < 1e-9 * np.abs(expected).max()
    assert np.ptp(expected) > 10.0  # it varies: not a vacuous check
    # joint_reactions reports it as the driver's torque on the crank about z
    on_crank = joint_reactions(mb, traj)["motor"]["crank"]
    np.testing.assert_allclose(on_crank.torque_cm_world[:, 2], traj.multiplier("motor_1"),
                               rtol=1e-12, atol=1e-9)


def test_a_driver_speed_that_is_a_parameter():
    w = sp.Symbol("w")
    mb = slider_crank.build_multibody()
    driven = Multibody(mb.bodies, [*mb.joints, Driver("motor", mb.joint("J1"),
                                                      THETA0 + w * time)],
                       gravity=mb.gravity, parameters={w: OMEGA})
    start = slider_crank.initial_state(THETA0, 2.0)
    traj = driven.simulate((0.0, 1.0), start["q0"], start["qd0"], parameters={w: 2.0},
                           t_eval=[1.0])
    assert traj["crank_theta"][0] == pytest.approx(THETA0 + 2.0, abs=1e-10)


def test_a_driven_slider_needs_newtons_force():
    """A 3 kg block pushed along an inclined guide: s = 0.2 sin(3 t); the driver's
    force along the guide is m (s'' + g . axis)."""
    block = PlanarBody("block", 3.0, 0.1)
    axis = np.array([np.cos(0.4), np.sin(0.4), 0.0])
    guide = Prismatic("guide", Ground(), block, axis_a=axis)
    push = Driver("push", guide, 0.2 * sp.sin(3 * time))
    mb = Multibody([block], [guide, push], gravity=(0, -9.81, 0))
    traj = mb.simulate((0.0, 2.0), {}, {"block_x": 0.6 * axis[0], "block_y": 0.6 * axis[1]},
                       t_eval=np.linspace(0, 2, 21))
    s_dd = -1.8 * np.sin(3 * traj.t)
    expected = 3.0 * (s_dd + 9.81 * axis[1])
    np.testing.assert_allclose(traj.multiplier("push_1"), expected, rtol=1e-9, atol=1e-9)


def test_a_driver_on_a_joint_without_a_coordinate_is_refused():
    ball = Spherical("ball", Ground(), PlanarBody("b", 1.0, 1.0))
    with pytest.raises(ModelError, match="driver 'd': a driver moves a Revolute or Prismatic"):
        Driver("d", ball, time)
    pin = Revolute("pin", Ground(), PlanarBody("c", 1.0, 1.0))
    with pytest.raises(ModelError, match="expression of the time and parameters"):
        Driver("d", pin, pin.body_b.coordinates[0])


def test_a_driver_whose_joint_is_not_in_the_joints_is_refused():
    """Without its joint's own rows the driver fixes only the angle: the body would fall
    freely while turning. The error names the driver and the joint, and says what to do."""
    disk = PlanarBody("disk", 1.0, 0.1)
    pin = Revolute("pin", Ground(), disk)
    motor = Driver("motor", pin, 2 * time)
    with pytest.raises(ModelError, match=r"driver 'motor' drives joint 'pin', which is not in "
                       r"this system's joints .*add the joint to the joints list"):
        Multibody([disk], [motor], gravity=(0, -9.81, 0))
    # with the joint listed the disk stays on its pin and turns at 2 rad/s
    mb = Multibody([disk], [pin, motor], gravity=(0, -9.81, 0))
    traj = mb.simulate((0.0, 1.0), {}, {"disk_theta": 2.0}, t_eval=[1.0])
    assert traj["disk_theta"][0] == pytest.approx(2.0, abs=1e-9)
    assert abs(traj["disk_y"][0]) < 1e-9


def damped(t, x0, k, c, m):
    """x(t) of m x'' + c x' + k x = 0 from rest at x0 (underdamped)."""
    w0, zeta = np.sqrt(k / m), c / (2 * np.sqrt(k * m))
    wd = w0 * np.sqrt(1 - zeta**2)
    return x0 * np.exp(-zeta * w0 * t) * (np.cos(wd * t) + zeta * w0 / wd * np.sin(wd * t))


def test_a_torsional_spring_and_damper():
    k, c, J = 4.0, 0.3, 0.5
    disk = PlanarBody("disk", 2.0, J)
    pin = Revolute("pin", Ground(), disk)
    mb = Multibody([disk], [pin], gravity=(0, 0, 0),
                   joint_springs=[JointSpring("coil", pin, k, c, rest=0.1)])
    q0, _ = mb.initial_state(orientations={disk: 0.5})
    traj = mb.simulate((0.0, 3.0), q0, t_eval=np.linspace(0, 3, 31))
    expected = 0.1 + damped(traj.t, 0.4, k, c, J)
    np.testing.assert_allclose(traj["disk_theta"], expected, atol=1e-9)
    # the energy outputs see the spring: V = k/2 (theta - rest)^2
    np.testing.assert_allclose(potential_energy(mb, traj), k / 2 * (expected - 0.1) ** 2,
                               atol=1e-9)


def test_a_linear_joint_spring_with_parameters():
    k, c = sp.symbols("k c")
    block = PlanarBody("block", 2.0, 0.1)
    guide = Prismatic("guide", Ground(), block, axis_a=(1, 0, 0))
    mb = Multibody([block], [guide], gravity=(0, 0, 0),
                   joint_springs=[JointSpring("spring", guide, k, c)])
    traj = mb.simulate((0.0, 3.0), {"block_x": 0.2}, t_eval=np.linspace(0, 3, 31),
                       parameters={k: 8.0, c: 0.5})
    np.testing.assert_allclose(traj["block_x"], damped(traj.t, 0.2, 8.0, 0.5, 2.0),
                               atol=1e-9)
