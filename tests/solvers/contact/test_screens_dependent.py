"""The force and cone screens where the segment's model has dependent rows (a block on
two equal contacts, a box on its four corners): C gives them the multipliers the
events see, the minimum-norm ones and the held friction shared by load, so those
segments take their steps in C stretches too.

References: the same run held in the Python loop by a user event that never fires
(``test_screens.py``'s method: with DOP853 both loops take the same steps, so the
switch instants and states agree bit for bit), and the closed-form instants: a block
of mass 1 pushed by ``k t`` on two contacts sharing its weight slips when ``k t``
reaches ``mu g``, a block on two rough corners turned by a torque ``k t`` lifts one
when the torque reaches ``m g b`` (moment balance); the box on its four corners slips
on all of them at once at ``mu m g / k``, and dropped flat it lands on all four at
``sqrt(2 h / g)``. Each run steps at most ``MAX_STEP`` so that its
resting segments take many steps (at rest, a step could grow to the whole segment).
"""

from __future__ import annotations

import numpy as np
import pytest
import sympy as sp

from dalembert import System, Unilateral, coordinates
from dalembert import t as time
from dalembert.multibody import Force, Ground, Multibody, RigidBody, plane_contact
from dalembert.solvers.native import run as native_run

g, mu = 9.81, 0.5
MAX_STEP = 0.01
X, Y = coordinates("x y")
A, B, C, M = 0.2, 0.15, 0.1, 2.0
CORNERS = [(sx * A / 2, sy * B / 2) for sx, sy in [(-1, -1), (1, -1), (1, 1), (-1, 1)]]


def never(t, q, qd):
    """A user event that never fires: its run steps in the Python loop."""
    return 1.0


@pytest.fixture
def both(monkeypatch):
    """``both(system, *args, onsets=0, **options)``: the run screened in C and the run
    stepped in Python. Returns them with the steps the first ran in C stretches whose
    screens read minimum-norm multipliers, split into ``(without, with)`` held friction
    shared by load (the premise of the comparison: some are run). Its screens may flag
    no more steps than events fire, each ending a segment (each flagged step costs a
    step in Python: screens that flag in vain would hide behind equal results), and one
    more per slip from rest in two directions (``onsets``: its stop's screen reads 0
    at its start, below its margin, until the contact has moved)."""
    steps = {False: 0, True: 0}
    any_stretch = []
    flagged = []
    run = native_run._Stretches.run

    def counted(self, *args, **kwargs):
        ran = run(self, *args, **kwargs)
        any_stretch.append(True)
        table = self._screens
        if table is not None and table.struct.n_group:
            steps[bool(table.struct.n_held)] += self._run.n_steps
        if not ran and table is not None:
            flagged.append(self.solver.t)
        return ran

    monkeypatch.setattr(native_run._Stretches, "run", counted)

    def simulate_both(system, *args, onsets: int = 0, **options):
        screened = system.simulate(*args, max_step=MAX_STEP, **options)
        ran = (steps[False], steps[True])
        assert len(flagged) <= screened.stats["n_segments"] - 1 + onsets, flagged
        any_stretch.clear()
        stepped = system.simulate(*args, max_step=MAX_STEP, events=[never], **options)
        assert not any_stretch  # held in the Python loop
        assert screened.success and stepped.success, (screened.message, stepped.message)
        return screened, stepped, ran

    return simulate_both


def switches(traj) -> np.ndarray:
    return np.array([s.t for s in traj.contacts.switches])


def assert_same(screened, stepped, tol: float = 0.0) -> None:
    """The same switches, steps and states, bit for bit (``tol`` 0: DOP853, the same
    steps), or to ``tol`` relative (Radau, whose stretches hold the Newton matrices
    differently)."""
    assert [s.closed for s in screened.contacts.switches] == \
        [s.closed for s in stepped.contacts.switches]
    if tol:
        assert np.abs(switches(screened) - switches(stepped)).max() <= tol
        scale = 1.0 + np.abs(stepped.q).max()
        assert np.abs(screened.q[-1] - stepped.q[-1]).max() <= tol * scale
        return
    assert np.array_equal(switches(screened), switches(stepped))
    assert screened.stats == stepped.stats
    assert np.array_equal(screened.t, stepped.t)
    assert np.array_equal(screened.q, stepped.q)
    assert np.array_equal(screened.qd, stepped.qd)


def two_contacts(push: sp.Expr) -> System:
    """A block of mass 1 on two frictional contacts with the same row (rank 1),
    pushed along the floor by ``push``."""
    return System([X, Y], kinetic=(X.diff() ** 2 + Y.diff() ** 2) / 2,
                  potential=g * Y - push * X,
                  constraints=[Unilateral(Y, name, friction=mu, tangents=[X.diff()])
                               for name in ("a", "b")])


def box_on_four(force: tuple) -> Multibody:
    """A box on its four bottom corners, pushed at its mass center by ``force``."""
    inertia = M / 12 * np.diag([B**2 + C**2, A**2 + C**2, A**2 + B**2])
    body = RigidBody("box", M, inertia)
    corners = [plane_contact(f"c{k}", Ground(), body, point=(x, y, -C / 2), friction=mu)
               for k, (x, y) in enumerate(CORNERS)]
    return Multibody([body], gravity=(0, 0, -g), contacts=corners,
                     forces=[Force(body, force)])


def on_the_floor(box: Multibody, height: float = 0.0):
    return box.initial_state(positions={"box": (0, 0, C / 2 + height)})


@pytest.mark.parametrize("method, tol", [("DOP853", 0.0), ("Radau", 1e-8)])
def test_a_block_on_two_equal_contacts_slips_when_pushed_by_k_t(method, tol, both):
    """Sticking, each contact holding half the friction (the cone screens read the
    shares), until ``k t = mu g``; then sliding."""
    k = 20.0
    screened, stepped, (_, shared) = both(two_contacts(k * time), (0.0, 0.4),
                                          {"x": 0.0, "y": 0.0}, method=method)
    assert shared > 10
    assert switches(screened)[1:] == pytest.approx([mu * g / k], abs=1e-10)
    assert screened.contacts.switches[1].closed == (0, 1)
    assert_same(screened, stepped, tol)


def test_a_block_on_two_rough_corners_tips_when_its_torque_reaches_m_g_b(both):
    """A block ``2b x 2h`` flat on two rough corners (their friction rows the same:
    dependent), turned by a torque ``k t`` about its centre: by moment balance the
    loads are ``(m g -+ k t / b) / 2``, and one corner leaves the floor at
    ``t = m g b / k`` (a force screen reads its load); it then tips about the other."""
    from test_rough import B, H, M, corner, th

    k = 10.0
    right, left = corner(B, -H), corner(-B, -H)
    tipped = System([X, Y, th], kinetic=M / 2 * (X.diff() ** 2 + Y.diff() ** 2)
                    + M * (B**2 + H**2) / 6 * th.diff() ** 2,
                    potential=M * g * Y - k * time * th,
                    constraints=[Unilateral(c[1], name, friction=np.inf,
                                            tangents=[c[0].diff(time)])
                                 for c, name in ((right, "right"), (left, "left"))])
    screened, stepped, (plain, _) = both(
        tipped, (0.0, 0.25), {"x": 0.0, "y": H, "theta": 0.0})
    assert plain > 10
    assert switches(screened)[1:] == pytest.approx([M * g * B / k], abs=1e-10)
    assert screened.contacts.switches[-1].closed == (1,)  # turning about the left one
    assert_same(screened, stepped)


def test_a_box_on_four_corners_slips_on_all_of_them_at_mu_m_g_over_k(both):
    """Pushed by ``k t`` along the angle 0.5: the four corners hold the push together
    (dependent normal and friction rows) until ``k t = mu m g``."""
    k, angle = 40.0, 0.5
    box = box_on_four((k * time * np.cos(angle), k * time * np.sin(angle), 0))
    q0, qd0 = on_the_floor(box)
    screened, stepped, (_, shared) = both(box, (0.0, 0.246), q0, qd0, onsets=1)
    assert shared > 10
    assert switches(screened)[1:] == pytest.approx([mu * M * g / k], abs=1e-12)
    assert screened.contacts.switches[1].closed == (0, 1, 2, 3)
    assert_same(screened, stepped)


def test_a_box_dropped_flat_settles_on_four_corners_and_rests_pushed_below_its_cone(both):
    """Falling flat onto its four corners (a plastic impact on all at once), then at
    rest on them for the rest of the run, pushed by 8 < mu m g."""
    force, angle, height = 8.0, 0.5, 0.01
    box = box_on_four((force * np.cos(angle), force * np.sin(angle), 0))
    q0, qd0 = on_the_floor(box, height)
    screened, stepped, (_, shared) = both(box, (0.0, 1.0), q0, qd0)
    assert shared > 50
    assert switches(screened)[1:] == pytest.approx([np.sqrt(2 * height / g)], abs=1e-10)
    assert screened.contacts.switches[-1].closed == (0, 1, 2, 3)
    assert np.ptp(screened["box_x"][screened.t > 0.1]) == 0.0  # at rest, held
    assert_same(screened, stepped)
