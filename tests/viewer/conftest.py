"""Fixtures of the viewer's tests (the runs themselves: viewer_runs.py)."""

from __future__ import annotations

import pytest
from viewer_runs import swinging_chain


@pytest.fixture(scope="module")
def chain256_page(tmp_path_factory: pytest.TempPathFactory):
    """The viewer's page of a 10 s run of a 256-link chain (1001 outputs)."""
    from dalembert.plotting import view

    traj, mb = swinging_chain(256, 10.0, 1001)
    return view(traj, mb.system, tmp_path_factory.mktemp("chain256") / "chain256.html")
