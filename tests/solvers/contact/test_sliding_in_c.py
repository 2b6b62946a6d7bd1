"""Sliding friction computed in C (``native/friction.c``): a sliding segment's steps in
the C loop no longer call Python at each evaluation for its friction forces.

References (closed forms):

- A box on its four bottom corners (mass ``m``, the corners at ``(x_i, y_i)`` from the
  centre, ``C/2`` below it) launched sliding along ``d`` without a push: every corner
  slides along ``d``, so friction totals ``-mu m g d`` and the centre decelerates at
  ``mu g`` along a straight line, stopping at ``v0 / (mu g)``. It does not turn: the
  normal forces balance the friction's moment about the centre, ``sum N_i r_i =
  (mu m g C / 2) d`` (in the floor's plane), which is parallel to ``d``, so the
  friction's own moment about the vertical, ``-mu (sum N_i r_i) x d``, is 0. The four
  normal rows have rank 3, and the run reports the minimum-norm normal forces, linear
  in the corners' places (equal springs): ``N_i = m g / 4 + (mu m g C / 2)
  (d_x x_i / sum x_j^2 + d_y y_i / sum y_j^2)``, each corner's friction ``-mu N_i d``.
- A block on two equal contacts (rank 1) sliding along a floor against a damping force
  ``-k v`` read from the state at each evaluation (the user's input):
  ``v' = -(k/m) v - mu g``, so ``v = (v0 + a) exp(-k t/m) - a`` with ``a = mu g m / k``,
  stopping at ``(m/k) ln((v0 + a) / a)``; each contact carries ``m g / 2``.

Each run is also compared with the Python loop, whose friction is the Python solve's.
A box pushed off its centre is checked against its statics while it holds (friction
balancing the push within the cones), the limit load computed apart where it breaks
loose, and a planar model derived apart once it slides.
"""

from __future__ import annotations

import numpy as np
import pytest
import sympy as sp

from dalembert import System, Unilateral, coordinates
from dalembert import t as time
from dalembert.multibody import Force, Ground, Multibody, RigidBody, plane_contact
from dalembert.solvers.contact import friction

g, mu = 9.81, 0.4
A, B, C, M = 0.2, 0.15, 0.1, 2.0
CORNERS = [(sx * A / 2, sy * B / 2) for sx, sy in [(-1, -1), (1, -1), (1, 1), (-1, 1)]]
X, Y = coordinates("x y")


@pytest.fixture
def python_friction(monkeypatch):
    """The number of times the Python side computed sliding friction forces (a list
    holding one count)."""
    calls = [0]
    call = friction.SlidingForces.__call__

    def counted(self, *args):
        calls[0] += 1
        return call(self, *args)

    monkeypatch.setattr(friction.SlidingForces, "__call__", counted)
    return calls


def box_on_four(friction: float = mu, forces: tuple = ()) -> Multibody:
    inertia = M / 12 * np.diag([B**2 + C**2, A**2 + C**2, A**2 + B**2])
    body = RigidBody("box", M, inertia)
    corners = [plane_contact(f"c{k}", Ground(), body, point=(x, y, -C / 2), friction=friction)
               for k, (x, y) in enumerate(CORNERS)]
    return Multibody([body], gravity=(0, 0, -g), contacts=corners,
                     forces=[Force(body, *f) for f in forces])


@pytest.mark.parametrize("backend", ["c", "python"])
def test_a_box_launched_sliding_on_four_corners_stops_at_v0_over_mu_g(backend,
                                                                      python_friction):
    v0, angle = 1.2, 0.5
    d = np.array([np.cos(angle), np.sin(angle)])
    box = box_on_four()
    q0, qd0 = box.initial_state(positions={"box": (0, 0, C / 2)},
                                velocities={"box": (*(v0 * d), 0)})
    stop = v0 / (mu * g)
    times = np.linspace(0.0, 0.5, 26)
    # steps of at most 2 ms: many evaluations in the sliding segment
    traj = box.simulate((0.0, 0.5), q0, qd0, t_eval=times, max_step=2e-3, backend=backend)
    assert traj.success, traj.message
    (t_stop,) = [s.t for s in traj.contacts.switches[1:]]
    assert abs(t_stop - stop) < 1e-12
    t = np.minimum(traj.t, stop)
    s = v0 * t - mu * g * t**2 / 2  # along d
    assert np.abs(traj["box_x"] - s * d[0]).max() < 1e-12
    assert np.abs(traj["box_y"] - s * d[1]).max() < 1e-12
    assert np.abs(traj["box_z"] - C / 2).max() < 1e-12
    assert np.abs(traj["box_b3"]).max() < 1e-12  # no yaw
    sliding = traj.t < stop
    xs, ys = np.array(CORNERS).T
    moment = mu * M * g * C / 2
    for k, (x, y) in enumerate(CORNERS):
        normal = M * g / 4 + moment * (d[0] * x / (xs**2).sum() + d[1] * y / (ys**2).sum())
        assert np.abs(traj.multiplier(f"c{k}_1")[sliding] - normal).max() < 1e-10
        forces = np.stack([traj.multiplier(f"c{k}_friction_{j}") for j in (1, 2)], axis=1)
        assert np.abs(forces[sliding] + mu * normal * d).max() < 1e-10
    # in C: the outputs' friction and the stop's location in Python, none at the
    # steps' evaluations
    evaluations = traj.stats["nfev"]
    assert evaluations > 1000
    if backend == "c":
        assert python_friction[0] < evaluations / 20


def test_a_block_damped_by_a_state_input_while_sliding_on_two_contacts(python_friction):
    """The user's input read at each state still is, with the friction in C."""
    k, v0, u = 3.0, 2.0, sp.Symbol("u")
    block = System([X, Y], kinetic=(X.diff()**2 + Y.diff()**2) / 2, potential=g * Y,
                   generalized_forces={X: u}, inputs=[u],
                   constraints=[Unilateral(Y, name, friction=mu, tangents=[X.diff()])
                                for name in ("a", "b")])
    a = mu * g / k
    stop = np.log((v0 + a) / a) / k
    times = np.linspace(0.0, 0.6, 31)
    runs = {backend: block.simulate((0.0, 0.6), {X: 0.0, Y: 0.0}, {X: v0},
                                    inputs=lambda t, q, qd: [-k * qd[0]], t_eval=times,
                                    max_step=2e-3, backend=backend)
            for backend in ("c", "python")}
    for traj in runs.values():
        assert traj.success, traj.message
        (t_stop,) = [s.t for s in traj.contacts.switches[1:]]
        assert abs(t_stop - stop) < 1e-12
        sliding = traj.t < stop
        t = traj.t[sliding]
        v = (v0 + a) * np.exp(-k * t) - a
        assert np.abs(traj["x_dot"][sliding] - v).max() < 1e-12
        assert np.abs(traj["x_dot"][~sliding]).max() < 1e-12
        for name in ("a", "b"):
            assert np.abs(traj.multiplier(name) - g / 2).max() < 1e-12
            assert np.abs(traj.multiplier(f"{name}_friction_1")[sliding] + mu * g / 2).max() \
                < 1e-12
    assert np.abs(runs["c"].q - runs["python"].q).max() < 1e-13


#: Pushes ``(mu, angle, k, point)`` off the box's centre: the first in the next two
#: tests; then three drawn at random (mu in 0.2-0.6, k in 5-20 N/s, any direction, any
#: point within 8 x 6 cm of the centre) that took over a million evaluations or
#: stalled while the corners slipped one by one.
OFF_CENTRE = [(0.23425966685744976, 1.4879242956303682, 17.01911697809595, (0.03, -0.02)),
              (0.4500381866418668, 5.637360571650786, 16.6352853536779,
               (-0.043966849601505306, -0.023980045810652946)),
              (0.58240068385159, 1.304903297657757, 17.426673279117963,
               (-0.05611486030687676, 0.0015365539723877775)),
              (0.25142808110767983, 3.137055329483761, 14.022475364350361,
               (-0.07540975866048888, -0.042248869850705285))]


def test_a_box_pushed_off_its_centre_holds_within_its_cones_until_it_breaks_loose():
    """Pushed by ``k t`` at a point off its centre, one corner's share of the friction
    reaches its cone first; from there every corner's friction is Coulomb's law at the
    level of accelerations, and the box stays at rest (the load is still within what
    the four cones hold together, below the limit load of the test after this one):
    no more switches, no creep, and friction forces that balance the push, each within
    its cone. Both loops switch at the same instant and agree on the motion (the
    forces of a body held on four corners are not unique, so they are not compared)."""
    friction, angle, k, point = OFF_CENTRE[0]
    push_at, direction = np.array(point), np.array([np.cos(angle), np.sin(angle)])
    box = box_on_four(friction, [((k * time * direction[0], k * time * direction[1], 0),
                                  (*push_at, 0.0))])
    q0, qd0 = box.initial_state(positions={"box": (0, 0, C / 2)})
    times = np.linspace(0.2, 0.245, 19)
    runs = [box.simulate((0.0, 0.245), q0, qd0, t_eval=times, method="DOP853",
                         backend=backend) for backend in ("c", "python")]
    instants = []
    for traj in runs:
        assert traj.success, traj.message
        assert len(traj.contacts.switches) == 2  # the start, then the first slip
        instants.append(traj.contacts.switches[1].t)
        assert np.abs(traj.qd).max() < 1e-12
        after = traj.t > instants[-1]
        assert after.sum() > 5
        f = np.stack([[traj.multiplier(f"c{j}_friction_{i}")[after] for i in (1, 2)]
                      for j in range(4)])  # corner, component, time
        normal = np.stack([traj.multiplier(f"c{j}_1")[after] for j in range(4)])
        push = k * traj.t[after] * direction[:, None]
        assert np.abs(f.sum(axis=0) + push).max() < 1e-9 * np.abs(push).max()
        corners = np.array(CORNERS)
        moment = (corners[:, 0, None] * f[:, 1] - corners[:, 1, None] * f[:, 0]).sum(axis=0) \
            + push_at[0] * push[1] - push_at[1] * push[0]
        assert np.abs(moment).max() < 1e-9 * np.abs(push).max()
        assert np.all(np.linalg.norm(f, axis=1) <= friction * normal * (1 + 1e-9))
    assert abs(instants[0] - instants[1]) < 1e-12
    assert np.abs(runs[0].q - runs[1].q).max() < 1e-12


def planar_box_sliding(push_rate: float, angle: float, point: tuple[float, float],
                       friction: float):
    """The right-hand side of the box sliding on all four corners, derived in planar
    coordinates ``(x, y, theta)`` and their rates: each corner's friction ``-mu N_i``
    along its velocity, the push ``k t (cos a, sin a)`` at the body point ``point``
    (at the centre's height). The box neither tips nor lifts, so the normal forces
    hold ``sum N_i = m g`` and zero moment about the two horizontal axes through the
    centre, where each corner's friction acts ``C/2`` below it; of the forces doing so
    (four for three equations), the minimum-norm ones, as the run reports them
    (linear in each corner's place: equal springs)."""
    corners, p = np.array(CORNERS), np.array(point)
    spin_inertia = M / 12 * (A**2 + B**2)

    def rhs(t: float, s: np.ndarray) -> list[float]:
        _, _, theta, vx, vy, w = s
        turn = np.array([[np.cos(theta), -np.sin(theta)], [np.sin(theta), np.cos(theta)]])
        r = corners @ turn.T
        v = np.array([vx, vy]) + w * np.column_stack([-r[:, 1], r[:, 0]])
        u = v / np.linalg.norm(v, axis=1)[:, None]
        # the balance A N = (m g, 0, 0) + F N, the friction's moments F N
        rows = np.vstack([np.ones(4), r[:, 1], -r[:, 0]])
        moments = np.vstack([np.zeros(4), C / 2 * friction * u[:, 1],
                             -C / 2 * friction * u[:, 0]])
        inverse = np.linalg.pinv(rows)
        N = np.linalg.solve(np.eye(4) - inverse @ moments, inverse @ [M * g, 0.0, 0.0])
        f = -friction * N[:, None] * u
        push = push_rate * t * np.array([np.cos(angle), np.sin(angle)])
        at = turn @ p
        a = (push + f.sum(axis=0)) / M
        spin = at[0] * push[1] - at[1] * push[0] + (r[:, 0] * f[:, 1] - r[:, 1] * f[:, 0]).sum()
        return [vx, vy, w, a[0], a[1], spin / spin_inertia]

    return rhs


def limit_load_instant(push_rate: float, angle: float, point: tuple[float, float],
                       friction: float) -> float:
    """The instant the push ``k t (cos a, sin a)`` at the body point ``point`` becomes
    more than the four corners' friction can hold the box at rest against: the first
    ``t`` at which no friction forces ``f_i`` balancing it (force and moment about the
    vertical) stay within every cone, ``|f_i| <= mu N_i``, the normal forces
    ``N(f)`` the minimum-norm ones holding the weight and the friction's moments about
    the horizontal axes (as :func:`planar_box_sliding`'s). Found as the root of the
    least largest ``|f_i| / (mu N_i)`` (SLSQP over the forces, from even shares) less 1."""
    from scipy.optimize import brentq, minimize

    corners, p = np.array(CORNERS), np.array(point)
    rows = np.vstack([np.ones(4), corners[:, 1], -corners[:, 0]])
    inverse = np.linalg.pinv(rows)

    def normal(f: np.ndarray) -> np.ndarray:
        f = f.reshape(4, 2)
        return inverse @ [M * g, -C / 2 * f[:, 1].sum(), C / 2 * f[:, 0].sum()]

    def least_ratio(t: float) -> float:
        push = push_rate * t * np.array([np.cos(angle), np.sin(angle)])
        spin = p[0] * push[1] - p[1] * push[0]
        held = [{"type": "eq", "fun": lambda z: z[:8].reshape(4, 2).sum(axis=0) + push},
                {"type": "eq", "fun": lambda z: spin + (corners[:, 0] * z[1:8:2]
                                                        - corners[:, 1] * z[0:8:2]).sum()},
                {"type": "ineq", "fun": lambda z: z[8] * friction * normal(z[:8])
                 - np.linalg.norm(z[:8].reshape(4, 2), axis=1)}]
        found = minimize(lambda z: z[8], np.append(np.tile(-push / 4, 4), 2.0),
                         constraints=held, method="SLSQP",
                         options={"ftol": 1e-14, "maxiter": 500})
        # (it may end on its line search at the optimum, which it has then reached to
        # far below what matters here: the forces balance and stay in their cones)
        for constraint in held:
            value = constraint["fun"](found.x)
            assert (value > -1e-9).all() and (constraint["type"] == "ineq"
                                              or (abs(value) < 1e-9).all()), found.message
        return float(found.x[8])

    # (from a push that loads every corner: at none the least ratio is at |f| = 0, where
    # its gradient is not defined)
    return brentq(lambda t: least_ratio(t) - 1.0, 0.1, 1.0, xtol=1e-10)


@pytest.mark.parametrize("friction, angle, k, point", OFF_CENTRE)
def test_a_box_pushed_off_its_centre_breaks_loose_then_slides_turning_as_in_planar_coordinates(
        friction, angle, k, point):
    """Held at rest by its four corners' friction (Coulomb's law at the level of
    accelerations, from the first corner's slip on) until the growing push breaks it
    loose, where the push leaves what the corners' friction can hold
    (:func:`limit_load_instant`), its speed growing as the square of the time since
    (the excess load grows linearly from 0). From 0.05 s later on it slides and turns
    as the planar model derived apart (:func:`planar_box_sliding`), started from the
    run's state. (With the corners slipping one by one it crept at up to 1e-6 m/s
    before breaking loose, and stalled or crawled there.)"""
    from scipy.integrate import solve_ivp

    loose = limit_load_instant(k, angle, point, friction)
    push = (k * time * np.cos(angle), k * time * np.sin(angle), 0)
    box = box_on_four(friction, [(push, (*point, 0.0))])
    q0, qd0 = box.initial_state(positions={"box": (0, 0, C / 2)})
    times = np.linspace(loose + 0.05, 1.0, 8)
    around = loose + np.array([-1e-3, 5e-3, 1e-2])
    traj = box.simulate((0.0, 1.0), q0, qd0, t_eval=np.concatenate([[0.1], around, times]))
    assert traj.success, traj.message
    # at rest until then (to rounding: 1e-15 measured)
    assert np.abs(traj.q[:2, :2]).max() < 1e-12
    speed = np.hypot(traj["box_x_dot"][1:4], traj["box_y_dot"][1:4])
    assert speed[0] < 1e-12 < 1e-5 < speed[1]
    # 4 times as fast at twice the time since (0.02-0.03% measured; breaking loose
    # 1e-5 s off gives 0.2%)
    assert speed[2] / speed[1] == pytest.approx(4.0, rel=2e-3)
    b0, b3 = traj["box_b0"][4:], traj["box_b3"][4:]
    planar = np.column_stack([traj["box_x"][4:], traj["box_y"][4:], 2 * np.arctan2(b3, b0),
                              traj["box_x_dot"][4:], traj["box_y_dot"][4:],
                              2 * (b0 * traj["box_b3_dot"][4:] - b3 * traj["box_b0_dot"][4:])])
    assert abs(planar[-1, 2]) > 0.5  # it has turned more than 30 degrees
    reference = solve_ivp(planar_box_sliding(k, angle, point, friction), (times[0], 1.0),
                          planar[0], t_eval=times, rtol=1e-13, atol=1e-15, method="DOP853")
    # at the default tolerances (5e-10 to 1.1e-8 measured; 6.2e-12 at rtol=1e-12 for the
    # first)
    assert np.abs(planar - reference.y.T).max() < 1e-7
