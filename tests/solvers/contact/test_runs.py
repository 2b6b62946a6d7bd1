"""Runs with unilateral constraints, event-driven (``solvers/contact/driver.py``).

References (closed forms): a ball bouncing on a floor with restitution ``e`` (impact
times ``t_1 (1 + 2 sum e^j)``, apex heights ``e^(2k) h0``, rest at
``t_1 (1 + e) / (1 - e)``, then the floor's force equal to the weight); Newton's cradle
(the last ball leaves); a particle whirled on a string in a vertical circle below the
critical speed (the string goes slack where its tension ``m v^2 / l + m g cos(theta)``
vanishes, ``cos(theta) = (2 g l - v0^2) / (3 g l)``, the particle flies a parabola, and
the string catches it where the parabola meets the circle, an inelastic catch losing
the radial part of the kinetic energy).
"""

from __future__ import annotations

import numpy as np
import pytest
import sympy as sp
from scipy.optimize import brentq

from dalembert import ConstraintError, System, Unilateral, coordinates

g, h0 = 9.81, 1.0
(Y,) = coordinates("y")


def ball(e: float, **unilateral) -> System:
    return System([Y], kinetic=Y.diff() ** 2 / 2, potential=g * Y,
                  constraints=[Unilateral(Y, name="floor", restitution=e, **unilateral)])


@pytest.mark.parametrize("backend", ["c", "python"])
def test_bouncing_ball_impacts_apexes_and_rest(backend):
    e = 0.8
    t1 = np.sqrt(2 * h0 / g)
    impacts = t1 + 2 * t1 * np.cumsum(np.r_[0.0, e ** np.arange(1, 20)])
    apexes = impacts + e ** np.arange(1, 21) * g * t1 / g  # after bounce k: v_k / g
    t_inf = t1 * (1 + e) / (1 - e)
    traj = ball(e).simulate((0.0, t_inf + 0.5), {"y": h0}, t_eval=np.r_[apexes, t_inf + 0.5],
                            backend=backend)
    assert traj.success
    times = np.array([i.t for i in traj.contacts.impacts])
    assert np.abs(times[:20] - impacts).max() < 1e-10
    assert np.abs(traj.q[:20, 0] - e ** (2 * np.arange(1, 21)) * h0).max() < 1e-10
    # each impact loses (1 - e^2) of the kinetic energy before it
    for i in traj.contacts.impacts[:20]:
        before = i.qd_before[0] ** 2 / 2
        assert abs(i.energy_lost - (1 - e**2) * before) < 1e-12 * max(before, 1.0)
        assert abs(i.impulses[0] - (1 + e) * -i.qd_before[0]) < 1e-12
    # at rest from t_inf on (the last bounces below rest_speed become plastic)
    rest = traj.contacts.switches[-1]
    assert rest.closed == (0,) and abs(rest.t - t_inf) < 1e-5
    assert abs(traj.q[-1, 0]) < 1e-15 and abs(traj.multiplier("floor")[-1] - g) < 1e-12
    assert traj.contacts.closed_at(np.array([t_inf + 0.5])).tolist() == [[True]]


def test_bouncing_ball_never_penetrates_and_keeps_every_step():
    traj = ball(0.5).simulate((0.0, 2.0), {"y": h0})
    assert traj.q.min() > -1e-14
    assert np.all(np.diff(traj.t) > 0)  # one point per time: the post-impact state
    closed = traj.contacts.closed_at(traj.t)[:, 0]
    assert np.all(traj.multipliers[~closed] == 0.0)
    assert np.all(traj.multipliers[closed] >= 0.0)
    # the energy drops at the impacts only, by what they lost
    lost = sum(i.energy_lost for i in traj.contacts.impacts)
    assert abs(traj.energy[0] - traj.energy[-1] - lost) < 1e-9
    assert traj.stats["n_impacts"] == len(traj.contacts.impacts)


def test_rest_speed_sets_when_the_ball_stops():
    slow = ball(0.8, rest_speed=0.5).simulate((0.0, 5.0), {"y": h0})
    v1 = np.sqrt(2 * g * h0)  # impact k arrives at e^(k-1) v1: plastic once below 0.5
    arrivals = v1 * 0.8 ** np.arange(20)
    assert len(slow.contacts.impacts) == int(np.argmax(arrivals < 0.5)) + 1


@pytest.mark.parametrize("law, last", [("sequential", [0.0, 0.0, 0.0, 1.0]),
                                       ("simultaneous", [-0.5, 0.5, 0.5, 0.5])])
def test_newtons_cradle_run(law, last):
    xs = coordinates("x0 x1 x2 x3")
    cradle = System(list(xs), kinetic=sum(x.diff() ** 2 for x in xs) / 2, constraints=[
        Unilateral(xs[k + 1] - xs[k], name=f"gap{k}", restitution=1.0) for k in range(3)])
    traj = cradle.simulate((0.0, 2.0), {"x0": -1.0}, {"x0": 1.0}, impact_law=law)
    assert np.abs(traj.qd[-1] - last).max() < 1e-12
    assert len(traj.contacts.impacts) == 1 and abs(traj.contacts.impacts[0].t - 1.0) < 1e-12
    assert np.abs(traj.qd.sum(axis=1) - 1.0).max() < 1e-12  # momentum


def test_slack_string_leaves_the_circle_and_is_caught():
    X, Z = coordinates("x z")
    m, l, v0 = 1.0, 1.0, 6.0  # 2 g l < v0^2 < 5 g l: slack above the centre
    string = System([X, Z], kinetic=m / 2 * (X.diff() ** 2 + Z.diff() ** 2),
                    potential=m * g * Z,
                    constraints=[Unilateral(l - sp.sqrt(X**2 + Z**2), name="string")])
    traj = string.simulate((0.0, 1.5), {"x": 0.0, "z": -l}, {"x": v0}, dense_output=True)
    assert traj.success
    slack_t, caught = traj.contacts.switches[1].t, traj.contacts.impacts[0]
    # slack where the tension vanishes (theta from the bottom)
    theta = np.arccos((2 * g * l - v0**2) / (3 * g * l))
    x, z = traj.sol(slack_t)[:2]
    assert abs(np.arctan2(x, -z) - theta) < 1e-9
    # then a parabola, caught where it meets the circle again
    vx, vz = traj.sol(slack_t)[2:]
    def radius(s):
        return np.hypot(x + vx * s, z + vz * s - g * s**2 / 2) - l
    flight = brentq(radius, 0.05, 2.0, xtol=1e-15)  # leaves inwards
    assert abs(caught.t - (slack_t + flight) ) < 1e-9
    pos = np.array([x + vx * flight, z + vz * flight - g * flight**2 / 2])
    vel = np.array([vx, vz - g * flight])
    radial = vel @ pos / l
    assert abs(caught.energy_lost - m * radial**2 / 2) < 1e-8
    assert traj.contacts.switches[2].closed == (0,)  # taut again (e = 0)
    assert np.abs(traj.contacts.switches[1].q - traj.sol(slack_t)[:2]).max() < 1e-12


def test_unilateral_bad_input_is_named():
    for bad in ({"restitution": 1.5}, {"restitution": -0.1}, {"rest_speed": 0.0},
                {"rest_speed": float("inf")}, {"restitution": "high"}):
        with pytest.raises(ConstraintError, match="unilateral constraint 'floor'"):
            ball(0.5, **bad) if "restitution" not in bad else System(
                [Y], kinetic=Y.diff() ** 2 / 2, constraints=[Unilateral(Y, name="floor", **bad)])
    with pytest.raises(Exception, match="'floor' is violated at the start"):
        ball(0.5).simulate((0.0, 1.0), {"y": -0.1})
    with pytest.raises(ValueError, match="forward in time only"):
        ball(0.5).simulate((1.0, 0.0), {"y": 1.0})
    with pytest.raises(ConstraintError, match="two constraints are named 'floor'"):
        System([Y], kinetic=Y.diff() ** 2 / 2, constraints=[
            Unilateral(Y, name="floor"), Unilateral(Y - 1, name="floor")])
    with pytest.raises(ConstraintError, match="'roof' is not a unilateral constraint"):
        ball(0.5).with_gaps_closed(["roof"])


def test_user_events_are_kept_apart_from_the_contacts():
    def apex(t, q, qd):
        return qd[0]
    apex.direction = -1
    traj = ball(0.5).simulate((0.0, 1.5), {"y": h0}, events=[apex])
    assert len(traj.t_events) == 1
    t1 = np.sqrt(2 * h0 / g)
    expected = t1 + 0.5 * g * t1 / g  # the first apex after the first bounce
    assert abs(traj.t_events[0][0] - expected) < 1e-10


def test_restitution_as_a_parameter_swept_by_an_ensemble():
    e = sp.Symbol("e")
    system = System([Y], kinetic=Y.diff() ** 2 / 2, potential=g * Y, parameters={e: 0.5},
                    constraints=[Unilateral(Y, name="floor", restitution=e)])
    values = [0.3, 0.6, 0.9]
    table = system.simulate_many((0.0, 2.0), {"e": values}, q0={"y": h0},
                                 t_eval=np.linspace(0.0, 2.0, 11)).summary
    t1 = np.sqrt(2 * h0 / g)
    for value, row in zip(values, table.itertuples()):
        times = t1 + 2 * t1 * np.cumsum(np.r_[0.0, value ** np.arange(1, 200)])
        rest = t1 * (1 + value) / (1 - value)
        if rest > 2.0:  # still bouncing at the end: every closed-form impact before it
            assert row.n_impacts == np.count_nonzero(times <= 2.0)
        assert abs(row.t_first_impact - t1) < 1e-12
        assert row.energy_error < 1e-12  # T + V plus what the impacts took
    with pytest.raises(Exception, match="restitution of unilateral constraint 'floor', "
                                        "the parameter 'e', must be in"):
        system.simulate((0.0, 1.0), {"y": h0}, parameters={"e": 1.5})


def test_a_contact_run_keeps_one_time_limit_and_stops_a_hanging_input():
    u = sp.Symbol("u")
    pushed = System([Y], kinetic=Y.diff() ** 2 / 2, potential=g * Y,
                    generalized_forces=[u], inputs=[u],
                    constraints=[Unilateral(Y, name="floor", restitution=0.5)])

    def hanging(t, q, qd):
        if t > 0.8:  # after the first impact (t = 0.4515)
            while True:
                pass
        return 0.0

    with pytest.warns(Warning):
        traj = pushed.simulate((0.0, 5.0), {"y": h0}, inputs=hanging, timeout=1.0)
    assert traj.status == "timeout"
    assert len(traj.contacts.impacts) == 1 and traj.t[-1] > 0.45


def test_a_contact_run_saved_and_loaded_keeps_its_impacts_and_switches(tmp_path):
    traj = ball(0.5).simulate((0.0, 2.0), {"y": h0})
    again = type(traj).load(traj.save(tmp_path / "ball.npz"))
    assert again.contacts is not None and again.contacts.names == ("floor",)
    for before, after in zip(traj.contacts.impacts, again.contacts.impacts, strict=True):
        assert before.t == after.t and before.energy_lost == after.energy_lost
        assert np.array_equal(before.impulses, after.impulses)
        assert np.array_equal(before.qd_after, after.qd_after)
    assert [(s.t, s.closed) for s in again.contacts.switches] == \
        [(s.t, s.closed) for s in traj.contacts.switches]
    assert np.array_equal(again.contacts.closed_at(traj.t), traj.contacts.closed_at(traj.t))
    # a file whose contact arrays disagree with its contacts is refused, naming the array
    import zipfile

    from dalembert import TrajectoryFileError

    broken = tmp_path / "broken.npz"
    with zipfile.ZipFile(tmp_path / "ball.npz") as source, \
            zipfile.ZipFile(broken, "w") as target:
        for item in source.infolist():
            if item.filename != "impact_impulses.npy":
                target.writestr(item, source.read(item.filename))
    with pytest.raises(TrajectoryFileError, match="'impact_impulses' is missing"):
        type(traj).load(broken)
