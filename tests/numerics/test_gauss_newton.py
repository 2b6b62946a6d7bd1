"""Gauss-Newton's least-change projection: far starts, the rounding floor, no solution.

References are closed forms: the least-change projection onto a circle about the
origin is along the ray through the start.
"""

from __future__ import annotations

import numpy as np
import pytest

from dalembert.numerics.gauss_newton import ACCEPT_TOL, gauss_newton, newton_progress


def circle(radius: float):
    return (lambda q: np.array([q @ q - radius**2]), lambda q: 2.0 * q[None, :])


@pytest.mark.parametrize("start", [(0.1, -1.0), (0.01, -0.02), (1e-3, 0.0), (30.0, 40.0)])
def test_far_starts_reach_the_point_on_the_ray_with_a_line_search(start):
    psi, jacobian = circle(2.0)
    q = np.array(start)
    found = gauss_newton(psi, jacobian, q, line_search=True)
    assert found.converged
    np.testing.assert_allclose(found.q, 2.0 * q / np.hypot(*q), rtol=0, atol=1e-14)


def test_a_full_step_that_gains_less_than_half_is_progress():
    # r = 1 -> 2.5 for radius 2: |psi| goes 3 -> 2.25, then quadratically to zero
    psi, jacobian = circle(2.0)
    found = gauss_newton(psi, jacobian, np.array([0.1, -1.0]))
    assert found.converged
    np.testing.assert_allclose(found.q, 2.0 * np.array([0.1, -1.0]) / np.hypot(0.1, 1.0),
                               rtol=0, atol=1e-14)
    # without a line search an overshooting step (r = 0.022 -> 89) ends it
    assert not gauss_newton(psi, jacobian, np.array([0.01, -0.02])).converged


def test_a_rounding_floor_ends_the_iteration_without_searching():
    # psi carries noise of 1e-12 (above the target, below the acceptance): Newton
    # must stop there after a few evaluations, not halve its way through the floor.
    rng = np.random.default_rng(0)
    calls = []

    def psi(q):
        calls.append(1)
        return np.array([q[0] - 1.0 + 1e-12 * rng.uniform(-1, 1)])

    found = gauss_newton(psi, lambda q: np.ones((1, 1)), np.array([5.0]), line_search=True)
    assert found.converged and abs(found.q[0] - 1.0) < 1e-11
    assert len(calls) < 10


def test_no_solution_is_not_converged():
    psi = lambda q: np.array([q @ q + 1.0])  # noqa: E731
    found = gauss_newton(psi, lambda q: 2.0 * q[None, :], np.array([0.3, 0.4]),
                         line_search=True)
    assert not found.converged and found.residual >= 1.0


def test_progress_is_halving_near_the_floor_and_any_gain_far_from_it():
    far, near = np.array([3.0]), np.array([0.5 * ACCEPT_TOL])
    assert newton_progress(np.array([2.25]), far, 1.0)
    assert not newton_progress(np.array([3.5]), far, 1.0)
    assert not newton_progress(0.9 * near, near, 1.0)
    assert newton_progress(0.4 * near, near, 1.0)
    assert newton_progress(np.array([1.0]), np.array([np.inf]), 1.0)
    assert not newton_progress(np.array([np.nan]), far, 1.0)
