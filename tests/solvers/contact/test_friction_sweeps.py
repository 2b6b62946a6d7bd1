"""The contact impulses with Coulomb friction (``solve_friction``) where they are not
unique, against closed forms.

A box on its four bottom corners (half sides ``a, b``, ``c`` above them), its Delassus
matrix built here by hand: a corner ``r`` from the centre moves along ``e`` at
``e . v + (r x e) . omega``, so its row is ``[e, r x e]`` and ``W = J M^-1 J^T``
(``M = diag(m, m, m, I)``). Four coplanar corners: the normal rows have rank 3, the
eight tangent rows rank 3 (12 rows, 6 velocities), so the impulses are not unique,
only the velocities they leave and the total force and moment on the box. In the
frame of an incline of slope ``alpha``, gravity is ``g sin(alpha)`` down the slope
and ``g cos(alpha)`` into it; one step of ``h`` from rest:

- ``tan(alpha) < mu``: the box stays at rest; the normal impulses add up to
  ``m g h cos(alpha)``, the friction impulses to ``m g h sin(alpha)`` up the slope;
- sliding at ``v0`` (flat, or down an incline steeper than ``mu``): the friction
  impulses add up to ``mu`` times the normal ones, against the sliding, and the box
  leaves at ``v0 + g h (sin(alpha) - mu cos(alpha))``, not turning.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from dalembert.errors import ContactError
from dalembert.solvers.contact import impulses
from dalembert.solvers.contact.impulses import solve_friction

g, h, mu = 9.81, 1e-3, 0.5
m, a, b, c = 2.0, 0.1, 0.075, 0.05
INERTIA = m / 3 * np.diag([b**2 + c**2, a**2 + c**2, a**2 + b**2])
CORNERS = [np.array([sx * a, sy * b, -c]) for sx, sy in [(-1, -1), (1, -1), (1, 1), (-1, 1)]]
AXES = np.eye(3)


def box_problem(alpha: float, v0: float = 0.0):
    """``W``, ``q``, the tangent groups and ``J``, ``M^-1`` of one step of the box on
    an incline of ``alpha`` (in its frame), sliding at ``v0`` down it (along -x)."""
    normal = [np.concatenate([AXES[2], np.cross(r, AXES[2])]) for r in CORNERS]
    tangent = [np.concatenate([e, np.cross(r, e)]) for r in CORNERS for e in AXES[:2]]
    J = np.array(normal + tangent)
    inverse = np.linalg.inv(np.block([[m * np.eye(3), np.zeros((3, 3))],
                                      [np.zeros((3, 3)), INERTIA]]))
    gravity = g * np.array([-math.sin(alpha), 0.0, -math.cos(alpha)])
    free = np.concatenate([np.array([-v0, 0.0, 0.0]) + h * gravity, np.zeros(3)])
    groups = [np.array([4 + 2 * k, 5 + 2 * k]) for k in range(4)]
    return J @ inverse @ J.T, J @ free, groups, J, inverse, free


def solved(alpha: float, v0: float = 0.0):
    W, q, groups, J, inverse, free = box_problem(alpha, v0)
    P = solve_friction(W, q, np.full(4, mu), groups)
    normals, friction = P[:4], P[4:].reshape(4, 2)
    assert (normals >= 0).all()  # each corner's impulse in its cone
    assert (np.linalg.norm(friction, axis=1) <= mu * normals * (1 + 1e-12)).all()
    return normals, friction, free + inverse @ J.T @ P


def at_rest(after: np.ndarray) -> bool:
    """The velocity, and the spin times the box's size, zero to rounding (a sweep's
    velocities settle to ``1e-14`` of the step's)."""
    return bool(np.abs(after[:3]).max() < 1e-13 and a * np.abs(after[3:]).max() < 1e-13)


def test_the_box_on_its_corners_is_a_problem_of_impulses_not_unique():
    W = box_problem(0.0)[0]
    assert np.linalg.matrix_rank(W[:4, :4]) == 3
    assert np.linalg.matrix_rank(W[4:, 4:]) == 3
    assert np.linalg.matrix_rank(W) == 6


@pytest.mark.parametrize("alpha", [0.0, 0.2, 0.4, math.atan(mu) - 0.01])
def test_a_box_at_rest_on_an_incline_it_grips_stays_at_rest(alpha):
    normals, friction, after = solved(alpha)
    assert at_rest(after)
    assert abs(normals.sum() - m * g * h * math.cos(alpha)) < 1e-12 * m * g * h
    total = friction.sum(axis=0)  # up the slope (+x), nothing across it
    assert abs(total[0] - m * g * h * math.sin(alpha)) < 1e-12 * m * g * h
    assert abs(total[1]) < 1e-12 * m * g * h


@pytest.mark.parametrize(("alpha", "v0"), [(0.0, 1.0), (0.0, 0.02), (0.5, 0.0),
                                           (0.6, 0.3)])
def test_a_box_sliding_on_its_corners_is_braked_by_mu_times_its_weight(alpha, v0):
    normals, friction, after = solved(alpha, v0)
    down = v0 + g * h * (math.sin(alpha) - mu * math.cos(alpha))  # along -x
    assert down > 0  # still sliding at the step's end
    assert abs(after[0] + down) < 1e-13
    assert at_rest(np.concatenate([[0.0], after[1:]]))  # not lifted, not turned
    assert abs(normals.sum() - m * g * h * math.cos(alpha)) < 1e-12 * m * g * h
    total = friction.sum(axis=0)
    assert abs(total[0] - mu * normals.sum()) < 1e-12 * m * g * h
    assert abs(total[1]) < 1e-12 * m * g * h


@pytest.mark.parametrize(("alpha", "v0"), [(0.4, 0.0), (0.6, 0.3)])
def test_sweeps_started_anywhere_leave_the_same_velocities(alpha, v0):
    """The time-stepping mode starts each step's sweeps from the step before's
    impulses: from the solution, from another of the (not unique) solutions, from a
    start outside the cone, the velocities after the step are the closed form's (at
    rest, or braked by ``mu`` times the weight), and the start within rounding of a
    solution is one (it is kept: no drift along the impulses' null space)."""
    W, q, groups, J, inverse, free = box_problem(alpha, v0)
    cold = solve_friction(W, q, np.full(4, mu), groups)
    other = cold.copy()
    other[:4] += 0.1 * m * g * h * np.array([1.0, -1.0, 1.0, -1.0])  # the normals' null space
    for start in (cold, other, np.full(len(q), 1.0)):
        P = solve_friction(W, q, np.full(4, mu), groups, start)
        after = free + inverse @ J.T @ P
        down = max(v0 + g * h * (math.sin(alpha) - mu * math.cos(alpha)), 0.0)
        assert abs(after[0] + down) < 1e-13
        assert at_rest(np.concatenate([[0.0], after[1:]]))
    assert np.abs(solve_friction(W, q, np.full(4, mu), groups, cold) - cold).max() \
        < 1e-12 * m * g * h


def test_a_box_slowed_to_rest_within_the_step_grips():
    v0 = 0.5 * mu * g * h  # friction could take twice this in the step
    normals, friction, after = solved(0.0, v0)
    assert at_rest(after)
    assert abs(friction.sum(axis=0)[0] - m * v0) < 1e-12 * m * g * h
    assert abs(normals.sum() - m * g * h) < 1e-12 * m * g * h


def test_a_particle_sliding_with_three_tangent_rows_of_rank_two():
    """A sphere's sliding velocity in space is three rows (its world components in the
    tangent plane), of rank 2: its tangential block is singular."""
    n = np.array([0.0, 0.6, 0.8])
    J = np.vstack([n, np.eye(3) - np.outer(n, n)])
    v0 = np.array([1.0, -0.8, 0.6])  # along the plane
    free = v0 - h * g * n  # gravity along -n only: the plane is the floor here
    W, q = J @ J.T, J @ free  # unit mass
    P = solve_friction(W, q, np.array([mu]), [np.array([1, 2, 3])])
    after = free + J.T @ P
    assert abs(P[0] - g * h) < 1e-14
    assert np.abs(after - v0 * (1 - mu * g * h / np.linalg.norm(v0))).max() < 1e-14


def test_sweeps_that_do_not_converge_raise(monkeypatch):
    W, q, groups, *_ = box_problem(0.4)
    monkeypatch.setattr(impulses, "MAX_SWEEPS", 3)
    with pytest.raises(ContactError, match=r"friction .*\(4 contacts\) did not converge "
                                           r"in 3 sweeps \(their velocities still "
                                           r"changed by .* of their size"):
        solve_friction(W, q, np.full(4, mu), groups)
