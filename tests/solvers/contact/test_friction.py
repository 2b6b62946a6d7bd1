"""Coulomb friction in the time-stepping contact mode (``solvers/contact/time_stepping.py``).

References (closed forms): a block sliding on a floor decelerates at ``mu g`` and stops
at ``v0 / (mu g)``; on an incline it sticks when ``tan(alpha) < mu`` and otherwise
slides at ``g (sin(alpha) - mu cos(alpha))``; a sphere launched sliding without spin
rolls from ``t = 2 v0 / (7 mu g)`` at ``5/7 v0`` (its angular momentum about the
contact line is conserved: friction and the normal force pass through it). The
scheme's impulses over a step are exact for these constant forces, so the velocities
match to rounding on the step grid, away from the step where sliding stops.
"""

from __future__ import annotations

import numpy as np
import pytest

from dalembert import ConstraintError, System, Unilateral, coordinates

g, mu = 9.81, 0.3
X, Y, TH = coordinates("x y theta")
H = 1e-3


def block(alpha: float = 0.0) -> System:
    """A unit block on a floor ``y >= 0`` tilted by ``alpha`` (gravity along -y
    rotated: the floor is the incline, ``x`` down the slope)."""
    return System([X, Y], kinetic=(X.diff() ** 2 + Y.diff() ** 2) / 2,
                  potential=g * (Y * np.cos(alpha) - X * np.sin(alpha)),
                  constraints=[Unilateral(Y, name="floor", friction=mu,
                                          tangents=[X.diff()])])


def test_a_sliding_block_decelerates_at_mu_g_and_stops():
    v0 = 2.0
    traj = block().simulate((0.0, 1.0), {"x": 0.0, "y": 0.0}, {"x": v0},
                            contact_mode="time-stepping", contact_step=H)
    assert traj.success, traj.message
    stop = v0 / (mu * g)
    sliding = traj.t < stop - H
    assert np.abs(traj["x_dot"][sliding] - (v0 - mu * g * traj.t[sliding])).max() < 1e-12
    assert np.abs(traj["x_dot"][traj.t > stop + H]).max() < 1e-12  # stopped, stays
    assert abs(traj["x"][-1] - v0**2 / (2 * mu * g)) < v0 * H  # within a step's travel
    # the friction force: mu times the normal force, against the motion, while sliding
    friction, normal = traj.multiplier("floor_friction_1"), traj.multiplier("floor")
    assert np.abs(normal[1:] - g).max() < 1e-9
    assert np.abs(friction[1:][sliding[1:]] + mu * g).max() < 1e-9


@pytest.mark.parametrize("alpha", [0.2, 0.4])  # tan 0.2 = 0.203 < 0.3 < tan 0.4 = 0.423
def test_a_block_on_an_incline_sticks_or_slides(alpha):
    traj = block(alpha).simulate((0.0, 0.5), {"x": 0.0, "y": 0.0},
                                 contact_mode="time-stepping", contact_step=H)
    speed = traj["x_dot"]
    if np.tan(alpha) < mu:
        assert np.abs(speed).max() < 1e-12 and np.abs(traj["x"]).max() < 1e-12
        assert abs(traj.multiplier("floor_friction_1")[-1] + g * np.sin(alpha)) < 1e-9
    else:
        a = g * (np.sin(alpha) - mu * np.cos(alpha))
        assert np.abs(speed - a * traj.t).max() < 1e-12


def test_a_sphere_launched_sliding_rolls_at_five_sevenths():
    m, r, v0 = 1.0, 0.1, 2.0
    inertia = 2 / 5 * m * r**2
    sphere = System([X, Y, TH], kinetic=m / 2 * (X.diff() ** 2 + Y.diff() ** 2)
                    + inertia / 2 * TH.diff() ** 2, potential=m * g * Y,
                    constraints=[Unilateral(Y - r, name="floor", friction=mu,
                                            tangents=[X.diff() + r * TH.diff()])])
    traj = sphere.simulate((0.0, 0.8), {"y": r}, {"x": v0}, contact_mode="time-stepping",
                           contact_step=H)
    t_roll = 2 * v0 / (7 * mu * g)
    slip = traj["x_dot"] + r * traj["theta_dot"]
    assert np.abs(slip[traj.t > t_roll + H]).max() < 1e-12  # rolling from then on
    assert np.abs(slip[traj.t < t_roll - H]).min() > 0  # sliding before
    assert np.abs(traj["x_dot"][-1] - 5 / 7 * v0) < 1e-12
    # the angular momentum about the contact line (clockwise): m r x' - I theta'
    about = m * r * traj["x_dot"] - inertia * traj["theta_dot"]
    assert np.abs(about - m * r * v0).max() < 1e-12


def test_friction_bad_input_is_named():
    with pytest.raises(ConstraintError, match="friction of unilateral constraint 'floor'"):
        System([X, Y], kinetic=X.diff() ** 2, constraints=[
            Unilateral(Y, name="floor", friction=-0.1, tangents=[X.diff()])])
    with pytest.raises(ConstraintError, match="'floor' has friction but no tangents"):
        System([X, Y], kinetic=X.diff() ** 2, constraints=[
            Unilateral(Y, name="floor", friction=0.3)])
    with pytest.raises(ConstraintError, match="not linear in the velocities"):
        System([X, Y], kinetic=X.diff() ** 2, constraints=[
            Unilateral(Y, name="floor", friction=0.3, tangents=[X.diff() ** 2])])
