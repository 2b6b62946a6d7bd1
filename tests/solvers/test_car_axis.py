"""The car axis (IVP Test Set, index 3) against the Test Set's 22-digit reference at
``t = 3`` (``car_axis.py``: the model as a dalembert System, the reference, and why its
multipliers compare one to one), with every kind of method at its default tolerances
and IDA tightened.

Measured (positions: largest relative error of ``xl, yl, xr, yr``; multipliers:
of ``lambda1, lambda2``; ``atol = rtol / 100``; CPU seconds on the development machine):

| method | rtol | positions | multipliers | s |
|---|---|---|---|---|
| DOP853 | 1e-11 (default) | 5.1e-13 | 7.6e-12 | 0.007 |
| Radau | 1e-8 (default) | 1.1e-10 | 5.3e-10 | 2.6 |
| BDF | 1e-8 (default) | 3.7e-7 | 2.2e-6 | 1.0 |
| IDA | 1e-8 (default) | 1.4e-7 | 9.8e-7 | 1.0 |
| IDA | 1e-11 | 6.6e-10 | 3.5e-9 | 2.6 |
| IDA | 1e-12 | 8.3e-11 | 4.0e-10 | 5.5 |

IDA's position error runs 2 to 80 times its ``rtol`` from 1e-6 to 1e-12 (its
multipliers are out of the error test); it meets the issue's targets (positions 1e-9,
multipliers 1e-7) from 1e-11, and is tested at 1e-12. The bounds below leave a factor
of about 3 over these values (the issue's targets for Radau and IDA at 1e-12).
"""

from __future__ import annotations

import car_axis
import numpy as np
import pytest


@pytest.fixture(scope="module")
def system():
    return car_axis.build()


def relative(found: np.ndarray, reference: np.ndarray) -> float:
    return float((np.abs(found - reference) / np.abs(reference)).max())


@pytest.mark.parametrize(("method", "rtol", "positions", "multipliers"), [
    ("DOP853", None, 2e-12, 3e-11),   # the explicit defaults, 1e-11 / 1e-13
    ("Radau", None, 1e-9, 1e-7),      # the implicit defaults, 1e-8 / 1e-10: the issue's
    ("BDF", None, 1.5e-6, 1e-5),      # targets (1e-9, 1e-7) for Radau
    ("IDA", None, 6e-7, 5e-6),
    ("IDA", 1e-12, 1e-9, 1e-7),
])
def test_positions_and_multipliers_at_t3(system, method, rtol, positions, multipliers):
    options = {} if rtol is None else {"rtol": rtol, "atol": rtol / 100}
    traj = system.simulate((0, 3), car_axis.Q0, car_axis.QD0, method=method,
                           t_eval=[0.0, 1.5, 3.0], **options)
    assert traj.status == "finished"
    assert relative(traj.q[-1], car_axis.REFERENCE_POSITIONS) < positions
    assert relative(traj.multipliers[-1], car_axis.REFERENCE_MULTIPLIERS) < multipliers


def test_the_start_is_the_test_sets_and_is_consistent(system):
    """The Test Set's initial values satisfy both constraints and their derivatives, so
    the initial projection changes nothing."""
    state = system.consistent_initial_state(car_axis.Q0, car_axis.QD0)
    np.testing.assert_array_equal(state.q, car_axis.Q0)
    np.testing.assert_allclose(state.qd, car_axis.QD0, atol=1e-15)
