"""The hanging chain: equilibrium against the discrete catenary, reactions, a conserved swing."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.optimize import brentq

from dalembert.examples import hanging_chain as example

pytestmark = pytest.mark.filterwarnings("error::dalembert.errors.InitialConditionsAdjusted")

N, M, G, A, S = example.N_MASSES, 0.1, 9.81, 0.1, 1.5
WEIGHT = N * M * G


@pytest.fixture(scope="module")
def system():
    # measured: 0.6-1.0 s to build the model, 0.5-1.4 s to derive, 0.5-0.7 s to generate
    # code, 0.4-0.6 s for the statics functions (40 coordinates, 21 constraints)
    return example.build(m_value=M, g_value=G, a_value=A, s_value=S)


@pytest.fixture(scope="module")
def eq(system):
    return system.equilibrium(example.EQUILIBRIUM_GUESS)


def discrete_catenary() -> tuple[np.ndarray, float]:
    """Positions ``(N, 2)`` and horizontal tension ``H``, solved independently.

    By symmetry each pin carries half the weight; with no horizontal load the
    horizontal tension ``H`` is the same in every rod, so rod ``k`` (``k = 0..N``)
    slopes at ``tan(phi_k) = (k m g - W / 2) / H``; ``H`` makes the span ``S``.
    """
    vertical = np.arange(N + 1) * M * G - WEIGHT / 2

    def directions(h: float) -> np.ndarray:
        return np.column_stack([np.full(N + 1, h), vertical]) / np.hypot(h, vertical)[:, None]

    h = brentq(lambda h: A * directions(h)[:, 0].sum() - S, 1e-6, 1e6, xtol=1e-15, rtol=1e-15)
    return A * np.cumsum(directions(h), axis=0)[:-1], h


def test_equilibrium_is_the_discrete_catenary(eq):
    points, _ = discrete_catenary()
    assert eq.stability == "stable"
    assert np.abs(eq.q - points.ravel()).max() < 1e-12  # measured 2.2e-16


def test_support_reactions_carry_the_weight(system, eq):
    left, right = example.support_reactions(system, eq.q, eq.multipliers)
    _, h = discrete_catenary()
    total = left + right
    assert abs(total[1] - WEIGHT) < 1e-12 * WEIGHT  # measured 0 (19.62 N)
    assert abs(total[0]) < 1e-12 * WEIGHT  # measured 3.6e-15 N
    np.testing.assert_allclose([left[1], right[1]], WEIGHT / 2, rtol=1e-12)
    np.testing.assert_allclose([-left[0], right[0]], h, rtol=1e-10)


def test_horizontal_tension_is_the_same_in_every_rod(system, eq):
    nodes = example.draw(system, eq.q)[0]
    # rod k pulls along its own direction: 2 lambda_k (p_k+1 - p_k)
    horizontal = 2 * eq.multipliers * np.diff(nodes[:, 0])
    assert np.ptp(horizontal) < 1e-12 * np.abs(horizontal).max()


def test_initial_shape_is_on_the_rods(system):
    q0 = np.array([example.INITIAL["q0"][k] for k in example.NAMES])
    lengths = np.linalg.norm(np.diff(example.draw(system, q0)[0], axis=0), axis=1)
    assert np.abs(lengths - A).max() < 1e-14


@pytest.mark.validation
def test_small_swing_conserves_energy(system, eq):
    times = np.linspace(0.0, example.T_END, 201)
    traj = system.simulate((0.0, example.T_END), **example.INITIAL, t_eval=times)
    assert traj.success
    # it does swing: the midpoint moves by about 2 cm sideways (measured 1.9e-2)
    mid = example.NAMES.index("x10")
    assert np.ptp(traj.q[:, mid]) > 1e-3
    e = traj.energy
    assert np.abs(e - e[0]).max() / abs(e[0]) < 1e-10  # measured 6e-14
    errors = example.checks(system, traj)
    assert errors["max position residual"] < 1e-12
