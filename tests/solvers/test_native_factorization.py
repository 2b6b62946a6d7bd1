"""The C block/Schur KKT factorization (``dl_kkt_factor``, ``dl_kkt_solve``) against the
dense solve of the active rows' KKT system (:mod:`factorization_cases`)."""

from __future__ import annotations

import numpy as np
import pytest
from factorization_cases import MODELS, case, dense_reference, relative, right_hand_sides

from dalembert import SingularSystemError
from dalembert.solvers.kkt.factorization import Backend, kkt_factorization
from dalembert.solvers.native.factorization import SchurFactorization, schur_applies

#: The four-bar at its initial configuration: the Schur complement A M^-1 A^T has about
#: the square of the KKT matrix's condition (~1e3), so a right-hand side that is not the
#: model's own (random c on the loop's rows) loses more digits (measured ~5e-12) than
#: the dense solve of the whole matrix; the solution's residual stays at rounding.
TOLERANCE = {"four-bar": 1e-10}


@pytest.fixture(scope="module", params=MODELS)
def model(request):
    return request.param, *case(request.param)


def test_many_right_hand_sides_match_the_dense_solve(model):
    name, pattern, values, f, c, kept = model
    tol = TOLERANCE.get(name, 1e-12)
    active = np.isin(np.arange(pattern.m), kept)
    kkt = SchurFactorization(pattern)
    kkt.factor(values, kept)
    rhs = right_hand_sides(f, c, k=4)
    x, lam = kkt.solve(rhs)
    x_ref, lam_ref = dense_reference(pattern, values, rhs, active)
    assert x.shape == (pattern.n, 4) and lam.shape == (pattern.m, 4)
    assert relative(x, x_ref) < tol and relative(lam, lam_ref) < tol
    # one right-hand side at a time: the same numbers as the columns
    x1, lam1 = kkt.solve(rhs[:, 2])
    assert np.array_equal(x1, x[:, 2]) and np.array_equal(lam1, lam[:, 2])


def test_other_active_rows_refactor_without_rebuilding(model):
    """Some rows between blocks made inactive (the last band rows of the Schur order,
    so a body or more is set free), then all the independent rows again: each solve
    against the dense one of its own rows, on the same object and tables."""
    name, pattern, values, f, c, kept = model
    tol = TOLERANCE.get(name, 1e-12)
    kkt = SchurFactorization(pattern)
    structure, shared = kkt.structure, kkt._shared
    rhs = right_hand_sides(f, c, k=3, seed=2)
    band = np.intersect1d(kkt.structure.band_row, kept)
    fewer = np.setdiff1d(kept, band[-3:])
    for rows in (kept, fewer, kept):
        active = np.isin(np.arange(pattern.m), rows)
        kkt.factor(values, active)
        x, lam = kkt.solve(rhs)
        x_ref, lam_ref = dense_reference(pattern, values, rhs, active)
        assert relative(x, x_ref) < tol and relative(lam, lam_ref) < tol
        assert not lam[~active].any()
        # the inactive rows' entries of c are ignored
        noisy = rhs.copy()
        noisy[pattern.n:][~active] = 1e3
        assert np.array_equal(kkt.solve(noisy)[0], x)
    assert kkt.structure is structure and kkt._shared is shared


def test_an_inactive_row_inside_a_block_is_not_folded():
    """A tumbling quaternion body with its unit-norm row inactive: M's block is singular
    (rank 3), so the factorization refuses; with the row active it is the dense solve."""
    pattern, values, f, c, _ = case("spherical-chain")
    kkt = SchurFactorization(pattern)
    s = kkt.structure
    internal = s.pair_row[s.block_pairs[s.elim_blocks[0]]]
    active = np.ones(pattern.m, dtype=bool)
    active[internal] = False
    with pytest.raises(SingularSystemError, match="mass matrix"):
        kkt.factor(values, active)
    with pytest.raises(RuntimeError, match="factor"):
        kkt.solve(np.zeros(pattern.n + pattern.m))
    kkt.factor(values)
    rhs = right_hand_sides(f, c)
    x, lam = kkt.solve(rhs)
    x_ref, lam_ref = dense_reference(pattern, values, rhs, np.ones(pattern.m, dtype=bool))
    assert relative(x, x_ref) < 1e-12 and relative(lam, lam_ref) < 1e-12


def test_dependent_rows_all_active_are_refused():
    """The four-bar's rows all active: A is rank deficient, S singular."""
    pattern, values, *_ = case("four-bar")
    with pytest.raises(SingularSystemError, match="singular"):
        SchurFactorization(pattern).factor(values)


def test_the_factory_chooses_it_when_asked():
    pattern, *_ = case("hanging-chain")
    assert schur_applies(pattern)
    assert kkt_factorization(pattern, Backend.SCHUR).backend is Backend.SCHUR
