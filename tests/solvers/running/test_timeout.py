"""``simulate(timeout=)``: a run past its time limit stops between two steps (between
two stretches of C steps) with status ``"timeout"`` and returns what it computed.

Checked against the pendulum's minimal-coordinate reference (the part kept is the
right motion, not a truncated or corrupted one) and its energy, in both loops.
"""

from __future__ import annotations

import numpy as np
import pytest
from pendulum_case import Q0, position_error

from dalembert import IntegrationWarning, Trajectory

BACKENDS = ["c", "python"]
#: A span no run reaches within the limit (about 1e6 pendulum periods).
NEVER = (0.0, 2e6)


@pytest.mark.parametrize("backend", BACKENDS)
def test_a_run_past_its_time_limit_returns_what_it_computed(pendulum, reference, backend,
                                                           time_bound):
    with time_bound(60.0), pytest.warns(IntegrationWarning, match=(
            r"stopped at t=\S+: the run's time limit \(timeout=\) passed; returning the "
            r"trajectory up to t=")):
        traj = pendulum.simulate(NEVER, Q0, backend=backend, timeout=0.2)
    assert traj.status == "timeout" and not traj.success
    assert 0.0 < traj.t[-1] < NEVER[1] and len(traj.t) > 2
    assert np.all(np.diff(traj.t) > 0)
    early = traj.t <= 4.0  # where the reference is
    assert position_error(_part(traj, early), reference) < 1e-8
    energy = traj.kinetic_energy + traj.potential_energy
    assert np.abs(energy - energy[0]).max() < 1e-8
    assert traj.position_residual.max() < 1e-12


def _part(traj, keep):
    """The trajectory's times and positions where ``keep`` (what position_error reads)."""
    class Part:
        t = traj.t[keep]

        def __getitem__(self, name):
            return traj[name][keep]
    return Part()


def test_a_timed_out_trajectory_is_saved_and_loaded(pendulum, tmp_path):
    with pytest.warns(IntegrationWarning):
        traj = pendulum.simulate(NEVER, Q0, t_eval=np.linspace(0.0, 2e6, 2_000_001),
                                 timeout=0.1)
    traj.save(tmp_path / "run.npz")
    back = Trajectory.load(tmp_path / "run.npz")
    assert back.status == "timeout" and back.message == traj.message
    assert np.array_equal(back.q, traj.q)


def test_a_run_within_its_time_limit_is_unchanged(pendulum):
    free = pendulum.simulate((0.0, 1.0), Q0, t_eval=[0.5, 1.0])
    limited = pendulum.simulate((0.0, 1.0), Q0, t_eval=[0.5, 1.0], timeout=600.0)
    assert limited.status == "finished"
    assert np.array_equal(free.q, limited.q)


@pytest.mark.parametrize("bad", [0.0, -1.0, float("nan"), float("inf"), "1s", True])
def test_a_time_limit_that_is_not_a_positive_number_is_named(pendulum, bad):
    with pytest.raises(ValueError, match="The 'timeout' parameter of simulate must be"):
        pendulum.simulate((0.0, 1.0), Q0, timeout=bad)
