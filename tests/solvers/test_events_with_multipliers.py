"""Event functions that see the multipliers: a string going slack.

A particle on a string of length l is launched from the bottom with speed v0,
v0^2 = 3.5 g l, too slow to loop: the string's tension

    T = m (v^2 / l + g cos(theta)) = m (v0^2 / l - 2 g + 3 g cos(theta))

(theta from the bottom, by energy) vanishes at cos(theta*) = -1/2, theta* = 120 deg.
The time to get there is the quadrature t* = int_0^theta* l dtheta / v(theta),
computed here with SciPy's ``quad`` (independent of the simulation). The event is
``lambda t, q, qd, lam: lam[0]``: with the rod written as x^2 + y^2 - l^2 = 0 the
tension is -2 lambda l, so the multiplier crosses zero upwards.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import quad

from dalembert import Holonomic, System, coordinates

G, L, M = 9.81, 1.3, 0.7
V0 = np.sqrt(3.5 * G * L)
x, y = coordinates("x y")


def slack_time() -> float:
    theta_star = np.arccos(-0.5)
    speed = lambda th: np.sqrt(V0**2 - 2 * G * L * (1 - np.cos(th)))  # noqa: E731
    value, _ = quad(lambda th: L / speed(th), 0.0, theta_star, epsabs=0, epsrel=1e-13,
                    limit=200)
    return value


@pytest.mark.parametrize("backend", ["c", "python"])
def test_a_string_goes_slack_at_the_closed_form_time(backend):
    string = System([x, y], kinetic=M / 2 * (x.diff() ** 2 + y.diff() ** 2),
                    potential=M * G * y, constraints=[Holonomic(x**2 + y**2 - L**2,
                                                                name="string")])

    def slack(t, q, qd, lam):
        return lam[0]

    slack.terminal, slack.direction = True, 1
    traj = string.simulate((0, 5), {x: 0.0, y: -L}, {x: V0, y: 0.0}, events=[slack],
                           backend=backend)
    assert traj.status == "event"
    assert traj.t_events[0][0] == pytest.approx(slack_time(), abs=1e-10)
    q = traj.y_events[0][0][:2]
    assert np.degrees(np.arctan2(q[0], -q[1])) == pytest.approx(120.0, abs=1e-7)
    assert abs(traj.multipliers[-1, 0]) < 1e-8  # the tension there: zero
