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
