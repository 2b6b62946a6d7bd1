"""Ensembles run here and on threads: each case as if simulated alone, a sweep against a
closed form, faults recorded per case, retry, interruption, stores and reductions."""

from __future__ import annotations

import time
import warnings

import numpy as np
import pytest
from ensemble_models import (
    THETA0,
    blow_up,
    pendulum,
    released,
    small_chain,
    through_bottom,
    tilted_state,
    tip_z,
)
from scipy import stats

from dalembert import EnsembleError, EnsembleWarning, ParameterError
from dalembert.ensemble import grid, sample

T_EVAL = np.linspace(0.0, 2.0, 41)


@pytest.fixture(scope="module")
def pend():
    return pendulum()


@pytest.fixture(scope="module")
def mb():
    return small_chain()


def alone(system, case, initial, **options):
    """The case simulated by itself, as a user would."""
    q0, qd0 = initial(case)
    parameters = {k: v for k, v in case.items() if k in {p.name for p in system.parameters}}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return system.simulate((T_EVAL[0], T_EVAL[-1]), q0, qd0, parameters=parameters,
                               t_eval=T_EVAL, **options)


@pytest.mark.parametrize("scheduler", ["serial", "threads"])
def test_every_case_equals_the_case_simulated_alone(mb, scheduler):
    cases = sample({"m": stats.uniform(0.5, 1.0), "angle": stats.uniform(0.2, 0.6)}, 8, seed=5)

    def initial(case):
        return tilted_state(mb, case["angle"])

    before = time.time()
    result = mb.system.simulate_many((0.0, 2.0), cases, initial_state=initial, t_eval=T_EVAL,
                                     rtol=1e-8, atol=1e-10, outputs={"tip_z": tip_z},
                                     scheduler=scheduler, workers=2, batch_size=3,
                                     progress=False)
    after = time.time()
    assert result.scheduler == scheduler and result.failed == []
    # the timeline: every case within the call; serially, each after the one before
    started = result.summary["started"].map(lambda t: t.timestamp()).to_numpy()
    ended = started + result.summary["seconds"].to_numpy()
    assert before <= started.min() and ended.max() <= after
    if scheduler == "serial":
        assert np.all(started[1:] >= ended[:-1] - 1e-3)  # two clocks: rounding of theirs
    ds = result.dataset
    for i in (0, 4, 7):  # sampled
        traj = alone(mb.system, cases.iloc[i].to_dict(), initial, rtol=1e-8, atol=1e-10)
        for name in ("q", "qd", "multipliers", "constraint_forces", "energy",
                     "position_residual", "velocity_residual"):
            assert np.abs(ds[name].values[i] - getattr(traj, name)).max() <= 1e-12, name
        assert np.abs(ds["tip_z"].values[i] - tip_z(mb.system, traj)).max() <= 1e-12
        assert ds["m"].values[i] == cases["m"][i]  # the case's values label it
        row = result.summary.loc[i]
        assert row["status"] == "finished" and row["t_end"] == 2.0
        assert row["final_link3_z"] == traj["link3_z"][-1]
        assert abs(row["energy_error"] - np.abs(traj.energy - traj.energy[0]).max()
                   / abs(traj.energy[0])) <= 1e-15


def test_an_ensemble_that_keeps_no_dynamics_gives_the_same_cases(pend):
    """Kept without accelerations, multipliers or forces (and no output function that
    might read them), the cases solve no KKT system at their output times: their states,
    energies, residuals and summaries are still those of the cases simulated alone; an
    output function gets the whole trajectory."""
    cases = grid(l=[0.8, 1.0, 1.3], theta=[0.3, 1.1])
    result = pend.simulate_many((0.0, 2.0), cases, initial_state=released, t_eval=T_EVAL,
                                keep=("q", "energy"), scheduler="serial", progress=False)
    forces = pend.simulate_many((0.0, 2.0), cases, initial_state=released, t_eval=T_EVAL,
                                keep=("q",), outputs={"force_x": force_x},
                                scheduler="serial", progress=False)
    assert set(result.dataset.data_vars) >= {"q", "energy"}
    assert "multipliers" not in result.dataset
    for i in range(len(cases)):
        traj = alone(pend, cases.iloc[i].to_dict(), released)
        assert np.abs(result.dataset["q"].values[i] - traj.q).max() <= 1e-12
        assert np.abs(result.dataset["energy"].values[i] - traj.energy).max() <= 1e-12
        row = result.summary.loc[i]
        for name in ("position_residual", "velocity_residual"):
            assert abs(row[f"max_{name}"] - getattr(traj, name).max()) <= 1e-14, name
        assert row["final_x"] == traj["x"][-1]
        assert np.abs(forces.dataset["force_x"].values[i] - force_x(pend, traj)).max() <= 1e-12


def force_x(system, traj) -> np.ndarray:
    """The rod's pull on the bob along x (an output that reads the multipliers)."""
    return traj.constraint_forces[:, 0]


def test_a_length_sweep_follows_the_pendulums_period_law(pend):
    """T(l) = 2 pi sqrt(l / g) (1 + theta0^2 / 16), the period measured where the bob
    next crosses the bottom going the same way (cubic Hermite on x, x_dot)."""
    lengths = [0.25, 0.5, 1.0, 2.0, 4.0]
    t_eval = np.linspace(0.0, 4.2, 4201)
    result = pend.simulate_many((0.0, 4.2), grid(l=lengths), initial_state=through_bottom,
                                t_eval=t_eval, scheduler="serial", progress=False)
    x = result.dataset["q"].sel(coordinate="x").values
    v = result.dataset["qd"].sel(coordinate="x").values
    for i, l in enumerate(lengths):
        law = 2 * np.pi * np.sqrt(l / 9.81) * (1 + THETA0**2 / 16)
        k = np.flatnonzero((x[i, :-1] < 0) & (x[i, 1:] >= 0) & (t_eval[:-1] > law / 2))[0]
        period = _hermite_root(t_eval[k], t_eval[k + 1], x[i, k], x[i, k + 1], v[i, k],
                               v[i, k + 1])
        assert abs(period / law - 1) < 1e-8, (l, period, law)


def going_back(t, q, qd):
    """The bob crossing the bottom towards -x."""
    return q[0]


going_back.direction = -1  # type: ignore[attr-defined]


def stop_going_back(t, q, qd):
    return q[0]


stop_going_back.direction, stop_going_back.terminal = -1, True  # type: ignore[attr-defined]


def test_the_summary_gives_each_events_first_time_and_count(pend):
    """Released through the bottom towards +x, the bob comes back through it at half
    a period, T(l) = 2 pi sqrt(l / g) (1 + theta0^2 / 16), then once a period."""
    lengths = [0.25, 1.0, 4.0]
    result = pend.simulate_many((0.0, 4.2), grid(l=lengths), initial_state=through_bottom,
                                events=[going_back, stop_going_back, lambda t, q, qd: 1.0],
                                scheduler="serial", progress=False)
    summary = result.summary
    for i, l in enumerate(lengths):
        law = 2 * np.pi * np.sqrt(l / 9.81) * (1 + THETA0**2 / 16)
        assert abs(summary["t_event_going_back"][i] / (law / 2) - 1) < 1e-8
        # the terminal one ends the run at the first, so the other counts one
        assert summary["n_events_going_back"][i] == 1
        assert summary["t_event_stop_going_back"][i] == summary["t_event_going_back"][i]
        assert np.isnan(summary["t_event_2"][i]) and summary["n_events_2"][i] == 0
        assert summary["status"][i] == "event"
    free = pend.simulate_many((0.0, 4.2), grid(l=lengths), initial_state=through_bottom,
                              events=[going_back], scheduler="serial", progress=False)
    for i, l in enumerate(lengths):
        law = 2 * np.pi * np.sqrt(l / 9.81) * (1 + THETA0**2 / 16)
        assert free.summary["n_events_going_back"][i] == int(4.2 / law + 0.5)


def _hermite_root(t0, t1, x0, x1, v0, v1):
    """The zero of the cubic Hermite interpolant of (x, x') on [t0, t1] (Newton)."""
    h = t1 - t0
    s = -x0 / (x1 - x0)
    for _ in range(50):
        h00, h10, h01, h11 = (2 * s**3 - 3 * s**2 + 1, s**3 - 2 * s**2 + s,
                              -2 * s**3 + 3 * s**2, s**3 - s**2)
        d00, d10, d01, d11 = (6 * s**2 - 6 * s, 3 * s**2 - 4 * s + 1, -6 * s**2 + 6 * s,
                              3 * s**2 - 2 * s)
        f = h00 * x0 + h10 * h * v0 + h01 * x1 + h11 * h * v1
        df = d00 * x0 + d10 * h * v0 + d01 * x1 + d11 * h * v1
        s -= f / df
    return t0 + s * h


def test_the_warning_of_failed_cases_points_at_the_users_call(pend):
    cases = [{"l": 1.0, "m": 1.0}, {"l": 1.0, "m": np.nan}]
    with pytest.warns(EnsembleWarning) as caught:
        pend.simulate_many((0.0, 1.0), cases, initial_state=released, t_eval=T_EVAL[:3],
                           scheduler="serial", progress=False)
    assert [w.filename for w in caught if w.category is EnsembleWarning] == [__file__]


def test_failing_cases_are_recorded_and_the_others_complete(pend):
    cases = [{"l": 1.0, "m": 1.0}, {"l": 1.0, "m": 0.0},  # no inertia: KKT singular
             {"l": 1.5, "m": 1.0}, {"l": 1.0, "m": np.nan}, {"l": 0.5, "m": 2.0}]
    with pytest.warns(EnsembleWarning, match="2 of 5 cases did not succeed \\(2 error\\); the "
                      "first, case 1: SingularSystemError"):
        result = pend.simulate_many((0.0, 2.0), cases, initial_state=released, t_eval=T_EVAL,
                                    scheduler="serial", progress=False)
    assert result.failed == [1, 3]
    summary = result.summary
    assert summary["status"].tolist() == ["finished", "error", "finished", "error", "finished"]
    assert "singular" in summary.loc[1, "message"]
    assert summary.loc[3, "message"].startswith("ParameterError") and "not finite" in \
        summary.loc[3, "message"]
    assert np.isnan(result.dataset["q"].values[[1, 3]]).all()
    for i in (0, 2, 4):
        traj = alone(pend, cases[i], released)
        assert np.array_equal(result.dataset["q"].values[i], traj.q)


def test_an_integration_failure_keeps_what_it_computed():
    system = blow_up()
    cases = [{"tc": 10.0}, {"tc": 1.3}]
    with pytest.warns(EnsembleWarning, match="1 failed"):
        result = system.simulate_many((0.0, 2.0), cases, t_eval=T_EVAL, scheduler="threads",
                                      workers=2, progress=False)
    row = result.summary.loc[1]
    assert row["status"] == "failed" and "t=1.3" in row["message"]
    assert 1.2 < row["t_end"] < 1.3
    x = result.dataset["q"].values[1, :, 0]
    reached = row["t_end"] >= T_EVAL
    assert np.isfinite(x[reached]).all() and np.isnan(x[~reached]).all()
    # x(t) = k (ln(tc / (tc - t)) - t / tc): the part computed is right
    t = T_EVAL[reached]
    assert np.abs(x[reached] - (np.log(1.3 / (1.3 - t)) - t / 1.3)).max() < 1e-7


def test_retry_runs_the_failed_cases_again_and_keeps_the_others(pend, tmp_path):
    marker = tmp_path / "first-try"

    def flaky(case):  # fails the first time it sees case l = 2 (a transient fault)
        if case["l"] == 2.0 and not marker.exists():
            marker.write_text("seen")
            raise OSError("the license server did not answer")
        return released(case)

    cases = grid(l=[1.0, 2.0, 3.0])
    with pytest.warns(EnsembleWarning, match="OSError: the license server"):
        first = pend.simulate_many((0.0, 2.0), cases, initial_state=flaky, t_eval=T_EVAL,
                                   scheduler="serial", progress=False)
    assert first.failed == [1]
    again = first.retry()
    assert again.failed == [] and again.summary["status"].eq("finished").all()
    assert np.array_equal(again.dataset["q"].values[[0, 2]], first.dataset["q"].values[[0, 2]])
    assert np.array_equal(again.dataset["q"].values[1], alone(pend, {"l": 2.0}, released).q)
    assert first.failed == [1]  # the first result is left as it was


def test_interrupting_returns_what_finished(pend):
    calls = []

    def ctrl_c_at_the_fourth(case):
        calls.append(case["l"])
        if len(calls) == 4:
            raise KeyboardInterrupt
        return released(case)

    with pytest.warns(EnsembleWarning, match="interrupted: 7 not-run of 10 cases"):
        result = pend.simulate_many((0.0, 2.0), grid(l=np.linspace(1, 2, 10)),
                                    initial_state=ctrl_c_at_the_fourth, t_eval=T_EVAL,
                                    scheduler="serial", progress=False)
    assert result.interrupted
    assert result.summary["status"].tolist() == ["finished"] * 3 + ["not-run"] * 7
    assert np.isfinite(result.dataset["q"].values[:3]).all()
    assert np.isnan(result.dataset["q"].values[3:]).all()


@pytest.mark.parametrize("suffix", [".zarr", ".nc"])
def test_a_stored_ensemble_reads_back_equal_and_reduces_lazily(pend, tmp_path, suffix):
    cases = sample({"l": stats.uniform(0.5, 1.5), "theta": stats.uniform(0.2, 0.5)}, 13,
                   seed=2)
    cases.loc[4, "l"] = 0.0  # a rod of no length fails: its values stay NaN, not reduced
    options = dict(initial_state=released, t_eval=T_EVAL, scheduler="serial",
                   progress=False, batch_size=5)
    with pytest.warns(EnsembleWarning):
        memory = pend.simulate_many((0.0, 2.0), cases, **options)
        stored = pend.simulate_many((0.0, 2.0), cases, store=tmp_path / f"run{suffix}",
                                    **options)
    assert stored.dataset["q"].chunks is not None  # read lazily
    for name in ("q", "multipliers", "energy", "status", "t_end", "l"):
        assert np.array_equal(stored.dataset[name].values, memory.dataset[name].values,
                              equal_nan=True), name
    assert stored.summary.equals(memory.summary.assign(
        seconds=stored.summary["seconds"], started=stored.summary["started"])
    )  # all but the times taken
    ok = np.arange(13) != 4
    y = memory.dataset["q"].sel(coordinate="y").values[ok]
    band = stored.quantile("q", [0.1, 0.5, 0.9], coordinate="y")
    assert np.allclose(band.values, np.quantile(y, [0.1, 0.5, 0.9], axis=0), rtol=0,
                       atol=1e-15)
    assert np.allclose(stored.mean("energy").values,
                       memory.dataset["energy"].values[ok].mean(axis=0), rtol=1e-15)
    with pytest.raises(EnsembleError, match="exists; pass overwrite=True"):
        pend.simulate_many((0.0, 2.0), cases, store=tmp_path / f"run{suffix}", **options)


def test_overwriting_a_netcdf_store_an_earlier_result_reads(pend, tmp_path):
    # HDF5 cannot truncate a file that is open: the store is replaced by a new file,
    # and the earlier result keeps reading its own
    path = tmp_path / "run.nc"
    options = dict(initial_state=released, t_eval=T_EVAL, scheduler="serial",
                   progress=False, keep=("q",), store=path, overwrite=True)
    first = pend.simulate_many((0.0, 2.0), grid(l=[1.0, 2.0]), **options)
    second = pend.simulate_many((0.0, 2.0), grid(l=[3.0, 4.0]), **options)
    for result, lengths in ((first, [1.0, 2.0]), (second, [3.0, 4.0])):
        q = result.dataset["q"].values
        np.testing.assert_allclose(np.hypot(q[..., 0], q[..., 1]),
                                   np.broadcast_to(np.array(lengths)[:, None], q.shape[:2]),
                                   rtol=1e-12)


def test_bad_arguments_are_refused_before_anything_runs(pend):
    cases = grid(l=[1.0])
    for kwargs, match in [
        ({"scheduler": "mpi"}, "The 'scheduler' parameter of simulate_many must be one of "
                               "'auto', 'serial', 'threads', 'processes', 'dask'; got 'mpi'"),
        ({"scheduler": "dask"}, "needs client="),
        ({"client": "serial"}, "client must be a dask.distributed.Client, got str 'serial'; "
                               "for scheduler='serial' write scheduler='serial'"),
        ({"client": 2}, "client must be a dask.distributed.Client, got int 2$"),
        ({"keep": ["q", "tension"]}, "'tension', which is not a trajectory quantity"),
        ({"outputs": {"q": tip_z}}, "name of a trajectory quantity"),
        ({"store": "run.csv"}, "must end in .zarr"),
        ({"dense_output": True}, "dense_output"),
        ({"workers": 0}, "The 'workers' parameter of simulate_many must be a positive whole "
                         "number or None; got 0"),
    ]:
        with pytest.raises(EnsembleError, match=match):
            pend.simulate_many((0.0, 1.0), cases, initial_state=released, progress=False,
                               **kwargs)
    with pytest.raises(ValueError, match="The 'rtol' parameter of simulate"):
        pend.simulate_many((0.0, 1.0), cases, initial_state=released, rtol=-1.0)
    with pytest.raises(ParameterError, match="'x' is a coordinate of this model, not a "
                                             "parameter: give its initial value in q0"):
        pend.simulate_many((0.0, 1.0), cases, initial_state=released, parameters={"x": 0.1})


def test_auto_runs_short_ensembles_here_and_long_ones_in_parallel(pend, monkeypatch):
    """Short: here. Long: on threads where the first case ran in the C loop (its
    stretches release the GIL), on a local cluster of processes where it ran in the
    Python loop. The same arrays every way."""
    from dalembert.ensemble import backends
    from dalembert.ensemble import run as run_module

    chosen = []

    class LocalCluster(backends.Serial):  # stands in for a cluster: runs the cases here
        name = "dask"

        def __init__(self, system, settings, names, client=None, workers=None):
            chosen.append(client)
            super().__init__(system, settings, names)

    monkeypatch.setattr(run_module, "Dask", LocalCluster)
    cases = grid(l=[1.0, 1.5, 2.0])
    short = pend.simulate_many((0.0, 2.0), cases, initial_state=released, t_eval=T_EVAL,
                               progress=False)
    assert short.scheduler == "serial" and chosen == []
    monkeypatch.setattr(run_module, "AUTO_PARALLEL_SECONDS", 0.0)
    monkeypatch.setattr(run_module, "AUTO_THREADS_SECONDS", 0.0)
    monkeypatch.setattr(run_module.os, "cpu_count", lambda: 2)
    in_c = pend.simulate_many((0.0, 2.0), cases, initial_state=released, t_eval=T_EVAL,
                              progress=False)
    assert in_c.scheduler == "threads" and chosen == []
    in_python = pend.simulate_many((0.0, 2.0), cases, initial_state=released,
                                   t_eval=T_EVAL, progress=False, backend="python")
    assert in_python.scheduler == "dask" and chosen == [None]  # a local cluster
    assert in_python.summary["status"].eq("finished").all()
    for result in (in_c, in_python):
        np.testing.assert_allclose(result.dataset["q"].values, short.dataset["q"].values,
                                   rtol=0, atol=1e-12)


def test_a_local_cluster_that_cannot_start_is_explained(pend, monkeypatch):
    import distributed

    def cannot(*args, **kwargs):
        raise RuntimeError("Nanny failed to start.")

    monkeypatch.setattr(distributed, "LocalCluster", cannot)
    with pytest.raises(EnsembleError, match="if __name__ == '__main__':"):
        pend.simulate_many((0.0, 1.0), grid(l=[1.0]), initial_state=released,
                           scheduler="processes", progress=False)


@pytest.mark.parametrize("suffix", [".zarr", ".nc"])
def test_a_retry_updates_a_store_in_place(pend, tmp_path, suffix):
    marker = tmp_path / "first-try"

    def flaky(case):
        if case["l"] == 2.0 and not marker.exists():
            marker.write_text("seen")
            raise OSError("the license server did not answer")
        return released(case)

    cases = grid(l=[1.0, 1.5, 2.0, 2.5, 3.0])
    with pytest.warns(EnsembleWarning):
        first = pend.simulate_many((0.0, 2.0), cases, initial_state=flaky, t_eval=T_EVAL,
                                   scheduler="serial", progress=False, batch_size=2,
                                   store=tmp_path / f"run{suffix}")
    assert first.failed == [2] and np.isnan(first.dataset["q"].values[2]).all()
    again = first.retry()
    import xarray as xr

    on_disk = xr.open_dataset(tmp_path / f"run{suffix}", chunks={},
                              engine="zarr" if suffix == ".zarr" else "h5netcdf")
    assert again.failed == [] and (on_disk["status"].values == 0).all()
    assert np.array_equal(on_disk["q"].values[2], alone(pend, {"l": 2.0}, released).q)
    assert np.array_equal(on_disk["q"].values[[0, 1, 3, 4]],
                          again.dataset["q"].values[[0, 1, 3, 4]])
    on_disk.close()


@pytest.mark.parametrize("suffix", [".zarr", ".nc"])
def test_a_store_block_made_of_several_batches_reads_back_equal(pend, tmp_path, suffix):
    """On 2 threads the last round of batches is cut in parts: a store's block is then
    written once all of its parts are in, and equals the run kept in memory."""
    cases = grid(l=np.linspace(0.5, 2.0, 10))
    options = dict(initial_state=released, t_eval=T_EVAL, progress=False, batch_size=4)
    memory = pend.simulate_many((0.0, 2.0), cases, scheduler="serial", **options)
    stored = pend.simulate_many((0.0, 2.0), cases, scheduler="threads", workers=2,
                                store=tmp_path / f"run{suffix}", **options)
    if suffix == ".zarr":  # netCDF is read back in one chunk
        assert stored.dataset["q"].chunks[0] == (4, 4, 2)
    for name in ("q", "qd", "multipliers", "energy", "status", "t_end"):
        assert np.array_equal(stored.dataset[name].values, memory.dataset[name].values), name
