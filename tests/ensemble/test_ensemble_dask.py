"""Ensembles on a ``LocalCluster`` of processes: the same answers as alone and as
serially, the model shipped to workers with an empty code cache, a worker dying
mid-run, and a Ctrl-C while the client waits.

One small cluster (2 single-threaded workers) serves the module; each worker gets
its own empty code cache, as a worker on another machine would have. The scheduler
gives up on a task at the first death of its worker (``allowed-failures`` 0, default
3): the ensemble then runs the batch's cases one by one, which is what these tests
check, and a case that always kills its worker costs two deaths, not eight.
"""

from __future__ import annotations

import logging
import warnings

import dask
import numpy as np
import pytest
from distributed import Client, LocalCluster
from distributed.diagnostics.plugin import SchedulerPlugin
from ensemble_models import (
    brake,
    damper,
    kill_always,
    kill_once,
    pendulum,
    pushed_bead,
    released,
    released_slowly,
    small_chain,
    tilted_state,
    tip_z,
)
from scipy import stats

from dalembert import EnsembleWarning
from dalembert.ensemble import grid, sample
from dalembert.ensemble import run as run_module
from dalembert.ensemble.model import package

T_EVAL = np.linspace(0.0, 1.5, 31)


@pytest.fixture(scope="module")
def cluster(tmp_path_factory):
    cache = tmp_path_factory.mktemp("worker-cache")
    with dask.config.set({"distributed.scheduler.allowed-failures": 0}):
        local = LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                             dashboard_address=None, silence_logs=logging.CRITICAL,
                             env={"DALEMBERT_CACHE_DIR": str(cache)})
        client = Client(local)
    yield client, cache
    client.close()
    local.close()


def alone(system, case, initial, **options):
    q0, qd0 = initial(case)
    parameters = {k: v for k, v in case.items() if k in {p.name for p in system.parameters}}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return system.simulate((T_EVAL[0], T_EVAL[-1]), q0, qd0, parameters=parameters,
                               t_eval=T_EVAL, **options)


def test_cases_on_processes_equal_the_cases_alone_and_the_serial_run(cluster):
    client, cache = cluster
    mb = small_chain()
    cases = sample({"m": stats.uniform(0.5, 1.0), "angle": stats.uniform(0.2, 0.6)}, 6, seed=9)

    def initial(case):  # a closure over the mechanism: it travels with the model
        return tilted_state(mb, case["angle"])

    options = dict(initial_state=initial, t_eval=T_EVAL, rtol=1e-8, atol=1e-10,
                   outputs={"tip_z": tip_z}, batch_size=2, progress=False)
    result = mb.system.simulate_many((0.0, 1.5), cases, client=client, **options)
    serial = mb.system.simulate_many((0.0, 1.5), cases, scheduler="serial", **options)
    assert result.scheduler == "dask" and result.failed == []
    assert result.summary["worker"].nunique() == 2  # both workers took part
    for name in ("q", "qd", "multipliers", "constraint_forces", "energy", "tip_z"):
        assert np.array_equal(result.dataset[name].values, serial.dataset[name].values), name
    for i in (1, 4):  # sampled
        traj = alone(mb.system, cases.iloc[i].to_dict(), initial, rtol=1e-8, atol=1e-10)
        assert np.abs(result.dataset["q"].values[i] - traj.q).max() <= 1e-12
        assert np.abs(result.dataset["multipliers"].values[i] - traj.multipliers).max() <= 1e-12
    # each worker's empty cache holds exactly what was shipped: nothing compiled there
    shipped = {f"dalembert_{lib.key}.so" for lib in package(mb.system).libraries}
    assert {p.name for p in (cache / "c").glob("*.so")} == shipped


def test_inputs_on_processes_equal_the_serial_run(cluster):
    client, _ = cluster
    bead = pushed_bead()
    options = dict(q0=[0.5, 0.5], qd0=[1.0, 1.0], inputs={"v": brake}, t_eval=T_EVAL,
                   keep=("q", "multipliers", "inputs"), batch_size=2, progress=False)
    cases = grid(u=[-1.0, 0.0, 2.0], m=[1.0, 3.0])
    result = bead.simulate_many((0.0, 1.5), cases, client=client, **options)
    serial = bead.simulate_many((0.0, 1.5), cases, scheduler="serial", **options)
    assert result.failed == []
    for name in ("q", "multipliers", "inputs"):
        assert np.array_equal(result.dataset[name].values, serial.dataset[name].values), name
    np.testing.assert_array_equal(result.dataset["inputs"].sel(input="u").values[:, 0],
                                  cases["u"].to_numpy())
    # each case's own controller, made where the case runs
    options = {**options, "inputs": None}
    cases = grid(u=[0.0, 1.0], c=[0.5, 2.0])
    result = bead.simulate_many((0.0, 1.5), cases, client=client, case_inputs=damper, **options)
    serial = bead.simulate_many((0.0, 1.5), cases, scheduler="serial", case_inputs=damper,
                                **options)
    assert result.failed == []
    assert np.array_equal(result.dataset["inputs"].values, serial.dataset["inputs"].values)


def test_a_worker_dying_once_loses_no_case(cluster, tmp_path):
    client, _ = cluster
    pend = pendulum()
    cases = grid(l=[0.8, 1.0, 1.2, 1.4], victim=[0.0])
    cases.loc[2, "victim"] = 1.0
    result = pend.simulate_many((0.0, 1.5), cases, initial_state=kill_once(
        str(tmp_path / "killed")), client=client, t_eval=T_EVAL, batch_size=2, progress=False)
    assert (tmp_path / "killed").exists()  # a worker did die
    assert result.failed == []
    for i in range(4):
        assert np.array_equal(result.dataset["q"].values[i],
                              alone(pend, cases.iloc[i].to_dict(), released).q)


def test_a_case_that_kills_every_worker_is_lost_alone(cluster):
    client, _ = cluster
    pend = pendulum()
    cases = grid(l=[0.8, 1.0, 1.2], victim=[0.0])
    cases.loc[1, "victim"] = 1.0
    with pytest.warns(EnsembleWarning, match="1 of 3 cases did not succeed \\(1 lost\\)"):
        result = pend.simulate_many((0.0, 1.5), cases, initial_state=kill_always,
                                    client=client, t_eval=T_EVAL, batch_size=3,
                                    progress=False)
    assert result.summary["status"].tolist() == ["finished", "lost", "finished"]
    assert "died" in result.summary.loc[1, "message"]
    assert np.array_equal(result.dataset["q"].values[2],
                          alone(pend, cases.iloc[2].to_dict(), released).q)


def _relayed(client) -> int:
    """How many times the scheduler has gathered results for a client."""
    return sum(event.get("action") == "gather" for _, event in client.get_events("all"))


def test_results_come_straight_from_the_workers_of_a_scheduler_on_this_machine(cluster):
    """Not relayed by the scheduler (which runs in the client's process): unless the
    client says otherwise, as a client of a remote cluster may have to."""
    client, _ = cluster
    pend = pendulum()
    cases = grid(l=[0.8, 1.0, 1.2, 1.4])
    options = dict(initial_state=released, t_eval=T_EVAL, batch_size=2, progress=False)
    before = _relayed(client)
    straight = pend.simulate_many((0.0, 1.5), cases, client=client, **options)
    assert _relayed(client) == before
    with Client(client.scheduler.address, direct_to_workers=False) as relaying:
        relayed = pend.simulate_many((0.0, 1.5), cases, client=relaying, **options)
        assert _relayed(relaying) >= before + 2  # a gather for each batch
    assert np.array_equal(straight.dataset["q"].values, relayed.dataset["q"].values)


class _Graphs(SchedulerPlugin):
    """Counts the graphs the scheduler receives and the tasks in each."""

    def __init__(self):
        self.tasks = []

    def update_graph(self, scheduler, *, tasks, **kwargs):
        self.tasks.append(len(tasks))


def test_the_batches_reach_the_scheduler_in_one_graph(cluster):
    """The model's package is pickled once for all the batches of a call (one graph),
    and the scheduler holds one copy of it: sent task by task, each batch's copy would
    be pickled and held apart (bench/README.md measures the client's memory)."""
    client, _ = cluster
    graphs = _Graphs()
    client.cluster.scheduler.add_plugin(graphs, name="count-graphs")
    try:
        result = pendulum().simulate_many((0.0, 1.5), grid(l=np.linspace(0.5, 2.0, 12)),
                                          initial_state=released, client=client,
                                          t_eval=T_EVAL, batch_size=2, progress=False)
    finally:
        client.cluster.scheduler.remove_plugin("count-graphs")
    assert (result.summary["status"] == "finished").all()
    assert len(graphs.tasks) == 1 and graphs.tasks[0] >= 6  # 6 batches (the last split)


class _CtrlCAfter:
    """A progress bar whose second update is a Ctrl-C (the user's, while the client
    waits for the cluster)."""

    def __init__(self, total, show):
        self.updates = 0

    def update(self, n):
        if n:
            self.updates += 1
            if self.updates == 2:
                raise KeyboardInterrupt

    def close(self):
        pass


def test_ctrl_c_while_waiting_returns_what_finished(cluster, monkeypatch):
    client, _ = cluster
    monkeypatch.setattr(run_module, "_bar", _CtrlCAfter)
    pend = pendulum()
    cases = grid(l=np.linspace(0.5, 2.0, 12))
    with pytest.warns(EnsembleWarning, match="interrupted"):
        result = pend.simulate_many((0.0, 1.5), cases, initial_state=released_slowly, client=client,
                                    t_eval=T_EVAL, batch_size=2)
    status = result.summary["status"]
    assert result.interrupted
    assert set(status) <= {"finished", "not-run"} and (status == "not-run").any()
    assert (status == "finished").sum() >= 4  # the two batches taken before the Ctrl-C
    for i in np.flatnonzero(status == "finished")[:2]:
        assert np.array_equal(result.dataset["q"].values[i],
                              alone(pend, cases.iloc[i].to_dict(), released).q)
    assert np.isnan(result.dataset["q"].values[np.flatnonzero(status == "not-run")]).all()
    assert client.run(lambda: True)  # the cluster is still there for the next run


# distributed leaves a probed socket open when it starts an in-process cluster's servers
@pytest.mark.filterwarnings("ignore:unclosed <socket:ResourceWarning")
def test_a_worker_with_two_threads_gives_the_serial_answers():
    """A Dask worker running two tasks at once: its threads take turns for their Python
    (dalembert.solvers.native.turns) and each case gives the serial run's arrays."""
    mb = small_chain()
    cases = sample({"m": stats.uniform(0.5, 1.0), "angle": stats.uniform(0.2, 0.6)}, 6, seed=3)

    def initial(case):
        return tilted_state(mb, case["angle"])

    options = dict(initial_state=initial, t_eval=T_EVAL, rtol=1e-8, atol=1e-10,
                   batch_size=1, progress=False)
    with LocalCluster(n_workers=1, threads_per_worker=2, processes=False,
                      dashboard_address=":0", silence_logs=logging.CRITICAL) as local, \
            Client(local) as client:
        threaded = mb.system.simulate_many((0.0, 1.5), cases, client=client, **options)
    serial = mb.system.simulate_many((0.0, 1.5), cases, scheduler="serial", **options)
    assert threaded.failed == []
    for name in ("q", "qd", "multipliers", "energy"):
        assert np.array_equal(threaded.dataset[name].values, serial.dataset[name].values), name
