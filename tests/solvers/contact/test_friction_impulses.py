"""The friction impulses of an impact, recorded with its normal impulses.

References (independent of the code's rows):

- a sphere (``I = 2/5 m r^2``) landing on a floor with Coulomb friction: its contact
  point's sliding velocity ``v_t = x' + r theta'`` changes by ``J_t (1/m + r^2/I) =
  7/2 J_t / m``, so where it grips (``mu J_n >= 2/7 m |v_t|``, or a rough floor)
  ``J_t = -2/7 m v_t``, else ``J_t = -mu J_n sign(v_t)``; the normal impulse is
  ``m (1 + e) sqrt(2 g h)``;
- a body landing on corners: the impulses are the only ones acting, so the sum of
  the normal impulses is ``m`` times the jump of the vertical velocity, that of the
  friction impulses ``m`` times the jump of the horizontal one, and their moments
  about the centre ``I`` times the jump of the angular velocity.
"""

from __future__ import annotations

import math
import zipfile

import numpy as np
import pytest
import test_rough as rough
from test_sliding import B, H, box_on_two_corners

from dalembert import System, TrajectoryFileError, Unilateral, coordinates

G = 9.81
X, Y, TH = coordinates("x y theta")


def ball(mu: float, m: float = 1.0, r: float = 0.1, e: float = 0.5) -> System:
    inertia = 2 / 5 * m * r**2
    return System([X, Y, TH], kinetic=m / 2 * (X.diff() ** 2 + Y.diff() ** 2)
                  + inertia / 2 * TH.diff() ** 2, potential=m * G * Y,
                  constraints=[Unilateral(Y - r, name="floor", restitution=e, friction=mu,
                                          tangents=[X.diff() + r * TH.diff()])])


@pytest.mark.parametrize("mu", [0.05, 0.3, math.inf])
@pytest.mark.parametrize("spin", [0.0, 30.0, -50.0])
def test_a_ball_landing_takes_the_friction_impulse_of_its_sliding(mu, spin):
    m, r, v, h, e = 1.0, 0.1, 2.0, 0.5, 0.5
    traj = ball(mu, m, r, e).simulate((0.0, 0.35), {"y": r + h}, {"x": v, "theta": spin})
    assert traj.success, traj.message
    first = traj.contacts.impacts[0]
    normal = m * (1 + e) * math.sqrt(2 * G * h)
    v_t = v + r * spin
    grips = mu * normal >= 2 / 7 * m * abs(v_t)
    expected = -2 / 7 * m * v_t if grips else -mu * normal * math.copysign(1.0, v_t)
    assert abs(first.impulses[0] - normal) < 1e-12
    (friction,) = first.friction_impulses
    assert friction.shape == (1,)
    assert abs(friction[0] - expected) < 1e-12
    # the friction impulse is all that changes x': m (x'+ - x'-)
    assert abs(m * (first.qd_after[0] - first.qd_before[0]) - friction[0]) < 1e-12



def test_a_box_landing_flat_while_sliding_balances_momentum():
    traj = box_on_two_corners().simulate((0.0, 0.4), {"x": 0.0, "y": H + 0.3, "theta": 0.0},
                                         {"x": 2.0})
    assert traj.success, traj.message
    (hit,) = traj.contacts.impacts
    jump = hit.qd_after - hit.qd_before
    friction = sum(f[0] for f in hit.friction_impulses)
    assert abs(jump[0] - friction) < 1e-12  # unit mass
    assert abs(jump[1] - hit.impulses.sum()) < 1e-12
    # both corners at height -H from the centre, at +-B: moments about the centre
    inertia = ((2 * B) ** 2 + (2 * H) ** 2) / 12
    moment = B * (hit.impulses[0] - hit.impulses[1]) + H * friction
    assert abs(inertia * jump[2] - moment) < 1e-12
    assert friction < 0.0 and jump[1] > 0.0


@pytest.mark.parametrize("mu", [0.1, 0.5, math.inf])
def test_a_rocking_block_landing_on_its_corners_balances_momentum(mu):
    traj = rough.block(mu).simulate((0.0, 2.5), rough.tilted(-0.1))
    assert traj.success, traj.message
    impacts = traj.contacts.impacts
    assert len(impacts) >= 3
    at = {s.t: s.q for s in traj.contacts.switches}
    for hit in impacts:
        q = at[hit.t]
        c, s = math.cos(q[2]), math.sin(q[2])
        jump = hit.qd_after - hit.qd_before
        friction = np.array([f[0] for f in hit.friction_impulses])
        assert abs(rough.M * jump[0] - friction.sum()) < 1e-12
        assert abs(rough.M * jump[1] - hit.impulses.sum()) < 1e-12
        moment = 0.0
        for u, p_n, p_t in zip((rough.B, -rough.B), hit.impulses, friction):
            dx, dy = u * c + rough.H * s, u * s - rough.H * c  # corner (u, -H) from the centre
            moment += dx * p_n - dy * p_t
        assert abs(rough.I_CM * jump[2] - moment) < 1e-12
    assert any(np.abs(np.concatenate(hit.friction_impulses)).max() > 1e-3 for hit in impacts)


def test_friction_impulses_are_saved_and_loaded(tmp_path):
    traj = ball(0.3).simulate((0.0, 0.35), {"y": 0.6}, {"x": 2.0})
    assert traj.contacts.tangents == (1,)
    path = traj.save(tmp_path / "ball.npz")
    again = type(traj).load(path)
    assert again.contacts.tangents == (1,)
    for before, after in zip(traj.contacts.impacts, again.contacts.impacts, strict=True):
        assert np.array_equal(before.friction_impulses[0], after.friction_impulses[0])
    # a file of an earlier version, without them, reads without friction impulses
    older, half = tmp_path / "older.npz", tmp_path / "half.npz"
    for target, left_out in ((older, ("impact_friction_impulses.npy",
                                      "contact_tangents.npy")),
                             (half, ("contact_tangents.npy",))):
        with zipfile.ZipFile(path) as source, zipfile.ZipFile(target, "w") as out:
            for item in source.infolist():
                if item.filename not in left_out:
                    out.writestr(item, source.read(item.filename))
    read = type(traj).load(older)
    assert read.contacts.tangents == (0,)
    assert read.contacts.impacts[0].friction_impulses[0].shape == (0,)
    with pytest.raises(TrajectoryFileError, match="'contact_tangents' is missing"):
        type(traj).load(half)


def test_a_time_step_landing_records_its_friction_impulse():
    """Moreau-Jean: ``M (v+ - v-) = h f + A^T P``; nothing but friction acts along
    ``x``, so its impulse is ``m`` times the jump of ``x'``, in the cone of ``P_n``."""
    m, mu = 1.0, 0.3
    traj = ball(mu, m).simulate((0.0, 0.35), {"y": 0.6}, {"x": 2.0},
                                contact_mode="time-stepping", contact_step=1e-3)
    assert traj.success, traj.message
    hit = traj.contacts.impacts[0]
    (friction,) = hit.friction_impulses
    assert friction.shape == (1,) and friction[0] < 0.0
    assert abs(m * (hit.qd_after[0] - hit.qd_before[0]) - friction[0]) < 1e-12
    assert abs(friction[0]) <= mu * hit.impulses[0] * (1 + 1e-12)
