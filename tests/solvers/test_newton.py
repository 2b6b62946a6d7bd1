"""The implicit solvers' systems ``(I - c J) x = b`` on the KKT structure
(``solvers/newton.py``) and Radau solving its Newton systems with them.

References: ``I - c J`` with ``J`` from central differences of the right-hand side
(the KKT solve itself, a path that uses no derivative), for real ``c`` and for Radau's
complex ``c``, on a quaternion body, Pfaffian rows, dependent rows, velocity-dependent
forces and a chain; Radau on a 24-link chain (above the dense limit) against SciPy's
Radau on the dense exact Jacobian (the same steps) and a tight DOP853 reference.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest
import sympy as sp
from test_jacobian import central_differences, stiff_double_pendulum

from dalembert import Holonomic, System, coordinates
from dalembert.examples import heavy_top, rolling_disk
from dalembert.multibody import chain
from dalembert.solvers.dynamics import first_order_rhs
from dalembert.solvers.newton import DenseLinearization, KKTLinearization, kkt_linearization
from dalembert.solvers.running import run_data
from dalembert.solvers.steppers.scipy_ivp import LinearizedRadau

#: Radau's complex eigenvalue (SciPy's MU_COMPLEX) and its real one.
MU_COMPLEX = 3 + 0.5 * (3 ** (1 / 3) - 3 ** (2 / 3)) - 0.5j * (3 ** (5 / 6) + 3 ** (7 / 6))
MU_REAL = 3 + 3 ** (2 / 3) - 3 ** (1 / 3)


def dependent_rows() -> tuple[System, dict, np.ndarray]:
    x, y = coordinates("x y")
    rod = x**2 + y**2 - 1
    system = System([x, y], kinetic=(x.diff() ** 2 + y.diff() ** 2) / 2, potential=9.81 * y,
                    constraints=[Holonomic(rod, name="rod"), Holonomic(2 * rod, name="again")])
    q0 = {x: np.sin(1.0), y: -np.cos(1.0)}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        kept = system.plan((0, 0.2), q0).kept
    assert kept is not None and len(kept) == 1
    return system, q0, kept


def cases():
    top = heavy_top.build()
    yield "heavy top", top, top.simulate((0, 0.2), **heavy_top.INITIAL, t_eval=[0.2]), None
    disk = rolling_disk.build()
    yield "rolling disk", disk, disk.simulate((0, 0.2), **rolling_disk.INITIAL,
                                              t_eval=[0.2]), None
    spring, q0 = stiff_double_pendulum(1e4)
    yield "damped spring", spring, spring.simulate((0, 0.05), q0, t_eval=[0.05]), None
    pendulum, q0, kept = dependent_rows()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        traj = pendulum.simulate((0, 0.2), q0, t_eval=[0.2])
    yield "dependent rows", pendulum, traj, kept
    mb = swinging_chain(6)
    yield "planar chain", mb.system, mb.simulate((0, 0.3), hanging(6), t_eval=[0.3]), None


@pytest.mark.parametrize("c", [1e-3, 0.05, 0.05 / MU_REAL, 0.05 / MU_COMPLEX])
def test_the_solve_inverts_i_minus_c_j_of_central_differences(c):
    rng = np.random.default_rng(3)
    for name, system, traj, kept in cases():
        num = system.numeric()
        y = np.concatenate([traj.q[-1], traj.qd[-1]])
        J = central_differences(first_order_rhs(num, 0.0, kept), traj.t[-1], y)
        b = rng.standard_normal(y.size)
        x = KKTLinearization(num, kept, traj.t[-1], y).factor(c)(b)
        residual = (np.eye(y.size) - c * J) @ x - b
        scale = 1 + abs(c) * np.abs(J).max() * np.abs(x).max()
        assert np.abs(residual).max() < 1e-6 * scale, name


def test_one_assembly_serves_every_state():
    """The positions of the values are worked out once: the second linearization of
    a run reuses them and still solves its own state's system."""
    system, q0 = stiff_double_pendulum(1e4)
    traj = system.simulate((0, 0.05), q0, t_eval=[0.0, 0.05])
    num = system.numeric()
    linearize = kkt_linearization(num, None)
    for k in (0, 1):
        y = np.concatenate([traj.q[k], traj.qd[k]])
        lin = linearize(traj.t[k], y, None)
        J = central_differences(first_order_rhs(num, 0.0, None), traj.t[k], y)
        x = lin.factor(0.01)(np.ones(8))
        assert np.abs((np.eye(8) - 0.01 * J) @ x - 1).max() < 1e-6 * (1 + 0.01 * np.abs(J).max())
    assert linearize(traj.t[0], y, None).assembly is lin.assembly


def test_a_singular_matrix_says_so():
    """A matrix that cannot be factored raises ``LinAlgError`` (on which Radau halves
    its step), not SuperLU's ``RuntimeError``: here a linearization whose masses were
    zeroed (zero pivots)."""
    x, y = coordinates("x y")
    system = System([x, y], kinetic=(x.diff() ** 2 + y.diff() ** 2) / 2,
                    constraints=[Holonomic(x**2 + y**2 - 1, name="rod")])
    lin = KKTLinearization(system.numeric(), None, 0.0, np.array([1.0, 0.0, 0.0, 0.0]))
    x_ = lin.factor(0.5)(np.ones(4))
    assert np.all(np.isfinite(x_))
    lin._Mv = np.zeros_like(lin._Mv)  # no mass: M and the rows leave a zero pivot
    with pytest.raises(np.linalg.LinAlgError):
        lin.factor(0.0)


def swinging_chain(n: int):
    """Planar links hanging straight in a field with a sideways part: they swing."""
    return chain(n, 1.0, 1.0, 0.05, joint="revolute", planar=True, gravity=(5.0, -9.81, 0.0))


def hanging(n: int) -> dict[str, float]:
    return {f"link{k}_y": -(k - 0.5) for k in range(1, n + 1)}


def test_radau_on_the_kkt_structure_takes_scipys_steps(monkeypatch):
    """24 planar links (144 state components, above the dense limit): Radau on the
    KKT-structured systems takes the steps of Radau on the dense exact Jacobian, to
    rounding, and meets a tight DOP853 reference (the Python loop's Radau; the C
    loop's is ``tests/solvers/test_native_radau.py``'s)."""
    mb = swinging_chain(24)
    assert 2 * mb.system.numeric().n > run_data.DENSE_STATE_MAX
    options = dict(method="Radau", rtol=1e-8, atol=1e-10, t_eval=[0.4], backend="python")
    structured = mb.simulate((0, 0.4), hanging(24), **options)
    monkeypatch.setattr(run_data, "DENSE_STATE_MAX", 10**9)
    dense = mb.simulate((0, 0.4), hanging(24), **options)
    reference = mb.simulate((0, 0.4), hanging(24), rtol=1e-12, atol=1e-14, t_eval=[0.4])
    assert structured.stats["n_steps"] == dense.stats["n_steps"]
    assert structured.stats["nlu"] == dense.stats["nlu"]
    assert np.abs(structured.q[-1] - dense.q[-1]).max() < 1e-11
    assert np.abs(structured.q[-1] - reference.q[-1]).max() < 1e-7


def test_linearized_radau_counts_its_jacobians_and_factorizations():
    """SciPy's counters keep their meaning: a Jacobian per linearization, a
    factorization per matrix (two per new step size: the real and the complex)."""
    J = np.array([[0.0, 1.0], [-1e4, -10.0]])
    calls = []

    def linearize(t, y, f):
        calls.append(t)
        return DenseLinearization(J)

    solver = LinearizedRadau(lambda t, y: J @ y, 0.0, np.array([1.0, 0.0]), 1.0,
                             linearize=linearize)
    while solver.status == "running":
        solver.step()
    assert solver.njev == len(calls)
    assert solver.nlu % 2 == 0 and solver.nlu > 0


def test_a_symbolic_time_dependent_model_is_linearized_at_its_time():
    """A rheonomic constraint (a pendulum whose rod lengthens with t): the solve uses
    the state's own time."""
    x, y = coordinates("x y")
    from dalembert import t as time
    length = 1 + 0.5 * sp.sin(time)
    system = System([x, y], kinetic=(x.diff() ** 2 + y.diff() ** 2) / 2, potential=9.81 * y,
                    constraints=[Holonomic(x**2 + y**2 - length**2, name="rod")])
    radial = np.array([np.sin(1.0), -np.cos(1.0)])  # the rod lengthens at 0.5 at t = 0
    traj = system.simulate((0, 0.6), dict(zip((x, y), radial)), dict(zip((x, y), 0.5 * radial)),
                           t_eval=[0.6])
    num = system.numeric()
    yv = np.concatenate([traj.q[-1], traj.qd[-1]])
    J = central_differences(first_order_rhs(num, 0.0, None), 0.6, yv)
    x_ = KKTLinearization(num, None, 0.6, yv).factor(0.02)(np.arange(4.0))
    assert np.abs((np.eye(4) - 0.02 * J) @ x_ - np.arange(4.0)).max() < 1e-6 * (
        1 + 0.02 * np.abs(J).max() * np.abs(x_).max())
