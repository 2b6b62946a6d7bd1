"""Consistent initial values: read them, check them, project them onto the constraints."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from functools import cached_property

import numpy as np

from ..codegen.compiled import NumericModel
from ..errors import ConstraintError, InitialConditionError, SingularSystemError
from ..model.values import free_mask
from ..numerics.conditioning import GRAM_DENSE_MAX, spd_condition
from ..numerics.rank import (
    SCREEN_FROM,
    ConstraintRank,
    constraint_rank,
    dependent_error,
    sparse_constraint_rank,
)
from ..numerics.singular import DENSE_ROWS, NEAR
from ..options import RedundantConstraints, VelocityProjection
from .initial_checks import check_finite, check_kinetic_energy, check_resolvable
from .kkt.dense import SINGULAR_COND, check_kkt, solve_kkt
from .kkt.sparse import DENSE_MAX, kkt_condition, kkt_solver, matvec
from .projection import StepProjector, project_positions, project_velocities

#: Changes smaller than this (relative) are rounding, not worth reporting.
REPORT_TOL = 1e-10
#: Above this many KKT unknowns the O(size^3) dense diagnosis is not run (for a
#: 64-link hinge chain its singular values cost more than the simulation).
DENSE_CHECK_MAX = 500
#: Estimated 1-norm condition number beyond which a large KKT matrix counts as singular.
KKT_COND_LIMIT = 1e13


@dataclass(frozen=True)
class InitializationReport:
    """What consistent initialization changed: per-coordinate position and velocity changes.

    ``rank`` describes the constraints at the consistent state: the true degrees of
    freedom ``n - rank(A)`` and the dependent (redundant) constraints, if any.
    """

    names: tuple[str, ...]
    q_given: np.ndarray
    qd_given: np.ndarray
    q: np.ndarray
    qd: np.ndarray
    rank: ConstraintRank | None = field(default=None, compare=False)
    #: How the velocities were made consistent (the ``velocity_projection`` option).
    velocity_projection: VelocityProjection = "kinetic-energy"
    #: ``M (qd - qd_given)``: with the kinetic-energy projection, the generalized
    #: impulse ``A^T mu`` of the plastic impact onto the constraints (``None`` if the
    #: velocities were not changed that way).
    impulse: np.ndarray | None = field(default=None, compare=False)
    #: The energy of the velocity change, ``(qd - qd_given)^T M (qd - qd_given) / 2``,
    #: for the kinetic-energy projection: what a plastic impact dissipates, which is
    #: ``T(qd_given) - T(qd)`` where the constraints do not move (a driver's may add
    #: energy: see :attr:`kinetic_energy_change`).
    kinetic_energy_lost: float = 0.0

    @property
    def degrees_of_freedom(self) -> int:
        """``n - rank(A)`` at the initial state."""
        return len(self.names) if self.rank is None else self.rank.degrees_of_freedom

    @property
    def dependent_constraints(self) -> list[str]:
        """Names of the constraints that are combinations of those listed before them."""
        return [] if self.rank is None else self.rank.dependent_names

    @property
    def kinetic_energy_change(self) -> float:
        """``T(qd) - T(qd_given)`` with the kinetic-energy projection (0 without its
        impulse): negative where an impact dissipates energy, positive where a driver
        or another moving constraint sets the mechanism in motion.

        With the impulse ``p = M (qd - qd_given)`` (``M`` symmetric) it is
        ``p . (qd + qd_given) / 2``.

        Examples
        --------
        A unit mass at rest whose constraint ``x = 2 t`` moves it at 2: it gains 2.

        >>> import numpy as np
        >>> report = InitializationReport(("x",), np.zeros(1), np.zeros(1), np.zeros(1),
        ...                               np.array([2.0]), impulse=np.array([2.0]))
        >>> report.kinetic_energy_change
        2.0
        """
        if self.impulse is None:
            return 0.0
        return 0.5 * float(self.impulse @ (self.qd + self.qd_given))

    @property
    def changed(self) -> bool:
        return bool(self.changed_positions() or self.changed_velocities())

    def changed_positions(self) -> list[str]:
        return list(self._changed_positions)

    def changed_velocities(self) -> list[str]:
        return list(self._changed_velocities)

    # measured once: a run asks for them to warn and again to describe the report
    @cached_property
    def _changed_positions(self) -> tuple[str, ...]:
        return tuple(_changed(self.names, self.q_given, self.q))

    @cached_property
    def _changed_velocities(self) -> tuple[str, ...]:
        return tuple(_changed(self.names, self.qd_given, self.qd))

    def __str__(self) -> str:
        text = self.describe_changes()
        if self.rank is not None and (self.rank.dependent or self.rank.near):
            text += "\n" + str(self.rank)
        return text

    def describe_changes(self) -> str:
        if not self.changed:
            return "initial conditions satisfy the constraints; nothing changed"
        lines = ["initial conditions were projected onto the constraints:"]
        pairs = (("", self.q_given, self.q), ("_dot", self.qd_given, self.qd))
        # each coordinate against its own size here (the report as a whole: the largest)
        moved = [np.abs(new - given) > REPORT_TOL * np.maximum(1.0, np.abs(given))
                 for _, given, new in pairs]
        for i, name in enumerate(self.names):
            for (label, given, new), listed in zip(pairs, moved):
                if listed[i]:
                    lines.append(f"  {name}{label}: {given[i]:.10g} -> {new[i]:.10g}")
        if self.changed_velocities():
            lines.append(self._velocity_note())
        return "\n".join(lines)

    def _velocity_note(self) -> str:
        if self.velocity_projection == "least-change" or self.impulse is None:
            return ("velocities: the nearest consistent ones (least change, "
                    "velocity_projection='least-change')")
        change = self.kinetic_energy_change
        moved = [f"{n}: {v:.6g}" for n, v in zip(self.names, self.impulse)
                 if abs(v) > REPORT_TOL * max(1.0, float(np.abs(self.impulse).max()))]
        return ("velocities: those after a perfectly plastic impact onto the constraints "
                "(the projection in the kinetic-energy metric, independent of units; "
                "velocity_projection='least-change' gives the nearest ones instead); "
                f"generalized impulse M (qd - qd0) = A^T mu: {', '.join(moved)}; "
                f"kinetic energy {'gained' if change > 0 else 'lost'} {abs(change):.6g}")


def _changed(names: Sequence[str], given: np.ndarray, new: np.ndarray) -> list[str]:
    scale = max(1.0, float(np.abs(given).max(initial=0.0)))
    return [names[int(i)] for i in np.flatnonzero(np.abs(given - new) > REPORT_TOL * scale)]


def consistent_state(
    num: NumericModel,
    t0: float,
    q0: np.ndarray,
    qd0: np.ndarray,
    names: Sequence[str],
    constraint_labels: Sequence[str],
    fixed: Sequence[object] | None = None,
    constraint_names: Sequence[str] | None = None,
    redundant_constraints: RedundantConstraints = "minimum-norm",
    velocity_projection: VelocityProjection = "kinetic-energy",
    driven: bool = False,
    kinetic_energy: bool = True,
) -> InitializationReport:
    """Project ``(q0, qd0)`` onto the constraints and check the KKT matrix there.

    Positions move the least (Gauss-Newton, minimum-norm steps). Velocities, with
    ``velocity_projection="kinetic-energy"``, become those after a perfectly
    plastic impact onto the constraints: ``M (qd - qd0) = A^T mu``, ``A qd + b =
    0``, the projection in the kinetic-energy metric, which does not depend on the
    units or the scaling of the coordinates (a sphere set sliding on a table starts
    rolling at 5/7 of its speed whatever its radius); ``"least-change"`` gives the
    Euclidean nearest ones instead. The rank of ``A`` is measured at the projected
    positions. Dependent constraints raise a :class:`ConstraintError` naming them
    with ``redundant_constraints="error"``; with ``"minimum-norm"`` they are
    recorded in the report (``report.rank``). Constraints that leave no degree of
    freedom raise, unless they are ``driven`` (some depend on time: a prescribed
    motion, whose multipliers are the driving forces). The checks of
    :mod:`.initial_checks` run too: finite model values (where the projections use
    them, and at the end), constraints the projection can resolve, and, with
    ``kinetic_energy`` (``M`` comes from a kinetic energy, not from a Lagrangian that
    may be indefinite), ``T >= 0``.
    """
    free = free_mask(fixed, names)
    row_names = constraint_labels if constraint_names is None else constraint_names
    check_finite(num, t0, q0, None, names, row_names, "at the initial positions given")
    # Large models with every coordinate free are projected with the sparse solver.
    sparse = StepProjector(num) if num.m > DENSE_MAX and free.all() else None
    rank = None
    try:
        q = _project_positions(num, t0, q0, free, sparse)
    except (np.linalg.LinAlgError, InitialConditionError) as exc:
        raise _not_consistent(exc, names, free) from exc
    check_finite(num, t0, q, qd0, names, row_names, "at the initial state")
    try:
        if num.m:
            rank = _rank_at(num, t0, q, names, constraint_labels, constraint_names,
                            redundant_constraints, driven)
        kept = None if rank is None else rank.kept
        check_resolvable(num, t0, q, constraint_labels)
        if kinetic_energy:
            check_kinetic_energy(num, t0, q, qd0, names, kept)
        _check_kkt_at(num, t0, q, qd0, kept, names)  # before the impact's KKT solve
        impulse, lost = None, 0.0
        if velocity_projection == "kinetic-energy":
            qd, impulse, lost = plastic_impact(num, t0, q, qd0, free, kept)
        else:
            if kept is not None:
                sparse = None  # the sparse velocity projection needs independent rows
            qd = _project_velocities(num, t0, q, qd0, free, sparse)
    except (np.linalg.LinAlgError, InitialConditionError) as exc:
        raise _not_consistent(exc, names, free) from exc
    _check_consistent(num, t0, q, qd, free, names)
    check_finite(num, t0, q, qd, names, row_names, "at the consistent initial state")
    return InitializationReport(tuple(names), q0, qd0, q, qd, rank, velocity_projection,
                                impulse, lost)


def _not_consistent(exc: Exception, names: Sequence[str], free: np.ndarray) -> Exception:
    """The error of a projection that failed: what was held fixed, what to do."""
    if isinstance(exc, np.linalg.LinAlgError):
        return InitialConditionError(f"could not project the initial state: {exc}")
    held = [n for n, f in zip(names, free) if not f]
    hint = f" with {', '.join(held)} held fixed" if held else ""
    return InitialConditionError(
        f"the initial conditions cannot be made consistent{hint}: {exc}. "
        "Start closer to a configuration that satisfies the constraints"
        + ("; or fix fewer coordinates" if held else "")
    )


def plastic_impact(
    num: NumericModel, t: float, q: np.ndarray, qd0: np.ndarray,
    free: np.ndarray | None = None, kept: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray, float]:
    """Velocities after a perfectly plastic impact of ``qd0`` onto ``A qd + b = 0``.

    The impact's impulse ``A^T mu`` acts along the constraint normals only:
    ``M (qd - qd0) = A^T mu`` with ``A qd + b = 0``, the KKT system

        [ M  A^T ] [ qd  ]   [ M qd0 ]
        [ A   0  ] [ -mu ] = [  -b   ]

    which is the projection of ``qd0`` in the kinetic-energy metric (it minimizes
    ``(qd - qd0)^T M (qd - qd0)``) and stays regular where ``M`` alone is singular
    (a quaternion's inertia block). Coordinates not ``free`` keep their velocity
    (rows ``qd_i = qd0_i`` added to ``A``).

    Parameters
    ----------
    num
        The bound numeric model.
    t, q
        The time and the (consistent) positions.
    qd0
        The velocities given.
    free
        Which coordinates may change (default all).
    kept
        The independent rows of ``A`` when some are dependent.

    Returns
    -------
    qd, impulse, lost
        The velocities, the generalized impulse ``M (qd - qd0)`` and the kinetic
        energy the impact removed, ``(qd0 - qd)^T M (qd0 - qd) / 2``.

    Examples
    --------
    A particle on the line ``x = y`` moving along ``x`` keeps the part of its momentum
    along the line (half its speed in each coordinate), whatever its mass:

    >>> import sympy as sp
    >>> from dalembert import System, Holonomic, coordinates
    >>> x, y = coordinates("x y")
    >>> m = sp.Symbol("m")
    >>> line = System([x, y], kinetic=m / 2 * (x.diff()**2 + y.diff()**2),
    ...               constraints=[Holonomic(x - y)], parameters={m: 3.0})
    >>> qd, impulse, lost = plastic_impact(line.numeric(), 0.0, np.zeros(2),
    ...                                    np.array([1.0, 0.0]))
    >>> qd, impulse, lost
    (array([0.5, 0.5]), array([-1.5,  1.5]), 0.75)
    """
    n, pat = num.n, num.pattern
    qd0 = np.asarray(qd0, dtype=float)
    if num.m == 0:
        return qd0.copy(), np.zeros(n), 0.0
    Mv, _, Av, _ = num.kkt_sparse(t, q, qd0)
    _, b = num.velocity_sparse(t, q)
    momentum = matvec(pat.M_rows, pat.M_cols, Mv, qd0, n)
    if free is None or free.all():
        qd, _ = kkt_solver(pat, kept).solve(Mv, momentum, Av, -b)
    else:
        held = np.flatnonzero(~free)
        A = pat.dense_A(Av)
        rows = np.arange(num.m) if kept is None else kept
        A_held = np.vstack([A[rows], np.eye(n)[held]])
        c_held = np.concatenate([-b[rows], qd0[held]])
        rank = constraint_rank(A_held, [str(i) for i in range(len(A_held))], n)
        qd, _ = solve_kkt(pat.dense_M(Mv), momentum, A_held, c_held, rank.kept)
        qd[held] = qd0[held]  # held exactly, not to the solve's rounding
    change = qd - qd0
    impulse = matvec(pat.M_rows, pat.M_cols, Mv, change, n)
    return qd, impulse, 0.5 * float(change @ impulse)


def _project_positions(num: NumericModel, t0: float, q0: np.ndarray, free: np.ndarray,
                       sparse: StepProjector | None) -> np.ndarray:
    if sparse is not None:
        try:
            return sparse.positions(t0, q0, refactor=True)
        except (SingularSystemError, np.linalg.LinAlgError, InitialConditionError):
            pass  # dependent constraints, or too far: the dense least squares decide
    return project_positions(num, t0, q0, free)


def _project_velocities(num: NumericModel, t0: float, q: np.ndarray, qd0: np.ndarray,
                        free: np.ndarray, sparse: StepProjector | None) -> np.ndarray:
    if sparse is not None:
        try:
            return sparse.velocities(t0, q, qd0)
        except (SingularSystemError, np.linalg.LinAlgError):
            pass
    return project_velocities(num, t0, q, qd0, free)


def _check_kkt_at(num: NumericModel, t0: float, q: np.ndarray, qd: np.ndarray,
                  kept: np.ndarray | None, names: Sequence[str]) -> None:
    """Refuse a singular KKT matrix; the dense SVD diagnosis only where it is affordable.

    The sparse screen estimates the condition number from the factorization. Below
    ``1e10 / size`` the matrix is surely regular. Up to ``DENSE_CHECK_MAX`` unknowns
    the exact SVD decides otherwise (and names the coordinates). Larger mechanisms
    can be regular yet worse conditioned than that (a 1024-link hinge chain of thin
    cylinders: about 1e12), so there the estimate itself decides, against
    ``KKT_COND_LIMIT``.
    """
    Mv, _, Av, _ = num.kkt_sparse(t0, q, qd)
    solver = kkt_solver(num.pattern, kept)
    if not solver.dense:
        cond = kkt_condition(solver, Mv, Av)
        if cond < 1e10 / solver.size:
            return
        if solver.size > DENSE_CHECK_MAX:
            if cond < KKT_COND_LIMIT:
                return
            if cond >= SINGULAR_COND:
                raise SingularSystemError(
                    f"the KKT matrix [[M, A^T], [A, 0]] is singular at the initial state "
                    f"(condition number estimate {cond:.1e}): the motion is not determined. "
                    "Check the kinetic energy (a direction without inertia the constraints "
                    "leave free) or add the missing constraint."
                )
            raise SingularSystemError(
                f"the KKT matrix [[M, A^T], [A, 0]] is ill-conditioned at the initial state "
                f"(condition number estimate {cond:.1e}, above the {KKT_COND_LIMIT:.0e} "
                "trusted for large mechanisms): a direction with almost no inertia (the spin "
                "of a thin rod about its own axis, a very light body among heavy ones) or "
                "nearly dependent constraints. Give that direction more inertia (a thin rod: "
                "a larger radius), model the rod without that rotation (two particles and a "
                "Distance joint), or start away from a singular configuration."
            )
    M, A = num.pattern.dense_M(Mv), num.pattern.dense_A(Av)
    check_kkt(M, A if kept is None else A[kept], names, "at the initial state")


def _rank_at(
    num: NumericModel, t0: float, q: np.ndarray, names: Sequence[str],
    labels: Sequence[str], constraint_names: Sequence[str] | None, mode: str,
    driven: bool = False,
) -> ConstraintRank:
    """Measure the rank of ``A`` once; refuse no freedom (unless the constraints are
    driven: the motion is then prescribed), and dependence if asked to."""
    Av, _ = num.velocity_sparse(t0, q)
    pat = num.pattern
    label = labels if constraint_names is None else constraint_names
    rank = _well_conditioned(num, Av, label)
    if rank is None:
        rank = _singular_start(num, t0, q, Av, sparse_constraint_rank(
            pat.A_rows, pat.A_cols, Av, (num.m, num.n), label))
    if rank.degrees_of_freedom == 0 and not driven:
        raise ConstraintError(
            f"the constraints leave no degree of freedom at the initial state: rank(A) = "
            f"{rank.rank} independent constraints ({num.m} given) on {num.n} coordinates "
            f"({', '.join(names)}); remove constraints or add coordinates (a motion "
            "prescribed by constraints that depend on time is fine)"
        )
    if rank.dependent and mode == "error":
        raise dependent_error([labels[i] for i in rank.dependent], "at the initial state")
    return rank


def _well_conditioned(num: NumericModel, Av: np.ndarray,
                      names: Sequence[str]) -> ConstraintRank | None:
    """Full rank and no singular value of ``A`` under ``NEAR`` of the largest, from one
    condition estimate of ``A A^T`` below ``NEAR^-2``; ``None`` if it is not, or where
    the rank test would not screen with ``A A^T`` (few rows, or no fewer rows than
    coordinates): then :func:`~dalembert.numerics.rank.sparse_constraint_rank` and
    :func:`_singular_start` measure. Their screens estimate the same condition number
    (the rank's against a looser bound), which this computes once."""
    m, n = num.m, num.n
    if not (SCREEN_FROM < m < n and m <= min(GRAM_DENSE_MAX, DENSE_ROWS)):
        return None
    A = num.pattern.dense_A(Av)
    if spd_condition(A @ A.T) < NEAR**-2:
        return ConstraintRank(n, m, (), tuple(names))
    return None


def _singular_start(num: NumericModel, t0: float, q: np.ndarray, Av: np.ndarray,
                    rank: ConstraintRank) -> ConstraintRank:
    """``rank`` with what makes its count of degrees of freedom uncertain: singular
    values below ``NEAR`` (a well-conditioned ``A A^T`` proves there are none, without
    an SVD), and for dependent rows the rank at a nearby state along the motion (a step
    of 1e-6 along the null space of ``A``: higher there at a singular configuration,
    the same for redundant joints, whose change is second order, ~1e-12)."""
    pat = num.pattern
    if num.m == 0 or (not rank.dependent and num.m > DENSE_ROWS):
        return rank
    A = pat.dense_A(Av)
    # no singular value of A under NEAR of the largest when cond(A A^T) < NEAR^-2
    # (its LAPACK estimate, a Cholesky: an SVD only where one may be)
    if not rank.dependent and spd_condition(A @ A.T) < NEAR**-2:
        return rank
    kept = A if rank.kept is None else A[rank.kept]
    _, s, vt = np.linalg.svd(A)
    near = int(np.count_nonzero(np.linalg.svd(kept, compute_uv=False) < NEAR * s[0]))
    nearby = None
    if rank.dependent:
        null = vt[rank.rank:]
        direction = np.random.default_rng(0).standard_normal(len(null)) @ null
        step = 1e-6 * max(1.0, float(np.abs(q).max(initial=0.0)))
        A_near = pat.dense_A(num.velocity_sparse(t0, q + step * direction)[0])
        found = constraint_rank(A_near, rank.names, num.n).rank
        nearby = found if found > rank.rank else None
    return replace(rank, near=near, rank_nearby=nearby)


def _check_consistent(
    num: NumericModel, t0: float, q: np.ndarray, qd: np.ndarray, free: np.ndarray,
    names: Sequence[str],
) -> None:
    """The velocity projection is exact only if the free coordinates can reach it."""
    if num.m == 0:
        return
    Av, b = num.velocity_sparse(t0, q)
    pat = num.pattern
    residual = np.abs(matvec(pat.A_rows, pat.A_cols, Av, qd, num.m) + b).max()
    if residual > 1e-10 * max(1.0, np.abs(qd).max()):
        held = [n for n, f in zip(names, free) if not f]
        raise InitialConditionError(
            f"the initial velocities cannot satisfy the constraints (residual {residual:.2e})"
            + (f" with {', '.join(held)} held fixed; fix fewer coordinates" if held else "")
        )

