"""Rough contacts (``friction=math.inf``): never sliding, event-driven.

References: Housner's rocking block (Housner 1963, "The behavior of inverted pendulum
structures during earthquakes"): a rigid block ``2b x 2h`` rocking on rough ground,
its impacts plastic, turns about the corner that lands, the other lifting; angular
momentum about the landing corner is conserved through the impact, so the angular
velocity drops by

    omega+ / omega- = (I_cm + m R^2 cos(2 alpha)) / I_O = 1 - 3/2 sin(alpha)^2,

``R = sqrt(b^2 + h^2)``, ``sin(alpha) = b / R``, ``I_O = 4/3 m R^2`` about a corner.
Between impacts energy is conserved (each swing's closed form from the heights of the
centre); the corner it turns about does not move. And a sliding body landing on a
rough floor stops sliding at once, by momentum about the contact.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
import sympy as sp

from dalembert import System, Unilateral, coordinates
from dalembert import t as time

M, G, B, H = 1.0, 9.81, 0.2, 1.0
R = math.hypot(B, H)
I_CM = M * R**2 / 3  # a uniform rectangle 2b x 2h: m (4 b^2 + 4 h^2) / 12
I_CORNER = I_CM + M * R**2
HOUSNER = 1 - 1.5 * (B / R) ** 2

x, y, th = coordinates("x y theta")


def corner(u: float, v: float) -> tuple[sp.Expr, sp.Expr]:
    """The world position of the body point ``(u, v)`` (from the centre, body axes)."""
    return (x + u * sp.cos(th) - v * sp.sin(th), y + u * sp.sin(th) + v * sp.cos(th))


def block(law_friction: float = math.inf) -> System:
    right, left = corner(B, -H), corner(-B, -H)
    return System(
        [x, y, th],
        kinetic=M / 2 * (x.diff() ** 2 + y.diff() ** 2) + I_CM / 2 * th.diff() ** 2,
        potential=M * G * y,
        constraints=[
            Unilateral(right[1], name="right", friction=law_friction,
                       tangents=[right[0].diff(time)]),
            Unilateral(left[1], name="left", friction=law_friction,
                       tangents=[left[0].diff(time)])])


def tilted(theta0: float) -> dict:
    """At rest on its right corner (at the origin), turned by ``theta0 < 0``."""
    c, s = math.cos(theta0), math.sin(theta0)
    return {x: -(B * c + H * s), y: -(B * s - H * c), th: theta0}


@pytest.fixture(scope="module")
def rocking():
    theta0 = -0.1
    traj = block().simulate((0.0, 2.5), tilted(theta0), t_eval=np.linspace(0, 2.5, 2501))
    assert traj.status == "finished"
    return theta0, traj


def test_each_impact_keeps_housners_fraction_of_the_angular_velocity(rocking):
    theta0, traj = rocking
    impacts = traj.contacts.impacts
    assert len(impacts) >= 3
    # the first swing from rest: the centre falls from h cos(t0) - b sin(t0) to h
    drop = (H * math.cos(theta0) - B * math.sin(theta0)) - H
    omega = math.sqrt(2 * M * G * drop / I_CORNER)
    for k, hit in enumerate(impacts[:3]):
        before, after = hit.qd_before[2], hit.qd_after[2]
        assert abs(abs(before) - omega) < 1e-9 * omega, k  # energy kept in each swing
        assert after / before == pytest.approx(HOUSNER, rel=1e-10), k
        assert hit.energy_lost == pytest.approx(
            I_CORNER / 2 * omega**2 * (1 - HOUSNER**2), rel=1e-9)
        omega *= HOUSNER
        # it lands on one corner, the other lifts: only the landing one pushes
        assert (hit.impulses > 0).sum() == 1


def test_the_corner_it_turns_about_does_not_slide(rocking):
    _, traj = rocking
    closed = traj.contacts.closed_at(traj.t)
    corners = {"right": (B, -H), "left": (-B, -H)}
    for k, name in enumerate(("right", "left")):
        u, v = corners[name]
        on = closed[:, k]
        px = traj["x"] + u * np.cos(traj["theta"]) - v * np.sin(traj["theta"])
        py = traj["y"] + u * np.sin(traj["theta"]) + v * np.cos(traj["theta"])
        home = 0.0 if name == "right" else -2 * B
        assert on.any()
        assert np.abs(px[on] - home).max() < 1e-9
        assert np.abs(py[on]).max() < 1e-9
        assert (traj.multiplier(name)[on] >= -1e-9).all()  # pushing only


def test_a_block_landing_flat_while_sliding_trips_over_its_leading_corner():
    """The block falling flat onto rough ground while moving sideways at 1 m/s: the
    leading corner grips and the block turns about it (the trailing one would have to
    pull to hold too), by angular momentum about that corner,
    ``I_O omega = m (b v_down - h v_x)``."""
    v_x, v_down = 1.0, math.sqrt(2 * G * 0.05)
    traj = block().simulate((0.0, 0.2), {x: 0.0, y: H + 0.05, th: 0.0}, {x: v_x},
                            t_eval=[0.0, 0.2])
    hit = traj.contacts.impacts[0]
    omega = M * (B * v_down - H * v_x) / I_CORNER
    assert hit.qd_after[2] == pytest.approx(omega, rel=1e-12)
    # the leading (right) corner stops dead: the centre turns about it, omega x (-b, h)
    np.testing.assert_allclose(hit.qd_after[:2], [-omega * H, -omega * B], rtol=1e-12)
    assert hit.impulses[0] > 0 and hit.impulses[1] == 0


def test_a_rough_contact_closing_while_sliding_grips():
    """A particle skimming the floor (touching, not approaching) at 1 m/s under
    gravity: the contact closes, and being rough it stops the sliding at once, the
    kinetic energy of the sliding lost."""
    px, py = coordinates("px py")
    particle = System([px, py], kinetic=(px.diff() ** 2 + py.diff() ** 2) / 2,
                      potential=G * py,
                      constraints=[Unilateral(py, name="floor", friction=math.inf,
                                              tangents=[px.diff()])])
    traj = particle.simulate((0.0, 0.5), {px: 0.0, py: 0.0}, {px: 1.0}, t_eval=[0.0, 0.5])
    assert traj.status == "finished"
    (grip,) = traj.contacts.impacts
    assert grip.t == 0.0 and grip.energy_lost == pytest.approx(0.5, rel=1e-12)
    np.testing.assert_allclose(traj.qd[-1], 0.0, atol=1e-12)
    assert traj.q[-1][0] == 0.0
    assert traj.multiplier("floor")[-1] == pytest.approx(G, rel=1e-12)


def test_rough_contacts_are_refused_in_the_time_stepping_mode():
    with pytest.raises(ValueError, match="'right' is rough"):
        block().simulate((0.0, 0.1), tilted(-0.1), contact_mode="time-stepping")
