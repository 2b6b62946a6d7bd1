"""The exact derivatives the implicit solvers use, on every model of the gallery.

At a state of each example's own run (a short stretch from its initial state), the
exact first-order Jacobian (``solvers/jacobian.py``) against central differences of
the right-hand side (the KKT solve itself on the rows a run solves for, which uses no
derivative: with dependent rows, the kept ones, without the run's fallback to a
least-squares solve where a perturbed state leaves the dropped ones unmet), and the
KKT-structured solve with ``I - c J`` (``solvers/newton.py``) for Radau's complex
``c`` against the same differences. The inputs of a controlled example are held at
their values (the exact Jacobian leaves out inputs computed from the state: those
runs use forward differences, see ``run_data._jacobian``).
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from test_jacobian import central_differences

from dalembert.examples import EXAMPLES, load
from dalembert.solvers.jacobian import first_order_jacobian
from dalembert.solvers.kkt.sparse import kkt_solver
from dalembert.solvers.newton import KKTLinearization

#: Radau's complex eigenvalue over a step of 0.01.
C_COMPLEX = 0.01 / (3 + 0.5 * (3 ** (1 / 3) - 3 ** (2 / 3))
                    - 0.5j * (3 ** (5 / 6) + 3 ** (7 / 6)))


def kkt_rhs(num, kept):
    """``[qd, qdd]`` from the KKT system on the ``kept`` rows (all: ``None``)."""
    solver = kkt_solver(num.pattern, kept)
    rows = np.arange(num.m) if kept is None else kept

    def rhs(t, y):
        q, qd = num.layout.split(y)
        Mv, f, Av, c = num.kkt_sparse(t, q, qd)
        return np.concatenate([qd, solver.factor(Mv, Av)(np.concatenate([f, c[rows]]))[:num.n]])

    return rhs


@pytest.mark.parametrize("name", list(EXAMPLES))
def test_exact_derivatives_against_central_differences(name):
    example = load(name)
    system = example.build()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        traj = system.simulate((0.0, 0.05), **example.INITIAL, t_eval=[0.0, 0.05])
    num = getattr(system, "system", system).numeric()  # a Multibody's System
    t = float(traj.t[-1])
    y = np.concatenate([traj.q[-1], traj.qd[-1]])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        inputs = {k: v for k, v in example.INITIAL.items() if k in ("inputs", "sample_time")}
        kept = getattr(system, "system", system).plan((t, t + 0.01), traj.q[-1],
                                                        traj.qd[-1], **inputs).kept
    differences = central_differences(kkt_rhs(num, kept), t, y)
    exact = first_order_jacobian(num, kept)(t, y)
    scale = max(1.0, np.abs(differences).max())
    assert np.abs(exact - differences).max() <= 1e-6 * scale, name
    b = np.random.default_rng(0).standard_normal(y.size)
    x = KKTLinearization(num, kept, t, y).factor(C_COMPLEX)(b)
    residual = (np.eye(y.size) - C_COMPLEX * differences) @ x - b
    assert np.abs(residual).max() <= 1e-6 * (1 + abs(C_COMPLEX) * scale * np.abs(x).max()), name
