"""Models, values and the dense reference shared by the KKT factorization tests.

The reference is one ``numpy.linalg.solve`` of the dense KKT matrix of the active rows
alone, ``[[M, A_a^T], [A_a, 0]] [x; -lambda_a] = [f; c_a]``: independent of every
backend's storage, order, folding and treatment of inactive rows.
"""

from __future__ import annotations

import warnings

import numpy as np

from dalembert.examples import load

#: gallery examples: a chain of quaternion bodies (a unit-norm row inside each body's
#: block), a planar chain of rods, and a closed loop with dependent rows
MODELS = ("spherical-chain", "hanging-chain", "four-bar")


def case(name: str):
    """``(pattern, values, f, c, kept)`` at the example's initial configuration with
    other velocities; ``kept``: the independent rows there."""
    module = load(name)
    system = module.build()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the four-bar's dependent rows are reported
        report = system.consistent_initial_state(module.INITIAL["q0"],
                                                 module.INITIAL.get("qd0"))
    num = system.numeric()
    rng = np.random.default_rng(1)
    q = report.q
    qd = report.qd + 0.5 * rng.standard_normal(num.n)
    Mv, f, Av, c = num.kkt_sparse(0.3, q, qd)
    kept = np.arange(num.m) if report.rank.kept is None else report.rank.kept
    return num.pattern, np.concatenate([Mv, Av]), f, c, np.asarray(kept)


def dense_reference(pattern, values, rhs, active):
    """``(x, lambda)`` of the dense KKT system of the active rows, ``lambda`` 0 elsewhere."""
    n, n_m = pattern.n, len(pattern.M_rows)
    M, A = pattern.dense_M(values[:n_m]), pattern.dense_A(values[n_m:])
    rows = np.flatnonzero(active)
    K = np.block([[M, A[rows].T], [A[rows], np.zeros((len(rows), len(rows)))]])
    z = np.linalg.solve(K, np.concatenate([rhs[:n], rhs[n:][rows]]))
    lam = np.zeros((pattern.m, *rhs.shape[1:]))
    lam[rows] = -z[n:]
    return z[:n], lam


def right_hand_sides(f, c, k=3, seed=0):
    """The model's own ``[f; c]`` and ``k - 1`` random ones, as columns."""
    rng = np.random.default_rng(seed)
    own = np.concatenate([f, c])[:, None]
    return np.hstack([own, rng.standard_normal((len(own), k - 1))])


def relative(x, reference):
    return np.abs(x - reference).max() / np.abs(reference).max()
