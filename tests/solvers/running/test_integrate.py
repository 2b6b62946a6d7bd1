"""Integration: methods, t_eval, dense output, events, direction, stabilization, stiffness."""

from __future__ import annotations

import numpy as np
import pytest
import sympy as sp
from pendulum_case import PERIOD, Q0, G, position_error

from dalembert import Holonomic, System, coordinates, t


@pytest.mark.parametrize(
    ("method", "rtol", "atol", "tol"),
    [("DOP853", 1e-11, 1e-13, 1e-10), ("RK45", 1e-10, 1e-12, 3e-9),
     ("Radau", 1e-8, 1e-10, 1e-7), ("BDF", 1e-9, 1e-11, 1e-7)],
)
def test_methods_agree_with_minimal_coordinates(pendulum, reference, method, rtol, atol, tol):
    traj = pendulum.simulate((0, 2), q0=Q0, method=method, rtol=rtol, atol=atol)
    assert traj.success and traj.t[-1] == 2
    assert position_error(traj, reference) < tol
    assert traj.position_residual.max() < 1e-13 and traj.velocity_residual.max() < 1e-12
    assert traj.stats["n_steps"] == traj.stats["n_projections"] == len(traj) - 1


def test_tension_and_energy(pendulum):
    traj = pendulum.simulate((0, 3), q0=Q0)
    v2 = traj["x_dot"] ** 2 + traj["y_dot"] ** 2
    tension = v2 - G * traj["y"]  # m v^2 / l + m g cos(theta)
    assert np.abs(-2 * traj.multiplier("rod") - tension).max() < 1e-9
    assert np.abs(traj.energy - traj.energy[0]).max() < 1e-10
    np.testing.assert_allclose(traj.constraint_forces,
                               2 * traj.multiplier("rod")[:, None] * traj.q, atol=1e-12)


def test_t_eval_outputs_exactly_there(pendulum, reference):
    t_eval = np.linspace(0.1, 2, 37)
    traj = pendulum.simulate((0, 2), q0=Q0, t_eval=t_eval)
    assert np.array_equal(traj.t, t_eval)
    assert position_error(traj, reference) < 1e-10
    assert traj.position_residual.max() < 1e-13


def test_dense_output_on_the_manifold(pendulum, reference):
    traj = pendulum.simulate((0, 2), q0=Q0, dense_output=True)
    s = np.random.default_rng(3).uniform(0, 2, 50)
    states = traj.sol(s)
    assert states.shape == (4, 50)
    theta = reference(s)[0]
    assert np.abs(states[0] - np.sin(theta)).max() < 1e-9
    assert np.abs(states[0] ** 2 + states[1] ** 2 - 1).max() < 1e-14
    assert np.abs(states[0] * states[2] + states[1] * states[3]).max() < 1e-13
    assert np.array_equal(traj.sol(traj.t[5]), np.concatenate([traj.q[5], traj.qd[5]]))
    with pytest.raises(ValueError, match="outside the integrated interval"):
        traj.sol(2.5)


def test_backward_integration_returns_to_the_start(pendulum, reference):
    forward = pendulum.simulate((0, 1.3), q0=Q0)
    back = pendulum.simulate((1.3, 0), q0=forward.q[-1], qd0=forward.qd[-1],
                             dense_output=True, t_eval=np.linspace(1.3, 0, 14))
    assert back.success and back.t[-1] == 0
    assert np.abs(back.q[-1] - [Q0["x"], Q0["y"]]).max() < 1e-10
    assert np.abs(back.qd[-1]).max() < 1e-9
    assert position_error(back, reference) < 1e-10
    theta = reference(0.65)[0]
    assert abs(back.sol(0.65)[0] - np.sin(theta)) < 1e-9


def crossing(t_, q, qd):
    """x = 0: the bob passes under the pivot."""
    return q[0]


def event(direction: float = 0, terminal: bool | int = False):
    def fn(t_, q, qd):
        return crossing(t_, q, qd)

    fn.direction, fn.terminal = direction, terminal
    return fn


def test_non_terminal_events_all_crossings(pendulum):
    traj = pendulum.simulate((0, 2 * PERIOD), q0=Q0, events=[event()])
    expected = PERIOD * np.array([0.25, 0.75, 1.25, 1.75])
    assert traj.status == "finished"
    assert np.abs(traj.t_events[0] - expected).max() < 1e-10
    assert np.abs(traj.y_events[0][:, 0]).max() < 1e-12


def test_event_direction(pendulum):
    down, up = event(direction=-1), event(direction=+1)
    traj = pendulum.simulate((0, 2 * PERIOD), q0=Q0, events=[down, up])
    assert np.abs(traj.t_events[0] - PERIOD * np.array([0.25, 1.25])).max() < 1e-10
    assert np.abs(traj.t_events[1] - PERIOD * np.array([0.75, 1.75])).max() < 1e-10


def test_terminal_event_stops_there(pendulum):
    traj = pendulum.simulate((0, 2 * PERIOD), q0=Q0, events=[event(terminal=True)],
                             dense_output=True)
    assert traj.status == "event" and traj.success
    assert abs(traj.t[-1] - PERIOD / 4) < 1e-10 and abs(traj["x"][-1]) < 1e-12
    assert "t=0.5" in traj.message
    assert traj.sol.t_max == traj.t[-1]


def test_terminal_count_and_backward_events(pendulum):
    traj = pendulum.simulate((0, 2 * PERIOD), q0=Q0, events=[event(terminal=2)])
    assert abs(traj.t[-1] - 0.75 * PERIOD) < 1e-10 and len(traj.t_events[0]) == 2
    back = pendulum.simulate((0, -PERIOD), q0=Q0, events=[event(terminal=True)])
    assert abs(back.t[-1] + PERIOD / 4) < 1e-10


def test_terminal_event_with_t_eval(pendulum):
    t_eval = np.linspace(0, PERIOD, 11)
    traj = pendulum.simulate((0, PERIOD), q0=Q0, t_eval=t_eval, events=[event(terminal=True)])
    assert np.array_equal(traj.t, t_eval[t_eval <= PERIOD / 4])


def test_stabilization_none_projection_baumgarte(pendulum, reference):
    runs = {s: pendulum.simulate((0, 4), q0=Q0, stabilization=s, method="RK45", rtol=1e-6,
                                 atol=1e-8) for s in (None, "projection", "baumgarte")}
    drift = {s: r.position_residual.max() for s, r in runs.items()}
    # velocities projected with the positions' factor: residual ~ position change x drift
    assert drift["projection"] < 1e-13 and runs["projection"].velocity_residual.max() < 1e-12
    assert drift[None] > 1e-7  # raw index-1 formulation drifts
    assert drift["baumgarte"] < drift[None] / 10
    for r in runs.values():
        assert position_error(r, reference) < 1e-4


def test_baumgarte_without_projection_allows_lsoda(pendulum, reference):
    traj = pendulum.simulate((0, 2), q0=Q0, method="LSODA", stabilization="baumgarte",
                             rtol=1e-10, atol=1e-12)
    assert traj.success and position_error(traj, reference) < 1e-7


def stiff_exact(m: float, k: float, c: float):
    """Closed form of M x'' + c x' + k x = k sin t, x(0) = x'(0) = 0, with M = 5 m."""
    M = 5 * m
    a, b = np.linalg.solve([[k - M, -c], [c, k - M]], [k, 0.0])  # a sin t + b cos t
    r = np.roots([M, c, k])
    C = np.linalg.solve([[1, 1], r], [-b, -a])
    return lambda s: np.real(a * np.sin(s) + b * np.cos(s) + C[0] * np.exp(r[0] * s)
                             + C[1] * np.exp(r[1] * s))


@pytest.mark.validation
@pytest.mark.parametrize(("method", "rtol", "atol", "tol"),
                         [("Radau", 1e-8, 1e-10, 1e-10), ("BDF", 1e-6, 1e-8, 1e-7)])
def test_stiff_mechanism_with_implicit_methods(method, rtol, atol, tol):
    # Mass 1e-3 on the line y = 2x, pulled along x by a stiff spring k = 1e6 (damping
    # c = 200) towards sin(t). Minimal coordinate x (y = 2x): 5 m x'' = -k (x - sin t) - c x',
    # eigenvalues -5.9e3 and -3.4e4 against the slow forcing: stiff.
    x, y = coordinates("x y")
    m, k, c = 1e-3, 1e6, 200.0
    system = System([x, y], kinetic=m / 2 * (x.diff() ** 2 + y.diff() ** 2),
                    potential=k / 2 * (x - sp.sin(t)) ** 2, generalized_forces={x: -c * x.diff()},
                    constraints=[Holonomic(y - 2 * x, name="line")])
    traj = system.simulate((0, 2), q0=[0, 0], method=method, rtol=rtol, atol=atol)
    # Explicit methods need 12800 (DOP853) to 32800 (RK45) steps here. BDF's count
    # depends on rounding: 4700-10300 with the right-hand side scaled by 1 +- 1e-15.
    assert traj.success and traj.stats["n_steps"] < 11000
    assert np.abs(traj["x"] - stiff_exact(m, k, c)(traj.t)).max() < tol
    assert np.abs(traj["y"] - 2 * traj["x"]).max() < 1e-14


def test_finite_difference_jacobian_step_stays_bounded():
    # A state component that the right-hand side ignores made SciPy's num_jac grow its
    # step until overflow (RuntimeWarning, then BDF crawled); ours keeps a fixed step.
    from dalembert.solvers.running.integrate import finite_difference_jacobian

    jac = finite_difference_jacobian(lambda t_, y: np.array([y[1], -y[0], 0.0]))
    for _ in range(500):
        J = jac(0.0, np.array([1.0, 2.0, 3.0]))
    np.testing.assert_allclose(J, [[0, 1, 0], [-1, 0, 0], [0, 0, 0]], atol=1e-7)


def test_progress_bar(pendulum, capsys):
    traj = pendulum.simulate((0, 1), q0=Q0, progress=True)
    assert traj.success
    err = capsys.readouterr().err
    assert "simulating" in err and "100%" in err


def test_progress_bar_stops_at_terminal_event(pendulum, capsys):
    pendulum.simulate((0, PERIOD), q0=Q0, progress=True, events=[event(terminal=True)])
    last = capsys.readouterr().err.replace("\r", "\n").strip().splitlines()[-1]
    assert f"t={PERIOD / 4:.3g}/{PERIOD:.3g}" in last
