"""A body resting on contacts lifted by a growing force: every contact's force reaches 0
at the same instant, and the body leaves all of them together.

References (closed form): a body of mass ``m`` resting on a floor under gravity and
lifted at its mass center by ``k t`` presses on the floor with ``m g - k t``, which
reaches 0 at ``t* = m g / k``; from there nothing holds it, ``y'' = (k t - m g) / m``,
so ``y = k (t - t*)^3 / (6 m)`` (starting at rest), every contact force 0 and, pushed
at its mass center, it does not turn. This holds on one contact (the control case) and
on several whose normal rows are dependent (a block on two contacts with the same
row; a box on its four coplanar corners, rank 3 of 4), with friction or without: at
``t*`` every contact's force falls through 0 together and, open or closed, each
meets the complementarity conditions there (its force 0, its free acceleration 0);
the choice is the one that holds a moment later (they open), not one contact at a
time, each leaving the others with all the load, at the same instant without end.
Sliding along the floor at ``v0``, ``x'' = -mu (g - k t)`` until ``t*`` (the normal
force is the weight less the lift), then ``x' `` constant.
"""

from __future__ import annotations

import numpy as np
import pytest
import sympy as sp

from dalembert import System, Unilateral, coordinates
from dalembert import t as time
from dalembert.multibody import Force, Ground, Multibody, RigidBody, plane_contact
from dalembert.solvers.contact.gaps import Gaps
from dalembert.solvers.contact.laws import closed_gaps

g, mu, RATE = 9.81, 0.5, 20.0
X, Y = coordinates("x y")
LIFT = sp.Symbol("lift")
TIMES = np.linspace(0.0, 1.0, 21)  # the lift-offs are at 0.4905 (block) and 0.5 (box)


def lifted(t: np.ndarray, mass: float, rate: float) -> np.ndarray:
    """The height above rest of a body of mass ``mass`` lifted by ``rate t`` (off the
    floor at ``t* = mass g / rate``)."""
    off = mass * g / rate
    return rate * np.maximum(t - off, 0.0) ** 3 / (6 * mass)


def block(contacts: int, friction: float | None, inputs: bool = False) -> System:
    """A unit mass on ``contacts`` contacts with the row ``y`` (the floor), lifted by
    ``RATE t`` (or by the input ``lift``)."""
    options = {} if friction is None else {"friction": friction, "tangents": [X.diff()]}
    force = LIFT if inputs else RATE * time
    return System([X, Y], kinetic=(X.diff()**2 + Y.diff()**2) / 2, potential=g * Y,
                  generalized_forces={Y: force}, inputs=[LIFT] if inputs else (),
                  constraints=[Unilateral(Y, name, **options) for name in "ab"[:contacts]])


def check_lift_off(traj, names: list[str], off: float, height: np.ndarray,
                   expected: np.ndarray) -> None:
    """Every contact closed until ``off``, all open from there (one switch, at ``off``
    to 1e-12), the height as ``expected`` and every contact force 0 after."""
    assert traj.success, traj.message
    switches = traj.contacts.switches
    assert [s.closed for s in switches] == [tuple(range(len(names))), ()]
    assert abs(switches[1].t - off) < 1e-12
    assert np.abs(height - expected).max() < 1e-10
    after = traj.t > off
    assert after.sum() > 5
    for name in names:
        assert np.abs(traj.multiplier(name)[after]).max() == 0.0


@pytest.mark.parametrize("backend", ["c", "python"])
@pytest.mark.parametrize("friction", [None, mu])
@pytest.mark.parametrize("contacts", [1, 2])
def test_a_block_lifted_off_its_contacts_leaves_them_all_at_once(contacts, friction, backend):
    """One contact (the control case) or two with the same row, each carrying half the
    weight; with friction the sticking contacts' cones shrink to 0 with their normal
    forces at the same instant."""
    traj = block(contacts, friction).simulate((0.0, 1.0), {X: 0.0, Y: 0.0}, t_eval=TIMES,
                                              backend=backend)
    names = ["a", "b"][:contacts]
    check_lift_off(traj, names, g / RATE, traj["y"], lifted(traj.t, 1.0, RATE))
    assert np.abs(traj["x"]).max() == 0.0
    if friction is not None:  # holding nothing, before and after
        for name in names:
            assert np.abs(traj.multiplier(f"{name}_friction_1")).max() < 1e-12
    before = traj.t < g / RATE
    for name in names:  # the weight less the lift, shared equally
        assert np.abs(traj.multiplier(name)[before]
                      - (g - RATE * traj.t[before]) / contacts).max() < 1e-12


def test_a_block_lifted_by_an_input_leaves_its_two_contacts_at_once():
    """The lift an input function of time: the choice a moment after the instant reads
    the inputs there."""
    traj = block(2, mu, inputs=True).simulate(
        (0.0, 1.0), {X: 0.0, Y: 0.0}, t_eval=TIMES, inputs=lambda t, q, qd: [RATE * t])
    check_lift_off(traj, ["a", "b"], g / RATE, traj["y"], lifted(traj.t, 1.0, RATE))


A, B, C, M = 0.2, 0.15, 0.1, 2.0
CORNERS = [(sx * A / 2, sy * B / 2) for sx, sy in [(-1, -1), (1, -1), (1, 1), (-1, 1)]]


def box_lifted(friction: float) -> Multibody:
    """The box of ``test_resting_on_four.py`` on its four corners, lifted at its mass
    center by ``lift t``."""
    inertia = M / 12 * np.diag([B**2 + C**2, A**2 + C**2, A**2 + B**2])
    body = RigidBody("box", M, inertia)
    corners = [plane_contact(f"c{k}", Ground(), body, point=(x, y, -C / 2), friction=friction)
               for k, (x, y) in enumerate(CORNERS)]
    return Multibody([body], gravity=(0, 0, -g), contacts=corners,
                     forces=[Force(body, (0, 0, LIFT * time))])


@pytest.mark.parametrize("backend", ["c", "python"])
@pytest.mark.parametrize("friction", [0.0, mu])
def test_a_box_lifted_off_its_four_corners_leaves_them_all_at_once(friction, backend):
    box = box_lifted(friction)
    q0, qd0 = box.initial_state(positions={"box": (0, 0, C / 2)})
    rate = 2 * M * g  # off at t* = 0.5
    traj = box.simulate((0.0, 1.0), q0, qd0, t_eval=TIMES, parameters={"lift": rate},
                        backend=backend, timeout=120)
    names = [f"c{k}_1" for k in range(4)]
    check_lift_off(traj, names, M * g / rate, traj["box_z"] - C / 2,
                   lifted(traj.t, M, rate))
    for part in ("x", "y", "b1", "b2", "b3"):  # no sliding, no roll, pitch or yaw
        assert np.abs(traj[f"box_{part}"]).max() < 1e-12
    before = traj.t < M * g / rate
    for k in range(4 if friction else 0):  # nothing to hold, before and after
        for j in (1, 2):
            assert np.abs(traj.multiplier(f"c{k}_friction_{j}")).max() < 1e-12
    for name in names:  # the four equal springs' loads: a quarter each
        assert np.abs(traj.multiplier(name)[before]
                      - (M * g - rate * traj.t[before]) / 4).max() < 1e-10


@pytest.mark.parametrize("backend", ["c", "python"])
def test_a_sliding_block_lifted_off_two_contacts_leaves_them_at_once(backend):
    """Sliding at ``v0`` on both: ``x'' = -mu (g - k t)`` (the weight less the lift is
    the normal force, whichever contact carries it) until ``t*``, then free."""
    v0, rough = 1.0, 0.1  # still sliding at t* (v = 0.76)
    traj = block(2, rough).simulate((0.0, 1.0), {X: 0.0, Y: 0.0}, {X: v0}, t_eval=TIMES,
                                    backend=backend)
    off = g / RATE
    held = np.minimum(traj.t, off)
    x = v0 * traj.t - rough * (g * held**2 / 2 - RATE * held**3 / 6) \
        - rough * (g * off - RATE * off**2 / 2) * (traj.t - held)
    check_lift_off(traj, ["a", "b"], off, traj["y"], lifted(traj.t, 1.0, RATE))
    assert np.abs(traj["x"] - x).max() < 1e-10


def test_the_closed_set_decides_a_tie_by_what_follows_it():
    """At ``t*`` both contacts meet the conditions open or closed (their forces and the
    free acceleration 0): lifted on, they open; with no lift and no weight (the forces
    stay 0) they stay as they were, closed."""
    touching, rest = np.ones(2, dtype=bool), np.zeros(2)
    for system, expected in [(block(2, None), ()),
                             (System([X, Y], kinetic=(X.diff()**2 + Y.diff()**2) / 2,
                                     constraints=[Unilateral(Y, "a"), Unilateral(Y, "b")]),
                              (0, 1))]:
        full = system.with_gaps_closed().numeric()
        gaps = Gaps.of(system.definition.unilateral, 0, [0.0, 0.0])
        assert closed_gaps(full, gaps, g / RATE, rest, rest, touching) == expected
        # a moment before the lift-off both press (each half of the rest)
        assert closed_gaps(full, gaps, 0.9 * g / RATE, rest, rest, touching) == (0, 1)
