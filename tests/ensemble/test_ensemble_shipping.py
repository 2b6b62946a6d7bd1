"""A System travels to a worker with its compiled code: an empty code cache there
compiles nothing, and the copy simulates exactly as the original."""

from __future__ import annotations

import pickle
import warnings

import numpy as np
import pytest
from ensemble_models import small_chain, tilted_state

from dalembert.codegen import c_backend
from dalembert.ensemble import model
from dalembert.solvers.native import library


def no_compiling(*args, **kwargs):
    raise AssertionError("a library was compiled on the worker")


@pytest.mark.skipif(c_backend.find_compiler() is None, reason="ships compiled C code")
def test_a_worker_with_an_empty_cache_loads_the_shipped_code_and_compiles_nothing(
        tmp_path, monkeypatch):
    mb = small_chain()
    q0, qd0 = tilted_state(mb, 0.4)
    options = dict(parameters={"m": 1.3}, rtol=1e-9, atol=1e-11, t_eval=[0.5, 1.0])
    pack = model.package(mb.system, {"angle": 0.4})  # in the client
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        here = mb.system.simulate((0, 1), q0, qd0, **options)
    keys = {lib.key for lib in pack.libraries}
    assert len(keys) == 2  # the model's kernels and the C loop
    # the "worker": an empty code cache, no C loop loaded yet, and no compiling allowed
    monkeypatch.setenv("DALEMBERT_CACHE_DIR", str(tmp_path / "cache"))
    monkeypatch.setattr(c_backend, "_compile", no_compiling)
    library._runtime.cache_clear()
    try:
        system, extra = model._unpack(pack)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            there = system.simulate((0, 1), q0, qd0, **options)
            assert system.plan((0, 1), q0, qd0, parameters={"m": 1.3}).loop == "c"
    finally:
        library._runtime.cache_clear()  # later tests load the C loop from their own cache
    assert extra == {"angle": 0.4} and system is not mb.system
    assert np.array_equal(there.q, here.q)
    assert np.array_equal(there.multipliers, here.multipliers)
    stored = {p.name for p in (tmp_path / "cache" / "c").glob("*.so")}
    assert stored == {f"dalembert_{k}.so" for k in keys}


def test_the_package_leaves_out_what_a_system_computes_on_first_use():
    mb = small_chain()
    mb.system.compiled  # noqa: B018
    mb.system.equations()
    pack = model.package(mb.system)
    system = pickle.loads(pack.system)
    assert "compiled" not in vars(system) and "_equations" not in vars(system.definition)
    assert "system" not in vars(system.definition.multibody)


def test_a_process_prepares_a_model_once_whatever_the_ensembles_settings():
    mb = small_chain()
    first_system, first = model.prepared(model.package(mb.system, {"t_end": 1.0}))
    second_system, second = model.prepared(model.package(mb.system, {"t_end": 2.0}))
    assert first_system is second_system and first_system is not mb.system
    assert (first, second) == ({"t_end": 1.0}, {"t_end": 2.0})


def test_a_batchs_arrays_travel_beside_the_pickle_not_inside_it():
    """A worker's batch pickles each kept quantity as one out-of-band buffer over its
    cases (protocol 5, as Dask sends results): nothing of the arrays is copied into the
    stream, the trajectories' views (``q``, ``qd``) included."""
    from dalembert.ensemble.cases import CaseColumns
    from dalembert.ensemble.worker import CaseSettings, run_batch
    from dalembert.options import simulation_options

    mb = small_chain()
    t_eval = np.linspace(0.0, 1.0, 101)
    settings = CaseSettings((0.0, 1.0), t_eval, simulation_options((0.0, 1.0), t_eval=t_eval),
                            np.zeros(21), np.zeros(21), {"m": 1.0},
                            CaseColumns(("m",), (), (), ()),
                            lambda case: tilted_state(mb, case["angle"]))
    done = run_batch(mb.system, settings, [0, 1], np.array([[1.5, 0.4], [0.8, 0.2]]),
                     ["m", "angle"])
    assert [o.status for o in done.cases] == ["finished", "finished"]
    assert done.arrays["q"].shape == (2, 101, 21)
    buffers: list[pickle.PickleBuffer] = []
    stream = pickle.dumps(done, protocol=5, buffer_callback=buffers.append)
    sizes = sorted(memoryview(b).nbytes for b in buffers)
    assert sizes == sorted(a.nbytes for a in done.arrays.values())
    assert len(stream) < min(a.nbytes for a in done.arrays.values() if a.ndim == 3)
