"""The KKT factorization object's Python backends (dense, band, SuperLU) against the
dense solve of the active rows' KKT system (:mod:`factorization_cases`), and against
each other and the C one."""

from __future__ import annotations

import numpy as np
import pytest
from factorization_cases import MODELS, case, dense_reference, relative, right_hand_sides

from dalembert import SingularSystemError
from dalembert.codegen.compiled import SparsePattern
from dalembert.solvers.kkt.factorization import (
    BAND_MAX,
    Backend,
    active_rows,
    band_lu,
    choose_backend,
    kkt_factorization,
)
from dalembert.solvers.native.factorization import schur_applies

PYTHON = (Backend.DENSE, Backend.BAND, Backend.SPLU)


@pytest.fixture(scope="module", params=MODELS)
def model(request):
    return case(request.param)


@pytest.mark.parametrize("backend", PYTHON)
def test_active_rows_changed_between_solves_match_the_dense_solve(model, backend):
    """The independent rows, then fewer (the last three of them), then the independent
    ones again, on one object: each against the dense solve of its own rows."""
    pattern, values, f, c, kept = model
    kkt = kkt_factorization(pattern, backend)
    assert kkt.backend is backend
    rhs = right_hand_sides(f, c, k=3)
    for rows in (kept, kept[:-3], kept):
        active = active_rows(rows, pattern.m)
        kkt.factor(values, rows)
        x, lam = kkt.solve(rhs)
        x_ref, lam_ref = dense_reference(pattern, values, rhs, active)
        assert relative(x, x_ref) < 1e-12 and relative(lam, lam_ref) < 1e-12
        assert not lam[~active].any()
        x1, lam1 = kkt.solve(rhs[:, 1])  # one right-hand side: the same as its column
        assert relative(x1, x[:, 1]) < 1e-15 and relative(lam1, lam[:, 1]) < 1e-15


def test_the_backends_agree(model):
    """Every backend, the C one included where it applies, on the same rows."""
    pattern, values, f, c, kept = model
    rhs = right_hand_sides(f, c, k=2, seed=5)
    backends = PYTHON + ((Backend.SCHUR,) if schur_applies(pattern) else ())
    results = []
    for backend in backends:
        kkt = kkt_factorization(pattern, backend)
        kkt.factor(values, kept)
        results.append(kkt.solve(rhs))
    x0, lam0 = results[0]
    for x, lam in results[1:]:
        assert relative(x, x0) < 1e-10 and relative(lam, lam0) < 1e-10


def test_a_changed_active_set_builds_nothing_structural(model):
    """The band order and storage map and the sparse maps are made once per pattern:
    refactoring with other rows, or a new factorization object, makes none anew."""
    pattern, values, f, c, kept = model
    objects = [kkt_factorization(pattern, b) for b in PYTHON]
    for kkt in objects:
        kkt.factor(values, kept)
    lu, maps = band_lu(pattern), kkt_factorization(pattern, Backend.SPLU)._maps
    for kkt in objects:
        kkt.factor(values, kept[1:])
        kkt.solve(np.concatenate([f, c]))
    assert band_lu(pattern) is lu
    assert kkt_factorization(pattern, Backend.SPLU)._maps is maps


def test_singular_matrix_is_reported():
    """A coordinate without inertia and no row holding it: singular."""
    pattern = SparsePattern(2, 1, np.array([0]), np.array([0]), np.array([0]),
                            np.array([1]))
    for backend in (Backend.BAND, Backend.SPLU):
        kkt = kkt_factorization(pattern, backend)
        kkt.factor(np.array([1.0, 1.0]))  # the row holds the massless coordinate
        with pytest.raises(SingularSystemError, match="singular"):
            kkt.factor(np.array([1.0, 1.0]), np.array([False]))
    kkt = kkt_factorization(pattern, Backend.DENSE)
    kkt.factor(np.array([1.0, 1.0]), np.array([False]))
    with pytest.raises(SingularSystemError, match="singular"):
        kkt.solve(np.zeros(3))


def test_bad_input_is_named():
    pattern = SparsePattern(2, 1, np.array([0, 1]), np.array([0, 1]), np.array([0]),
                            np.array([1]))
    kkt = kkt_factorization(pattern)
    with pytest.raises(RuntimeError, match="factor"):
        kkt.solve(np.zeros(3))
    with pytest.raises(ValueError, match="3 values of M and A"):
        kkt.factor(np.ones(4))
    with pytest.raises(ValueError, match="between 0 and 0"):
        kkt.factor(np.ones(3), np.array([1]))
    with pytest.raises(ValueError, match="one entry per row"):
        kkt.factor(np.ones(3), np.array([True, False]))
    kkt.factor(np.ones(3))
    with pytest.raises(ValueError, match="n \\+ m = 3 rows"):
        kkt.solve(np.zeros(4))


def test_the_choice_follows_the_band():
    """A chain's band is narrow whatever its length; a star (every row on one hub
    coordinate) makes the band as wide as the system: dense when small, else SuperLU."""
    chain, *_ = case("hanging-chain")
    assert choose_backend(chain) is Backend.BAND
    for n, expected in ((30, Backend.DENSE), (BAND_MAX + 40, Backend.SPLU)):
        rows = np.arange(n - 1)
        star = SparsePattern(n, n - 1, np.arange(n), np.arange(n),
                             np.concatenate([rows, rows]),
                             np.concatenate([np.zeros(n - 1, int), rows + 1]))
        assert band_lu(star).width > BAND_MAX
        assert choose_backend(star) is expected
