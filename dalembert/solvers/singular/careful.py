"""Through a singular configuration: the combinations of rows losing rank left out.

Near a singular configuration (:mod:`dalembert.numerics.singular`) the kept rows of
``A`` are nearly dependent, and the KKT solve enforces them with multipliers that
grow like ``1 / sigma_min``: the accelerations carry rounding errors amplified as
much, the step size collapses, and the motion may leave its branch. While
*careful*, the combinations of rows (scaled to unit length) whose singular values are
below ``TRUNCATE`` of the largest, with the cluster they fall in (:func:`cluster`),
are left out of the KKT solve and of the projections: the rank-revealing,
minimum-norm treatment of dependent rows, for a moment (:mod:`~dalembert.solvers.kkt.truncated`).
They are enforced again as soon as they are independent enough, the state projected
onto them at once (velocities in the kinetic-energy metric, so that their return
changes the energy to second order only).
The combinations are fixed over a step (found at its start), so that its right-hand
side is smooth.

The step after one that ends near a singular configuration (the Gram matrix of the
rows scaled to unit length worse conditioned than ``NEAR**-2``) is careful:
:class:`CarefulModel` measures it after every step, in band form
(:mod:`dalembert.numerics.gram`: a band Cholesky factorization screens, the band
eigensolver decides only when a pivot is small), in time linear in the mechanism.
The C loop ends a stretch of steps on the same screen, from its own factorization,
and takes the careful steps the Python way (:class:`CarefulSteps`), handing back to C
once the state is clear of the singular configuration.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Protocol

import numpy as np
from scipy.integrate import OdeSolver

from ...codegen.compiled import NumericModel, SparsePattern
from ...errors import SingularSystemError
from ...numerics.gram import UnitGram
from ...numerics.singular import GAP, JUMP, NEAR, SCREEN, TRUNCATE, named
from ..kkt.sparse import matvec
from ..kkt.truncated import TruncatedKKT
from ..pattern_cache import PatternCache


class Outputs(Protocol):
    """``outputs(t, y)``: the derived arrays at the states ``y`` (rows) at times ``t``;
    with ``dynamics=False`` the KKT system is not solved (``qdd``, the multipliers and
    the constraint forces are NaN), for runs that keep none of them."""

    def __call__(self, t: np.ndarray, y: np.ndarray,
                 dynamics: bool = True) -> dict[str, np.ndarray]: ...


#: Passages a warning lists by their times, at most.
SHOWN = 4
#: Newton iterations of a careful position projection, at most.
NEWTON = 8
#: A careful position projection is done when the enforced combinations of ``psi``
#: (rows scaled to unit length) are below this, relative to ``max(1, |q|)``.
POSITION_RTOL = 1e-14


class RetakeStep(Exception):
    """A step the loop must take again, shorter: its projection moved its end much
    further than its own error (a jump onto another branch of the constraints), or it
    left combinations of rows out beyond the singular configuration's reach.

    Internal control flow, never seen by a user: raised by the careful projection and
    caught by the loops (:mod:`~dalembert.solvers.running.loop`), which retake the step
    a quarter as long, and stop the run with a warning when it keeps jumping."""


@dataclass(frozen=True)
class Truncation:
    """The combinations of rows a careful step leaves out, fixed over the step."""

    #: ``1 / |row|`` at the step's start, by row of the solve.
    scale: np.ndarray
    #: The near dependencies of the scaled rows (columns, orthonormal).
    V: np.ndarray
    #: The largest eigenvalue of the scaled rows' Gram matrix.
    largest: float


@dataclass(frozen=True)
class Measurement:
    """How near a singular configuration the rows of ``A`` are."""

    #: Their Gram matrix (rows of unit length) is worse conditioned than ``NEAR**-2``.
    near: bool
    #: The smallest singular value of the scaled rows over the largest (``nan`` where
    #: the screen found them clear of a rank drop: not measured).
    ratio: float
    #: What a careful step from here leaves out (``None`` unless ``near``).
    truncation: Truncation | None
    #: The rows (of the solve) with a large part in the nearest dependency (when near).
    rows: tuple[int, ...] = ()


def measure(gram: UnitGram, Av: np.ndarray) -> Measurement:
    """Whether rows ``Av`` are near a singular configuration (their Gram matrix, rows of
    unit length, worse conditioned than ``NEAR**-2``), and then the truncation: the
    eigenvectors of the eigenvalues below ``TRUNCATE**2`` of the largest, with the
    cluster they belong to (:func:`cluster`).

    >>> gram = UnitGram(np.array([0, 1, 1]), np.array([0, 0, 1]), 2)
    >>> measure(gram, np.array([1.0, 1.0, 1.0])).near
    False
    >>> found = measure(gram, np.array([1.0, 1.0, 1e-6]))
    >>> found.near, f"{found.ratio:.1e}", found.truncation.V.shape, found.rows
    (True, '5.0e-07', (2, 1), (0, 1))
    """
    values = gram.values(Av)
    if gram.pivot_ratio(values) >= SCREEN:
        return Measurement(False, np.nan, None)
    w = gram.eigenvalues(values)
    largest = float(w[-1]) if len(w) else 0.0
    ratio = float(np.sqrt(w[0] / largest)) if largest > 0 else 0.0
    if not len(w) or w[0] >= NEAR**2 * largest:
        return Measurement(False, ratio, None)
    k = cluster(w)
    V = gram.near_null(values, max(k, 1))  # the nearest dependency names the rows
    weight = np.abs(V[:, 0])
    rows = np.flatnonzero(weight > 0.1 * weight.max())
    rows = rows[np.argsort(-weight[rows], kind="stable")]
    return Measurement(True, ratio, Truncation(values.scale, V[:, :k], largest),
                       tuple(int(r) for r in rows))


def nothing_left_out(gram: UnitGram, Av: np.ndarray) -> Truncation:
    """The truncation that leaves nothing out (its ``largest``, 1, is the Gram matrix's
    diagonal: a lower bound of its largest eigenvalue, enough to set a shift)."""
    return Truncation(gram.scale(Av), np.zeros((gram.size, 0)), 1.0)


def cluster(w: np.ndarray) -> int:
    """How many eigenvalues ``w`` (ascending) a careful step leaves out: those under
    ``TRUNCATE**2`` of the largest, and every one above them that is within
    ``GAP**2`` of the one before and under ``NEAR**2`` of the largest (still near the
    singular configuration: a careful step must end with what it left out nearly
    dependent, :meth:`CarefulModel.project`).

    Near a singular configuration several singular values often fall together (N
    four-bars lying flat at once); left out together, the set changes twice per
    passage, not once per singular value (each change costs the step-size controller
    a restart).

    >>> cluster(np.array([1e-12, 4e-12, 1e-10, 1.0]))  # 1e-6, 2e-6, 1e-5: one cluster
    3
    >>> cluster(np.array([1e-12, 1e-9, 1.0]))           # 1e-6 and 3e-5: 30x apart
    1
    """
    largest = w[-1]
    k = int(np.count_nonzero(w < TRUNCATE**2 * largest))
    while 0 < k < len(w) and w[k] < GAP**2 * w[k - 1] and w[k] < NEAR**2 * largest:
        k += 1
    return k


@dataclass
class Passage:
    """A stretch of a run near a singular configuration (careful steps)."""

    start: float
    end: float
    #: The smallest singular value of the kept rows (unit length) over the largest.
    ratio: float
    #: The most combinations of rows left out at once.
    left_out: int
    #: The rows (of the solve) with a large part in the nearest dependency, where it
    #: was nearest.
    rows: tuple[int, ...]

    def note(self, t: float, found: Measurement) -> None:
        self.end = t
        if found.ratio < self.ratio:
            self.ratio, self.rows = found.ratio, found.rows
        if found.truncation is not None:
            self.left_out = max(self.left_out, found.truncation.V.shape[1])


def _singular_values(solver: TruncatedKKT, Av: np.ndarray, scale: np.ndarray,
                     V: np.ndarray) -> np.ndarray:
    """``|A^T v|`` for each combination ``v`` (a column of ``V``) of the rows of the
    solve, scaled by ``scale``: near ``v``'s singular value where ``v`` is nearly a
    singular vector."""
    return np.linalg.norm(solver.transposed_product(Av, scale, V), axis=0)


def _truncated(p: SparsePattern, rows: np.ndarray | None) -> TruncatedKKT:
    assert rows is not None  # always asked for with its rows
    return TruncatedKKT(p, rows)


def _truncated_unit(p: SparsePattern, rows: np.ndarray | None) -> TruncatedKKT:
    assert rows is not None
    return TruncatedKKT(p, rows, unit_mass=True)


#: The unit-mass Gram matrices of each pattern's sets of rows (index maps only).
_GRAMS: PatternCache[UnitGram] = PatternCache(
    lambda p, rows: UnitGram(p.A_rows, p.A_cols, p.m, rows), "unit Gram matrices")
#: The truncated KKT solves of each pattern's sets of rows, with the mass matrix...
_TRUNCATED: PatternCache[TruncatedKKT] = PatternCache(_truncated, "truncated KKT solves")
#: ... and with a unit mass matrix (the position projection).
_TRUNCATED_UNIT: PatternCache[TruncatedKKT] = PatternCache(_truncated_unit,
                                                           "truncated projections")


class CarefulModel:
    """The careful right-hand side and projection of a model, and the switch between
    them and the ordinary ones (see the module docstring).

    Parameters
    ----------
    num
        The compiled equations bound to parameter values.
    kept
        The independent rows at the start (``None``: all).
    rhs, project
        The ordinary right-hand side and projection.
    t_span
        The run's time span (the direction of its steps).
    names
        Every constraint row's name (default ``row 0``, ``row 1``...), for messages.
    tolerance
        ``(rtol, atol)`` of the steps: a projection at a step's end that moves the
        state by more than :data:`~dalembert.numerics.singular.JUMP` times it (a
        jump to another branch of the constraints) raises :class:`RetakeStep`
        for the loop to take the step again, shorter (``None``: not checked).
    """

    def __init__(self, num: NumericModel, kept: np.ndarray | None,
                 rhs: Callable[[float, np.ndarray], np.ndarray],
                 project: Callable[[float, np.ndarray], np.ndarray],
                 t_span: tuple[float, float] = (0.0, 1.0),
                 names: list[str] | tuple[str, ...] | None = None,
                 tolerance: tuple[float | np.ndarray, float | np.ndarray] | None = None) -> None:
        self.num, self._rhs, self._project = num, rhs, project
        self.tolerance = tolerance
        self.names = list(names) if names is not None else [f"row {k}" for k in range(num.m)]
        self.direction = 1.0 if t_span[1] >= t_span[0] else -1.0
        self._reached = t_span[0]
        pattern = num.pattern
        self.rows = np.arange(num.m) if kept is None else np.asarray(kept, dtype=np.intp)
        self.careful = False
        #: The combinations left out by the careful steps from here (``None``: none).
        self.truncation: Truncation | None = None
        #: The run's passages near singular configurations, in time order.
        self.passages: list[Passage] = []
        #: The last step's end was careful or switched: the right-hand side there is not
        #: the one its last stage saw (a loop evaluates it afresh to go on).
        self.rhs_changed = False
        self._last_step: tuple[bool, Truncation | None] = (False, None)
        place = {int(r): k for k, r in enumerate(num.holonomic_rows)}  # row -> entry of psi
        holonomic = np.array([int(r) in place for r in self.rows], dtype=bool)
        self._psi_at = np.array([place[int(r)] for r in self.rows[holonomic]], dtype=int)
        self._all_holonomic = bool(holonomic.all())
        hol_rows = self.rows[holonomic]
        self._gram = _GRAMS.get(pattern, self.rows)
        self._hol_gram = self._gram if self._all_holonomic else _GRAMS.get(pattern, hol_rows)
        self._dynamics = _TRUNCATED.get(pattern, self.rows)
        self._positions = _TRUNCATED_UNIT.get(pattern, hol_rows)

    def warning(self) -> str:
        """What the run's passages near singular configurations call for saying (``""``
        if there were none): :func:`passages_message`."""
        if not self.passages:
            return ""
        return passages_message(self.passages, [self.names[int(r)] for r in self.rows])

    def restart(self, t: float, q: np.ndarray) -> None:
        """Ready for a segment of the run from ``(t, q)`` (the passages of the run's
        earlier segments are kept: a run's data is its own, made for it)."""
        self._reached = t
        self.careful, self._last_step = False, (False, None)
        self.measure(t, q)

    def measure(self, t: float, q: np.ndarray, Av: np.ndarray | None = None) -> None:
        """Careful from here if ``q`` is near a singular configuration (a passage noted);
        ``Av``: the values of ``A`` there, if the caller has them."""
        if self.num.m == 0:
            return
        found = measure(self._gram, self.num.velocity_sparse(t, q)[0] if Av is None else Av)
        if found.near:
            if not self.careful:
                self.passages.append(Passage(t, t, found.ratio, 0, found.rows))
            self.passages[-1].note(t, found)
        self.careful, self.truncation = found.near, found.truncation

    def rhs(self, t: float, y: np.ndarray) -> np.ndarray:
        """The right-hand side, careful or not: as the step under way is taken, or, at a
        time inside the step just taken (its dense output's extra stages, evaluated
        after the switch at its end), as that step was."""
        careful, cut = self._mode(t)
        if not careful or cut is None:
            return self._rhs(t, y)
        num = self.num
        q, qd = num.layout.split(y)
        Mv, f, Av, c = num.kkt_sparse(t, q, qd)
        try:
            solve = self._dynamics.factor(Mv, Av, cut.scale, cut.V, cut.largest)
        except SingularSystemError as exc:  # the mass matrix, then: the loop says so
            raise SingularSystemError(f"the KKT matrix is singular at t={t:.6g} although "
                                      "the nearly dependent constraints are left out") from exc
        return num.layout.join(qd, solve(f, c[self.rows] * cut.scale)[0])

    def project(self, t: float, y: np.ndarray) -> np.ndarray:
        """The projection, careful or not; at a step's end (a time beyond every one
        projected before) the switch for the next step. An output inside the step just
        taken is projected the way its end was.

        When the switch enforces combinations the step left out, the state is
        projected onto them at once (velocities in the kinetic-energy metric), so that
        the next step starts consistent with what it enforces: the drift the left-out
        combinations gathered would otherwise enter its accelerations amplified by
        their small singular values.
        """
        if self.direction * (t - self._reached) <= 0:  # an output inside the last step
            careful, cut = self._mode(t)
            return self._careful_project(t, y, cut) if careful else self._project(t, y)
        projected = self._careful_project(t, y, self.truncation) if self.careful \
            else self._project(t, y)
        Av = self.num.velocity_sparse(t, projected[:self.num.n])[0]  # the step end's A
        if self._left_out():  # (leaving combinations out, it cannot jump)
            self._check_reach(t, Av)
        else:
            self._check_correction(t, y, projected)
        y = projected
        self._reached = t
        before, was_careful = self._left_out(), self.careful
        self._last_step = (self.careful, self.truncation)
        self.measure(t, y[:self.num.n], Av)
        self.rhs_changed = was_careful or self.careful
        if self._left_out() < before:
            y = self._careful_project(t, y, self.truncation or nothing_left_out(self._gram, Av))
        return y

    def _check_reach(self, t: float, Av: np.ndarray) -> None:
        """Raise :class:`RetakeStep` if the combinations the step left out are no longer
        nearly dependent at its end (singular values above ``NEAR`` of the largest): the
        step ran on without them too far from the singular configuration, where they
        carry real constraint forces."""
        cut = self.truncation
        assert cut is not None
        spread = _singular_values(self._dynamics, Av, self._gram.scale(Av), cut.V)
        if spread.max(initial=0.0) > NEAR * np.sqrt(cut.largest):
            raise RetakeStep(f"the step to t={t:.6g} left out combinations of constraints "
                             "that are no longer nearly dependent at its end")

    def _check_correction(self, t: float, y: np.ndarray, projected: np.ndarray) -> None:
        """Raise :class:`RetakeStep` if the projection moved the step's end by more
        than ``JUMP`` times the tolerance (the solvers' error norm). Only a projection
        enforcing every combination of rows is checked: one that leaves the nearly
        dependent ones out cannot reach another branch through them, and corrects in
        the others the drift its left-out ones gathered."""
        if self.tolerance is None:
            return
        rtol, atol = self.tolerance
        scale = atol + rtol * np.maximum(np.abs(y), np.abs(projected))
        size = float(np.sqrt(np.mean(((projected - y) / scale) ** 2)))
        if size > JUMP:
            raise RetakeStep(f"the projection at t={t:.6g} moved the state by {size:.3g} "
                             "times the tolerance (the step's error norm), a jump onto "
                             "another branch of the constraints")

    def _mode(self, t: float) -> tuple[bool, Truncation | None]:
        """Careful or not, and what is left out, at ``t``: the step under way's from the
        last step's end on, that step's before it."""
        if self.direction * (t - self._reached) < 0:
            return self._last_step
        return self.careful, self.truncation

    def _left_out(self) -> int:
        """How many combinations the next step leaves out."""
        return self.truncation.V.shape[1] if self.careful and self.truncation else 0

    def _careful_project(self, t: float, y: np.ndarray, cut: Truncation | None) -> np.ndarray:
        num, layout = self.num, self.num.layout
        assert cut is not None  # careful: measured near
        q, qd = self._positions_projected(t, layout.q(y).copy(), cut), layout.qd(y)
        Mv, _, Av, _ = num.kkt_sparse(t, q, qd)
        b = num.velocity_sparse(t, q)[1]
        pattern = num.pattern
        residual = (matvec(pattern.A_rows, pattern.A_cols, Av, qd, num.m) + b)[self.rows]
        try:
            solve = self._dynamics.factor(Mv, Av, cut.scale, cut.V, cut.largest)
        except SingularSystemError as exc:
            raise SingularSystemError(f"the velocity projection at t={t:.6g} is singular "
                                      "although the nearly dependent constraints are left "
                                      "out") from exc
        return layout.join(q, qd + solve(np.zeros(num.n), -residual * cut.scale)[0])

    def _positions_projected(self, t: float, q: np.ndarray, cut: Truncation) -> np.ndarray:
        """Newton with minimum-norm steps on the enforced combinations of ``psi`` (one
        factorization, refreshed when an iteration gains less than half)."""
        num, n = self.num, self.num.n
        if not len(self._psi_at):
            return q
        if not self._all_holonomic:
            Av = num.velocity_sparse(t, q)[0]
            cut = measure(self._hol_gram, Av).truncation or nothing_left_out(self._hol_gram, Av)
        tol = POSITION_RTOL * max(1.0, float(np.abs(q).max(initial=0.0)))
        solve = None
        residual_before = np.inf
        for _ in range(NEWTON):
            psi = num.position_constraint(t, q)[self._psi_at] * cut.scale
            enforced = psi - cut.V @ (cut.V.T @ psi)
            residual = float(np.abs(enforced).max(initial=0.0))
            if residual < tol:
                break
            if solve is None or residual > 0.5 * residual_before:
                solve = self._positions.factor(None, num.velocity_sparse(t, q)[0], cut.scale,
                                               cut.V, cut.largest)
            q = q + solve(np.zeros(n), -psi)[0]
            residual_before = residual
        return q

    def outputs(self, outputs: Outputs,
                inputs: Callable[[float, np.ndarray, np.ndarray], np.ndarray] | None = None
                ) -> Outputs:
        """``outputs`` with, at each time near a singular configuration where a careful
        step would leave combinations of rows out, the accelerations, multipliers and
        constraint forces of that truncated solve (the minimum-norm multipliers), and
        ``near_singular`` marking those times. Only a run that passed near one
        (:attr:`passages`) is measured at its output times: the others pay nothing.

        At a time exactly at a singular configuration (a run started there) the full
        KKT system is singular: its solve fails there, and the truncated one alone
        gives the outputs (:func:`_solved_where_regular`)."""
        num, pattern = self.num, self.num.pattern

        def truncated(t: np.ndarray, y: np.ndarray, dynamics: bool = True
                      ) -> dict[str, np.ndarray]:
            failed = np.zeros(len(t), dtype=bool)
            try:
                out = outputs(t, y, dynamics=dynamics)
            except SingularSystemError:
                if not self.passages:  # not a singular configuration the run met
                    raise
                out, failed = _solved_where_regular(outputs, t, y)
            near = np.zeros(len(t), dtype=bool)
            out["near_singular"] = near
            if not (self.passages and dynamics):
                return out
            for i, (ti, yi) in enumerate(zip(t, y)):
                q, qd = num.layout.split(yi)
                if num.m == 0 or not np.all(np.isfinite(yi)):
                    continue
                cut = measure(self._gram, num.velocity_sparse(ti, q)[0]).truncation
                if cut is None or not cut.V.shape[1]:
                    if failed[i]:  # singular, yet no combination of rows to leave out
                        raise SingularSystemError(
                            f"the KKT matrix is singular at t={ti:.6g}, where no "
                            "combination of constraint rows is nearly dependent (a "
                            "coordinate without inertia?)")
                    continue
                if inputs is not None:
                    num.set_inputs(inputs(ti, q, qd))
                Mv, f, Av, c = num.kkt_sparse(ti, q, qd)
                qdd, lam_scaled = self._dynamics.factor(Mv, Av, cut.scale, cut.V,
                                                        cut.largest)(f, c[self.rows] * cut.scale)
                lam = np.zeros(num.m)
                lam[self.rows] = lam_scaled * cut.scale
                near[i] = True
                out["qdd"][i], out["multipliers"][i] = qdd, lam
                out["constraint_forces"][i] = matvec(pattern.A_cols, pattern.A_rows, Av, lam,
                                                     num.n)
            return out

        return truncated


def _solved_where_regular(outputs: Outputs, t: np.ndarray, y: np.ndarray
                          ) -> tuple[dict[str, np.ndarray], np.ndarray]:
    """``outputs`` at every time, those of the KKT solve (``qdd``, the multipliers, the
    constraint forces) left NaN at the times where it is singular; and those times
    (a mask), for the truncated solve to fill."""
    out = outputs(t, y, dynamics=False)
    failed = np.zeros(len(t), dtype=bool)
    for i in range(len(t)):
        try:
            row = outputs(t[i:i + 1], y[i:i + 1])
        except SingularSystemError:
            failed[i] = True
            continue
        for name in ("qdd", "multipliers", "constraint_forces"):
            out[name][i] = row[name][0]
    return out, failed


def passages_message(passages: list[Passage], names: list[str]) -> str:
    """What a :class:`~dalembert.errors.SingularConfigurationWarning` says of a run's
    passages near singular configurations (``names``: the rows of the solve).

    >>> print(passages_message([Passage(0.72, 0.723, 2e-9, 3, (1, 0))], ["a", "b", "c"]))
    the run passed near a singular configuration of the constraints once (t=0.72..0.723): \
they came within 2e-09 of losing rank (smallest singular value of the rows, scaled to \
unit length, over the largest), the rows involved: b, a. The steps there left out the \
nearly dependent combinations of rows (up to 3 at once); the multipliers at those times \
are the minimum-norm ones, not unique there (Trajectory.near_singular marks them)
    """
    times = ", ".join(f"t={p.start:.6g}..{p.end:.6g}" for p in passages[:SHOWN])
    if len(passages) > SHOWN:
        times += f" and {len(passages) - SHOWN} more"
    nearest = min(passages, key=lambda p: p.ratio)
    count = "once" if len(passages) == 1 else f"{len(passages)} times"
    left_out = max(p.left_out for p in passages)
    text = (f"the run passed near a singular configuration of the constraints {count} "
            f"({times}): they came within {nearest.ratio:.1g} of losing rank (smallest "
            "singular value of the rows, scaled to unit length, over the largest), the rows "
            f"involved: {named([names[r] for r in nearest.rows])}. ")
    if left_out:
        return text + ("The steps there left out the nearly dependent combinations of rows "
                       f"(up to {left_out} at once); the multipliers at those times are the "
                       "minimum-norm ones, not unique there (Trajectory.near_singular marks "
                       "them)")
    return text + ("The steps there were careful (every constraint still enforced); the "
                   "multipliers there are large and sensitive to the state")


@dataclass(frozen=True)
class CarefulSteps:
    """The careful model of a run (its ``rhs``, ``project`` and ``measure``) and, for a
    run whose solver steps in C, ``solver(t, y, h_abs)``: a Python solver of the same
    method and tolerances starting there with that step, to take the careful steps the
    Python way."""

    model: CarefulModel
    solver: Callable[[float, np.ndarray, float], OdeSolver] | None = None
