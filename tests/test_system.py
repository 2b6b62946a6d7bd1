"""The System facade: caching, description, parameters, Lagrangian-only models."""

from __future__ import annotations

import warnings

import numpy as np
import pytest
import sympy as sp

import dalembert.codegen.compiled as compiled_module
from dalembert import Holonomic, System, coordinates, t

x, y = coordinates("x y")
m, g, l = sp.symbols("m g l", positive=True)


def pendulum() -> System:
    return System([x, y], kinetic=m / 2 * (x.diff() ** 2 + y.diff() ** 2), potential=m * g * y,
                  constraints=[Holonomic(x**2 + y**2 - l**2, name="rod")],
                  parameters={m: 1.0, g: 9.81, l: 1.0}, name="pend")


def test_second_simulate_regenerates_nothing(monkeypatch):
    calls = []
    real = compiled_module.compile_equations

    def counting(eqs):
        calls.append(eqs)
        return real(eqs)

    monkeypatch.setattr(compiled_module, "compile_equations", counting)
    system = pendulum()
    first = system.simulate((0, 0.2), q0=[0.0, -1.0], qd0=[1.0, 0.0])
    compiled, eqs = system.compiled, system.equations()
    second = system.simulate((0, 0.2), q0=[0.0, -1.0], qd0=[1.0, 0.0], parameters={"g": 1.0})
    assert len(calls) == 1 and calls[0] is eqs
    assert system.compiled is compiled and system.equations() is eqs
    assert not np.allclose(first.q[-1], second.q[-1])  # the new g was used


def test_description():
    system = pendulum()
    assert system.coordinate_names == ("x", "y") and system.constraint_names == ("rod",)
    assert system.degrees_of_freedom == 1
    assert [s.name for s in system.parameters] == ["g", "l", "m"]
    assert repr(system) == "System('pend', coordinates=['x', 'y'], constraints=['rod'])"


def test_small_oscillation_period_matches_closed_form():
    # Released at 0.01 rad: period 2 pi sqrt(l/g) (1 + theta0^2/16) to 1e-8 relative.
    system = pendulum()
    th0 = 0.01
    period = 2 * np.pi * np.sqrt(1 / 9.81) * (1 + th0**2 / 16)

    def upward(t_, q, qd):
        return q[0]

    upward.direction = 1
    traj = system.simulate((0, 3), q0=[np.sin(th0), -np.cos(th0)], events=[upward])
    assert abs(traj.t_events[0][0] - 0.75 * period) < 1e-8


def test_lagrangian_only_model_conserves_jacobi_integral():
    # Charged particle in a uniform field B along z: circular motion of radius v m / (qB).
    q, B = sp.symbols("q B")
    L = m / 2 * (x.diff() ** 2 + y.diff() ** 2) + q * B / 2 * (x * y.diff() - y * x.diff())
    system = System([x, y], lagrangian=L, parameters={m: 2.0, q: 1.0, B: 4.0})
    s = np.linspace(0, 3, 31)
    traj = system.simulate((0, 3), q0=[0.0, 0.0], qd0=[1.0, 0.0], t_eval=s)
    omega = 4.0 / 2.0  # qB/m, clockwise for positive qB
    np.testing.assert_allclose(traj["x"], np.sin(omega * s) / omega, atol=1e-11)
    np.testing.assert_allclose(traj["y"], (np.cos(omega * s) - 1) / omega, atol=1e-11)
    assert np.all(np.isnan(traj.energy))
    assert np.abs(traj.jacobi_integral - 1.0).max() < 1e-10  # h = T = m v^2 / 2


def test_rotating_frame_jacobi_integral():
    # A bead on a rod spinning at Omega: r'' = Omega^2 r; h = T2 - T0 is conserved, E is not.
    W = 2.0
    T = (x.diff() ** 2 + (W * x) ** 2) / 2
    system = System([x], kinetic=T)
    s = np.linspace(0, 1, 11)
    traj = system.simulate((0, 1), q0=[0.1], t_eval=s)
    np.testing.assert_allclose(traj["x"], 0.1 * np.cosh(W * s), rtol=1e-10)
    assert np.abs(traj.jacobi_integral - traj.jacobi_integral[0]).max() < 1e-11
    assert np.ptp(traj.energy) > 0.1


def test_time_dependent_parameters_of_constraint():
    # A bead driven along x = t^2 / 2: A = [1, 0], so A^T lambda = m x'' gives lambda = m.
    system = System([x, y], kinetic=m / 2 * (x.diff() ** 2 + y.diff() ** 2),
                    constraints=[Holonomic(x - t**2 / 2, name="track")], parameters={m: 3.0})
    traj = system.simulate((0, 1), q0=[0.0, 0.0], qd0=[0.0, 0.5])
    assert np.abs(traj.multiplier("track") - 3.0).max() < 1e-12
    assert np.abs(traj["y"] - 0.5 * traj.t).max() < 1e-13


@pytest.mark.parametrize("stabilization", ["projection", "baumgarte", None])
def test_all_stabilizations_record_residuals(stabilization):
    traj = pendulum().simulate((0, 0.5), q0=[1.0, 0.0], stabilization=stabilization)
    assert traj.position_residual.shape == traj.t.shape
    assert traj.position_residual.max() < 1e-9


# -- warnings point at the user's line, not into the library ----------------------------
def recorded(call):
    """The warnings ``call()`` gives, each as ``(category name, file)``."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        call()
    return [(w.category.__name__, w.filename) for w in caught]


def test_the_warnings_of_simulate_plan_and_run_point_at_the_callers_line():
    system = pendulum()
    off = {"x": 1.1, "y": 0.0}  # off the rod: projected, InitialConditionsAdjusted
    twice = System([x, y], kinetic=m / 2 * (x.diff() ** 2 + y.diff() ** 2),
                   potential=m * g * y, parameters={m: 1.0, g: 9.81, l: 1.0},
                   constraints=[Holonomic(x**2 + y**2 - l**2, name="rod"),
                                Holonomic(2 * (x**2 + y**2 - l**2), name="again")])

    def failing(t, q, qd):
        return 1.0 / 0.0 if t > 0.1 else 1.0

    calls = {
        "InitialConditionsAdjusted": lambda: system.simulate((0, 0.1), off),
        "RedundantConstraintsWarning": lambda: twice.simulate((0, 0.1), {"x": 1.0, "y": 0.0}),
        "IntegrationWarning": lambda: system.simulate((0, 0.5), {"x": 1.0, "y": 0.0},
                                                      events=[failing]),
        "plan": lambda: system.plan((0, 0.1), off),
        "run": lambda: system.run(system.plan((0, 0.5), {"x": 1.0, "y": 0.0},
                                              events=[failing])),
    }
    for what, call in calls.items():
        found = recorded(call)
        assert found, what
        kind = {"plan": "InitialConditionsAdjusted", "run": "IntegrationWarning"}.get(what, what)
        assert kind in [name for name, _ in found], (what, found)
        assert all(file == __file__ for _, file in found), (what, found)


def test_options_checked_once_plan_each_run():
    """check_options once, plan_checked per run (what an ensemble does): each run's own
    parameters used, against the small-oscillation period 2 pi sqrt(l/g) (1 + th0^2/16)
    to 1e-8; run(dynamics=False) gives the same motion without the KKT outputs."""
    system, th0 = pendulum(), 0.01

    def upward(t_, q, qd):
        return q[0]

    upward.direction = 1
    options = system.check_options((0, 3), events=[upward])
    for gravity in (4.0, 9.81):
        plan = system.plan_checked(options, [np.sin(th0), -np.cos(th0)],
                                   parameters={"g": gravity})
        traj = system.run(plan)
        period = 2 * np.pi * np.sqrt(1 / gravity) * (1 + th0**2 / 16)
        assert abs(traj.t_events[0][0] - 0.75 * period) < 1e-8
    light = system.run(plan, dynamics=False)
    np.testing.assert_array_equal(light.q, traj.q)
    assert np.isnan(light.multipliers).all() and not np.isnan(traj.multipliers).any()


def test_check_options_refuses_what_simulate_refuses():
    system = pendulum()
    with pytest.raises(ValueError, match="rtol"):
        system.check_options((0, 1), rtol=-1.0)
    with pytest.warns(UserWarning) as caught:  # the adjusted start, said at the caller's line
        system.plan_checked(system.check_options((0, 1)), [2.0, 0.0])
    assert caught[0].filename == __file__


@pytest.mark.parametrize(("call", "message"), [
    (lambda s: s.simulate((0, 1), [0.0, -1.0], rtol=0.0),
     "The 'rtol' parameter of simulate must be a finite positive number or an array of "
     "them or None (the method's default); got 0.0."),
    (lambda s: s.plan((0, 1), [0.0, -1.0], backend="gpu"),
     "The 'backend' parameter of simulate must be one of 'auto', 'c', 'python'; got 'gpu'."),
    (lambda s: s.consistent_initial_state([0.0, -1.0], velocity_projection="nearest"),
     "The 'velocity_projection' parameter of consistent_initial_state must be one of "
     "'kinetic-energy', 'least-change'; got 'nearest'."),
    (lambda s: s.equilibrium([0.1, -1.0], max_iter=0),
     "The 'max_iter' parameter of equilibrium must be a positive whole number; got 0."),
    (lambda s: s.linearize([0.0, -1.0], on_marginal="warn"),
     "The 'on_marginal' parameter of linearize must be one of 'report', 'raise'; got 'warn'."),
])
def test_a_bad_keyword_is_refused_at_the_door_before_any_code_is_made(call, message):
    system = pendulum()
    with pytest.raises(ValueError) as info:
        call(system)
    assert str(info.value) == message
    assert "compiled" not in vars(system)  # nothing derived or compiled before the refusal


@pytest.mark.parametrize(("name", "where"), [
    ("x", "'x' is a coordinate of this model, not a parameter: give its initial value in q0"),
    ("u", "'u' is an input of this model, not a parameter: give its values with inputs="),
])
def test_a_parameter_named_as_a_coordinate_or_an_input_says_where_it_goes(name, where):
    from dalembert import ParameterError

    u = sp.Symbol("u")
    pushed = System([x, y], kinetic=m / 2 * (x.diff() ** 2 + y.diff() ** 2),
                    generalized_forces={x: u}, inputs=[u], parameters={m: 1.0})
    with pytest.raises(ParameterError, match=where):
        pushed.simulate((0, 1), [0.0, 0.0], inputs={"u": 1.0}, parameters={name: 1.0})
    with pytest.raises(ParameterError, match=where):
        System([x], kinetic=x.diff() ** 2 / 2, generalized_forces={x: u}, inputs=[u],
               parameters={name: 1.0})


class Counting:
    """A definition of one's own: a symbolic one, counting what the System asks of it."""

    def __init__(self, inner):
        self.inner, self.compiled = inner, 0

    def compile(self):
        self.compiled += 1
        return self.inner.compile()

    def __getattr__(self, name):
        return getattr(self.inner, name)


def test_a_system_runs_what_its_definition_gives():
    from dalembert.definition import SymbolicDefinition
    from dalembert.model.model import build_model

    (z,) = coordinates("z")
    falling = build_model([z], kinetic=m / 2 * z.diff() ** 2, potential=m * g * z)
    definition = Counting(SymbolicDefinition(falling))
    system = System.from_definition(definition, parameters={"m": 2.0, "g": 9.81})
    assert system.definition is definition and system.coordinate_names == ("z",)
    for v0 in (0.0, 3.0):
        traj = system.simulate((0, 2), [10.0], [v0], t_eval=[1.0, 2.0])
        # z(t) = z0 + v0 t - g t^2 / 2
        np.testing.assert_allclose(traj["z"], [10.0 + v0 - 9.81 / 2, 10.0 + 2 * v0 - 2 * 9.81],
                                   rtol=1e-12)
    assert definition.compiled == 1


def test_a_multibody_system_is_a_system_holding_its_mechanism():
    from dalembert.multibody import chain
    from dalembert.multibody.builder import multibody_of

    mb = chain(2, 1.0, 1.0, 0.05)
    assert isinstance(mb.system, System) and type(mb.system) is System
    assert multibody_of(mb.system) is mb and mb.system.definition.multibody is mb
