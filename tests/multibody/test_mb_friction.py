"""Coulomb friction on a Multibody's contacts and a disk's rim on a plane
(``multibody/contacts.py``), in the time-stepping contact mode unless said.

References (closed forms): a sphere launched sliding at ``v0`` without spin rolls from
``t = 2 v0 / (7 mu g)`` at ``5/7 v0`` (friction ``mu m g`` decelerates it and spins it
up; its angular momentum about the contact point is conserved: the contact force and
gravity pass through it or the centre above it); a body on an incline sticks when
``tan(alpha) < mu`` and otherwise slides at ``g (sin(alpha) - mu cos(alpha))`` (the
scheme's impulses are exact for these constant forces); a disk rolling upright keeps
``v = omega r`` with a contact force ``m g`` along the normal, and, launched sliding
without spin, rolls from ``t = v0 / (3 mu g)`` at ``2/3 v0`` (its moment about the
axis ``m r^2 / 2``); a disk dropped tilted onto its rim from ``h`` strikes at
``sqrt(2 h / g)``; a ball resting on a fixed sphere sticks or starts sliding as on an
incline of the same slope, and a planar disk on a fixed circle starts rolling at
``2/3 g sin(alpha)`` while ``tan(alpha) <= 3 mu``, else sliding; a box on a free moving
belt is carried along at the common speed of momentum conservation.
"""

from __future__ import annotations

import re

import numpy as np
import pytest

from dalembert import ModelError
from dalembert.multibody import (
    Ground,
    Multibody,
    Particle,
    PlanarBody,
    Prismatic,
    RigidBody,
    angular_velocities,
    disk_contact,
    plane_contact,
    sphere_contact,
)
from dalembert.multibody.rotations import elementary_rotation

g, mu, H = 9.81, 0.3, 1e-3


def test_a_sphere_launched_sliding_rolls_at_five_sevenths():
    m, r, v0 = 2.0, 0.1, 1.5
    ball = RigidBody("ball", m, np.eye(3) * 0.4 * m * r**2)
    mb = Multibody([ball], gravity=(0, 0, -g), contacts=[
        plane_contact("floor", Ground(), ball, radius=r, friction=mu)])
    q0, qd0 = mb.initial_state(positions={"ball": (0, 0, r)},
                               velocities={"ball": (v0, 0, 0)})
    traj = mb.simulate((0.0, 0.2), q0, qd0, contact_mode="time-stepping",
                       contact_step=H)
    assert traj.success, traj.message
    v = traj["ball_x_dot"]
    w = angular_velocities(mb, traj, "ball")[:, 1]  # about +y: rolling along +x
    rolls = 2 * v0 / (7 * mu * g)
    sliding = traj.t < rolls - H
    # while sliding: the friction force mu m g exactly (the step's impulse is exact)
    assert np.abs(v[sliding] - (v0 - mu * g * traj.t[sliding])).max() < 1e-9
    assert np.abs(traj.multiplier("floor_1")[1:] - m * g).max() < 1e-9
    friction = np.hypot(traj.multiplier("floor_friction_1"),
                        traj.multiplier("floor_friction_2"))
    assert np.abs(friction[1:][sliding[1:]] - mu * m * g).max() < 1e-9
    # then rolling, from within a step of the closed form, at 5/7 v0 (while sliding
    # the slip falls by 7/2 mu g h a step; rolling, the quaternion turns with the
    # spin over the step, so neither the slip nor the spin drifts)
    slip = v - w * r
    first = int(np.argmax(np.abs(slip) < 1e-9 * v0))
    assert first > 0 and abs(traj.t[first] - rolls) <= H
    assert np.abs(slip[first:]).max() < 1e-9 * v0
    assert np.abs(v[first:] - 5 / 7 * v0).max() < 1e-9 * v0
    # angular momentum about the contact point, m v r + I w, conserved
    L = m * v * r + 0.4 * m * r**2 * w
    assert np.abs(L - m * v0 * r).max() < 1e-9 * m * v0 * r


def test_a_point_on_an_incline_sticks_or_slides():
    """A particle on a plane tilted by ``alpha`` about ``y`` (3D: two tangents),
    sticking for tan 0.2 < 0.3 and sliding for tan 0.4 > 0.3."""
    for alpha in (0.2, 0.4):
        n = (-np.sin(alpha), 0.0, np.cos(alpha))  # downhill: +x along the slope
        down = np.array([np.cos(alpha), 0.0, np.sin(alpha)])
        block = Particle("block", 1.0)
        mb = Multibody([block], gravity=(0, 0, -g), contacts=[
            plane_contact("slope", Ground(), block, normal=n, friction=mu)])
        q0, qd0 = mb.initial_state(positions={"block": (0, 0, 0)})
        traj = mb.simulate((0.0, 0.3), q0, qd0, contact_mode="time-stepping",
                           contact_step=H)
        assert traj.success, traj.message
        velocity = np.column_stack([traj[f"block_{c}_dot"] for c in "xyz"])
        if np.tan(alpha) < mu:
            assert np.abs(velocity).max() < 1e-12
        else:
            a = g * (np.sin(alpha) - mu * np.cos(alpha))
            assert np.abs(velocity @ down + a * traj.t).max() < 1e-9  # down: -x, -z
            assert np.abs(velocity @ np.asarray(n)).max() < 1e-9


@pytest.mark.parametrize("alpha", [0.2, 0.4])
def test_a_planar_block_on_an_incline_sticks_or_slides(alpha):
    """A planar block on two corners (one tangent each) on a line tilted by
    ``alpha``: the frictions of the two corners add up as for one point."""
    w, h = 0.4, 0.1
    block = PlanarBody("block", 1.0, (w**2 + h**2) / 12)
    n = (-np.sin(alpha), np.cos(alpha), 0.0)
    corners = [plane_contact(f"corner{k}", Ground(), block, normal=n,
                             point=(s * w / 2, -h / 2, 0), friction=mu)
               for k, s in enumerate((-1, 1))]
    mb = Multibody([block], gravity=(0, -g, 0), contacts=corners)
    R = elementary_rotation("z", alpha)
    centre = R @ np.array([0.0, h / 2, 0.0])
    q0, qd0 = mb.initial_state(positions={"block": centre}, orientations={"block": R})
    traj = mb.simulate((0.0, 0.3), q0, qd0, contact_mode="time-stepping",
                       contact_step=H)
    assert traj.success, traj.message
    up = np.column_stack([traj["block_x_dot"], traj["block_y_dot"]]) @ R[:2, 0]
    if np.tan(alpha) < mu:
        assert np.abs(up).max() < 1e-9
    else:
        a = g * (np.sin(alpha) - mu * np.cos(alpha))
        assert np.abs(up + a * traj.t).max() < 1e-9
    assert np.abs(traj["block_theta_dot"]).max() < 1e-9


def _disk(m: float = 1.0, r: float = 0.3) -> tuple[RigidBody, np.ndarray]:
    """A thin disk, its axis body ``y``: moments ``m r^2 / 4`` across, ``/ 2`` about it."""
    return RigidBody("disk", m, np.diag([m * r**2 / 4, m * r**2 / 2, m * r**2 / 4])), \
        np.array([0.0, 1.0, 0.0])


def test_a_disk_rolls_upright_inside_the_friction_cone():
    m, r, v = 1.0, 0.3, 1.2
    disk, axis = _disk(m, r)
    mb = Multibody([disk], gravity=(0, 0, -g), contacts=[
        disk_contact("rim", Ground(), disk, r, axis=axis, friction=0.8)])
    q0, qd0 = mb.initial_state(positions={"disk": (0, 0, r)},
                               velocities={"disk": (v, 0, 0)},
                               angular_velocities={"disk": (0, v / r, 0)})
    traj = mb.simulate((0.0, 0.1), q0, qd0, contact_mode="time-stepping",
                       contact_step=H)
    assert traj.success, traj.message
    spin = angular_velocities(mb, traj, "disk")[:, 1]
    assert np.abs(traj["disk_x_dot"] - spin * r).max() < 1e-9 * v  # v = omega r
    assert np.abs(traj["disk_x_dot"] - v).max() < 1e-9 * v  # no drift, as for the sphere
    normal = traj.multiplier("rim_1")[1:]
    friction = np.hypot(traj.multiplier("rim_friction_1"),
                        traj.multiplier("rim_friction_2"))[1:]
    assert np.abs(normal - m * g).max() < 1e-6
    assert (friction <= 0.8 * normal).all()


def test_a_disk_launched_sliding_rolls_at_two_thirds():
    m, r, v0 = 1.0, 0.3, 1.5
    disk, axis = _disk(m, r)
    mb = Multibody([disk], gravity=(0, 0, -g), contacts=[
        disk_contact("rim", Ground(), disk, r, axis=axis, friction=mu)])
    q0, qd0 = mb.initial_state(positions={"disk": (0, 0, r)},
                               velocities={"disk": (v0, 0, 0)})
    traj = mb.simulate((0.0, 0.25), q0, qd0, contact_mode="time-stepping",
                       contact_step=H)
    assert traj.success, traj.message
    v = traj["disk_x_dot"]
    slip = v - angular_velocities(mb, traj, "disk")[:, 1] * r
    rolls = v0 / (3 * mu * g)
    first = int(np.argmax(np.abs(slip) < 1e-9 * v0))  # as for the sphere
    assert first > 0 and abs(traj.t[first] - rolls) <= H
    assert np.abs(v[first:] - 2 / 3 * v0).max() < 1e-9 * v0


def test_a_tilted_disk_dropped_strikes_its_rim_at_the_free_fall_time():
    """Event-driven, frictionless: the rim's lowest point, ``h`` over the floor, falls
    freely until the impact; the gap is never negative."""
    r, h, tilt = 0.3, 0.2, 0.5
    disk, axis = _disk(1.0, r)
    mb = Multibody([disk], gravity=(0, 0, -g), contacts=[
        disk_contact("rim", Ground(), disk, r, axis=axis)])
    R = elementary_rotation("x", tilt)  # the axis leans: n.a = sin(tilt)
    q0, qd0 = mb.initial_state(positions={"disk": (0, 0, h + r * np.cos(tilt))},
                               orientations={"disk": R})
    strike = np.sqrt(2 * h / g)
    traj = mb.simulate((0.0, strike + 0.05), q0, qd0)
    assert traj.success, traj.message
    assert abs(traj.contacts.impact_times[0] - strike) < 1e-9
    gap = mb.with_contacts_closed((0,)).system  # the gap as a row: psi's last entry
    psi = np.array([gap.numeric().position_constraint(t, q)[-1]
                    for t, q in zip(traj.t, traj.q)])
    assert psi.min() > -1e-9


def test_friction_bad_input_is_named():
    ball = Particle("ball", 1.0)
    for bad in (-0.1, np.nan, "0.3", True):
        with pytest.raises(ModelError, match="the friction must be a number >= 0"):
            plane_contact("floor", Ground(), ball, friction=bad)
    with pytest.raises(ModelError, match="friction"):
        sphere_contact("touch", ball, Particle("other", 1.0), 0.1, 0.1, friction=-1.0)
    disk, axis = _disk()
    with pytest.raises(ModelError, match="friction"):
        disk_contact("rim", Ground(), disk, 0.3, axis=axis, friction=float("nan"))
    with pytest.raises(ModelError, match="a particle has no axis"):
        disk_contact("rim", Ground(), ball, 0.3)
    with pytest.raises(ModelError, match="radius"):
        disk_contact("rim", Ground(), disk, 0.0, axis=axis)


@pytest.mark.parametrize("alpha", [0.2, 0.4])
def test_a_ball_on_a_fixed_sphere_sticks_or_starts_sliding(alpha):
    """A particle ball resting on a fixed sphere ``alpha`` off its top (3D: the sliding
    velocity's three components less the normal one): it sticks for ``tan(alpha) <
    mu``, else its first step's velocity is ``h g (sin(alpha) - mu cos(alpha))`` down
    the slope (at rest the step's impulses are exact), its friction ``mu m g cos``."""
    m, R, r, beta = 1.5, 1.0, 0.1, 0.7  # beta: the azimuth, every world component used
    ball = Particle("ball", m)
    mb = Multibody([ball], gravity=(0, 0, -g), contacts=[
        sphere_contact("dome", Ground(), ball, R, r, friction=mu)])
    n = np.array([np.sin(alpha) * np.cos(beta), np.sin(alpha) * np.sin(beta),
                  np.cos(alpha)])
    down = np.array([np.cos(alpha) * np.cos(beta), np.cos(alpha) * np.sin(beta),
                     -np.sin(alpha)])
    q0, qd0 = mb.initial_state(positions={"ball": (R + r) * n})
    traj = mb.simulate((0.0, 0.05), q0, qd0, contact_mode="time-stepping",
                       contact_step=H)
    assert traj.success, traj.message
    velocity = np.column_stack([traj[f"ball_{c}_dot"] for c in "xyz"])
    friction = np.linalg.norm(np.column_stack(
        [traj.multiplier(f"dome_friction_{k}") for k in (1, 2, 3)]), axis=1)
    assert abs(traj.multiplier("dome_1")[1] - m * g * np.cos(alpha)) < 1e-9
    if np.tan(alpha) < mu:
        assert np.abs(velocity).max() < 1e-12
        assert abs(friction[1] - m * g * np.sin(alpha)) < 1e-9
    else:
        a = g * (np.sin(alpha) - mu * np.cos(alpha))
        assert np.abs(velocity[1] - H * a * down).max() < 1e-12
        assert abs(friction[1] - mu * m * g * np.cos(alpha)) < 1e-9


def test_a_box_dropped_on_a_moving_belt_is_carried_along():
    """Friction against a moving plane: a planar box at rest on a free belt (a
    ``Prismatic`` along ``x``) moving at ``u``; the box speeds up at ``mu g``, the belt
    slows at ``mu g m / M``, until they move together at ``M u / (M + m)`` from
    ``t = u / (mu g (1 + m / M))``; the momentum ``M u`` is conserved throughout."""
    m, M, u, w, h = 1.0, 4.0, 2.0, 0.4, 0.1
    belt = PlanarBody("belt", M, 1.0)
    box = PlanarBody("box", m, m * (w**2 + h**2) / 12)
    corners = [plane_contact(f"corner{k}", belt, box, normal=(0, 1, 0),
                             point=(s * w / 2, -h / 2, 0), friction=mu)
               for k, s in enumerate((-1, 1))]
    mb = Multibody([belt, box], [Prismatic("rail", Ground(), belt, axis_a=(1, 0, 0))],
                   gravity=(0, -g, 0), contacts=corners)
    q0, qd0 = mb.initial_state(positions={"belt": (0, 0, 0), "box": (0, h / 2, 0)},
                               velocities={"belt": (u, 0, 0)})
    traj = mb.simulate((0.0, 0.6), q0, qd0, contact_mode="time-stepping",
                       contact_step=H)
    assert traj.success, traj.message
    v_box, v_belt = traj["box_x_dot"], traj["belt_x_dot"]
    assert np.abs(m * v_box + M * v_belt - M * u).max() < 1e-9
    together = u / (mu * g * (1 + m / M))
    sliding = traj.t < together - H
    assert np.abs(v_box[sliding] - mu * g * traj.t[sliding]).max() < 1e-9
    after = traj.t > together + H
    assert after.any()
    assert np.abs(v_box[after] - M * u / (M + m)).max() < 1e-9
    assert np.abs(v_belt[after] - M * u / (M + m)).max() < 1e-9


@pytest.mark.parametrize("alpha", [0.4, 1.3])  # tan 0.4 = 0.42 < 3 mu = 0.9 < tan 1.3
def test_a_planar_disk_on_a_fixed_circle_starts_rolling_or_sliding(alpha):
    """Planar bodies (one row, along ``z x n``): a disk (moment ``m r^2 / 2``) at rest on
    a fixed circle ``alpha`` off its top starts rolling, ``a = 2/3 g sin(alpha)`` with a
    friction ``m g sin(alpha) / 3``, while that is at most ``mu`` times the normal
    force (``tan(alpha) <= 3 mu``); else it slides, ``a = g (sin - mu cos)``, spinning up
    at ``mu m g cos(alpha) r / I``."""
    m, R, r = 1.0, 1.0, 0.2
    inertia = m * r**2 / 2
    disk = PlanarBody("disk", m, inertia)
    mb = Multibody([disk], gravity=(0, -g, 0), contacts=[
        sphere_contact("hill", Ground(), disk, R, r, friction=mu)])
    n = np.array([np.sin(alpha), np.cos(alpha), 0.0])
    down = np.array([np.cos(alpha), -np.sin(alpha), 0.0])
    q0, qd0 = mb.initial_state(positions={"disk": (R + r) * n})
    traj = mb.simulate((0.0, 2 * H), q0, qd0, contact_mode="time-stepping",
                       contact_step=H)
    assert traj.success, traj.message
    velocity = np.array([traj["disk_x_dot"][1], traj["disk_y_dot"][1], 0.0])
    normal, friction = traj.multiplier("hill_1")[1], traj.multiplier("hill_friction_1")[1]
    assert abs(normal - m * g * np.cos(alpha)) < 1e-9
    if np.tan(alpha) <= 3 * mu:
        assert np.abs(velocity - H * 2 / 3 * g * np.sin(alpha) * down).max() < 1e-12
        assert abs(abs(friction) - m * g * np.sin(alpha) / 3) < 1e-9
    else:
        a = g * (np.sin(alpha) - mu * np.cos(alpha))
        assert np.abs(velocity - H * a * down).max() < 1e-12
        spin = mu * m * g * np.cos(alpha) * r / inertia
        assert abs(abs(traj["disk_theta_dot"][1]) - H * spin) < 1e-9


def test_a_rough_disk_rolls_without_slipping_event_driven():
    """``friction=math.inf``: the rim's sliding rows hold while it is closed, so a disk
    rolling upright keeps ``v = omega r`` and its energy to rounding (rolling without
    slipping does no work), the floor carrying ``m g`` (event-driven: exact where the
    time-stepping mode keeps ``v = omega r`` within a step's error)."""
    m, r, v = 1.0, 0.3, 1.2
    disk, axis = _disk(m, r)
    mb = Multibody([disk], gravity=(0, 0, -g), contacts=[
        disk_contact("rim", Ground(), disk, r, axis=axis, friction=np.inf)])
    q0, qd0 = mb.initial_state(positions={"disk": (0, 0, r)},
                               velocities={"disk": (v, 0, 0)},
                               angular_velocities={"disk": (0, v / r, 0)})
    traj = mb.simulate((0.0, 1.0), q0, qd0, t_eval=np.linspace(0, 1, 11))
    assert traj.success, traj.message
    assert traj.contacts.impacts == []
    np.testing.assert_allclose(traj["disk_x"], v * traj.t, rtol=0, atol=1e-9)
    np.testing.assert_allclose(traj.energy, traj.energy[0], rtol=0, atol=1e-9)
    np.testing.assert_allclose(traj.multiplier("rim_friction_1"), 0.0, atol=1e-9)
    np.testing.assert_allclose(angular_velocities(mb, traj, "disk")[:, 1] * r, v, rtol=1e-9)
    np.testing.assert_allclose(traj.multiplier("rim_1"), m * g, rtol=1e-9)


@pytest.mark.parametrize("mode", ["event-driven", "time-stepping"])
def test_a_disk_landing_flat_ends_the_run_naming_the_contact(mode):
    """Lying flat, a disk's rim has no lowest point and its gap no derivative: the run
    ends as failed at the landing, naming the contact, with what it computed."""
    disk, _ = _disk()
    mb = Multibody([disk], gravity=(0, 0, -g), contacts=[
        disk_contact("rim", Ground(), disk, 0.3, axis=(0, 0, 1))])  # axis along the normal
    q0, qd0 = mb.initial_state(positions={"disk": (0, 0, 0.05)})
    with pytest.warns(Warning, match="'rim'.* no finite"):
        traj = mb.simulate((0.0, 0.5), q0, qd0, contact_mode=mode)
    assert traj.status == "failed"
    assert re.search(r"'rim'.* no finite", traj.message)
    landing = np.sqrt(2 * 0.05 / g)
    assert landing - 0.03 < traj.t[-1] <= landing  # what it computed, up to the landing
    np.testing.assert_allclose(traj["disk_z"], 0.05 - g / 2 * traj.t**2, atol=1e-6)
