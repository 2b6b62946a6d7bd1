"""A generated function called from C through ``dl_model.fn`` (``dl_call``, functions.c).

Reference: the same compiled function called from Python through the registry's
handle (``NumericModel.evaluate``), on a scatter driver (a Multibody, part by part)
and a flat function (a plain System): C must give the same values, bit for bit.
"""

from __future__ import annotations

import ctypes

import numpy as np
import pytest

from dalembert.examples import cartesian_pendulum
from dalembert.multibody import chain
from dalembert.solvers.native import NativeSolver, library


@pytest.mark.parametrize("make", [lambda: chain(3, 1.0, 1.0, 0.05).system,
                                  cartesian_pendulum.build], ids=["parts", "flat"])
def test_residual_jacobians_are_reached_from_c(make):
    num = make().numeric()
    rng = np.random.default_rng(0)
    t = np.array([0.3])
    q, qd, qdd = rng.uniform(-1, 1, (3, num.n))
    lam = rng.uniform(-1, 1, num.m)
    args = (ctypes.c_void_p * 5)(*[a.ctypes.data for a in (t, q, qd, qdd, lam)])
    lib, which = library.runtime(), library.FUNCTIONS["residual_jacobians"]
    before = NativeSolver(num)  # not generated yet: no function in its place
    assert lib.dl_call(*before._at, which, args, None) == -1
    reference = num.evaluate("residual_jacobians", 0.3, q, qd, qdd, lam)
    solver = NativeSolver(num)
    out = np.full(len(reference), np.nan)
    assert lib.dl_call(*solver._at, which, args, out.ctypes.data) == 0
    assert np.array_equal(out, reference)
    assert lib.dl_call(*solver._at, library.FN_COUNT, args, None) == -1
