"""Impact laws and closed contacts (``solvers/contact/laws.py``).

References: Newton's cradle worked by hand (the sequential law: each collision of two
equal balls with ``e = 1`` exchanges their velocities, so the last ball leaves; the
simultaneous law: the first ball against the others moving as one body); a rod
striking a floor with one end, the impulse from the contact point's normal velocity
law and the angular-momentum balance about the centre (closed form); a rod landing
flat on both ends at once (symmetric: no rotation); a block pressed on a floor and
one pulled off it (the sign of the contact force).
"""

from __future__ import annotations

import numpy as np
import pytest
import sympy as sp

from dalembert import ContactError, System, Unilateral, coordinates
from dalembert.solvers.contact.gaps import Gaps
from dalembert.solvers.contact.laws import closed_gaps, resolve_impact


def cradle(count: int, e: float = 1.0) -> tuple[System, Gaps]:
    xs = coordinates(" ".join(f"x{k}" for k in range(count)))
    gaps = [Unilateral(xs[k + 1] - xs[k], name=f"gap{k}", restitution=e)
            for k in range(count - 1)]
    system = System(list(xs), kinetic=sum(x.diff() ** 2 for x in xs) / 2, constraints=gaps)
    return system, Gaps(system.unilateral_names, 0, np.full(count - 1, e),
                        np.full(count - 1, 1e-6))


@pytest.mark.parametrize("count", [3, 5])
def test_cradle_sequential_passes_the_motion_to_the_last_ball(count):
    system, gaps = cradle(count)
    full = system.with_gaps_closed().numeric()
    v = np.zeros(count)
    v[0] = 1.0
    after = resolve_impact(full, gaps, 0.0, np.zeros(count), v, np.ones(count - 1, bool))
    expected = np.zeros(count)
    expected[-1] = 1.0
    assert np.abs(after.qd - expected).max() < 1e-14
    assert after.stages == count - 1
    assert abs(after.energy_lost) < 1e-14
    assert np.all(after.impulses > 0) and abs(after.impulses.sum() - (count - 1)) < 1e-13


@pytest.mark.parametrize("count", [3, 5])
def test_cradle_simultaneous_moves_the_rest_as_one_body(count):
    system, gaps = cradle(count)
    full = system.with_gaps_closed().numeric()
    v = np.zeros(count)
    v[0] = 1.0
    after = resolve_impact(full, gaps, 0.0, np.zeros(count), v, np.ones(count - 1, bool),
                           "simultaneous")
    rest = count - 1  # one ball against a body of mass count - 1, e = 1
    first, others = (1.0 - rest) / (1.0 + rest), 2.0 / (1.0 + rest)
    assert np.abs(after.qd - np.r_[first, [others] * rest]).max() < 1e-14
    assert abs(after.qd.sum() - 1.0) < 1e-14 and abs(after.energy_lost) < 1e-14


@pytest.mark.parametrize("e", [0.0, 0.5, 1.0])
def test_cradle_momentum_and_newton_law_for_any_restitution(e):
    system, gaps = cradle(3, e)
    full = system.with_gaps_closed().numeric()
    for law in ("sequential", "simultaneous"):
        after = resolve_impact(full, gaps, 0.0, np.zeros(3), np.array([2.0, 0.0, 0.0]),
                               np.ones(2, bool), law)
        assert abs(after.qd.sum() - 2.0) < 1e-13  # momentum
        # no ball passes through the next (a sequential impact ends when what still
        # approaches is below rounding, TOUCH_RTOL, relative)
        assert np.all(np.diff(after.qd) >= -1e-9 * 2.0)
        assert after.energy_lost >= -1e-13 and np.all(after.impulses >= -1e-13)


m, L, g = 2.0, 1.5, 9.81
X, Y, TH = coordinates("X Y theta")


def rod(e: float, ends: str = "left") -> System:
    inertia = m * L**2 / 12
    gaps = []
    if ends in ("left", "both"):
        gaps.append(Unilateral(Y - L / 2 * sp.sin(TH), name="left", restitution=e))
    if ends in ("right", "both"):
        gaps.append(Unilateral(Y + L / 2 * sp.sin(TH), name="right", restitution=e))
    return System([X, Y, TH], kinetic=m / 2 * (X.diff() ** 2 + Y.diff() ** 2)
                  + inertia / 2 * TH.diff() ** 2, potential=m * g * Y, constraints=gaps)


@pytest.mark.parametrize("e", [0.0, 1.0])
def test_rod_striking_with_one_end_against_the_closed_form(e):
    theta, v = 0.4, 3.0  # falling without rotation, the left end (lower) touching
    system = rod(e)
    full = system.with_gaps_closed().numeric()
    gaps = Gaps(("left",), 0, np.array([e]), np.array([1e-6]))
    q = np.array([0.0, L / 2 * np.sin(theta), theta])
    after = resolve_impact(full, gaps, 0.0, q, np.array([0.0, -v, 0.0]), np.array([True]))
    # contact point r = (-L/2 cos, -L/2 sin) from the centre; its normal velocity goes
    # from -v to e v; impulse P along y: m dv = P, I dw = r_x P
    r_x, inertia = -L / 2 * np.cos(theta), m * L**2 / 12
    P = (1 + e) * v / (1 / m + r_x**2 / inertia)
    expected = np.array([0.0, -v + P / m, r_x * P / inertia])
    assert np.abs(after.qd - expected).max() < 1e-12
    assert abs(after.impulses[0] - P) < 1e-12
    # angular momentum about the contact point is conserved through the impact
    r_y = -L / 2 * np.sin(theta)

    def about_contact(qd):  # I w + m (centre - contact) x v
        return inertia * qd[2] - m * (r_x * qd[1] - r_y * qd[0])
    assert abs(about_contact(after.qd) - about_contact(np.array([0.0, -v, 0.0]))) < 1e-12


def test_rod_landing_flat_lands_symmetrically():
    system = rod(0.5, "both")
    full = system.with_gaps_closed().numeric()
    gaps = Gaps(("left", "right"), 0, np.full(2, 0.5), np.full(2, 1e-6))
    for law in ("sequential", "simultaneous"):
        after = resolve_impact(full, gaps, 0.0, np.zeros(3), np.array([0.0, -2.0, 0.0]),
                               np.ones(2, bool), law)
        assert np.abs(after.qd - [0.0, 1.0, 0.0]).max() < 1e-13, law
        assert abs(after.impulses[0] - after.impulses[1]) < 1e-13


def test_closed_gaps_keeps_a_pressed_contact_and_opens_a_pulled_one():
    (h,) = coordinates("h")
    u = sp.Symbol("u")
    block = System([h], kinetic=h.diff() ** 2 / 2, potential=g * h,
                   generalized_forces=[u], constraints=[Unilateral(h, name="floor")],
                   inputs=[u])
    full = block.with_gaps_closed().numeric().for_run()  # its own inputs
    gaps = Gaps(("floor",), 0, np.zeros(1), np.full(1, 1e-6))
    for pull, closed in ((5.0, (0,)), (15.0, ())):  # weight 9.81
        full.set_inputs(np.array([pull]))
        assert closed_gaps(full, gaps, 0.0, np.zeros(1), np.zeros(1),
                           np.array([True])) == closed


def test_an_endless_impact_is_named():
    # a point between two elastic walls at the same place: the sequential law bounces
    # it from one to the other forever; Newton's law has no simultaneous solution
    # (each wall must send it back at 1 unless the other acts)
    (z,) = coordinates("z")
    system = System([z], kinetic=z.diff() ** 2 / 2, constraints=[
        Unilateral(z, name="below", restitution=1.0),
        Unilateral(-z, name="above", restitution=1.0)])
    full = system.with_gaps_closed().numeric()
    gaps = Gaps(("below", "above"), 0, np.ones(2), np.full(2, 1e-6))
    # both touching at z = 0, moving: the sequential law bounces it between them forever
    with pytest.raises(ContactError, match=r"did not end after 1000 stages .*'(below|above)'"):
        resolve_impact(full, gaps, 0.0, np.zeros(1), np.array([1.0]), np.ones(2, bool))
    with pytest.raises(ContactError, match="no solution with every impulse pushing"):
        resolve_impact(full, gaps, 0.0, np.zeros(1), np.array([1.0]), np.ones(2, bool),
                       "simultaneous")
