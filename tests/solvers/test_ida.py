"""``method="IDA"``: SUNDIALS IDA on the stabilized index-2 (GGL) form (``solvers/ida.py``,
``solvers/ggl.py``).

References: central differences of the GGL residual (built from the dense KKT blocks,
``psi`` and ``A v + b``, functions generated apart from the Jacobians) for the exact
Newton matrix, on a quaternion body, a rolling disk (Pfaffian rows), a time-dependent
constraint (the car axis) and dependent rows; the pendulum's quarter period in closed
form (an elliptic integral); steady rolling of a disk in closed form (tilt and
precession constant); a stiff spring (k = 1e6) against a tight DOP853 run. The car
axis against the IVP Test Set's reference is in ``test_car_axis.py``.
"""

from __future__ import annotations

import warnings

import car_axis
import numpy as np
import pytest
from scipy.special import ellipk
from test_jacobian import stiff_double_pendulum

from dalembert import Holonomic, System, coordinates
from dalembert.examples import heavy_top, rolling_disk
from dalembert.options import simulation_options
from dalembert.solvers import ida
from dalembert.solvers.ggl import CompressedColumns, GGLForm


def central_differences(form: GGLForm, t: float, y: np.ndarray, yp: np.ndarray,
                        cj: float) -> np.ndarray:
    """``dF/dy + cj dF/dy'`` by central differences along ``(e_j, cj e_j)``."""
    J = np.empty((form.size, form.size))
    for j in range(form.size):
        h = 1e-6 * max(1.0, abs(y[j]))
        e = np.zeros(form.size)
        e[j] = h
        J[:, j] = (form.residual(t, y + e, yp + cj * e)
                   - form.residual(t, y - e, yp - cj * e)) / (2 * h)
    return J


def assert_exact_newton_matrix(system: System, traj, kept=None, seed: int = 0) -> None:
    """At states of a run, with random multipliers, ``mu`` and rates (the residual need
    not vanish for its derivatives to be compared)."""
    form = GGLForm(system.numeric(), kept)
    rng = np.random.default_rng(seed)
    n = system.numeric().n
    for k in (0, len(traj.t) // 2, -1):
        y = rng.uniform(-1, 1, form.size)
        y[:2 * n] = np.concatenate([traj.q[k], traj.qd[k]])
        yp = rng.uniform(-1, 1, form.size)
        cj = rng.uniform(1, 100)
        exact = form.newton_matrix(traj.t[k], y, yp, cj)
        differences = central_differences(form, traj.t[k], y, yp, cj)
        scale = max(1.0, np.abs(differences).max())
        assert np.abs(exact - differences).max() <= 1e-6 * scale
        columns = CompressedColumns.of(form, traj.t[k], y, yp)
        np.testing.assert_array_equal(
            columns.dense(columns.values(form, traj.t[k], y, yp, cj)), exact)


def test_newton_matrix_of_a_quaternion_body():
    system = heavy_top.build()
    traj = system.simulate((0, 0.5), **heavy_top.INITIAL, t_eval=[0.0, 0.25, 0.5])
    assert_exact_newton_matrix(system, traj)


def test_newton_matrix_with_pfaffian_rows():
    system = rolling_disk.build()
    traj = system.simulate((0, 0.5), **rolling_disk.INITIAL, t_eval=[0.0, 0.25, 0.5])
    assert_exact_newton_matrix(system, traj)


def test_newton_matrix_with_a_moving_constraint():
    system = car_axis.build()
    traj = system.simulate((0, 1), car_axis.Q0, car_axis.QD0, t_eval=[0.0, 0.4, 1.0])
    assert_exact_newton_matrix(system, traj)


def rod_twice() -> tuple[System, dict]:
    x, y = coordinates("x y")
    rod = x**2 + y**2 - 1
    system = System([x, y], kinetic=(x.diff() ** 2 + y.diff() ** 2) / 2, potential=9.81 * y,
                    constraints=[Holonomic(rod, name="rod"), Holonomic(2 * rod, name="again")])
    return system, {x: 1.0, y: 0.0}


@pytest.mark.parametrize("linear_solver", ["dense", "sparse"])
def test_dependent_rows_are_left_out_and_the_quarter_period_holds(linear_solver,
                                                                  monkeypatch):
    """The rod given twice: the GGL form keeps one row (a dependent one would make the
    Newton matrix singular), and the pendulum released from the horizontal reaches the
    bottom after ``K(1/2) / sqrt(g)`` (``l = 1``); with the Newton matrix dense and
    in compressed columns (SuperLU)."""
    if linear_solver == "sparse":
        monkeypatch.setattr(ida, "DENSE_MAX", 0)
    system, q0 = rod_twice()
    quarter = ellipk(0.5) / np.sqrt(9.81)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        plan = system.plan((0, quarter), q0, method="IDA", rtol=1e-10, atol=1e-12,
                           t_eval=[0.0, quarter])
        traj = system.run(plan)
    assert plan.kept is not None and len(plan.kept) == 1
    assert plan.loop == "python" and "IDA" in plan.why_python
    assert traj.status == "finished"
    assert abs(traj["x"][-1]) < 1e-8 and abs(traj["y"][-1] + 1) < 1e-8
    assert_exact_newton_matrix(system, traj, plan.kept)


def test_steady_rolling_stays_steady():
    """A disk started in steady rolling (``rolling_disk.INITIAL``): tilt and precession
    rate stay at their start, the contact conditions hold."""
    system = rolling_disk.build()
    traj = system.simulate((0, 2), **rolling_disk.INITIAL, method="IDA", rtol=1e-10,
                           atol=1e-12, t_eval=np.linspace(0, 2, 11))
    assert traj.status == "finished"
    assert np.abs(traj["theta"] - rolling_disk.THETA0).max() < 1e-7
    assert np.abs(traj["psi_dot"] - traj["psi_dot"][0]).max() < 1e-6
    assert traj.position_residual.max() < 1e-9 and traj.velocity_residual.max() < 1e-8
    assert traj.multipliers.shape == (11, 3) and np.all(np.isfinite(traj.multipliers))


def test_a_stiff_spring_against_a_tight_reference():
    """k = 1e6 on a 5%-damped spring: IDA at its default tolerances (1e-8, 1e-10) meets a
    DOP853 run at 1e-12 to the accuracy its error control allows."""
    system, q0 = stiff_double_pendulum()
    reference = system.simulate((0, 1), q0, rtol=1e-12, atol=1e-14, t_eval=[1.0])
    traj = system.simulate((0, 1), q0, method="IDA", t_eval=[1.0])
    assert traj.status == "finished" and traj.stats["njev"] > 0
    assert np.abs(traj.q[-1] - reference.q[-1]).max() < 1e-6


def test_every_step_is_recorded_without_t_eval():
    system, q0 = rod_twice()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        traj = system.simulate((0, 0.3), q0, method="IDA")
    assert traj.t[0] == 0.0 and traj.t[-1] == 0.3
    assert len(traj.t) == traj.stats["n_steps"] + 1
    assert np.all(np.diff(traj.t) > 0)


@pytest.mark.parametrize(("options", "named"), [
    ({"events": [lambda t, q, qd: q[0]]}, "events"),
    ({"dense_output": True}, "dense_output"),
    ({"inputs": 1.0}, "inputs"),
    ({"stabilization": "baumgarte"}, "stabilization='baumgarte'"),
    ({"backend": "c"}, "backend='c'"),
    ({"rtol": [1e-8, 1e-8]}, "an array of 'rtol'"),
])
def test_what_ida_does_not_take_is_refused(options, named):
    with pytest.raises(ValueError, match=rf"method='IDA' cannot take {named}"):
        simulation_options((0.0, 1.0), method="IDA", **options)


def test_newton_matrix_of_a_chain_assembled_part_by_part():
    """The GGL derivatives through the part route (a Multibody's, whose global equations
    are never built): a 4-link chain of quaternion links on ball joints."""
    from dalembert.multibody import chain

    mb = chain(4, 1.0, 1.0, 0.05)
    omega = np.array([0.4, 0.7, 0.0])
    positions = {f"link{k + 1}": (0.0, 0.0, -(k + 0.5)) for k in range(4)}
    q0, qd0 = mb.initial_state(
        positions=positions,
        velocities={name: np.cross(omega, x) for name, x in positions.items()},
        angular_velocities=dict.fromkeys(positions, omega))
    traj = mb.simulate((0, 0.2), q0, qd0, t_eval=[0.0, 0.1, 0.2])
    assert_exact_newton_matrix(mb.system, traj)
    ida = mb.simulate((0, 0.2), q0, qd0, method="IDA", rtol=1e-10, atol=1e-12,
                      t_eval=[0.2])
    assert np.abs(ida.q[-1] - traj.q[-1]).max() < 1e-7


def test_without_scikit_sundae_the_door_says_what_to_install(monkeypatch):
    import importlib.util

    real = importlib.util.find_spec
    monkeypatch.setattr(importlib.util, "find_spec",
                        lambda name, *a: None if name == "sksundae" else real(name, *a))
    with pytest.raises(ImportError, match=r"pip install 'dalembert\[stiff\]'"):
        simulation_options((0.0, 1.0), method="IDA")


def test_a_timeout_ends_the_run_with_what_it_computed():
    system = car_axis.build()
    with pytest.warns(Warning, match="timeout"):
        traj = system.simulate((0, 3), car_axis.Q0, car_axis.QD0, method="IDA",
                               timeout=0.05)
    assert traj.status == "timeout" and 0 < traj.t[-1] < 3
    assert traj.position_residual.max() < 1e-8


def test_without_constraints_the_form_is_an_ode():
    """No constraint rows: ``y = [q, v]`` and nothing algebraic; ``x'' = -4 x`` from
    ``x = 1`` at rest is ``cos(2 t)``."""
    (x,) = coordinates("x")
    system = System([x], kinetic=x.diff() ** 2 / 2, potential=2 * x**2)
    times = np.linspace(0, 2, 5)
    traj = system.simulate((0, 2), [1.0], [0.0], method="IDA", rtol=1e-10, atol=1e-12,
                           t_eval=times)
    assert np.abs(traj["x"] - np.cos(2 * times)).max() < 1e-7
    assert np.abs(traj["x_dot"] + 2 * np.sin(2 * times)).max() < 1e-7
