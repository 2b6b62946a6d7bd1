"""One model struct (``dl_model``, constant) under runs on several threads, each with its
own ``dl_data``: every run gives, bit for bit, what it gives alone."""

from __future__ import annotations

import threading

import numpy as np
import pytest
import sympy as sp

from dalembert.multibody import chain
from dalembert.solvers.native import solver as native_solver_module

N = 3
m, l, r = sp.symbols("m l r", positive=True)
VALUES = [{m: 0.7, l: 1.3, r: 0.04}, {m: 2.5, l: 0.6, r: 0.08}]
TIMES = np.linspace(0.0, 30.0, 61)  # long enough for the C loops to overlap


@pytest.fixture(scope="module")
def symbolic_chain():
    mb = chain(N, l, m, r)
    mb.defaults = {m: 1.0, l: 1.0, r: 0.05}
    mb.system.compiled  # noqa: B018  (built before any thread runs)
    return mb


def _initial_state(mb, length):
    """The links hanging straight and turning as one rigid body about the pivot."""
    omega = np.array([0.4, 0.7, 0.0])
    positions = {f"link{k + 1}": (0.0, 0.0, -(k + 0.5) * length) for k in range(N)}
    velocities = {name: np.cross(omega, x) for name, x in positions.items()}
    return mb.initial_state(positions=positions, velocities=velocities,
                            angular_velocities=dict.fromkeys(positions, omega))


def _run(mb, values):
    q0, qd0 = _initial_state(mb, values[l])
    traj = mb.simulate((0.0, TIMES[-1]), q0, qd0, t_eval=TIMES, parameters=values,
                       rtol=1e-12, atol=1e-14)
    assert traj.status == "finished"
    return traj.q, traj.multipliers


def test_two_parameter_sets_share_one_model_struct(symbolic_chain):
    """Solvers over one compiled model with other parameter values point to one
    ``dl_model`` and to data of their own (the parameter vectors too)."""
    system = symbolic_chain.system
    a, b = (native_solver_module.NativeSolver(system.numeric(values)) for values in VALUES)
    assert a.model is b.model and a._at[0] == b._at[0]
    assert a._at[1] != b._at[1] and a.data.p != b.data.p and a.data.S != b.data.S


def test_runs_on_two_threads_over_one_model_give_what_they_give_alone(symbolic_chain,
                                                                     monkeypatch):
    alone = [_run(symbolic_chain, values) for values in VALUES]
    models = []
    init = native_solver_module.NativeSolver.__init__

    def recording(self, *args, **kwargs):
        init(self, *args, **kwargs)
        models.append(self._at[0])

    monkeypatch.setattr(native_solver_module.NativeSolver, "__init__", recording)

    def worker(k, start, results):
        start.wait()  # both runs at once
        results[k] = _run(symbolic_chain, VALUES[k])

    for _ in range(3):
        results: list[object] = [None, None]
        start = threading.Barrier(2)
        threads = [threading.Thread(target=worker, args=(k, start, results)) for k in range(2)]
        for thread in threads:
            thread.start()
        for thread in threads:
            thread.join()
        for (q, lam), (q_alone, lam_alone) in zip(results, alone):
            assert np.array_equal(q, q_alone) and np.array_equal(lam, lam_alone)
    assert models and len(set(models)) == 1  # every run over the one struct
    assert not np.allclose(alone[0][0], alone[1][0])  # the values do differ
