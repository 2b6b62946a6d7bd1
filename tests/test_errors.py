"""Bad input gets a clear error that names the problem (one test per situation).

Each situation here is a row of the table in ``docs/errors.md``.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest
import sympy as sp

from dalembert import (
    BadCacheEntryWarning,
    ConstraintError,
    DoubleCountingWarning,
    Holonomic,
    InitialConditionError,
    IntegrationWarning,
    ModelError,
    NativeUnavailableWarning,
    ParameterError,
    Pfaffian,
    PointForce,
    SingularSystemError,
    System,
    Trajectory,
    TrajectoryFileError,
    UnsafeCacheError,
    coordinates,
    t,
)
from dalembert.codegen import c_backend
from dalembert.codegen import cache as cache_module
from dalembert.codegen.compiled import compile_equations
from dalembert.errors import RedundantConstraintsWarning
from dalembert.solvers.native import library

x, y, z = coordinates("x y z")
m, g, l = sp.symbols("m g l", positive=True)
T2 = m / 2 * (x.diff() ** 2 + y.diff() ** 2)
T3 = m / 2 * (x.diff() ** 2 + y.diff() ** 2 + z.diff() ** 2)
ROD = Holonomic(x**2 + y**2 - l**2, name="rod")


def pendulum(**changes: object) -> System:
    """The Cartesian pendulum; ``changes`` replace its constructor arguments."""
    kwargs: dict[str, object] = dict(kinetic=T2, potential=m * g * y, constraints=[ROD],
                                     parameters={m: 1.0, g: 9.81, l: 1.0})
    kwargs.update(changes)
    return System([x, y], **kwargs)


@pytest.fixture(scope="module")
def pend() -> System:
    return pendulum()


# -- initial conditions ----------------------------------------------------------------
def test_unknown_coordinate_in_initial_conditions(pend):
    with pytest.raises(InitialConditionError, match=r"q0 names 'z'.*coordinates are x, y"):
        pend.simulate((0, 1), q0={"z": 1.0})


def test_unknown_coordinate_in_initial_velocities(pend):
    with pytest.raises(InitialConditionError, match=r"qd0 names 'w'"):
        pend.simulate((0, 1), q0={x: 1.0}, qd0={"w": 1.0})


def test_wrong_length_array(pend):
    with pytest.raises(InitialConditionError, match=r"q0 has 3 values for 2 coordinates"):
        pend.simulate((0, 1), q0=[1.0, 0.0, 0.0])


def test_non_finite_initial_value(pend):
    with pytest.raises(InitialConditionError, match=r"qd0 is not finite for y"):
        pend.simulate((0, 1), q0=[1.0, 0.0], qd0=[0.0, np.nan])


def test_unknown_fixed_coordinate(pend):
    with pytest.raises(InitialConditionError, match=r"fixed names 'z'"):
        pend.simulate((0, 1), q0=[1.0, 0.0], fixed=["z"])


# -- parameters ------------------------------------------------------------------------
def test_parameter_without_value_is_named():
    system = pendulum(parameters={m: 1.0, g: 9.81})
    with pytest.raises(ParameterError, match=r"no numeric value for parameter\(s\) l"):
        system.simulate((0, 1), q0=[1.0, 0.0])


def test_unknown_parameter_name():
    with pytest.raises(ParameterError, match=r"'k' is not a parameter.*g, l, m"):
        pendulum(parameters={m: 1.0, g: 9.81, l: 1.0, "k": 2.0})


@pytest.mark.parametrize("value", [np.nan, np.inf, -np.inf])
def test_non_finite_parameter(value):
    with pytest.raises(ParameterError, match=r"parameter 'g' = .* is not finite"):
        pendulum(parameters={m: 1.0, g: value, l: 1.0})


def test_non_finite_parameter_override(pend):
    with pytest.raises(ParameterError, match=r"parameter 'l' = inf is not finite"):
        pend.simulate((0, 1), q0=[1.0, 0.0], parameters={"l": np.inf})


def test_non_numeric_parameter():
    with pytest.raises(ParameterError, match=r"parameter 'm' = 'heavy' is not a number"):
        pendulum(parameters={m: "heavy", g: 9.81, l: 1.0})


# -- constraints -----------------------------------------------------------------------
@pytest.mark.parametrize("term", [x.diff() ** 2, sp.sin(x.diff())])
def test_pfaffian_not_linear_names_the_term(term):
    constraint = Pfaffian(term + y.diff(), name="skid")
    plain = str(term.subs(x.diff(), sp.Symbol("x_dot")))
    with pytest.raises(ConstraintError, match=r"'skid' is not linear") as info:
        pendulum(constraints=[constraint])
    assert plain in str(info.value)


def test_pfaffian_without_velocity():
    with pytest.raises(ConstraintError, match=r"contains no velocity.*Holonomic"):
        pendulum(constraints=[Pfaffian(x - y, name="p")])


def test_holonomic_containing_velocities():
    with pytest.raises(ConstraintError, match=r"holonomic constraint 'h' contains velocities"):
        pendulum(constraints=[Holonomic(x.diff() + y, name="h")])


def test_as_many_constraints_as_coordinates():
    system = pendulum(constraints=[Holonomic(x - 1), Holonomic(y - 1)],  # judged numerically
                      parameters={m: 1.0, g: 9.81})
    with pytest.raises(ConstraintError, match=r"no degree of freedom at the initial state: "
                       r"rank\(A\) = 2 independent constraints \(2 given\) on 2 coordinates"):
        system.simulate((0, 1), q0=[1.0, 1.0])


def test_more_constraints_than_coordinates_leaving_no_freedom():
    system = pendulum(constraints=[Holonomic(x - 1), Holonomic(y - 1), Holonomic(x - y)],
                      parameters={m: 1.0, g: 9.81})
    with pytest.raises(ConstraintError, match=r"rank\(A\) = 2 independent constraints "
                       r"\(3 given\) on 2 coordinates \(x, y\)"):
        system.consistent_initial_state([1.0, 1.0])


def circle_twice(**options: object) -> System:
    circle = x**2 + y**2 - l**2
    return System([x, y, z], kinetic=T3, parameters={m: 1.0, l: 1.0}, **options,
                  constraints=[Holonomic(circle, name="c1"), Holonomic(circle, name="c2")])


def test_same_circle_constraint_twice_is_named_with_error_option():
    with pytest.raises(ConstraintError, match=r"dependent \(redundant\).*'c2'") as info:
        circle_twice(redundant_constraints="error").simulate((0, 1), q0=[1.0, 0.0, 0.0])
    assert "'c1'" not in str(info.value)
    assert "redundant_constraints='minimum-norm'" in str(info.value)


def test_same_circle_twice_proceeds_with_a_warning_and_minimum_norm_multipliers():
    v = 2.0
    with pytest.warns(RedundantConstraintsWarning, match=r"2 degree\(s\) of freedom.*"
                      r"1 dependent on those listed before: c2\)"):
        traj = circle_twice().simulate((0, 1), q0=[1.0, 0.0, 0.0], qd0=[0.0, v, 0.5],
                                       t_eval=np.linspace(0, 1, 11))
    # Uniform circular motion: the total pull 2 (l1 + l2) l = -m v^2 / l, split evenly.
    np.testing.assert_allclose(traj.multipliers, -v**2 / 4, rtol=1e-10)
    assert np.abs(np.hypot(traj["x"], traj["y"]) - 1).max() < 1e-13
    assert "dependent on those listed before: c2" in traj.initialization


def test_simulate_option_overrides_the_system_option():
    with pytest.raises(ConstraintError, match=r"dependent \(redundant\).*'c2'"):
        circle_twice().simulate((0, 1), q0=[1.0, 0.0, 0.0], redundant_constraints="error")


def test_c_loop_required_where_it_does_not_apply(monkeypatch):
    monkeypatch.setenv("DALEMBERT_BACKEND", "numpy")
    with pytest.raises(ValueError, match=r"backend='c', but the C loop does not apply: the "
                                         r"model's functions were not generated in C"):
        pendulum().simulate((0, 1), q0=[1.0, 0.0], backend="c")


def test_native_keyword_is_a_deprecated_alias_of_backend(pend):
    with pytest.warns(DeprecationWarning, match=r"native=.*deprecated; use backend='python'"):
        plan = pend.plan((0, 1), q0=[1.0, 0.0], native=False)
    assert plan.loop == "python" and plan.options.backend == "python"
    with pytest.raises(ValueError, match=r"native=True and backend='python' are both given"), \
            pytest.warns(DeprecationWarning):
        pend.simulate((0, 1), q0=[1.0, 0.0], native=True, backend="python")


def test_invalid_redundant_constraints_option():
    with pytest.raises(ValueError, match=r"The 'redundant_constraints' parameter of System must "
                       r"be one of 'minimum-norm', 'error'; got 'ignore'"):
        circle_twice(redundant_constraints="ignore")


def test_proportional_linear_constraints_are_named():
    system = System([x, y, z], kinetic=T3,
                    constraints=[Holonomic(x - y, name="a"), Holonomic(2 * x - 2 * y, name="b")],
                    parameters={m: 1.0}, redundant_constraints="error")
    with pytest.raises(ConstraintError, match=r"constraint 'b' \(holonomic: 2\*x - 2\*y = 0\)"):
        system.simulate((0, 1), q0=[0.0, 0.0, 0.0])


def test_constraint_not_wrapped():
    with pytest.raises(ConstraintError, match=r"wrap it as dalembert.Holonomic"):
        pendulum(constraints=[x**2 + y**2 - l**2])


def test_duplicate_constraint_names():
    with pytest.raises(ConstraintError, match=r"two constraints are named 'c'"):
        System([x, y, z], kinetic=T3, constraints=[Holonomic(x, name="c"), Holonomic(y, name="c")])


# -- singular systems and inconsistent initial values ----------------------------------
def test_singular_kkt_names_the_massless_coordinate():
    system = System([x, y], kinetic=m / 2 * x.diff() ** 2, parameters={m: 1.0})
    with pytest.raises(SingularSystemError, match=r"singular at the initial state.*motion of y "):
        system.simulate((0, 1), q0=[0.0, 0.0])


def test_constraint_positions_fixed_inconsistently(pend):
    with pytest.raises(InitialConditionError, match=r"cannot be made consistent with x, y held"):
        pend.simulate((0, 1), q0=[0.0, 0.0], fixed=["x", "y"])


def test_constraint_without_real_solution():
    system = pendulum(constraints=[Holonomic(x**2 + y**2 + l**2, name="imaginary")])
    with pytest.raises(InitialConditionError, match=r"cannot be made consistent.*residual"):
        system.simulate((0, 1), q0=[0.1, 0.1])


def test_velocities_cannot_be_made_consistent():
    # Both coordinates the constraint x_dot = y_dot involves are held at speeds breaking it.
    system = System([x, y, z], kinetic=T3, constraints=[Pfaffian(x.diff() - y.diff(), name="p")],
                    parameters={m: 1.0})
    with pytest.raises(InitialConditionError, match=r"velocities cannot satisfy.*x, y held"):
        system.simulate((0, 1), q0=[0, 0, 0], qd0=[1.0, 0.0, 0.0], fixed=["x", "y"])


# -- integration failures --------------------------------------------------------------
def test_kkt_singular_during_the_run_returns_the_part_computed():
    # y = x^3 with no inertia in x: A = [3x^2, -1] leaves x undetermined when x reaches 0,
    # which happens when y(t) = -1 + t^2/2 reaches 0, at t = sqrt(2).
    system = System([x, y], kinetic=m / 2 * y.diff() ** 2, potential=-m * g * y,
                    constraints=[Holonomic(y - x**3, name="cubic")],
                    parameters={m: 1.0, g: 1.0})
    with pytest.warns(IntegrationWarning, match=r"returning the trajectory up to t=1\.41"):
        traj = system.simulate((0, 5), q0=[-1.0, -1.0])
    assert not traj.success
    assert traj.status == "failed"
    assert abs(traj.t[-1] - np.sqrt(2)) < 1e-3
    assert "t=1.41" in traj.message
    assert len(traj) > 10 and np.all(np.isfinite(traj.q))


def test_finite_time_blow_up_says_when():
    # x'' = x^3 with zero energy: x = 1 / (1 - t/sqrt(2)), infinite at t = sqrt(2).
    system = System([x], kinetic=x.diff() ** 2 / 2, potential=-(x**4) / 4)
    with pytest.warns(IntegrationWarning, match=r"failed at t=1\.41"):
        traj = system.simulate((0, 10), q0=[1.0], qd0=[1 / np.sqrt(2)])
    assert not traj.success
    assert abs(traj.t[-1] - np.sqrt(2)) < 1e-3
    assert "step size" in traj.message
    exact = 1 / (1 - traj.t[:50] / np.sqrt(2))
    assert np.allclose(traj["x"][:50], exact, rtol=1e-9)


def test_keyboard_interrupt_returns_the_part_computed(pend):
    calls = {"n": 0}

    def impatient(t_, q, qd):
        calls["n"] += 1
        if calls["n"] > 40:
            raise KeyboardInterrupt
        return 1.0

    with pytest.warns(IntegrationWarning, match=r"interrupted by the user at t="):
        traj = pend.simulate((0, 10), q0=[1.0, 0.0], events=[impatient])
    assert traj.status == "interrupted" and not traj.success
    assert len(traj) > 5 and traj.t[-1] < 10
    assert traj.position_residual.max() < 1e-12


def _interrupting(rhs):
    """``rhs`` that raises KeyboardInterrupt from its 201st call on (Ctrl-C)."""
    calls = {"n": 0}

    def wrapped(*args):
        calls["n"] += 1
        if calls["n"] > 200:
            raise KeyboardInterrupt
        return rhs(*args)

    return wrapped


@pytest.mark.parametrize("native", [False, True])
def test_keyboard_interrupt_in_the_right_hand_side(pend, monkeypatch, native):
    # The C loop returns to Python after every stretch of steps (one step here), so
    # Ctrl-C lands between stretches too.
    from dalembert.solvers.native import NativeSolver, run
    from dalembert.solvers.running import run_data

    real = run_data.first_order_rhs
    monkeypatch.setattr(run_data, "first_order_rhs", lambda *a: _interrupting(real(*a)))
    monkeypatch.setattr(NativeSolver, "rhs", _interrupting(NativeSolver.rhs))
    monkeypatch.setattr(run, "MAX_STEPS", 1)
    monkeypatch.setattr(run.StretchRunner, "run", _interrupting(run.StretchRunner.run))
    with pytest.warns(IntegrationWarning, match=r"interrupted"):
        traj = pend.simulate((0, 10), q0=[1.0, 0.0], backend="c" if native else "python")
    assert traj.status == "interrupted" and 0 < traj.t[-1] < 10 and len(traj) > 2


# -- model ------------------------------------------------------------------------------
def test_kinetic_energy_not_quadratic():
    system = System([x], kinetic=x.diff() ** 4)
    with pytest.raises(ModelError, match=r"not quadratic in the velocities.*12\*x_dot\*\*2"):
        system.equations()


def test_acceleration_in_kinetic_energy():
    with pytest.raises(ModelError, match=r"kinetic energy contains the acceleration of 'x'"):
        System([x], kinetic=x.diff(t, 2) ** 2)


def test_function_of_time_that_is_not_a_coordinate():
    f = sp.Function("f")(t)
    with pytest.raises(ModelError, match=r"depends on f\(t\), which is not one of the coord"):
        System([x], kinetic=x.diff() ** 2 + f)


def test_kinetic_energy_without_velocity():
    with pytest.raises(ModelError, match=r"kinetic energy contains no velocity"):
        System([x], kinetic=x**2)


def test_both_lagrangian_and_energies():
    with pytest.raises(ModelError, match=r"either lagrangian=L or kinetic=T"):
        System([x], kinetic=x.diff() ** 2, lagrangian=x.diff() ** 2)


def test_duplicate_coordinate():
    with pytest.raises(ModelError, match=r"coordinate 'x' is listed twice"):
        System([x, x], kinetic=x.diff() ** 2)


def test_unknown_coordinate_in_generalized_forces():
    with pytest.raises(ModelError, match=r"unknown coordinate 'w'"):
        System([x], kinetic=x.diff() ** 2, generalized_forces={"w": 1})


def test_double_counting_generalized_force():
    with pytest.warns(DoubleCountingWarning, match=r"force on 'y' contains -g\*m"):
        System([x, y], kinetic=T2, potential=m * g * y, generalized_forces={y: -m * g})


def test_double_counting_point_force():
    gravity = PointForce(force=[0, -m * g, 0], point=[x, y, 0], name="weight")
    with pytest.warns(DoubleCountingWarning, match=r"'y'.*counted twice"):
        System([x, y], kinetic=T2, potential=m * g * y, forces=[gravity])


def test_no_double_counting_warning_for_a_different_force():
    with warnings.catch_warnings():
        warnings.simplefilter("error", DoubleCountingWarning)
        System([x, y], kinetic=T2, potential=m * g * y, generalized_forces={y: -y.diff()})


# -- simulate() options ----------------------------------------------------------------
def test_invalid_method(pend):
    with pytest.raises(ValueError, match=r"The 'method' parameter of simulate must be one of "
                                         r"'RK23', .*'Radau'.* or a scipy.integrate.OdeSolver "
                                         r"subclass; got 'Euler'"):
        pend.simulate((0, 1), q0=[1.0, 0.0], method="Euler")


def test_lsoda_with_projection(pend):
    with pytest.raises(ValueError, match=r"LSODA cannot be restarted.*'baumgarte'"):
        pend.simulate((0, 1), q0=[1.0, 0.0], method="LSODA")


def test_invalid_stabilization(pend):
    with pytest.raises(ValueError, match=r"The 'stabilization' parameter of simulate must be "
                                         r"one of 'projection', 'baumgarte', None; got 'magic'"):
        pend.simulate((0, 1), q0=[1.0, 0.0], stabilization="magic")


def test_invalid_step_control(pend):
    with pytest.raises(ValueError, match=r"The 'step_control' parameter of simulate must be "
                                         r"one of 'PI', 'scipy'; got 'fast'"):
        pend.simulate((0, 1), q0=[1.0, 0.0], step_control="fast")


@pytest.mark.parametrize("t_span", [(0, 0), (0, np.inf), (0,), "ab", (0, np.nan)])
def test_bad_t_span(pend, t_span):
    with pytest.raises(ValueError, match=r"t_span must be"):
        pend.simulate(t_span, q0=[1.0, 0.0])


@pytest.mark.parametrize(
    ("t_eval", "match"),
    [([0.5, 2.0], "inside t_span"), ([[0.1, 0.2]], "1-D"), ([0.5, 0.2], "strictly ordered"),
     ([0.2, 0.2], "strictly ordered")],
)
def test_bad_t_eval(pend, t_eval, match):
    with pytest.raises(ValueError, match=match):
        pend.simulate((0, 1), q0=[1.0, 0.0], t_eval=t_eval)


def test_ida_refuses_what_it_does_not_take_yet(pend):
    with pytest.raises(ValueError, match=r"method='IDA' cannot take events \(not supported "
                                         r"with IDA yet; use 'Radau' or 'DOP853'\)"):
        pend.simulate((0, 1), q0=[1.0, 0.0], method="IDA", events=[lambda t, q, qd: q[0]])


def test_ida_without_scikit_sundae(pend, monkeypatch):
    import importlib.util

    real = importlib.util.find_spec
    monkeypatch.setattr(importlib.util, "find_spec",
                        lambda name, *a: None if name == "sksundae" else real(name, *a))
    with pytest.raises(ImportError, match=r"method='IDA' needs scikit-sundae \(SUNDIALS IDA\): "
                                          r"pip install 'dalembert\[stiff\]'"):
        pend.simulate((0, 1), q0=[1.0, 0.0], method="IDA")


@pytest.mark.parametrize(("rtol", "atol", "name"), [
    (-1.0, 1e-12, "rtol"), (1e-9, 0.0, "atol"), (0.0, 1e-12, "rtol"), (np.inf, 1e-12, "rtol"),
    (1e-9, np.nan, "atol"), ([1e-9, -1.0], 1e-12, "rtol"), ("tight", 1e-12, "rtol")])
def test_bad_tolerances(pend, rtol, atol, name):
    with pytest.raises(ValueError, match=rf"The '{name}' parameter of simulate must be a finite "
                                         r"positive number or an array of them or None "
                                         r"\(the method.s default\); got"):
        pend.simulate((0, 1), q0=[1.0, 0.0], rtol=rtol, atol=atol)


@pytest.mark.parametrize("gain", [-5.0, 0.0, np.nan, np.inf, "high"])
def test_baumgarte_gain_must_be_finite_and_positive(pend, gain):
    with pytest.raises(ValueError, match=r"The 'baumgarte_gain' parameter of simulate must be "
                                         r"a finite positive number or None; got"):
        pend.simulate((0, 1), q0=[1.0, 0.0], stabilization="baumgarte", baumgarte_gain=gain)


@pytest.mark.parametrize("stabilization", ["projection", None])
def test_baumgarte_gain_without_baumgarte(pend, stabilization):
    with pytest.raises(ValueError, match=r"baumgarte_gain=5.0 is given with stabilization="
                                         r".*the gain applies only to stabilization='baumgarte'"):
        pend.simulate((0, 1), q0=[1.0, 0.0], stabilization=stabilization, baumgarte_gain=5.0)


def test_t_eval_holding_nan(pend):
    with pytest.raises(ValueError, match=r"t_eval must be a 1-D array of finite times inside "
                                         r"t_span \(not finite at index 1\)"):
        pend.simulate((0, 1), q0=[1.0, 0.0], t_eval=[0.2, np.nan, 0.8])


@pytest.mark.parametrize(("name", "value"), [
    ("max_step", 0.0), ("first_step", -1e-3), ("dense_output", "yes"), ("progress", 1),
    ("backend", "gpu"), ("velocity_projection", "mass"), ("events", [1.0])])
def test_other_options_get_the_uniform_message(pend, name, value):
    with pytest.raises(ValueError, match=rf"The '{name}' parameter of simulate must be .*; got"):
        pend.simulate((0, 1), q0=[1.0, 0.0], **{name: value})


# -- the code cache and the C routes ---------------------------------------------------
needs_cc = pytest.mark.skipif(c_backend.find_compiler() is None, reason="no C compiler found")


@pytest.fixture()
def cache(tmp_path, monkeypatch):
    folder = tmp_path / "cache"
    monkeypatch.setenv("DALEMBERT_CACHE_DIR", str(folder))
    monkeypatch.setattr(c_backend, "_WARNED", set())  # each test sees its warnings
    return folder


@needs_cc
def test_a_shared_code_cache_is_refused(pend, cache):
    cache.mkdir(mode=0o777)
    cache.chmod(0o777)
    with pytest.warns(NativeUnavailableWarning, match=(
            rf"the model's C code is unavailable, using NumPy instead \(slower\): the code cache "
            rf"{cache} is writable by group or others \(mode 0777\): a library planted there "
            rf"would run as you. Make it private \(chmod 700 {cache}\) or set "
            "DALEMBERT_CACHE_DIR to a folder of your own")):
        compiled = compile_equations(pend.equations(), backend="c")
    assert compiled.backend == "numpy" and list(cache.iterdir()) == []
    with pytest.raises(UnsafeCacheError):
        c_backend.source_library("int f(void) { return 0; }")


@needs_cc
def test_a_damaged_cached_library_is_rebuilt(pend, cache):
    assert compile_equations(pend.equations(), backend="c").backend == "c"
    (library,) = (cache / "c").glob("*.so")
    # A new file in its place: the one this process has loaded stays as it was.
    truncated = library.with_name("truncated")
    truncated.write_bytes(library.read_bytes()[:1000])
    truncated.replace(library)
    with pytest.warns(BadCacheEntryWarning, match=(
            rf"the cached library {library} is truncated \(1000 of \d+ bytes\); it was not loaded "
            "but rebuilt")):
        again = compile_equations(pend.equations(), backend="c")
    assert again.backend == "c"


@needs_cc
def test_a_read_only_code_cache_names_the_cause(pend, cache, monkeypatch):
    def read_only(*args, **kwargs):
        raise OSError(30, "Read-only file system")

    monkeypatch.setattr(cache_module.tempfile, "mkdtemp", read_only)
    with pytest.warns(NativeUnavailableWarning, match=(
            rf"cannot write to the code cache {cache / 'c'}: Read-only file system; set "
            "DALEMBERT_CACHE_DIR to a writable folder")):
        assert compile_equations(pend.equations(), backend="c").backend == "numpy"


def test_no_c_compiler_is_said(cache, monkeypatch):
    monkeypatch.setattr(c_backend, "find_compiler", lambda: None)
    with pytest.warns(NativeUnavailableWarning, match=r"using NumPy instead \(slower\): no C "
                                                      r"compiler found .*DALEMBERT_BACKEND=numpy"):
        assert c_backend.backend() == "numpy"


@needs_cc
def test_an_unavailable_c_loop_is_said(pend, cache, monkeypatch):
    monkeypatch.setattr(library, "runtime_source", lambda: "#error no runtime")
    library._runtime.cache_clear()
    try:
        with pytest.warns(NativeUnavailableWarning, match=r"the C simulation loop is unavailable, "
                                                          r"the Python loop runs instead "
                                                          r"\(slower\): .*no runtime"):
            plan = pend.plan((0, 1), q0=[1.0, 0.0])
    finally:
        library._runtime.cache_clear()  # the next simulation loads the real one
    assert plan.loop == "python" and "no runtime" in plan.why_python


# -- trajectory files ------------------------------------------------------------------
@pytest.fixture(scope="module")
def short(pend):
    return pend.simulate((0, 0.1), q0=[1.0, 0.0])


def test_save_in_another_format(short, tmp_path):
    with pytest.raises(TrajectoryFileError, match=r"Trajectory.save writes NumPy .npz files "
                                                  r"only; '.*run.csv' has the suffix '.csv'"):
        short.save(tmp_path / "run.csv")


def test_load_a_file_that_is_not_a_trajectory(tmp_path):
    path = tmp_path / "run.npz"
    path.write_text("t,x\n0,1\n")
    with pytest.raises(TrajectoryFileError, match=rf"{path} is not a trajectory file: it is not "
                                                  r"an .npz archive"):
        Trajectory.load(path)


def test_load_a_trajectory_with_nonsense_metadata(short, tmp_path):
    path = short.save(tmp_path / "run.npz")
    with np.load(path) as data:
        content = {name: data[name] for name in data.files}
    content["meta"] = np.array(str(content["meta"]).replace('"finished"', "123"))
    np.savez(path, **content)
    with pytest.raises(TrajectoryFileError, match=rf"{path} is not a valid trajectory file: the "
                                                  r"field 'status' is 123, not a JSON str"):
        Trajectory.load(path)


def test_load_a_file_that_would_expand_too_far(short, tmp_path):
    path = short.save(tmp_path / "run.npz")
    with pytest.raises(TrajectoryFileError, match=rf"{path} would take \d+ bytes once read, more "
                                                  r"than the limit of 1000 bytes"):
        Trajectory.load(path, max_bytes=1000)
