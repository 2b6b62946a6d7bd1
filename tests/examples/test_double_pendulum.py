"""The Cartesian double pendulum against its two-angle equations and the closed-form modes."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from dalembert.examples import double_pendulum as example

pytestmark = pytest.mark.filterwarnings("error::dalembert.errors.InitialConditionsAdjusted")

G, L = 9.81, 1.0
TIMES = np.linspace(0.0, example.T_END, 1001)


@pytest.fixture(scope="module")
def system():
    return example.build(g_value=G, l_value=L)


def two_angle_pendulum(times: np.ndarray, g: float, length: float) -> np.ndarray:
    """Angles ``theta1, theta2`` (rows) from the minimal equations, integrated separately.

    Equal masses and lengths, ``d = theta1 - theta2``:
    ``2 th1'' + cos(d) th2'' = -th2'^2 sin(d) - 2 (g/l) sin(th1)`` and
    ``cos(d) th1'' + th2'' = th1'^2 sin(d) - (g/l) sin(th2)``.
    """
    def rhs(_t, u):
        th1, th2, w1, w2 = u
        d = th1 - th2
        mass = np.array([[2.0, np.cos(d)], [np.cos(d), 1.0]])
        force = [-w2**2 * np.sin(d) - 2 * g / length * np.sin(th1),
                 w1**2 * np.sin(d) - g / length * np.sin(th2)]
        return [w1, w2, *np.linalg.solve(mass, force)]

    sol = solve_ivp(rhs, (times[0], times[-1]), [*example.THETA0, 0.0, 0.0],
                    method="DOP853", rtol=1e-13, atol=1e-14, t_eval=times)
    assert sol.success
    return sol.y[:2]


def test_checks_contract(system):
    traj = system.simulate((0.0, 2.0), **example.INITIAL)
    errors = example.checks(system, traj)
    assert set(errors) == {"relative energy error", "max position residual",
                           "max velocity residual"}
    assert max(errors.values()) < 1e-9


@pytest.mark.validation
def test_same_motion_as_the_two_angle_equations(system):
    traj = system.simulate((0.0, example.T_END), **example.INITIAL, t_eval=TIMES)
    th1, th2 = two_angle_pendulum(TIMES, G, L)
    x1, y1 = L * np.sin(th1), -L * np.cos(th1)
    reference = np.column_stack([x1, y1, x1 + L * np.sin(th2), y1 - L * np.cos(th2)])
    assert traj.success
    # measured 4.7e-12 over 10 s (positions of order 1)
    assert np.abs(traj.q - reference).max() < 1e-8
    e = traj.energy
    assert np.abs(e - e[0]).max() / abs(e[0]) < 1e-10  # measured 3.3e-12


@pytest.mark.parametrize(("g", "length"), [(9.81, 1.0), (3.7, 0.6)])
def test_linearized_frequencies_are_the_closed_form(g, length):
    system = example.build(g_value=g, l_value=length)
    guess = {k: v * length for k, v in example.EQUILIBRIUM_GUESS.items()}
    eq = system.equilibrium(guess)
    lin = system.linearize(eq)
    expected = np.array([2 - np.sqrt(2), 2 + np.sqrt(2)]) * g / length
    assert eq.stability == lin.stability == "stable"
    np.testing.assert_allclose(eq.q, [0, -length, 0, -2 * length], atol=1e-12)
    np.testing.assert_allclose(lin.omega_squared, expected, rtol=1e-12)  # measured 2e-16
    # mode shapes: th2 / th1 = +-sqrt(2), so x2 / x1 = 1 +- sqrt(2) at the bottom
    shapes = lin.mode_shapes
    ratios = shapes[2] / shapes[0]
    np.testing.assert_allclose(ratios, [1 + np.sqrt(2), 1 - np.sqrt(2)], rtol=1e-10)
    np.testing.assert_allclose(shapes[[1, 3]], 0.0, atol=1e-12)  # no vertical motion


def test_draw_joins_pivot_and_both_bobs(system):
    q = np.array([example.INITIAL["q0"][k] for k in example.NAMES])
    (line,) = example.draw(system, q)
    np.testing.assert_allclose(np.linalg.norm(np.diff(line, axis=0), axis=1), L, rtol=1e-14)
