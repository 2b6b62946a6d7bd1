"""Coulomb friction in the event-driven contact mode (``solvers/contact/friction.py``).

References: closed forms of constant-force motions, and (for a puck whose sliding
direction turns) the sliding equations ``v' = F / m - mu g v / |v|`` integrated by
SciPy apart from the library.

- a block sliding on a floor decelerates at ``mu g`` and stops at ``v0 / (mu g)``,
  after ``v0^2 / (2 mu g)``;
- a block sent up an incline decelerates at ``g (sin(a) + mu cos(a))``, stops, then
  sticks if ``tan(a) < mu`` and otherwise slides back at ``g (sin(a) - mu cos(a))``;
- a block pushed by a force ``k t`` sticks until ``k t = mu m g`` and then moves by
  ``k (t - t_s)^3 / 6``;
- a sphere launched sliding without spin rolls from ``2 v0 / (7 mu g)`` at ``5/7 v0``,
  its angular momentum about the contact line conserved.

Each transition is an event located to rounding, so times and states match the
closed forms to rounding, not to a step.
"""

from __future__ import annotations

import numpy as np
import pytest
import sympy as sp
from scipy.integrate import solve_ivp

from dalembert import System, Unilateral, coordinates

g, mu = 9.81, 0.3
X, Y, Z, TH = coordinates("x y z theta")


def block(alpha: float = 0.0, **extra) -> System:
    """A unit block on a floor ``y >= 0`` tilted by ``alpha`` (``x`` down the slope)."""
    return System([X, Y], kinetic=(X.diff() ** 2 + Y.diff() ** 2) / 2,
                  potential=g * (Y * np.cos(alpha) - X * np.sin(alpha)),
                  constraints=[Unilateral(Y, name="floor", friction=mu,
                                          tangents=[X.diff()])], **extra)


def switch_times(traj) -> list[float]:
    return [s.t for s in traj.contacts.switches[1:]]


@pytest.mark.parametrize("backend", ["c", "python"])
def test_a_sliding_block_stops_at_v0_over_mu_g_and_sticks(backend):
    v0 = 2.0
    traj = block().simulate((0.0, 1.0), {"x": 0.0, "y": 0.0}, {"x": v0}, backend=backend)
    assert traj.success, traj.message
    stop = v0 / (mu * g)
    (t_stop,) = switch_times(traj)
    assert abs(t_stop - stop) < 1e-13
    sliding = traj.t < t_stop  # the point at the switch shows the state after it
    assert np.abs(traj["x_dot"][sliding] - (v0 - mu * g * traj.t[sliding])).max() < 1e-13
    assert np.abs(traj["x_dot"][~sliding]).max() < 1e-14
    assert abs(traj["x"][-1] - v0**2 / (2 * mu * g)) < 1e-13
    friction, normal = traj.multiplier("floor_friction_1"), traj.multiplier("floor")
    assert np.abs(normal - g).max() < 1e-12
    assert np.abs(friction[sliding] + mu * g).max() < 1e-12  # -mu N, against the motion
    assert np.abs(friction[~sliding]).max() < 1e-12  # stuck on a level floor: no force
    # the friction force is in the constraint forces: the floor's total force on x
    assert np.abs(traj.constraint_forces[sliding, 0] + mu * g).max() < 1e-12


@pytest.mark.parametrize("alpha", [0.2, 0.4])  # tan 0.2 = 0.203 < 0.3 < tan 0.4 = 0.423
def test_a_block_sent_up_an_incline_stops_then_sticks_or_slides_back(alpha):
    v0, t_end = 1.0, 1.0
    traj = block(alpha).simulate((0.0, t_end), {"x": 0.0, "y": 0.0}, {"x": -v0})
    assert traj.success, traj.message
    up = g * (np.sin(alpha) + mu * np.cos(alpha))
    t_stop, x_stop = v0 / up, -v0**2 / (2 * up)
    assert abs(switch_times(traj)[0] - t_stop) < 1e-13
    after = traj.t >= switch_times(traj)[0]
    if np.tan(alpha) < mu:  # it sticks, held by friction g sin(alpha) up the slope
        assert np.abs(traj["x"][after] - x_stop).max() < 1e-13
        assert np.abs(traj.multiplier("floor_friction_1")[after] + g * np.sin(alpha)).max() \
            < 1e-12
    else:
        down = g * (np.sin(alpha) - mu * np.cos(alpha))
        s = traj.t[after] - t_stop
        assert np.abs(traj["x_dot"][after] - down * s).max() < 1e-12
        assert np.abs(traj["x"][after] - (x_stop + down * s**2 / 2)).max() < 1e-12
        assert np.abs(traj.multiplier("floor_friction_1")[after]
                      + mu * g * np.cos(alpha)).max() < 1e-12


def test_a_block_pushed_harder_and_harder_slips_where_the_push_reaches_mu_m_g():
    u, k = sp.Symbol("u"), 5.0
    pushed = block(inputs=[u], generalized_forces=[u, 0])
    traj = pushed.simulate((0.0, 1.0), {"x": 0.0, "y": 0.0}, inputs={"u": lambda t: k * t})
    assert traj.success, traj.message
    t_slip = mu * g / k
    (t_switch,) = switch_times(traj)
    assert abs(t_switch - t_slip) < 1e-13
    stuck = traj.t < t_switch
    assert np.abs(traj["x"][stuck]).max() < 1e-15
    # held by friction -k t until then, inside the cone
    assert np.abs(traj.multiplier("floor_friction_1")[stuck] + k * traj.t[stuck]).max() < 1e-12
    s = traj.t[~stuck] - t_slip
    assert np.abs(traj["x"][~stuck] - k * s**3 / 6).max() < 1e-12


@pytest.mark.parametrize("backend", ["c", "python"])
def test_a_sphere_launched_sliding_rolls_from_2_v0_over_7_mu_g_at_five_sevenths(backend):
    from dalembert.examples import rolling_sphere  # the gallery's sphere: m = 1, mu = 0.3

    m, r, v0 = 1.0, rolling_sphere.RADIUS, rolling_sphere.V0
    assert mu == rolling_sphere.MU
    inertia = 2 / 5 * m * r**2
    sphere = rolling_sphere.build(m_value=m, g_value=g)
    traj = sphere.simulate((0.0, 0.8), {"y": r}, {"x": v0}, backend=backend)
    assert traj.success, traj.message
    t_roll = 2 * v0 / (7 * mu * g)
    assert abs(switch_times(traj)[0] - t_roll) < 1e-13
    rolling = traj.t >= switch_times(traj)[0]
    slip = traj["x_dot"] + r * traj["theta_dot"]
    assert np.abs(slip[rolling]).max() < 1e-14
    assert np.abs(traj["x_dot"][rolling] - 5 / 7 * v0).max() < 1e-13
    about = m * r * traj["x_dot"] - inertia * traj["theta_dot"]
    assert np.abs(about - m * r * v0).max() < 1e-14
    assert np.abs(traj.multiplier("floor_friction_1")[~rolling] + mu * m * g).max() < 1e-12


def test_a_puck_pushed_sideways_curves_stops_and_sticks():
    """Two sliding velocities: the sliding direction turns under a side force below
    ``mu m g``, against the sliding equations integrated by SciPy."""
    push = 0.5 * mu * g
    puck = System([X, Y, Z], kinetic=(X.diff() ** 2 + Y.diff() ** 2 + Z.diff() ** 2) / 2,
                  potential=g * Y - push * Z,
                  constraints=[Unilateral(Y, name="floor", friction=mu,
                                          tangents=[X.diff(), Z.diff()])])
    traj = puck.simulate((0.0, 1.5), {"x": 0.0, "y": 0.0, "z": 0.0}, {"x": 2.0},
                         rtol=1e-11, atol=1e-13)
    assert traj.success, traj.message

    def sliding(t, s):
        vx, vz = s[:2]
        speed = np.hypot(vx, vz)
        return [-mu * g * vx / speed, push - mu * g * vz / speed, vx, vz]

    def stops(t, s):
        return np.hypot(s[0], s[1]) - 1e-12
    stops.terminal = True
    ref = solve_ivp(sliding, (0.0, 1.5), [2.0, 0.0, 0.0, 0.0], method="DOP853",
                    rtol=1e-13, atol=1e-15, events=stops)
    t_stop = ref.t_events[0][0]
    (t_switch,) = switch_times(traj)
    assert abs(t_switch - t_stop) < 1e-9
    assert abs(traj["x"][-1] - ref.y[2, -1]) < 1e-9
    assert abs(traj["z"][-1] - ref.y[3, -1]) < 1e-9
    after = traj.t >= t_switch
    assert np.abs(traj["z_dot"][after]).max() < 1e-14  # stuck, the side force held
    held = np.hypot(traj.multiplier("floor_friction_1"), traj.multiplier("floor_friction_2"))
    assert np.abs(held[after] - push).max() < 1e-12
    assert (held <= mu * traj.multiplier("floor") + 1e-12).all()  # in the cone throughout


def test_a_sampled_push_slides_a_block_which_stops_after_the_push_ends():
    """A push of ``2 mu m g`` held by a zero-order hold (samples every 0.1 s, the push
    off from t = 0.25): sliding at ``mu g`` until the sample at 0.3 turns it off, then
    slowing at ``mu g`` to rest at 0.6, where it sticks."""
    u = sp.Symbol("u")
    pushed = block(inputs=[u], generalized_forces=[u, 0])
    traj = pushed.simulate((0.0, 1.0), {"x": 0.0, "y": 0.0},
                           inputs={"u": lambda t: 2 * mu * g if t < 0.25 else 0.0},
                           sample_time=0.1)
    assert traj.success, traj.message
    a = mu * g
    x, v, t = traj["x"], traj["x_dot"], traj.t
    pushing, slowing, resting = t <= 0.3, (t > 0.3) & (t < 0.6), t >= 0.6
    assert np.abs(v[pushing] - a * t[pushing]).max() < 1e-12
    assert np.abs(v[slowing] - a * (0.6 - t[slowing])).max() < 1e-12
    assert np.abs(x[resting] - a * 0.3**2).max() < 1e-12 and np.abs(v[resting]).max() < 1e-12
    assert abs(switch_times(traj)[-1] - 0.6) < 1e-12  # stopping is the last switch


def box_on_two_corners(alpha: float = 0.0, push: sp.Symbol | None = None) -> System:
    """A planar box (half width ``B``, half height ``H``, unit mass) standing on its two
    bottom corners, each a frictional contact, on a floor tilted by ``alpha``; pushed
    along it by the input ``push`` at its centre of mass, if given. Its corners slide
    along one row (they move together): their friction is statically indeterminate
    while they stick."""
    inertia = ((2 * B) ** 2 + (2 * H) ** 2) / 12
    corners = []
    for name, side in (("front", 1), ("back", -1)):
        px = X + side * B * sp.cos(TH) + H * sp.sin(TH)
        py = Y + side * B * sp.sin(TH) - H * sp.cos(TH)
        corners.append(Unilateral(py, name=name, friction=mu, tangents=[px.diff()]))
    return System([X, Y, TH], kinetic=(X.diff() ** 2 + Y.diff() ** 2) / 2
                  + inertia / 2 * TH.diff() ** 2,
                  potential=g * (Y * np.cos(alpha) - X * np.sin(alpha)), constraints=corners,
                  inputs=[] if push is None else [push],
                  generalized_forces=None if push is None else [push, 0, 0])


B, H = 0.5, 0.2


def test_a_box_sliding_on_two_corners_loads_its_front_corner_and_stops():
    """Friction ``mu m g`` at the floor, ``H`` below the centre, tips the box forward:
    the front corner carries ``m g / 2 + mu m g H / (2 B)``, the back one the rest."""
    v0 = 2.0
    traj = box_on_two_corners().simulate((0.0, 1.0), {"x": 0.0, "y": H, "theta": 0.0},
                                         {"x": v0})
    assert traj.success, traj.message
    (t_stop,) = switch_times(traj)
    assert abs(t_stop - v0 / (mu * g)) < 1e-13
    sliding = traj.t < t_stop
    front, back = traj.multiplier("front"), traj.multiplier("back")
    assert np.abs(front[sliding] - (g / 2 + mu * g * H / (2 * B))).max() < 1e-12
    assert np.abs(back[sliding] - (g / 2 - mu * g * H / (2 * B))).max() < 1e-12
    for name, normal in (("front", front), ("back", back)):  # each on its cone
        assert np.abs(traj.multiplier(f"{name}_friction_1")[sliding]
                      + mu * normal[sliding]).max() < 1e-12
    assert np.abs(traj["theta"]).max() < 1e-14
    assert abs(traj["x"][-1] - v0**2 / (2 * mu * g)) < 1e-13


def test_a_box_on_two_corners_pushed_harder_and_harder_slips_on_both_at_once():
    u, k = sp.Symbol("u"), 5.0
    traj = box_on_two_corners(push=u).simulate(
        (0.0, 1.0), {"x": 0.0, "y": H, "theta": 0.0}, inputs={"u": lambda t: k * t})
    assert traj.success, traj.message
    (t_slip,) = switch_times(traj)
    assert abs(t_slip - mu * g / k) < 1e-13
    moving = traj.t > t_slip
    assert np.abs(traj["x"][~moving]).max() < 1e-15
    assert np.abs(traj["x"][moving] - k * (traj.t[moving] - t_slip) ** 3 / 6).max() < 1e-12


@pytest.mark.parametrize("alpha", [0.2, 0.4])
def test_a_box_on_two_corners_on_an_incline_sticks_or_slides(alpha):
    traj = box_on_two_corners(alpha).simulate((0.0, 0.5),
                                              {"x": 0.0, "y": H, "theta": 0.0})
    assert traj.success, traj.message
    if np.tan(alpha) < mu:  # held, each corner using tan(alpha) of its normal force
        assert np.abs(traj["x"]).max() < 1e-14
        for name in ("front", "back"):
            ratio = traj.multiplier(f"{name}_friction_1") / traj.multiplier(name)
            assert np.abs(ratio + np.tan(alpha)).max() < 1e-12
    else:
        a = g * (np.sin(alpha) - mu * np.cos(alpha))
        assert np.abs(traj["x"] - a * traj.t**2 / 2).max() < 1e-12


@pytest.mark.parametrize("mu_impact", [0.05, 0.3])
def test_a_ball_landing_without_spin_takes_a_coulomb_impulse(mu_impact):
    """A sphere dropped from ``h`` moving at ``v`` without spin lands with the normal
    impulse ``m (1 + e) sqrt(2 g h)``; friction's impulse stops its sliding where
    ``mu P_n >= 2/7 m v`` (then ``x' = 5/7 v``, rolling), else takes ``mu P_n`` off
    its speed and spins it by ``mu P_n r / I``."""
    m, r, v, h, e = 1.0, 0.1, 2.0, 0.5, 0.5
    inertia = 2 / 5 * m * r**2
    ball = System([X, Y, TH], kinetic=m / 2 * (X.diff() ** 2 + Y.diff() ** 2)
                  + inertia / 2 * TH.diff() ** 2, potential=m * g * Y,
                  constraints=[Unilateral(Y - r, name="floor", restitution=e,
                                          friction=mu_impact,
                                          tangents=[X.diff() + r * TH.diff()])])
    traj = ball.simulate((0.0, 0.4), {"y": r + h}, {"x": v})
    assert traj.success, traj.message
    first = traj.contacts.impacts[0]
    assert abs(first.t - np.sqrt(2 * h / g)) < 1e-13
    falling = np.sqrt(2 * g * h)
    normal = m * (1 + e) * falling
    assert abs(first.impulses[0] - normal) < 1e-12
    if mu_impact * normal >= 2 / 7 * m * v:  # it grips: rolling as it leaves
        expected = [5 / 7 * v, e * falling, -5 / 7 * v / r]
    else:
        expected = [v - mu_impact * normal / m, e * falling, -mu_impact * normal * r / inertia]
    assert np.abs(first.qd_after - expected).max() < 1e-12
    kinetic = lambda qd: m / 2 * (qd[0] ** 2 + qd[1] ** 2) + inertia / 2 * qd[2] ** 2  # noqa: E731
    assert abs(first.energy_lost - (kinetic(first.qd_before) - kinetic(first.qd_after))) < 1e-12


def test_housners_block_rocks_as_on_rough_ground_where_friction_holds_its_corners():
    """A corner landing with ``mu`` above what the impact needs grips as a rough one:
    each impact keeps Housner's ``1 - 3/2 sin(alpha)^2`` of the angular velocity."""
    from test_rough import HOUSNER, block, tilted  # the rough block's model and start

    traj = block(0.5).simulate((0.0, 2.5), tilted(-0.1))
    assert traj.success, traj.message
    impacts = traj.contacts.impacts
    assert len(impacts) >= 3
    for hit in impacts[:3]:
        assert hit.qd_after[2] / hit.qd_before[2] == pytest.approx(HOUSNER, rel=1e-10)


def test_a_block_rocking_and_sliding_settles_flat_on_both_corners():
    """With ``mu = 0.1`` its corners slide as it rocks; the rocking dies out in
    impacts ever closer together (infinitely many in a finite time, rigidly), until
    every corner moves slower than its rest speed and the block rests flat on both,
    each carrying half its weight. Friction and the impacts only take energy."""
    from test_rough import G, M, block, tilted

    traj = block(0.1).simulate((0.0, 2.5), tilted(-0.1), t_eval=np.linspace(0.0, 2.5, 501))
    assert traj.success, traj.message
    assert traj.contacts.closed_at(traj.t[-1:]).all()  # both corners at the end
    assert abs(traj["theta"][-1]) < 1e-9
    for name in ("right", "left"):
        assert abs(traj.multiplier(name)[-1] - M * G / 2) < 1e-9
    total = traj.energy + traj.contacts.energy_lost_by(traj.t)
    assert np.all(np.diff(total) <= 1e-9 * abs(total[0]))
