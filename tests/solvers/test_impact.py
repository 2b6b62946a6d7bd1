"""An impact from the KKT matrix on the acting rows (``solvers/impact.py``).

References: closed forms of one-dimensional collisions (momentum conserved, Newton's
law on the relative velocity), a pendulum striking a wall at an angle (the rod holding,
the rate along the circle reversed times ``e``, the wall's impulse from the momentum
along the tangent), and the simultaneous solution of a three-ball cradle,
``[-1/3, 2/3, 2/3]``, worked by hand.
"""

from __future__ import annotations

import numpy as np
import pytest

from dalembert import Holonomic, System, coordinates
from dalembert.solvers.impact import impact

x1, x2, x3 = coordinates("x1 x2 x3")
x, y = coordinates("x y")


def balls(masses: list[float], gaps: int) -> System:
    coords = [x1, x2, x3][:len(masses)]
    kinetic = sum(m / 2 * c.diff() ** 2 for m, c in zip(masses, coords))
    contacts = [Holonomic(coords[k + 1] - coords[k], name=f"contact{k + 1}")
                for k in range(gaps)]
    return System(coords, kinetic=kinetic, constraints=contacts)


@pytest.mark.parametrize("e", [0.0, 0.6, 1.0])
def test_two_balls_on_a_line(e):
    m1, m2, v1, v2 = 1.0, 3.0, 2.0, -0.5
    after = impact(balls([m1, m2], 1).numeric(), 0.0, np.zeros(2), np.array([v1, v2]), [0], e)
    common = (m1 * v1 + m2 * v2) / (m1 + m2)
    expected = [common - m2 * e * (v1 - v2) / (m1 + m2), common + m1 * e * (v1 - v2) / (m1 + m2)]
    np.testing.assert_allclose(after.qd, expected, rtol=1e-14)
    reduced = m1 * m2 / (m1 + m2)
    assert after.impulses[0] == pytest.approx(reduced * (1 + e) * (v1 - v2), rel=1e-14)
    assert after.energy_lost == pytest.approx(0.5 * reduced * (1 - e**2) * (v1 - v2) ** 2,
                                              rel=1e-13, abs=1e-14)


@pytest.mark.parametrize("theta", [0.0, 0.4])
def test_a_pendulum_striking_a_wall(theta):
    """A unit bob on a unit rod, at the angle theta from the bottom, moving along the
    circle at 1.5 m/s, strikes the wall ``x <= sin(theta)``: the rod holds, the speed
    along the circle reverses times e, and the wall's impulse is ``(1 + e) v / cos(theta)``."""
    e, v = 0.7, 1.5
    wall = np.sin(theta)
    pendulum = System([x, y], kinetic=(x.diff() ** 2 + y.diff() ** 2) / 2, potential=9.81 * y,
                      constraints=[Holonomic(x**2 + y**2 - 1, name="rod"),
                                   Holonomic(wall - x, name="wall")])
    q = np.array([np.sin(theta), -np.cos(theta)])
    tangent = np.array([np.cos(theta), np.sin(theta)])
    after = impact(pendulum.numeric(), 0.0, q, v * tangent, [0, 1], np.array([0.0, e]))
    np.testing.assert_allclose(after.qd, -e * v * tangent, rtol=1e-13, atol=1e-15)
    assert after.impulses[1] == pytest.approx((1 + e) * v / np.cos(theta), rel=1e-13)
    assert after.qd @ q == pytest.approx(0.0, abs=1e-14)  # the rod's rate stays 0


def test_three_balls_at_once_and_one_contact_alone():
    cradle = balls([1.0, 1.0, 1.0], 2).numeric()
    before = np.array([1.0, 0.0, 0.0])
    both = impact(cradle, 0.0, np.zeros(3), before, [0, 1], 1.0)
    # v2 - v1 = 1, v3 - v2 = 0, v1 + v2 + v3 = 1 (momentum): by hand
    np.testing.assert_allclose(both.qd, [-1 / 3, 2 / 3, 2 / 3], rtol=1e-14)
    assert (both.impulses > 0).all() and both.energy_lost == pytest.approx(0.0, abs=1e-14)
    first = impact(cradle, 0.0, np.zeros(3), before, np.array([True, False]), 1.0)
    np.testing.assert_allclose(first.qd, [0.0, 1.0, 0.0], atol=1e-15)
    assert first.impulses[1] == 0.0


def test_bad_rows_and_restitution_are_named():
    num = balls([1.0, 1.0], 1).numeric()
    with pytest.raises(ValueError, match="indices between 0 and 0"):
        impact(num, 0.0, np.zeros(2), np.ones(2), [3])
    with pytest.raises(ValueError, match="restitution must be one finite number"):
        impact(num, 0.0, np.zeros(2), np.ones(2), [0], [0.5, 0.5])
