"""IFToMM A02 with N = 4 over 5 s (seven flat positions) at the default settings, in
both loops: B0 against the parallelogram's one-coordinate motion (integrated apart,
``J phi'' = -V cos(phi)``), every crank parallel (the right branch), energy kept."""

from __future__ import annotations

import numpy as np
import pytest

from dalembert.errors import SingularConfigurationWarning
from dalembert.examples import n_four_bar as example

TIMES = np.linspace(0.0, example.T_END, 101)


@pytest.mark.parametrize("backend", ["c", "python"])
def test_the_benchmark_passes_on_the_parallelogram_branch(backend):
    system = example.build()
    with pytest.warns(SingularConfigurationWarning, match="flat|singular configuration"):
        traj = system.simulate((0.0, example.T_END), **example.INITIAL, t_eval=TIMES,
                               backend=backend)
    assert traj.success, traj.message
    found = example.checks(system, traj)
    assert found["B0 position error (one-coordinate reference)"] < 1e-3
    assert found["B0 velocity error (one-coordinate reference)"] < 1e-3
    assert found["largest angle between cranks (0 on the branch)"] < 1e-3
    assert found["relative energy error"] < 1e-6
    # the crank passes the horizontal several times in 5 s
    phi = traj["crank0_theta"]
    assert np.count_nonzero(np.diff(np.sign(np.sin(phi)))) >= 3
