"""Consistent initial values: read them, check them, project them onto the constraints."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from ..codegen.compiled import NumericModel
from ..errors import ConstraintError, InitialConditionError, SingularSystemError
from ..model.values import free_mask
from ..numerics.rank import ConstraintRank, constraint_rank, dependent_error
from .kkt import REDUNDANT_MODES, check_kkt
from .projection import StepProjector, project_positions, project_velocities
from .sparse_kkt import DENSE_MAX, gram_well_conditioned, kkt_condition, kkt_solver, matvec

#: Changes smaller than this (relative) are rounding, not worth reporting.
REPORT_TOL = 1e-10
#: Above this many KKT unknowns the O(size^3) dense diagnosis is not run (its singular
#: values took 150 ms at 832 unknowns, a 64-link hinge chain: longer than the simulation).
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

    @property
    def degrees_of_freedom(self) -> int:
        """``n - rank(A)`` at the initial state."""
        return len(self.names) if self.rank is None else self.rank.degrees_of_freedom

    @property
    def dependent_constraints(self) -> list[str]:
        """Names of the constraints that are combinations of those listed before them."""
        return [] if self.rank is None else self.rank.dependent_names

    @property
    def changed(self) -> bool:
        return bool(self.changed_positions() or self.changed_velocities())

    def changed_positions(self) -> list[str]:
        return _changed(self.names, self.q_given, self.q)

    def changed_velocities(self) -> list[str]:
        return _changed(self.names, self.qd_given, self.qd)

    def __str__(self) -> str:
        text = self.describe_changes()
        if self.rank is not None and self.rank.dependent:
            text += "\n" + str(self.rank)
        return text

    def describe_changes(self) -> str:
        if not self.changed:
            return "initial conditions satisfy the constraints; nothing changed"
        lines = ["initial conditions were projected onto the constraints:"]
        for i, name in enumerate(self.names):
            for label, given, new in (("", self.q_given, self.q), ("_dot", self.qd_given, self.qd)):
                if name in _changed(self.names[i : i + 1], given[i : i + 1], new[i : i + 1]):
                    lines.append(f"  {name}{label}: {given[i]:.10g} -> {new[i]:.10g}")
        return "\n".join(lines)


def _changed(names: Sequence[str], given: np.ndarray, new: np.ndarray) -> list[str]:
    scale = max(1.0, float(np.abs(given).max(initial=0.0)))
    return [n for n, a, b in zip(names, given, new) if abs(a - b) > REPORT_TOL * scale]


def consistent_state(
    num: NumericModel,
    t0: float,
    q0: np.ndarray,
    qd0: np.ndarray,
    names: Sequence[str],
    constraint_labels: Sequence[str],
    fixed: Sequence[object] | None = None,
    constraint_names: Sequence[str] | None = None,
    redundant_constraints: str = "minimum-norm",
) -> InitializationReport:
    """Project ``(q0, qd0)`` onto the constraints and check the KKT matrix there.

    The rank of ``A`` is measured at the projected positions. Dependent constraints
    raise a :class:`ConstraintError` naming them with ``redundant_constraints="error"``;
    with ``"minimum-norm"`` they are recorded in the report (``report.rank``).
    Constraints that leave no degree of freedom always raise.
    """
    if redundant_constraints not in REDUNDANT_MODES:
        raise ValueError(f"redundant_constraints must be one of {REDUNDANT_MODES}, "
                         f"not {redundant_constraints!r}")
    free = free_mask(fixed, names)
    # Large models with every coordinate free are projected with the sparse solver.
    sparse = StepProjector(num) if num.m > DENSE_MAX and free.all() else None
    rank = None
    try:
        q = _project_positions(num, t0, q0, free, sparse)
        if num.m:
            rank = _rank_at(num, t0, q, names, constraint_labels, constraint_names,
                            redundant_constraints)
        if rank is not None and rank.dependent:
            sparse = None  # the sparse velocity projection needs independent rows
        qd = _project_velocities(num, t0, q, qd0, free, sparse)
    except np.linalg.LinAlgError as exc:
        raise InitialConditionError(f"could not project the initial state: {exc}") from exc
    except InitialConditionError as exc:
        held = [n for n, f in zip(names, free) if not f]
        hint = f" with {', '.join(held)} held fixed" if held else ""
        raise InitialConditionError(
            f"the initial conditions cannot be made consistent{hint}: {exc}. "
            "Start closer to a configuration that satisfies the constraints"
            + ("; or fix fewer coordinates" if held else "")
        ) from exc
    _check_consistent(num, t0, q, qd, free, names)
    _check_kkt_at(num, t0, q, qd, None if rank is None else rank.kept, names)
    return InitializationReport(tuple(names), q0, qd0, q, qd, rank)


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
            raise SingularSystemError(
                f"the KKT matrix [[M, A^T], [A, 0]] is singular at the initial state "
                f"(condition number estimate {cond:.1e}): the motion is not determined. "
                "Check the kinetic energy (a direction without inertia the constraints "
                "leave free) or add the missing constraint."
            )
    M, A = num.pattern.dense_M(Mv), num.pattern.dense_A(Av)
    check_kkt(M, A if kept is None else A[kept], names, "at the initial state")


def _rank_at(
    num: NumericModel, t0: float, q: np.ndarray, names: Sequence[str],
    labels: Sequence[str], constraint_names: Sequence[str] | None, mode: str,
) -> ConstraintRank:
    """Measure the rank of ``A`` once; refuse no freedom, and dependence if asked to."""
    Av, _ = num.velocity_sparse(t0, q)
    pat = num.pattern
    label = labels if constraint_names is None else constraint_names
    if num.m > DENSE_MAX and num.m < num.n and gram_well_conditioned(
            pat.A_rows, pat.A_cols, Av, (num.m, num.n)):
        rank = ConstraintRank(num.n, num.m, (), tuple(label))  # independent: no SVD needed
    else:
        A = pat.dense_A(Av)
        rank = constraint_rank(A, label)
    if rank.degrees_of_freedom == 0:
        raise ConstraintError(
            f"the constraints leave no degree of freedom at the initial state: rank(A) = "
            f"{rank.rank} independent constraints ({num.m} given) on {num.n} coordinates "
            f"({', '.join(names)}); remove constraints or add coordinates"
        )
    if rank.dependent and mode == "error":
        raise dependent_error([labels[i] for i in rank.dependent], "at the initial state")
    return rank


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

