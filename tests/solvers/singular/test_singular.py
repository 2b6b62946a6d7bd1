"""Singular configurations: an honest outcome in both loops, and an honest count of the
degrees of freedom at a singular start.

The mechanism is the IFToMM A02 benchmark's N-four-bar (N = 2 here: 5 links of 1 m and
1 kg, pinned to the ground at x = 0, 1, 2, gravity -y), built from planar bodies and
revolute joints. Started as a row of squares with B0 moving at 1 m/s, every crank
stays parallel to the first, so the motion is that of one coordinate, the crank angle
phi: ``J phi'' = -V cos(phi)`` with ``J = (N + 1)/3 + N`` (cranks about their pivots,
couplers translating on unit circles) and ``V = g ((N + 1)/2 + N)``, integrated here
separately. Each time the cranks lie flat the constraint Jacobian loses N ranks.
"""

from __future__ import annotations

import re
import warnings

import numpy as np
import pytest
from scipy.integrate import RK45, Radau, solve_ivp
from scipy.optimize import brentq

from dalembert import Holonomic, System, coordinates
from dalembert import t as time_symbol
from dalembert.errors import (
    IntegrationWarning,
    RedundantConstraintsWarning,
    SingularConfigurationWarning,
)
from dalembert.examples.n_four_bar import build_multibody
from dalembert.multibody import Ground, Multibody, PlanarBody, Revolute
from dalembert.solvers.running.integrate import finite_difference_jacobian, integrate
from dalembert.solvers.singular.careful import RetakeStep

G = 9.81


def four_bars(N: int) -> Multibody:
    """The gallery's A02 mechanism (the model under test; the reference is apart)."""
    return build_multibody(N, G)


def parallel_state(mb: Multibody, N: int, phi: float, rate: float):
    """Every crank at angle ``phi`` turning at ``rate``, the couplers translating."""
    c, s = np.cos(phi), np.sin(phi)
    pos, ori, vel, spin = {}, {}, {}, {}
    for k in range(N + 1):
        pos[f"crank{k}"], ori[f"crank{k}"] = (k + 0.5 * c, 0.5 * s), phi
        vel[f"crank{k}"], spin[f"crank{k}"] = (-0.5 * s * rate, 0.5 * c * rate), rate
    for k in range(1, N + 1):
        pos[f"coupler{k}"], ori[f"coupler{k}"] = (k - 0.5 + c, s), 0.0
        vel[f"coupler{k}"], spin[f"coupler{k}"] = (-s * rate, c * rate), 0.0
    return mb.initial_state(positions=pos, orientations=ori, velocities=vel,
                            angular_velocities=spin)


def reference_angle(N: int, times: np.ndarray) -> np.ndarray:
    J, V = (N + 1) / 3 + N, G * ((N + 1) / 2 + N)
    sol = solve_ivp(lambda t, y: [y[1], -V * np.cos(y[0]) / J], (0.0, times[-1]),
                    [np.pi / 2, -1.0], method="DOP853", rtol=1e-13, atol=1e-13, t_eval=times)
    return sol.y[0]


def b0_errors(traj, N: int) -> tuple[float, float]:
    """The largest distance of B0's position and velocity from the reference's."""
    phi = reference_angle(N, traj.t)
    J, V = (N + 1) / 3 + N, G * ((N + 1) / 2 + N)
    # the reference's rate from its energy integral, with the sign of the motion
    rate = -np.sqrt(np.maximum(1.0 + 2 * V * (1.0 - np.sin(phi)) / J, 0.0))
    th, w = traj["crank0_theta"], traj["crank0_theta_dot"]
    position = np.column_stack([traj["crank0_x"] + 0.5 * np.cos(th),
                                traj["crank0_y"] + 0.5 * np.sin(th)])
    velocity = np.column_stack([traj["crank0_x_dot"] - 0.5 * np.sin(th) * w,
                                traj["crank0_y_dot"] + 0.5 * np.cos(th) * w])
    exact_p = np.column_stack([np.cos(phi), np.sin(phi)])
    exact_v = np.column_stack([-np.sin(phi) * rate, np.cos(phi) * rate])
    return np.abs(position - exact_p).max(), np.abs(velocity - exact_v).max()


def crank_spread(traj, N: int) -> float:
    """The largest angle between two cranks (0 on the parallelogram branch)."""
    cranks = np.column_stack([traj[f"crank{k}_theta"] for k in range(N + 1)])
    return float(np.ptp(cranks, axis=1).max())


def flat_times(N: int, t_end: float) -> np.ndarray:
    """When the reference lies flat (sin phi = 0) within ``[0, t_end]``."""
    times = np.linspace(0.0, t_end, 200001)
    s = np.sin(reference_angle(N, times))
    return times[np.flatnonzero(np.sign(s[1:]) != np.sign(s[:-1]))]


def simulate_a02(N: int, t_end: float, backend: str, **options):
    """A02 from its row of squares; the run and the warnings it gave."""
    mb = four_bars(N)
    q0, qd0 = parallel_state(mb, N, np.pi / 2, -1.0)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        traj = mb.system.simulate((0, t_end), q0, qd0, backend=backend,
                                  t_eval=np.linspace(0, t_end, int(20 * t_end) + 1), **options)
    return traj, [w.message for w in caught]


@pytest.mark.validation
@pytest.mark.parametrize("backend", ["c", "python"])
@pytest.mark.parametrize("N", [2, 8, 16, 40])
def test_a02_passes_every_flat_position_on_its_branch(backend, N):
    """The IFToMM A02 benchmark at the default settings: 20 s, 20 passes through the
    flat position (N extra instantaneous degrees of freedom each time), 400 outputs. B0
    within 1e-3 of the one-coordinate reference (the benchmark's criterion) and every
    crank parallel to the first; the passages said in a SingularConfigurationWarning.
    Measured: B0 errors 1e-7..2e-5, cranks parallel to 1e-11."""
    traj, said = simulate_a02(N, 20.0, backend)
    assert traj.success, traj.message
    position, velocity = b0_errors(traj, N)
    assert position < 1e-3 and velocity < 1e-3
    assert crank_spread(traj, N) < 1e-6
    passages = [str(w) for w in said if isinstance(w, SingularConfigurationWarning)]
    assert len(passages) == 1
    # the passages the steps took carefully (a step may also pass a flat position whole)
    count = re.search(r"constraints (\d+) times", passages[0])
    assert count is not None and 1 <= int(count.group(1)) <= len(flat_times(N, 20.0)) == 20
    assert "minimum-norm" in passages[0] and re.search(r"rows involved: [OAB]\d+_\d", passages[0])


def test_radau_passes_every_flat_position_in_the_python_loop_too():
    """Radau through A02's flat positions (N = 2, 11 flat positions in 11 s, its default
    tolerances) in the Python loop: its careful steps are taken by a Radau of its own on
    the careful right-hand side, as in the C loop (its exact Jacobian is not that
    right-hand side's: before, it stopped at t = 10.4, the steps collapsed). B0 to the
    benchmark's 1e-3."""
    traj, _ = simulate_a02(2, 11.0, "python", method="Radau")
    assert traj.success, traj.message
    assert max(b0_errors(traj, 2)) < 1e-3
    assert crank_spread(traj, 2) < 1e-6


@pytest.mark.parametrize("backend", ["c", "python"])
@pytest.mark.parametrize("rtol", [1e-4, 1e-5, 1e-6, 1e-7, 1e-8, 1e-9, 1e-10])
def test_a02_at_every_tolerance_stays_on_its_branch(backend, rtol):
    """No tolerance gets stuck at a flat position or leaves the parallelogram branch
    (N = 8, 20 s); the error follows the tolerance (measured: 2e-3..7e-3 at 1e-4,
    4e-8..4e-7 at 1e-8 and below)."""
    traj, _ = simulate_a02(8, 20.0, backend, rtol=rtol, atol=rtol / 100)
    assert traj.success, traj.message
    assert crank_spread(traj, 8) < 1e-6
    assert max(b0_errors(traj, 8)) < max(1000 * rtol, 1e-5)


@pytest.mark.parametrize("backend", ["c", "python"])
def test_events_and_dense_output_through_the_flat_positions(backend):
    """With an event (the first crank's centre crossing y = 0: a flat position) and dense
    output the run steps one step at a time (the C loop's solver stepping in C), and
    still takes careful steps there: every event at the reference's flat time (to
    1e-7), on the branch, the dense output through them."""
    N = 2
    mb = four_bars(N)
    q0, qd0 = parallel_state(mb, N, np.pi / 2, -1.0)
    height = mb.system.coordinate_names.index("crank0_y")

    def flat(t, q, qd):
        return q[height]

    with pytest.warns(SingularConfigurationWarning):
        traj = mb.system.simulate((0, 5.0), q0, qd0, backend=backend, events=[flat],
                                  dense_output=True, t_eval=np.linspace(0, 5.0, 101))
    assert traj.success, traj.message
    J, V = (N + 1) / 3 + N, G * ((N + 1) / 2 + N)
    reference = solve_ivp(lambda t, y: [y[1], -V * np.cos(y[0]) / J], (0.0, 5.0),
                          [np.pi / 2, -1.0], method="DOP853", rtol=1e-13, atol=1e-13,
                          dense_output=True).sol
    expected = [brentq(lambda t: np.sin(reference(t)[0]), a, b, xtol=1e-14)
                for a, b in zip(flat_times(N, 5.0) - 1e-3, flat_times(N, 5.0) + 1e-3)]
    assert len(traj.t_events[0]) == len(expected) == 5
    assert np.abs(traj.t_events[0] - expected).max() < 1e-7
    assert crank_spread(traj, N) < 1e-6 and max(b0_errors(traj, N)) < 1e-5
    n = len(mb.system.coordinate_names)
    np.testing.assert_allclose(traj.sol(traj.t[1:-1])[:n].T, traj.q[1:-1], atol=1e-9)


def test_the_multipliers_at_a_flat_position_are_bounded_and_marked():
    """An output time exactly where the reference lies flat: marked near_singular, with
    the minimum-norm multipliers there (bounded: of the size they have a quarter turn
    away; the exact ones grow like 1 / distance to the flat position)."""
    N = 2
    flat = float(flat_times(N, 1.0)[0])
    mb = four_bars(N)
    q0, qd0 = parallel_state(mb, N, np.pi / 2, -1.0)
    times = np.array([0.0, 0.3, flat - 1e-3, flat, 1.0])
    with pytest.warns(SingularConfigurationWarning):
        traj = mb.system.simulate((0, 1.0), q0, qd0, t_eval=times)
    assert traj.near_singular.tolist() == [False, False, False, True, False]
    lam = np.abs(traj.multipliers).max(axis=1)
    assert np.all(np.isfinite(lam)) and lam[3] < 10 * lam[1]
    # the constraint forces there still hold the mechanism: M qdd = f + A^T lambda
    M, f, _, _ = mb.system.numeric().kkt_blocks(flat, traj.q[3], traj.qd[3])
    assert np.abs(M @ traj.qdd[3] - f - traj.constraint_forces[3]).max() < 1e-9



@pytest.mark.parametrize("backend", ["auto", "python"])
def test_a_run_started_exactly_flat_keeps_its_trajectory(backend):
    """A parallelogram four-bar started lying flat, its cranks turning: the KKT matrix is
    singular at t = 0. The run goes through and returns its trajectory (the multipliers
    at t = 0 used to raise), t = 0 marked near_singular with the minimum-norm
    multipliers there: the accelerations from the null-space method and the multipliers
    from a least-squares solve of A^T lambda = M qdd - f (dense, by SVD) agree to 1e-12."""
    from scipy.linalg import null_space

    mb = four_bars(1)
    q0, qd0 = parallel_state(mb, 1, 0.0, -1.0)
    with pytest.warns(RedundantConstraintsWarning), \
            pytest.warns(SingularConfigurationWarning, match=r"t=0\.\."):
        traj = mb.system.simulate((0, 1.0), q0, qd0, backend=backend,
                                  t_eval=np.linspace(0, 1.0, 11))
    assert traj.success, traj.message
    assert traj.t.tolist() == np.linspace(0, 1.0, 11).tolist()
    assert traj.near_singular[0] and not traj.near_singular[1:].any()
    M, f, A, c = mb.system.numeric().kkt_blocks(0.0, traj.q[0], traj.qd[0])
    assert np.linalg.matrix_rank(A) == A.shape[0] - 1  # exactly singular there
    N = null_space(A, rcond=1e-10)
    particular = np.linalg.pinv(A, rcond=1e-10) @ c
    qdd = particular + N @ np.linalg.solve(N.T @ M @ N, N.T @ (f - M @ particular))
    lam = np.linalg.lstsq(A.T, M @ qdd - f, rcond=1e-10)[0]
    assert np.abs(traj.qdd[0] - qdd).max() < 1e-12
    assert np.abs(traj.multipliers[0] - lam).max() < 1e-12
    assert np.abs(traj.constraint_forces[0] - A.T @ lam).max() < 1e-12
    assert np.all(np.isfinite(traj.multipliers))
    assert np.abs(traj.energy - traj.energy[0]).max() < 1e-8 * np.abs(traj.energy).max()

def four_bar_1313(backend: str):
    """A planar four-bar of links 1, 3, 1 on a ground of 3 (a parallelogram), whose
    crank turns all the way round: it lies flat twice a turn, where the
    anti-parallelogram branch crosses its own."""
    ground = Ground()
    crank, coupler, rocker = (PlanarBody(name, 1.0, length**2 / 12) for name, length in
                              (("crank", 1.0), ("coupler", 3.0), ("rocker", 1.0)))
    joints = [Revolute("O", ground, crank, (0, 0, 0), (-0.5, 0, 0)),
              Revolute("A", crank, coupler, (0.5, 0, 0), (-1.5, 0, 0)),
              Revolute("B", coupler, rocker, (1.5, 0, 0), (0.5, 0, 0)),
              Revolute("D", ground, rocker, (3, 0, 0), (-0.5, 0, 0))]
    mb = Multibody([crank, coupler, rocker], joints, gravity=(0, -G, 0))
    w = -8.0  # above the top: it turns all the way round
    q0, qd0 = mb.initial_state(
        positions={"crank": (0, 0.5), "coupler": (1.5, 1.0), "rocker": (3, 0.5)},
        orientations={"crank": np.pi / 2, "coupler": 0.0, "rocker": np.pi / 2},
        velocities={"crank": (-0.5 * w, 0), "coupler": (-w, 0), "rocker": (-0.5 * w, 0)},
        angular_velocities={"crank": w, "coupler": 0.0, "rocker": w})
    return mb.system.simulate((0, 10.0), q0, qd0, backend=backend,
                              t_eval=np.linspace(0, 10.0, 2001))


@pytest.mark.parametrize("backend", ["c", "python"])
def test_a_parallelogram_four_bar_passes_its_dead_centres(backend):
    """Links 1, 3, 1, 3: through its flat positions (about 25 in 10 s) on the
    parallelogram branch (crank and rocker parallel), energy conserved."""
    with pytest.warns(SingularConfigurationWarning, match=r"\d+ times"):
        traj = four_bar_1313(backend)
    assert traj.stats["n_steps"] < 20_000  # about 1,500: no crawl at the dead centres
    assert traj.success, traj.message
    assert np.abs(np.angle(np.exp(1j * (traj["crank_theta"] - traj["rocker_theta"])))
                  ).max() < 1e-6
    turns = np.abs(np.unwrap(traj["crank_theta"])[-1] - traj["crank_theta"][0]) / (2 * np.pi)
    assert turns > 5
    e = traj.energy
    assert np.abs(e - e[0]).max() < 1e-8 * np.abs(e).max()


@pytest.mark.parametrize("backend", ["c", "python"])
def test_a_rod_shrinking_to_zero_stops_within_seconds_naming_it(backend):
    """A Cartesian pendulum whose rod length 1 - t/2 reaches zero at t = 2: the
    constraint's gradient vanishes there. The run stops just before, naming the rod
    (it used to take millions of steps without a word). Started at t = 1.5, a quarter
    of the rod left: the steps collapse in the last thousandth either way (from t = 0
    the Python loop's careful steps took 36 s)."""
    x, y = coordinates("x y")
    rod = System([x, y], kinetic=(x.diff() ** 2 + y.diff() ** 2) / 2, potential=G * y,
                 constraints=[Holonomic(x**2 + y**2 - (1 - time_symbol / 2) ** 2, name="rod")])
    with pytest.warns(IntegrationWarning) as caught:
        traj = rod.simulate((1.5, 3.0), {x: 0.25, y: 0.0}, {x: -0.5}, backend=backend)
    assert traj.stats["n_steps"] < 50_000  # about 12,000 (millions before)
    assert not traj.success and 1.99 < traj.t[-1] < 2.0
    message = str(caught[-1].message)
    assert "the norm of rod fell" in message and "singular configuration" in message


def folded_ring(opening: float):
    """A planar loop of four rods pinned at one end, folded nearly flat: a rhombus of
    half-angle ``opening`` lying along x (0: a doubled straight line, out and back)."""
    ground = Ground()
    rods = [PlanarBody(f"rod{k}", 1.0, 1 / 12) for k in range(1, 5)]
    joints = [Revolute("pivot", ground, rods[0], (0, 0, 0), (-0.5, 0, 0))]
    joints += [Revolute(f"hinge{k + 1}", rods[k], rods[(k + 1) % 4], (0.5, 0, 0), (-0.5, 0, 0))
               for k in range(4)]
    mb = Multibody(rods, joints, gravity=(0, -G, 0))
    c, s = np.cos(opening), np.sin(opening)
    vertices = [(0.0, 0.0), (c, s), (2 * c, 0.0), (c, -s), (0.0, 0.0)]
    angles = [opening, -opening, np.pi + opening, np.pi - opening]
    q0, qd0 = mb.initial_state(
        positions={f"rod{k + 1}": tuple((np.array(vertices[k]) + vertices[k + 1]) / 2)
                   for k in range(4)},
        orientations={f"rod{k + 1}": angles[k] for k in range(4)})
    return mb, q0, qd0


def test_a_nearly_straight_closed_chain_swings_down_within_seconds():
    """The loop folded to 1e-4 rad of straight, released: it swings about its pivot
    staying nearly folded, careful all the while (it took 12 million steps and 134 s
    before careful steps existed); energy kept to 1e-5 of the swing."""
    mb, q0, qd0 = folded_ring(1e-4)
    with pytest.warns(RedundantConstraintsWarning, match="ambiguous"), \
            pytest.warns(SingularConfigurationWarning):
        traj = mb.system.simulate((0, 3.0), q0, qd0, t_eval=np.linspace(0, 3, 301))
    assert traj.stats["n_steps"] < 5_000  # about 260 (12 million before)
    assert traj.success, traj.message
    swing = np.ptp(traj.potential_energy)
    assert swing > 10.0
    assert np.abs(traj.energy - traj.energy[0]).max() < 1e-5 * swing


def test_a_closed_chain_stretched_straight_at_the_start():
    """A planar loop of four rods pinned at one end, folded into a doubled straight line
    (out along x and back): its hinge rows depend on each other at this configuration
    only. Said: 3 degrees of freedom here, 2 nearby; the run proceeds with that
    dependency left out while it lasts, every row enforced again after (the loop
    closed to rounding at the end), energy kept."""
    mb, q0, qd0 = folded_ring(0.0)
    report = mb.system.consistent_initial_state(q0, qd0)
    assert report.degrees_of_freedom == 3 and report.rank.rank_nearby == 10
    assert "this configuration only" in str(report.rank)
    with pytest.warns(RedundantConstraintsWarning, match="this configuration only"), \
            pytest.warns(SingularConfigurationWarning, match=r"t=0\.\.") as caught:
        traj = mb.system.simulate((0, 2.0), q0, qd0, t_eval=np.linspace(0, 2, 201))
    assert traj.stats["n_steps"] < 5_000  # about 270
    assert traj.success, traj.message
    assert "hinge" in str(caught[-1].message)
    assert traj.position_residual[-1] < 1e-12 and traj.velocity_residual[-1] < 1e-12
    swing = np.ptp(traj.potential_energy)  # it swings down about the pivot
    assert swing > 1.0
    assert np.abs(traj.energy - traj.energy[0]).max() < 1e-8 * swing


def test_a_step_whose_projection_jumps_is_taken_again_shorter():
    """The loop's side of a projection that jumps onto another branch: the step is
    retaken a quarter as long until it does not (here: while longer than 0.05), and a
    projection that always jumps stops the run naming it, keeping the steps before."""
    def projection(limit):
        state = {"t": 0.0}

        def project(t, y):
            if t > state["t"]:  # a step's end
                if t - state["t"] > limit:
                    raise RetakeStep(f"the projection at t={t:.6g} jumped")
                state["t"] = t
            return y
        return project

    result = integrate(lambda t, y: np.array([y[1], -y[0]]), (0.0, 2.0), np.array([1.0, 0.0]),
                       method=RK45, project=projection(0.05), rtol=1e-3, atol=1e-6)
    assert result.status == "finished" and np.diff(result.t).max() <= 0.05
    result = integrate(lambda t, y: np.array([y[1], -y[0]]), (0.0, 2.0), np.array([1.0, 0.0]),
                       method=RK45, project=projection(-1.0), rtol=1e-3, atol=1e-6)
    assert result.status == "failed" and "jumped" in result.message
    assert "at every step size down to" in result.message


def test_degrees_of_freedom_at_a_flat_start_are_counted_at_that_configuration():
    """A parallelogram four-bar lying flat: two instantaneous degrees of freedom there
    (the cranks can turn apart), one at every nearby configuration."""
    mb = four_bars(1)
    q0, qd0 = parallel_state(mb, 1, 0.0, 0.0)
    report = mb.system.consistent_initial_state(q0, qd0)
    assert report.degrees_of_freedom == 2
    assert report.rank.rank_nearby == report.rank.n - 1
    text = str(report.rank)
    assert "configuration only: a singular one" in text and "1 degree(s) of freedom" in text
    assert "The motion is unique" not in text


def test_near_a_flat_start_the_count_is_said_to_be_ambiguous():
    mb = four_bars(1)
    q0, qd0 = parallel_state(mb, 1, 1e-3, -1.0)
    with pytest.warns(RedundantConstraintsWarning, match="ambiguous: 1 more singular"):
        mb.system.plan((0, 0.1), q0, qd0)
    q0, qd0 = parallel_state(mb, 1, 0.5, -1.0)
    with warnings.catch_warnings():
        warnings.simplefilter("error", RedundantConstraintsWarning)
        mb.system.plan((0, 0.1), q0, qd0)  # well away from it: nothing to say


def test_radau_counts_the_evaluations_of_its_finite_difference_jacobian():
    calls = []

    def fun(t, y):
        calls.append(t)
        return np.array([y[1], -4.0 * y[0] - 0.1 * y[1] ** 3])

    result = integrate(fun, (0.0, 5.0), np.array([1.0, 0.0]), method=Radau, rtol=1e-6,
                       atol=1e-9, jac=finite_difference_jacobian(fun))
    assert result.stats["njev"] > 0
    assert result.stats["nfev"] == len(calls)
