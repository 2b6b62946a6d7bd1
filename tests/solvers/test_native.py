"""The C loop (:mod:`dalembert.solvers.native`) against the Python path and SciPy.

References: the dense KKT solve (:func:`~dalembert.solvers.kkt.dense.solve_kkt`), the
Python right-hand side with its Baumgarte terms, the Python step projector, and
SciPy's own Runge-Kutta solvers, which must take the same steps.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest
import scipy.integrate as si
import sympy as sp

from dalembert import Holonomic, Pfaffian, SingularSystemError, System, coordinates
from dalembert.codegen.compiled import SparsePattern
from dalembert.examples import EXAMPLES, load
from dalembert.multibody import chain
from dalembert.options import STEP_CONTROLS
from dalembert.solvers.dynamics import first_order_rhs
from dalembert.solvers.kkt.dense import solve_kkt
from dalembert.solvers.native import NATIVE_METHODS, NativeSolver, NotApplicable, native_solver
from dalembert.solvers.native.structure import BLOCK_MAX, schur_structure
from dalembert.solvers.outputs import evaluate_outputs
from dalembert.solvers.projection import StepProjector
from dalembert.solvers.running.integrate import integrate
from dalembert.solvers.steppers.scipy_ivp import CONTROLLED


def initial(name: str):
    module = load(name)
    system = module.build()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        report = system.consistent_initial_state(module.INITIAL["q0"], module.INITIAL.get("qd0"))
    return system.numeric(), report


def states(num, report, count=4, seed=0):
    """States near the initial one (off the constraints, which the solve allows)."""
    rng = np.random.default_rng(seed)
    for _ in range(count):
        q = report.q + 0.05 * rng.standard_normal(num.n)
        yield rng.random(), q, report.qd + 0.5 * rng.standard_normal(num.n)


def relative(x, reference):
    return np.abs(x - reference).max(initial=0.0) / max(1.0, np.abs(reference).max(initial=0.0))


#: Looser agreement where the example's own data make the KKT matrix ill-conditioned:
#: the flyball governor's shaft turns with I_zz = 5e-6 kg m^2 beside 5.3 kg arms, and
#: its K = 8e5 springs at the perturbed states give multipliers ~1e4 (measured 3e-11).
DENSE_TOL = {"flyball-governor": 1e-10}


@pytest.mark.parametrize("name", [n for n in EXAMPLES if n != "four-bar"])
def test_solve_matches_dense_reference(name):
    num, report = initial(name)
    solver = native_solver(num, np.concatenate([report.q, report.qd]))
    tol = DENSE_TOL.get(name, 1e-12)
    for t, q, qd in states(num, report):
        qdd, lam = solver.solve(t, q, qd)
        qdd_ref, lam_ref = solve_kkt(*num.kkt_blocks(t, q, qd))
        assert relative(qdd, qdd_ref) < tol and relative(lam, lam_ref) < tol


def test_masses_that_change_between_solves_are_factored_again():
    """A 1 x 1 mass that depends on the state (a particle on a cone in polar
    coordinates: M = diag(m, m r^2, m)) takes its new value at every solve, while the
    constant ones keep theirs: solves at alternating states against the dense one."""
    r, th, z = coordinates("r th z")
    system = System([r, th, z], kinetic=(r.diff() ** 2 + r**2 * th.diff() ** 2
                                         + z.diff() ** 2) / 2,
                    potential=9.81 * z, constraints=[Holonomic(z - r, name="cone")])
    num = system.numeric()
    solver = native_solver(num, np.array([1.0, 0.0, 1.0, 0.0, 1.0, 0.0]))
    assert solver.structure.unit.all()
    for radius in (1.0, 2.0, 1.0, 0.5, 0.5):
        q, qd = np.array([radius, 0.3, radius]), np.array([0.2, 1.5, 0.2])
        qdd, lam = solver.solve(0.0, q, qd)
        qdd_ref, lam_ref = solve_kkt(*num.kkt_blocks(0.0, q, qd))
        assert relative(qdd, qdd_ref) < 1e-12 and relative(lam, lam_ref) < 1e-12


def test_dependent_constraints_solve_the_kept_rows():
    """The four-bar's loop has a dependent row: the dense solve of the kept rows is the
    reference for qdd and the kept rows' multipliers; the dropped rows' are zero."""
    num, report = initial("four-bar")
    kept = report.rank.kept
    assert kept is not None and len(kept) < num.m
    solver = native_solver(num, np.concatenate([report.q, report.qd]), kept=kept)
    dropped = np.setdiff1d(np.arange(num.m), kept)
    t, q, qd = 0.3, report.q, report.qd  # on the constraints: the dropped rows follow
    qdd, lam = solver.solve(t, q, qd)
    M, f, A, c = num.kkt_blocks(t, q, qd)
    qdd_ref, mu = solve_kkt(M, f, A[kept], c[kept])
    assert relative(qdd, qdd_ref) < 1e-12 and relative(lam[kept], mu) < 1e-12
    assert np.all(lam[dropped] == 0.0)
    assert np.abs(A @ qdd - c).max() < 1e-10  # the dropped rows are met too


@pytest.mark.parametrize("name", ["heavy-top", "hanging-chain", "rolling-disk"])
def test_baumgarte_terms_match_python(name):
    num, report = initial(name)
    native = NativeSolver(num, baumgarte=7.0)
    python = first_order_rhs(num, 7.0)
    for t, q, qd in states(num, report):
        y = np.concatenate([q, qd])
        assert relative(native.rhs(t, y), python(t, y)) < 1e-12


@pytest.mark.parametrize("name", ["spherical-chain", "closed-chain", "coin", "dumbbell"])
def test_projection_matches_python(name):
    num, report = initial(name)
    native, python = NativeSolver(num), StepProjector(num)
    rng = np.random.default_rng(1)
    y0 = np.concatenate([report.q, report.qd])
    for _ in range(4):
        # Drift after a step is tolerance-sized; the C path reuses the position factor for
        # the velocities, which changes the result by drift squared.
        y = y0 + 1e-7 * rng.standard_normal(y0.size)
        projected = native.project(0.0, y)
        assert np.abs(projected - python(0.0, y)).max() < 1e-12
        q, qd = projected[: num.n], projected[num.n:]
        if num.holonomic_rows:
            assert np.abs(num.position_constraint(0.0, q)).max() < 1e-13
        A, b = num.velocity_constraint(0.0, q)
        assert np.abs(A @ qd + b).max() < 1e-12 * max(1.0, np.abs(qd).max())


@pytest.mark.parametrize("name", ["hanging-chain", "heavy-top", "rolling-disk", "whirled-string"])
def test_outputs_match_python(name):
    num, report = initial(name)
    t, q, qd = zip(*states(num, report))
    y = np.hstack([np.array(q), np.array(qd)])
    native = NativeSolver(num, baumgarte=5.0).outputs(np.array(t), y)  # never stabilized
    python = evaluate_outputs(num, np.array(t), y)
    assert native.keys() == python.keys()
    for key, value in python.items():
        assert relative(native[key], value) < 1e-12, key


@pytest.mark.parametrize("name", ["hanging-chain", "heavy-top", "rolling-disk", "whirled-string"])
def test_outputs_without_dynamics_leave_the_solve_out(name):
    """Without ``dynamics`` (an ensemble that keeps none of them) ``qdd``, the multipliers
    and the constraint forces are NaN, not stale; the residuals and energies are those
    computed beside the solve, in C and in Python."""
    num, report = initial(name)
    t, q, qd = zip(*states(num, report))
    t, y = np.array(t), np.hstack([np.array(q), np.array(qd)])
    solved = evaluate_outputs(num, t, y)
    for out in (NativeSolver(num).outputs(t, y, dynamics=False),
                evaluate_outputs(num, t, y, dynamics=False)):
        assert out.keys() == solved.keys()
        for key in ("qdd", "multipliers", "constraint_forces"):
            assert out[key].shape == solved[key].shape and np.isnan(out[key]).all(), key
        for key in ("position_residual", "velocity_residual"):
            np.testing.assert_allclose(out[key], solved[key], rtol=0, atol=1e-14, err_msg=key)
        assert relative(out["energies"], solved["energies"]) < 1e-14


@pytest.mark.parametrize("step_control", STEP_CONTROLS)
@pytest.mark.parametrize("method", ["DOP853", "RK45", "RK23"])
def test_runge_kutta_steps_are_pythons(method, step_control):
    """The C steps are the Python controlled solver's; under "scipy", SciPy's own."""
    num, report = initial("spherical-chain")
    y0 = np.concatenate([report.q, report.qd])
    native = native_solver(num, y0)
    scipy_class = getattr(si, method)
    t_eval = np.linspace(0.0, 1.0, 7)
    options = dict(rtol=1e-7, atol=1e-9, t_eval=t_eval, step_control=step_control)
    ours = integrate(native.rhs, (0.0, 1.0), y0, method=NATIVE_METHODS[scipy_class],
                     native=native, **options)
    ref = integrate(first_order_rhs(num), (0.0, 1.0), y0, method=CONTROLLED[scipy_class],
                    **options)
    assert ours.stats["n_steps"] == ref.stats["n_steps"]
    assert ours.stats["nfev"] == ref.stats["nfev"]
    assert np.abs(ours.y - ref.y).max() < 1e-9


@pytest.mark.validation
@pytest.mark.parametrize("joint", ["spherical", "revolute"])
def test_simulation_matches_python_loop(joint):
    mb = chain(6, 1.0, 1.0, 0.05, joint=joint)
    names = [b.name for b in mb.bodies]
    c, s = np.cos(0.5), np.sin(0.5)
    tilt = np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])
    q0, qd0 = mb.initial_state(
        positions={k: tilt @ [0, 0, -(i + 0.5)] for i, k in enumerate(names)},
        orientations=dict.fromkeys(names, tilt))
    runs = [mb.simulate((0, 2), q0, qd0, rtol=1e-9, atol=1e-11, backend=backend,
                        t_eval=np.linspace(0, 2, 21)) for backend in ("c", "python")]
    fast, slow = runs
    # The same method to rounding, which may move a step-size decision: compare at the
    # integration tolerance, not bit for bit.
    assert abs(fast.stats["n_steps"] - slow.stats["n_steps"]) <= 2
    assert np.abs(fast.q - slow.q).max() < 1e-9
    assert relative(fast.multipliers, slow.multipliers) < 1e-9
    assert fast.position_residual.max() < 1e-12
    energy = fast.kinetic_energy + fast.potential_energy
    assert np.ptp(energy) < 1e-7 * np.abs(energy).max()


def test_native_true_says_why_not(monkeypatch):
    from dalembert.codegen.c_backend import CompileError
    from dalembert.solvers.native import library

    def no_compiler():
        raise CompileError("no C compiler found")

    monkeypatch.setattr(library, "runtime", no_compiler)
    module = load("pendulum")
    with pytest.raises(ValueError, match="does not apply: the C runtime could not be "
                                         "compiled: no C compiler found"), \
            warnings.catch_warnings():
        warnings.simplefilter("ignore")
        module.build().simulate((0, 0.1), backend="c", **module.INITIAL)


def test_singular_constraints_raise():
    num, _ = initial("pendulum")
    solver = NativeSolver(num)
    with pytest.raises(SingularSystemError, match="singular"):
        solver.solve(0.0, np.zeros(2), np.zeros(2))  # the rod has no direction at 0


def test_wide_mass_blocks_are_not_native():
    n = BLOCK_MAX + 1
    rows, cols = np.divmod(np.arange(n * n), n)
    pattern = SparsePattern(n, 0, rows, cols, np.zeros(0, int), np.zeros(0, int))
    with pytest.raises(NotApplicable, match=f"couples {n} coordinates"):
        schur_structure(pattern)


def test_unit_block_tables():
    """Coordinate 0 has a row of its own (folded into its block): not a unit block. The
    unit blocks 1 and 2 share row 1; their products are the pattern of S they fill."""
    pattern = SparsePattern(3, 2, np.arange(3), np.arange(3), np.array([0, 1, 1]),
                            np.array([0, 1, 2]))
    s = schur_structure(pattern)
    assert s.unit.tolist() == [0, 1, 1]
    assert s.unit_slot.tolist() == [1, 2]
    assert s.unit_pair_row.tolist() == [1, 1]
    assert s.unit_pair_slot.tolist() == [1, 2]
    # one product z z per unit block, both on row 1's diagonal of S
    diagonal = s.row_pos[1] * (s.kd + 1)
    assert s.unit_gram_target.tolist() == [diagonal, diagonal]
    assert s.unit_gram_i.tolist() == s.unit_gram_j.tolist() == s.unit_pair_vec.tolist()


def chain_solves_match_dense_reference(mb) -> NativeSolver:
    """The C solve of a chain's KKT system at states off its initial one against the
    dense KKT solve; the solver, for what the caller checks of its structure."""
    num = mb.system.numeric()
    q0, _ = mb.initial_state()
    names = mb.system.coordinate_names
    q = np.array([q0[k] for k in names])
    rng = np.random.default_rng(3)
    solver = native_solver(num, np.concatenate([q, np.zeros(num.n)]))
    for _ in range(3):
        qs, qd = q + 0.05 * rng.standard_normal(num.n), rng.standard_normal(num.n)
        qdd, lam = solver.solve(0.3, qs, qd)
        qdd_ref, lam_ref = solve_kkt(*num.kkt_blocks(0.3, qs, qd))
        assert relative(qdd, qdd_ref) < 1e-12 and relative(lam, lam_ref) < 1e-12
    return solver


def test_planar_chain_solve_matches_dense_reference():
    """Planar bodies: all blocks 1 x 1 (flat loops), against the dense KKT solve."""
    solver = chain_solves_match_dense_reference(
        chain(5, 1.0, 1.0, 0.05, joint="revolute", planar=True))
    assert solver.structure.unit.all()


@pytest.mark.parametrize(("links", "joint", "kd", "rows"), [
    (1, "spherical", 2, 3),   # a width the band kernels take as a constant, one full row
    (4, "spherical", 5, 12),  # a constant width, most rows full
    (2, "revolute", 7, 8),    # a width they take as a variable, one full row
    (6, "revolute", 9, 28),   # a constant width, most rows full
])
def test_band_widths_solve_matches_dense_reference(links, joint, kd, rows):
    """The band's factorization and solves, whose rows of full width are unrolled for
    some widths, against the dense KKT solve at every kind of width and length."""
    solver = chain_solves_match_dense_reference(chain(links, 1.0, 1.0, 0.05, joint=joint))
    assert (solver.structure.kd, len(solver.structure.band_row)) == (kd, rows)


def block_with_internal_rows():
    """One 4 x 4 mass block (dense, constant) with three rows inside it (two holonomic,
    one Pfaffian, eliminated in the block) and a particle tied to it by a fourth row,
    the only one left in the band; a consistent state."""
    *b, x = coordinates("b0 b1 b2 b3 x")
    v = sp.Matrix([c.diff() for c in b])
    M = sp.Matrix([[4, 1, 0.5, 0], [1, 3, 0.2, 0.1], [0.5, 0.2, 2, 0.3], [0, 0.1, 0.3, 1.5]])
    system = System(
        [*b, x], kinetic=(v.T * M * v)[0] / 2 + x.diff() ** 2 / 2,
        potential=b[0] + b[2] * x / 2,
        constraints=[Holonomic(sum(c**2 for c in b) - 1, name="unit"),
                     Holonomic(b[1] - b[2] ** 2 - 0.1, name="cam"),
                     Pfaffian(b[0].diff() + 2 * b[3].diff() + b[1] * b[2].diff(), name="rate"),
                     Holonomic(x - b[1] - b[3], name="tie")])
    q = np.array([0.8, 0.19, 0.3, np.sqrt(1 - 0.64 - 0.19**2 - 0.09), 0.0])
    q[4] = q[1] + q[3]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        report = system.consistent_initial_state(
            q0=dict(zip(system.coordinate_names, q)),
            qd0=dict(zip(system.coordinate_names, [0.3, -0.2, 0.1, 0.4, 0.5])))
    return system.numeric(), report, system.constraint_names


def test_rows_inside_a_block_are_eliminated_there():
    """Several internal rows in one block, eliminated one after the other (a Pfaffian
    one inactive in the position projection): the same solve, multipliers of every
    row and projections as the references."""
    num, report, names = block_with_internal_rows()
    solver = NativeSolver(num)
    s = solver.structure
    tie = names.index("tie")
    assert s.band_row.tolist() == [tie] and len(s.elim_blocks) == 1
    block = s.elim_blocks[0]
    assert s.block_external[block] - s.block_pairs[block] == 3
    for t, q, qd in states(num, report):
        qdd, lam = solver.solve(t, q, qd)
        qdd_ref, lam_ref = solve_kkt(*num.kkt_blocks(t, q, qd))
        assert relative(qdd, qdd_ref) < 1e-12 and relative(lam, lam_ref) < 1e-12
    python = StepProjector(num)
    rng = np.random.default_rng(2)
    y0 = np.concatenate([report.q, report.qd])
    for _ in range(3):
        y = y0 + 1e-7 * rng.standard_normal(y0.size)
        assert np.abs(solver.project(0.0, y) - python(0.0, y)).max() < 1e-12
