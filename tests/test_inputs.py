"""Inputs: values given during a simulation (constants, controllers, tables, sampled).

References: the same control law written in SymPy inside the model (no input); a hand
loop of short simulations, one per sample, for the zero-order hold; closed forms for a
pushed particle (constant, ramp table); the values a run records and saves. Every
case in both loops (C and Python).
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest
import sympy as sp
from scipy.interpolate import CubicSpline

from dalembert import InputError, IntegrationWarning, ModelError, System, Trajectory, coordinates
from dalembert.multibody import Actuator, Force, Ground, Multibody, Particle, PlanarBody, Revolute

BACKENDS = ["c", "python"]
(theta,) = coordinates("theta")
u = sp.Symbol("u")
KP, KD = 20.0, 4.0


def pendulum(law=None) -> System:
    """A unit pendulum (angle theta) pushed by the torque ``u``, or by ``law`` itself."""
    return System([theta], kinetic=theta.diff() ** 2 / 2, potential=-9.81 * sp.cos(theta),
                  generalized_forces={theta: u if law is None else law},
                  inputs=[u] if law is None else [])


def pd(t, q, qd):
    return -KP * q[0] - KD * qd[0]


@pytest.mark.parametrize("backend", BACKENDS)
def test_a_python_controller_equals_the_same_law_in_sympy(backend):
    times = np.linspace(0.0, 3.0, 31)
    ours = pendulum().simulate((0, 3), {theta: 1.0}, inputs=pd, t_eval=times, backend=backend)
    law = -KP * theta - KD * theta.diff()
    reference = pendulum(law).simulate((0, 3), {theta: 1.0}, t_eval=times, backend=backend)
    assert np.abs(ours.q - reference.q).max() < 1e-10
    assert np.abs(ours.qd - reference.qd).max() < 1e-10
    # the trajectory records the torque applied at each output
    np.testing.assert_allclose(ours.input("u"), -KP * ours.q[:, 0] - KD * ours.qd[:, 0],
                               rtol=1e-13, atol=1e-13)


@pytest.mark.parametrize("backend", BACKENDS)
def test_a_sampled_controller_equals_a_hand_loop_of_short_runs(backend):
    """100 Hz zero-order hold over 1 s: 100 samples, each held over its interval."""
    system = pendulum()
    traj = system.simulate((0, 1), {theta: 1.0}, inputs=pd, sample_time=0.01,
                           t_eval=np.linspace(0, 1, 11), backend=backend)
    assert traj.stats["n_samples"] == 100
    q, qd, held = np.array([1.0]), np.array([0.0]), []
    for k in range(100):
        a, b = k * 0.01, (k + 1) * 0.01
        value = pd(a, q, qd)
        held.append(value)
        step = system.simulate((a, b), q, qd, inputs=value, t_eval=[b], backend=backend)
        q, qd = step.q[-1], step.qd[-1]
    assert np.abs(traj.q[-1] - q).max() < 1e-10
    assert np.abs(traj.qd[-1] - qd).max() < 1e-10
    # the values recorded are the held ones: at t = 0.1 the sample taken then
    np.testing.assert_allclose(traj.input("u")[1], held[10], rtol=1e-10)


@pytest.mark.parametrize("backend", BACKENDS)
def test_tables_and_interpolators(backend):
    """A unit mass pushed by u(t) = t from rest: x = t^3 / 6 (the table is exact)."""
    (x,) = coordinates("x")
    mass = System([x], kinetic=x.diff() ** 2 / 2, generalized_forces={x: u}, inputs=[u])
    table = ([0.0, 2.0], [0.0, 2.0])
    traj = mass.simulate((0, 2), {x: 0.0}, inputs=table, t_eval=[1.0, 2.0], backend=backend)
    np.testing.assert_allclose(traj["x"], np.array([1.0, 8.0]) / 6, rtol=1e-12)
    spline = CubicSpline([0.0, 1.0, 2.0, 3.0], [0.0, 1.0, 2.0, 3.0])  # a u(t)
    traj = mass.simulate((0, 2), {x: 0.0}, inputs={"u": spline}, t_eval=[2.0], backend=backend)
    assert traj["x"][0] == pytest.approx(8.0 / 6, rel=1e-12)
    with pytest.raises(InputError, match=r"covers t = 0 \.\. 2, not all of t_span"):
        mass.simulate((0, 3), {x: 0.0}, inputs=table)


def test_several_inputs_by_name_and_saved():
    (x,) = coordinates("x")
    v = sp.Symbol("v")
    both = System([x], kinetic=x.diff() ** 2 / 2, generalized_forces={x: u - v},
                  inputs=[u, v])
    traj = both.simulate((0, 1), {x: 0.0}, inputs={u: 3.0, "v": lambda t: 1.0},
                         t_eval=[0.5, 1.0])
    assert traj["x"][-1] == pytest.approx(1.0, rel=1e-12)  # (3 - 1) t^2 / 2
    assert traj.input_names == ("u", "v")
    np.testing.assert_array_equal(traj.inputs, [[3.0, 1.0], [3.0, 1.0]])
    import tempfile
    from pathlib import Path

    with tempfile.TemporaryDirectory() as folder:
        again = Trajectory.load(traj.save(Path(folder) / "run.npz"))
    np.testing.assert_array_equal(again.inputs, traj.inputs)
    assert again.input_names == ("u", "v")


def test_a_multibody_actuator_and_force_take_inputs():
    """A motor holding a disk's rate with a proportional controller, and a pushed
    particle: both against closed forms."""
    disk = PlanarBody("disk", 1.0, 0.5)
    pin = Revolute("pin", Ground(), disk)
    p = Particle("p", 2.0)
    F = sp.Symbol("F")
    mb = Multibody([disk, p], [pin], actuators=[Actuator("motor", pin, u)],
                   forces=[Force(p, (F, 0, 0))], inputs=[u, F], gravity=(0, 0, 0))
    assert mb.system.inputs == (u, F) and mb.system.parameters == ()
    gain = 4.0

    def control(t, q, qd):
        return np.array([gain * (2.0 - qd[2]), 1.0])  # [u, F]

    traj = mb.simulate((0, 2), {}, inputs=control, t_eval=[2.0])
    # 0.5 w' = 4 (2 - w): w = 2 (1 - exp(-8 t)); the particle: x = F t^2 / (2 m)
    assert traj["disk_theta_dot"][0] == pytest.approx(2 * (1 - np.exp(-16.0)), rel=1e-10)
    assert traj["p_x"][0] == pytest.approx(1.0, rel=1e-12)


@pytest.mark.parametrize("backend", BACKENDS)
def test_a_controller_that_raises_returns_the_run_so_far(backend):
    def failing(t, q, qd):
        if t > 0.5:
            raise RuntimeError("sensor lost")
        return pd(t, q, qd)

    with pytest.warns(IntegrationWarning, match="sensor lost") as record:
        traj = pendulum().simulate((0, 1), {theta: 1.0}, inputs=failing,
                                   t_eval=np.linspace(0, 1, 11), backend=backend)
    assert traj.status == "failed" and "the input 'u' raised at t=0.5" in traj.message
    assert 0.4 <= traj.t[-1] <= 0.5 and len(traj) >= 5
    assert isinstance(record[0].message.__cause__, InputError)


@pytest.mark.parametrize("backend", BACKENDS)
def test_a_controller_that_changes_its_arguments_changes_only_its_own_copy(backend):
    """Writing into the q and qd it is given (wrapping an angle, zeroing a rate) leaves
    the run alone: the same motion as the law written in SymPy."""
    def meddling(t, q, qd):
        torque = pd(t, q, qd)
        q[0], qd[0] = 5.0, 0.0
        return torque

    times = np.linspace(0.0, 3.0, 31)
    ours = pendulum().simulate((0, 3), {theta: 1.0}, inputs=meddling, t_eval=times,
                               backend=backend)
    reference = pendulum(-KP * theta - KD * theta.diff()).simulate(
        (0, 3), {theta: 1.0}, t_eval=times, backend=backend)
    assert ours.success
    assert np.abs(ours.q - reference.q).max() < 1e-10
    assert np.abs(ours.qd - reference.qd).max() < 1e-10


@pytest.mark.parametrize(("inputs", "message"), [
    (None, r"the model's inputs u have no values: pass inputs=\{'u': \.\.\.\}"),
    ({"w": 1.0}, r"'w' is not an input of this model \(its inputs: u\)"),
    ("fast", r"the input 'u' must be a finite number, a function"),
    (([0, 1], [0, 1, 2]), r"a table is \(times, values\) with at least two times"),
])
def test_bad_inputs_are_named(inputs, message):
    with pytest.raises(InputError, match=message):
        pendulum().simulate((0, 1), {theta: 1.0}, inputs=inputs)


@pytest.mark.parametrize("backend", BACKENDS)
def test_a_function_giving_the_wrong_shape_or_nan_stops_the_run(backend):
    with pytest.warns(IntegrationWarning):
        traj = pendulum().simulate((0, 1), {theta: 1.0}, inputs=lambda t: [1.0, 2.0],
                                   backend=backend)
    assert "the input 'u' gave an array of shape (2,)" in traj.message
    with pytest.warns(IntegrationWarning):
        traj = pendulum().simulate((0, 1), {theta: 1.0}, inputs=lambda t: np.nan,
                                   backend=backend)
    assert "the input 'u' gave [nan]" in traj.message


def test_sample_times_and_inputs_in_the_wrong_place_are_refused():
    with pytest.raises(ValueError, match="The 'sample_time' parameter of simulate must be"):
        pendulum().simulate((0, 1), {theta: 1.0}, inputs=pd, sample_time=0.0)
    (x,) = coordinates("x")
    with pytest.raises(ModelError, match="the input 'u' appears in the Lagrangian"):
        System([x], kinetic=x.diff() ** 2 / 2, potential=u * x, inputs=[u])
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        with pytest.raises(InputError, match="the model declares no inputs"):
            pendulum(0).simulate((0, 1), {theta: 1.0}, inputs=1.0)


def test_holding_replaces_the_sources_of_the_inputs_named():
    from dalembert.inputs import input_signal

    signal = input_signal({"u": pd, "v": lambda t: 2 * t}, ["u", "v"], None, (0.0, 1.0))
    held = signal.holding({"u": 4.0})
    assert held(0.5, np.array([1.0]), np.array([1.0])).tolist() == [4.0, 1.0]
    assert signal(0.5, np.array([1.0]), np.array([1.0])).tolist() == [-24.0, 1.0]  # unchanged
    with pytest.raises(InputError, match="'w' is not an input of this model"):
        signal.holding({"w": 1.0})
    with pytest.raises(InputError, match="must be a finite number, got nan"):
        signal.holding({"v": float("nan")})
    together = input_signal(lambda t: [t, t], ["u", "v"], None, (0.0, 1.0))
    with pytest.raises(InputError, match="gives u together with other inputs"):
        together.holding({"u": 1.0})


class _Gain:
    """A callable controller object: u = -k theta."""

    def __init__(self, k: float) -> None:
        self.k = k

    def __call__(self, t, q, qd):
        return -self.k * q[0]


@pytest.mark.parametrize("function", [lambda t, q: 1.0, lambda t, q, qd, extra: 1.0,
                                      lambda *, t: 1.0, lambda: 1.0])
def test_a_function_of_a_wrong_signature_is_refused_at_the_door(function):
    """Before any step: it would fail at its first call, a run of one point."""
    with pytest.raises(InputError, match=r"the input 'u': the function given takes \(.*\), so "
                       r"it cannot be called as u\(t, q, qd\) .* or u\(t\)"):
        pendulum().plan((0, 1), {theta: 1.0}, inputs=function)
    with pytest.raises(InputError, match=r"the input 'v': the function given takes"):
        System([theta], kinetic=theta.diff() ** 2 / 2, generalized_forces={theta: u + v},
               inputs=[u, v]).simulate((0, 1), {theta: 1.0}, inputs={"u": 0.0, "v": function})


v = sp.Symbol("v")


def test_every_valid_form_of_a_function_still_runs():
    """partial, callable objects, *args, defaults, builtins without a signature: each gives
    the torque its law says (the pendulum's closed-loop run against the law in SymPy)."""
    from functools import partial

    times = np.linspace(0.0, 1.0, 5)
    reference = pendulum(-3.0 * theta).simulate((0, 1), {theta: 1.0}, t_eval=times)
    laws = [partial(lambda k, t, q, qd: -k * q[0], 3.0), _Gain(3.0),
            lambda t, *state: -3.0 * state[0][0], lambda t, q, qd, scale=3.0: -scale * q[0]]
    for law in laws:
        traj = pendulum().simulate((0, 1), {theta: 1.0}, inputs=law, t_eval=times)
        assert np.abs(traj.q - reference.q).max() < 1e-10, law
    # of the time: a partial, a ufunc, a builtin whose signature cannot be read (u(t))
    for law, values in [(partial(lambda k, t: k * t, 0.5), 0.5 * times), (np.sin, np.sin(times)),
                        (partial(max, 0.25), np.maximum(0.25, times))]:
        traj = pendulum().simulate((0, 1), {theta: 1.0}, inputs=law, t_eval=times)
        assert traj.success and np.allclose(traj.input("u"), values, rtol=0, atol=1e-15), law


@pytest.mark.parametrize("backend", BACKENDS)
def test_an_input_that_raises_once_ends_the_run_in_every_loop(backend):
    """Raising once (a sensor glitch) is reported, not retried away: the C loop's
    stretches used to hand the step to Python, whose retry went through."""
    calls = {"raised": False}

    def glitch(t, q, qd):
        if t > 0.5 and not calls["raised"]:
            calls["raised"] = True
            raise RuntimeError("glitch")
        return pd(t, q, qd)

    with pytest.warns(IntegrationWarning, match="glitch"):
        traj = pendulum().simulate((0, 1), {theta: 1.0}, inputs=glitch,
                                   t_eval=np.linspace(0, 1, 11), backend=backend)
    assert traj.status == "failed" and "the input 'u' raised at t=0.5" in traj.message
    assert 0.4 <= traj.t[-1] <= 0.5


@pytest.mark.parametrize("backend", BACKENDS)
def test_ctrl_c_inside_an_input_function_interrupts_the_run_keeping_it(backend):
    """A Ctrl-C lands in the input's function when the C loop calls it: the run stops
    as interrupted, with the trajectory up to there (the C loop dropped it and ran on)."""
    calls = {"pressed": False}

    def pressed(t, q, qd):  # one Ctrl-C, as a signal gives it
        if t > 0.5 and not calls["pressed"]:
            calls["pressed"] = True
            raise KeyboardInterrupt
        return pd(t, q, qd)

    with pytest.warns(IntegrationWarning, match="interrupted"):
        traj = pendulum().simulate((0, 1), {theta: 1.0}, inputs=pressed,
                                   t_eval=np.linspace(0, 1, 11), backend=backend)
    assert traj.status == "interrupted"
    assert 0.4 <= traj.t[-1] <= 0.5 and len(traj) >= 5
