"""Initialization of large models: sparse projections and the sparse KKT screen.

Past ``DENSE_MAX`` constraints the initial projection uses the sparse KKT solver
(Newton with the minimum-norm step); the reference is the dense least-squares
projection, the same least-change problem solved by another route.
"""

from __future__ import annotations

import numpy as np
import pytest
import sympy as sp

from dalembert import Holonomic, SingularSystemError, System, coordinates
from dalembert.multibody import chain
from dalembert.solvers import initialization
from dalembert.solvers.projection import project_positions, project_velocities


def test_sparse_initial_projection_matches_the_dense_one():
    mb = chain(20, 1.0, 1.0, 0.05)  # 80 constraints: the sparse route
    system = mb.system
    q0, qd0 = mb.initial_state(positions={f"link{k + 1}": (0.0, 0.0, -k - 0.5)
                                          for k in range(20)},
                               angular_velocities={"link3": (0.3, 0.0, 0.1)})
    rng = np.random.default_rng(2)
    names = system.coordinate_names
    q = np.array([q0[k] for k in names]) + 1e-3 * rng.normal(size=len(names))
    qd = np.array([qd0[k] for k in names]) + 1e-3 * rng.normal(size=len(names))
    report = system.consistent_initial_state(q, qd)
    num = system.numeric()
    q_ref = project_positions(num, 0.0, q)
    qd_ref = project_velocities(num, 0.0, q_ref, qd)
    assert np.abs(report.q - q_ref).max() < 1e-11
    assert np.abs(report.qd - qd_ref).max() < 1e-11
    assert np.abs(num.position_constraint(0.0, report.q)).max() < 1e-13


def singular_system(size: int):
    """``x0`` has no inertia and no constraint: the KKT matrix is singular."""
    q = coordinates(" ".join(f"x{i}" for i in range(size)))
    m = sp.Symbol("m")
    T = sum(m / 2 * x.diff() ** 2 for x in q[1:])
    rods = [Holonomic(q[i] - q[i + 1] - 1, name=f"link{i}") for i in range(1, size - 1)]
    return System(q, kinetic=T, constraints=rods, parameters={m: 1.0})


def test_singular_kkt_found_by_the_sparse_screen_and_named_by_the_dense_check(monkeypatch):
    system = singular_system(40)  # 40 + 38 unknowns: past the dense solver's size
    q0 = {f"x{i}": -float(i) for i in range(40)}
    with pytest.raises(SingularSystemError, match="x0"):
        system.consistent_initial_state(q0)
    monkeypatch.setattr(initialization, "DENSE_CHECK_MAX", 10)  # as for a huge model
    with pytest.raises(SingularSystemError, match="condition number estimate"):
        system.consistent_initial_state(q0)
