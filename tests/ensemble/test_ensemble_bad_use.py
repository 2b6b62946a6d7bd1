"""Ensembles misused or hit by their surroundings: each case gets a message naming the
problem, and no computed case is lost."""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from ensemble_models import pendulum, released

from dalembert import EnsembleError, EnsembleWarning
from dalembert.ensemble import grid

T_EVAL = np.linspace(0.0, 1.0, 11)


@pytest.fixture(scope="module")
def pend():
    return pendulum()


def run(system, cases, **options):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", EnsembleWarning)
        return system.simulate_many((0.0, 1.0), cases, initial_state=released, t_eval=T_EVAL,
                                    scheduler="serial", progress=False, **options)


# -- retry -------------------------------------------------------------------------------------
@pytest.mark.parametrize(("cases", "got"), [
    ([{"l": 2.0}], "{'l': 2.0}"),
    (["0"], "'0'"),
    ([1.5], "1.5"),
    ([True], "True"),
])
def test_retry_with_what_is_not_case_numbers_says_so(pend, cases, got):
    first = run(pend, grid(l=[1.0, 2.0]))
    with pytest.raises(EnsembleError) as info:
        first.retry(cases=cases)
    message = str(info.value)
    assert message.startswith(f"retry takes case numbers (cases=[0, 3]), got {got}")
    assert "run simulate_many again with a new case table" in message


def test_retry_takes_numpy_case_numbers(pend):
    first = run(pend, grid(l=[1.0, 2.0]))
    again = first.retry(cases=np.array([1]))
    assert again.summary["status"].eq("finished").all()


# -- overwrite ---------------------------------------------------------------------------------
def test_overwrite_leaves_a_folder_this_library_did_not_write(pend, tmp_path):
    folder = tmp_path / "thesis.zarr"
    folder.mkdir()
    (folder / "chapter1.tex").write_text("months of work")
    with pytest.raises(EnsembleError) as info:
        run(pend, grid(l=[1.0, 2.0]), store=folder, overwrite=True)
    assert str(info.value) == (
        f"overwrite=True replaces only a store simulate_many wrote, and {folder} is a folder "
        "it did not write (it has no .dalembert-ensemble marker and is not a Zarr store of "
        "an ensemble); remove it yourself if it may go, or write to another path")
    assert (folder / "chapter1.tex").read_text() == "months of work"


@pytest.mark.parametrize("marker", [True, False], ids=["marked", "of-an-earlier-version"])
def test_overwrite_replaces_a_store_simulate_many_wrote(pend, tmp_path, marker):
    store = tmp_path / "run.zarr"
    run(pend, grid(l=[1.0, 2.0]), store=store)
    if not marker:  # an ensemble's Zarr store, as versions without the marker wrote it
        (store / ".dalembert-ensemble").unlink()
    again = run(pend, grid(l=[1.0, 2.0, 3.0]), store=store, overwrite=True)
    assert again.dataset.sizes["case"] == 3
    assert (store / ".dalembert-ensemble").is_file()


def test_overwrite_replaces_an_empty_folder_and_a_file(pend, tmp_path):
    (tmp_path / "empty.zarr").mkdir()
    (tmp_path / "old.nc").write_bytes(b"an old file")
    for store in (tmp_path / "empty.zarr", tmp_path / "old.nc"):
        assert run(pend, grid(l=[1.0]), store=store, overwrite=True).dataset.sizes["case"] == 1


# -- case tables and sizes, at the door ------------------------------------------------------------
def test_columns_of_unequal_length_are_named(pend):
    with pytest.raises(EnsembleError, match=r"the case columns have different lengths "
                                            r"\(l: 2, m: 1\); every column must give one "
                                            "value per case"):
        run(pend, {"l": [1.0, 2.0], "m": [1.0]})


@pytest.mark.parametrize("columns", [["l", "l"], ["l", " l"]], ids=["same", "same-stripped"])
def test_a_column_given_twice_is_named(pend, columns):
    import pandas as pd

    with pytest.raises(EnsembleError, match="the case column 'l' is given twice; give each "
                                            "column once"):
        run(pend, pd.DataFrame([[1.0, 2.0]], columns=columns))


def test_a_grid_of_too_many_cases_is_refused_before_it_is_made():
    import time

    start = time.perf_counter()
    with pytest.raises(EnsembleError, match=r"grid\(a=10000 values, b=10000 values\) makes "
                                            r"100000000 cases, more than the 10000000 a grid "
                                            "may have"):
        grid(a=np.arange(10_000.0), b=np.arange(10_000.0))
    assert time.perf_counter() - start < 1.0  # nothing was built


def test_results_larger_than_memory_are_refused_before_anything_runs(pend, monkeypatch):
    def forbidden(*args, **kwargs):
        raise AssertionError("a case ran")

    monkeypatch.setattr("dalembert.ensemble.worker.run_case", forbidden)
    times = np.linspace(0.0, 1.0, 10**6)
    with pytest.raises(EnsembleError) as info:
        pend.simulate_many((0.0, 1.0), grid(l=np.linspace(1.0, 2.0, 10**5)),
                           initial_state=released, t_eval=times, scheduler="serial",
                           progress=False)
    message = str(info.value)
    assert message.startswith("the results of 100000 cases at 1000000 output times would take "
                              "8.0 TB in memory, more than this machine's ")
    assert "pass store='results.zarr'" in message and "keep=" in message


def test_a_sample_time_of_too_many_samples_is_refused_at_the_door():
    import sympy as sp

    from dalembert import System, coordinates

    (theta,) = coordinates("theta")
    u = sp.Symbol("u")
    pushed = System([theta], kinetic=theta.diff() ** 2 / 2, potential=-9.81 * sp.cos(theta),
                    generalized_forces={theta: u}, inputs=[u])
    with pytest.raises(EnsembleError, match=r"sample_time=1e-10 over t_span \(0.0, 1.0\) makes "
                                            r"10000000000 samples per case, more than the "
                                            "100000000 a run may have; give a larger "
                                            "sample_time"):
        pushed.simulate_many((0.0, 1.0), {"theta": [1.0, 0.5]}, inputs=lambda t: 0.0,
                             sample_time=1e-10, scheduler="serial", progress=False)


# -- a damaged store -------------------------------------------------------------------------------
def test_a_damaged_zarr_chunk_is_named_and_a_retry_of_its_cases_repairs_it(pend, tmp_path):
    store = tmp_path / "run.zarr"
    result = run(pend, grid(l=[1.0, 2.0, 3.0]), store=store, batch_size=2)
    good = result.dataset["q"].values.copy()
    (store / "q" / "0.0.0").write_bytes(b"garbage!" * 10)  # cases 0 and 1 of q
    expected = (f"the store {store} cannot be read: the chunk of 'q' holding cases 0 to 1 is "
                "damaged (")
    for reduce in (lambda: result.mean("q"), lambda: result.quantile("q", 0.5)):
        with pytest.raises(EnsembleError) as info:
            reduce()
        assert str(info.value).startswith(expected), str(info.value)
        assert str(info.value).endswith("; result.retry(cases=[0, 1]) runs those cases again "
                                        "and rewrites it")
    for read in (lambda: result.dataset["q"].values, lambda: result.dataset.compute(),
                 lambda: result.dataset["q"].sel(case=0, time=0.5).values):
        with pytest.raises(EnsembleError) as info:
            read()
        assert str(info.value).startswith(expected), str(info.value)
    assert np.array_equal(result.dataset["q"].sel(case=2).values, good[2])  # another chunk
    with pytest.raises(EnsembleError, match="the chunk of 'q' holding cases 0 to 1 is damaged"):
        result.retry(cases=[1])  # the other case of the chunk must be read to keep it
    repaired = result.retry(cases=[0, 1])
    assert np.array_equal(repaired.dataset["q"].values, good)
    assert np.isfinite(repaired.mean("q").values).all()


def test_a_stored_dataset_reads_what_xarray_reads_from_the_store(pend, tmp_path):
    import xarray as xr

    store = tmp_path / "run.zarr"
    result = run(pend, grid(l=[1.0, 2.0, 3.0]), store=store, batch_size=2)
    plain = xr.open_zarr(store).load()
    read = result.dataset.load()
    assert set(read.variables) == set(plain.variables)
    for name in plain.variables:
        assert read[name].dtype == plain[name].dtype, name
        assert read[name].equals(plain[name]), name
        assert read[name].attrs == plain[name].attrs, name


# -- a full disk under a store ---------------------------------------------------------------------
@pytest.mark.parametrize("fails_from", [2, 4], ids=["a-block", "the-final-numbers"])
def test_a_full_disk_keeps_every_computed_case_in_memory(pend, tmp_path, monkeypatch,
                                                          fails_from):
    """The disk fills after the first block is written (or once every block is, when
    the per-case numbers are): every case is returned, in memory, and the warning
    names the store."""
    from dalembert.ensemble import store as store_module

    cases = grid(l=[1.0, 1.5, 2.0, 2.5, 3.0, 3.5])
    memory = run(pend, cases, batch_size=2)
    opened = store_module.FileSink._open
    calls = []

    def filling(self):
        calls.append(1)
        if len(calls) >= fails_from:
            raise OSError(28, "No space left on device", str(self.path))
        return opened(self)

    monkeypatch.setattr(store_module.FileSink, "_open", filling)
    path = tmp_path / "run.zarr"
    with pytest.warns(EnsembleWarning) as caught:
        result = pend.simulate_many((0.0, 1.0), cases, initial_state=released, t_eval=T_EVAL,
                                    scheduler="serial", progress=False, batch_size=2,
                                    store=path)
    (message,) = [str(w.message) for w in caught]
    assert message.startswith(f"could not write to the store {path} (No space left on device)")
    assert "the results of all 6 cases are returned in memory (result.dataset)" in message
    assert result.summary["status"].eq("finished").all()
    assert result.dataset["q"].chunks is None  # in memory, not read from the store
    got, want = result.dataset["q"].values, memory.dataset["q"].values
    assert np.array_equal(got, want), (np.isnan(got).sum(axis=(1, 2)), np.nanmax(abs(got - want)))
    assert np.array_equal(result.dataset["status"].values, memory.dataset["status"].values)


# -- a time limit per case -------------------------------------------------------------------------
def under_the_pivot(t, q, qd):
    """x = 0 crossed leftwards: a released case ends at its first quarter swing; one
    hanging at rest never crosses (x stays 0)."""
    return q[0]


under_the_pivot.terminal = True
under_the_pivot.direction = -1


@pytest.mark.parametrize("scheduler", ["serial", "threads"])
def test_a_case_past_its_time_limit_is_marked_and_the_others_kept(pend, scheduler):
    """Case 1 hangs at rest: with steps of at most 0.01 s its span of 1e7 s would take
    1e9 steps; the limit stops it between two steps, the released cases end at their
    event (the quarter period, checked against the small-swing law loosely: theta = 0.5)."""
    with pytest.warns(EnsembleWarning, match=r"1 of 3 cases did not succeed \(1 timeout\); the "
                                             r"first, case 1: stopped at t=\S+: the run's "
                                             r"time limit \(timeout=\) passed"):
        result = pend.simulate_many(
            (0.0, 1e7), grid(theta=[0.5, 0.0, 0.5], l=[1.0]), initial_state=released,
            t_eval=np.linspace(0.0, 1e7, 3), events=[under_the_pivot], max_step=0.01,
            timeout=1.0, scheduler=scheduler, workers=2, progress=False)
    summary = result.summary
    assert summary["status"].tolist() == ["event", "timeout", "event"]
    assert result.failed == [1]
    quarter = np.pi / 2 / np.sqrt(9.81)
    assert np.allclose(summary.loc[[0, 2], "t_event_under_the_pivot"], quarter, rtol=0.02)
    stopped = float(summary.loc[1, "message"].split("stopped at t=")[1].split(":")[0])
    assert 0.0 < stopped < 1e7


def test_the_time_limit_is_checked_at_the_door(pend):
    with pytest.raises(ValueError, match="The 'timeout' parameter of simulate must be"):
        run(pend, grid(l=[1.0]), timeout=-1.0)
