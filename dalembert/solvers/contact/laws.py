"""Impact laws and the contacts that stay closed, on the model with every gap a row.

**Impacts.** At an instant where gaps touch, the velocities jump by impulses
``Lambda >= 0`` on the gaps (and any impulse on the bilateral rows, which hold), each
gap's rate after set by Newton's law ``g+ = -e g-`` where it acts, and left free to
open (``g+ >= -e min(g-, 0)``) where it does not: a linear complementarity problem
over the touching gaps. Each candidate set of acting gaps is one solve of the KKT
matrix on those rows (:func:`~dalembert.solvers.impact.impact`); the set is found by
a pivoting search (drop the gap pulling most, else add the gap violated most) and, if
that cycles, by enumerating the sets (exact, for the few contacts of this mode).

Two laws (:data:`IMPACT_LAWS`):

- ``"sequential"`` (default): the approaching gaps are resolved first, then the gaps
  the impulse makes approach, stage by stage, as a wave runs through a chain of
  contacts (in the spirit of Han and Gilmore's algorithm). Newton's cradle gives the
  physical outcome (the last ball leaves, the others stop) and a body landing flat on
  two contacts at once lands symmetrically (they approach together: one stage).
- ``"simultaneous"``: every touching gap in one complementarity problem (what
  Siconos, Pinocchio's ``impulseDynamics`` and a QP/LCP over all contacts give): the
  cradle of three balls ends at ``[-1/3, 2/3, 2/3]`` times the first ball's speed.

An impact slower than a gap's ``rest_speed`` is plastic (``e = 0``): the contact then
stays closed instead of bouncing infinitely often in a finite time.

A rough contact (``friction=math.inf``) acts with its sliding velocities' rows: where
it acts they end at 0 (it grips where it lands), with an impulse as large as that
takes; where it does not act, they are free.

**Closed contacts.** After a switch, the gaps that stay closed are those of the
complementarity problem at the acceleration level: among the touching gaps at rest,
each closed one pushes (``lambda >= 0``) and each open one does not accelerate into
its obstacle (``g'' >= 0``). Where some meet them open or closed alike (each force 0
with each free acceleration 0: a body lifted off several contacts, their forces
reaching 0 together), the choice is the one that meets them a moment later
(:func:`_look_ahead`).
"""

from __future__ import annotations

import itertools
from collections.abc import Callable, Iterable
from dataclasses import dataclass

import numpy as np

from ...codegen.compiled import NumericModel
from ...errors import ContactError, SingularSystemError
from ...options import IMPACT_LAWS, ImpactLaw
from ..impact import Impact, impact
from ..kkt.factorization import kkt_factorization
from ..kkt.sparse import matvec
from .friction import Friction, coulomb_impact, solve_sliding
from .gaps import FORCE_RTOL, TOUCH_RTOL, Gaps

__all__ = ["IMPACT_LAWS", "ImpactLaw", "ImpactOutcome", "closed_gaps", "resolve_impact"]
#: Stages of a sequential impact before it is called endless.
MAX_STAGES = 1000
#: Largest number of candidate gaps whose sets are enumerated when pivoting cycles.
MAX_ENUMERATED = 12
#: How far ahead, relative to ``1 + |t|``, the closed set's ties are decided (see
#: :func:`_look_ahead`): far above rounding, so that a force's rate of change shows,
#: and far below the time scales of the motion, so that its Taylor expansion holds.
LOOK_AHEAD = 1e-6


@dataclass(frozen=True)
class ImpactOutcome:
    """What an impact did.

    Attributes
    ----------
    qd
        The velocities after.
    impulses
        The impulse on each gap (0 where it did not act).
    friction_impulses
        Each gap's friction impulse: its impulse in its sliding velocities' rows (one
        entry per sliding velocity; 0 where it did not act, empty without friction).
    generalized_impulse
        ``M (qd+ - qd-)``, by coordinate.
    energy_lost
        ``T- - T+``.
    stages
        The stages of a sequential impact (1 for a simultaneous one).
    """

    qd: np.ndarray
    impulses: np.ndarray
    friction_impulses: tuple[np.ndarray, ...]
    generalized_impulse: np.ndarray
    energy_lost: float
    stages: int


def resolve_impact(full: NumericModel, gaps: Gaps, t: float, q: np.ndarray,
                   qd: np.ndarray, touching: np.ndarray,
                   law: ImpactLaw = "sequential") -> ImpactOutcome:
    """The velocities after an impact on the touching gaps, by ``law``.

    Parameters
    ----------
    full
        The model with every gap a row (:mod:`~dalembert.solvers.contact.gaps`).
    gaps
        Where its gaps are, their restitution and rest speed.
    t, q, qd
        The instant and the state before.
    touching
        Which gaps touch (a boolean mask over the gaps).
    law
        ``"sequential"`` or ``"simultaneous"`` (see the module docstring).

    Raises
    ------
    ContactError
        A sequential impact that does not end in :data:`MAX_STAGES` stages, or no set
        of acting gaps meeting the complementarity conditions.

    Examples
    --------
    Three unit balls on a line touching, the first arriving at 1 (Newton's cradle,
    ``e = 1``):

    >>> from dalembert import Holonomic, System, Unilateral, coordinates
    >>> a, b, c = coordinates("a b c")
    >>> balls = System([a, b, c], kinetic=sum(x.diff()**2 for x in (a, b, c)) / 2,
    ...                constraints=[Unilateral(b - a, "ab", 1.0), Unilateral(c - b, "bc", 1.0)])
    >>> full = balls.with_gaps_closed().numeric()
    >>> gaps = Gaps(("ab", "bc"), 0, np.ones(2), np.full(2, 1e-6))
    >>> touching = np.array([True, True])
    >>> for law in IMPACT_LAWS:
    ...     after = resolve_impact(full, gaps, 0.0, np.zeros(3), np.array([1.0, 0, 0]),
    ...                            touching, law)
    ...     print(law, np.round(after.qd, 12) + 0.0)
    sequential [0. 0. 1.]
    simultaneous [-0.33333333  0.66666667  0.66666667]
    """
    v = np.asarray(qd, dtype=float)
    total = np.zeros(gaps.count)
    every = np.zeros(full.m)  # every row's impulse, summed over the stages
    stages = 0
    while True:
        before = gaps.rates(full, t, q, v)
        scale = TOUCH_RTOL * (1.0 + np.abs(before).max(initial=0.0))
        approaching = touching & (before < -scale)
        if not approaching.any():
            break
        if stages >= (1 if law == "simultaneous" else MAX_STAGES):
            other = "simultaneous" if law == "sequential" else "sequential"
            raise ContactError(
                f"an impact at t={t:.6g} did not end after {stages} stages of the {law} "
                f"law (gaps {_named(gaps, approaching)} still closing): try "
                f"impact_law={other!r}")
        candidates = touching if law == "simultaneous" else approaching
        # Newton's law on the approaching gaps; a slow one is plastic (see rest_speed)
        e = np.where(approaching & (-before >= gaps.rest_speed), gaps.restitution, 0.0)
        chosen = np.flatnonzero(candidates)
        sliding = gaps.friction is not None and bool(
            np.any((gaps.friction[chosen] > 0) & (gaps.friction[chosen] < np.inf)))
        after = coulomb_impact(full, gaps, t, q, v, chosen, e) if sliding else \
            _complementary(full, gaps, t, q, v, before, chosen, e)
        v = after.qd
        total += after.impulses[gaps.rows]
        every += after.impulses
        stages += 1
    lost = float(full.energies(t, q, qd)[0] - full.energies(t, q, v)[0])
    return ImpactOutcome(v, total, gaps.tangential(every),
                         _momentum_change(full, t, q, qd, v), lost, stages)


def closed_gaps(full: NumericModel, gaps: Gaps, t: float, q: np.ndarray,
                qd: np.ndarray, touching: np.ndarray, exclude: Iterable[int] = (),
                friction: Friction | None = None,
                inputs_at: Callable[[float, np.ndarray, np.ndarray], np.ndarray | None]
                | None = None) -> tuple[int, ...]:
    """The gaps that are closed from ``(t, q, qd)`` on: among the touching gaps at rest
    (rate 0 to rounding; ``exclude`` left open), a set whose multipliers push and whose
    others do not accelerate into their obstacles.

    Parameters
    ----------
    full, gaps
        As for :func:`resolve_impact`.
    t, q, qd
        The state (after any impact).
    touching
        Which gaps touch.
    exclude
        Gaps to leave open (one that is separating at this instant).
    friction
        How each frictional gap acts where it is closed (held, or sliding:
        :class:`~dalembert.solvers.contact.friction.Friction`); ``None``: the rough
        ones held, no other friction.
    inputs_at
        The inputs at a state, ``inputs_at(t, q, qd)`` (or ``None``: those ``full``
        holds), for the ties decided a moment later (:func:`_look_ahead`: contacts
        whose forces reach 0 together, each open or closed alike at ``t``).

    Raises
    ------
    ContactError
        No such set exists (a contact problem with no solution, such as Painleve's).

    Examples
    --------
    A unit ball resting on a floor under gravity stays on it:

    >>> import sympy as sp
    >>> from dalembert import System, Unilateral, coordinates
    >>> (y,) = coordinates("y")
    >>> ball = System([y], kinetic=y.diff()**2 / 2, potential=9.81 * y,
    ...               constraints=[Unilateral(y, "floor")])
    >>> gaps = Gaps(("floor",), 0, np.zeros(1), np.full(1, 1e-6))
    >>> closed_gaps(ball.with_gaps_closed().numeric(), gaps, 0.0, np.zeros(1),
    ...             np.zeros(1), np.array([True]))
    (0,)
    """
    rates = gaps.rates(full, t, q, qd)
    resting = touching & (np.abs(rates) <= TOUCH_RTOL * (1.0 + np.abs(rates).max(initial=0.0)))
    for k in exclude:
        resting[k] = False
    candidates = np.flatnonzero(resting)
    if not len(candidates):
        return ()
    friction = friction or Friction(set(gaps.rough))
    now = _Checker(full, gaps, t, q, qd, candidates, friction)
    found = _search(candidates, now.check)
    if found is None:
        raise ContactError(
            f"at t={t:.6g} no set of the touching gaps {_named(gaps, resting)} can stay "
            "closed: each choice pulls on a contact or moves one into its obstacle (a "
            "contact problem without a solution at this state)")
    return tuple(int(k) for k in _look_ahead(now, found, inputs_at))


class _Checker:
    """The complementarity conditions of the candidate gaps at one state, for any set
    of them closed."""

    def __init__(self, full: NumericModel, gaps: Gaps, t: float, q: np.ndarray,
                 qd: np.ndarray, candidates: np.ndarray, friction: Friction) -> None:
        self.full, self.gaps, self.t, self.q, self.qd = full, gaps, t, q, qd
        self.candidates, self.friction = candidates, friction
        self.values = full.kkt_sparse(t, q, qd)
        self.kkt = kkt_factorization(full.pattern)
        #: each set checked, by its bytes: its ``qdd`` (``None``: singular) and
        #: :meth:`check`'s answer (the search and the look ahead ask again)
        self.seen: dict[bytes, tuple[np.ndarray | None, np.ndarray, np.ndarray]] = {}

    def check(self, chosen: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Each candidate's violation (positive: wrong) with ``chosen`` closed: a
        closed gap pulling, an open one accelerating into its obstacle; and the
        tolerance of each."""
        key = chosen.tobytes()
        if key not in self.seen:
            self.seen[key] = self._solve(chosen)
        _, wrong, scale = self.seen[key]
        return wrong, scale

    def _solve(self, chosen: np.ndarray
               ) -> tuple[np.ndarray | None, np.ndarray, np.ndarray]:
        full, gaps, candidates = self.full, self.gaps, self.candidates
        f, Av, c = self.values[1:]
        pattern = full.pattern
        try:
            qdd, lam = solve_sliding(full, gaps, self.t, self.q, self.qd,
                                     self.friction.of(chosen.tolist()),
                                     self.friction.directions, self.kkt, self.values)
        except SingularSystemError:  # dependent contact rows: another set will do
            return None, np.full(len(candidates), np.inf), np.zeros(len(candidates))
        accel = matvec(pattern.A_rows, pattern.A_cols, Av, qdd, full.m) - c
        force, gap_accel = lam[gaps.rows], accel[gaps.rows]
        scale = FORCE_RTOL * (1.0 + np.abs(f).max(initial=0.0) + np.abs(lam).max(initial=0.0))
        wrong = np.where(np.isin(np.arange(gaps.count), chosen), -force, -gap_accel)
        return qdd, wrong[candidates], np.full(len(candidates), scale)


def _look_ahead(now: _Checker, found: np.ndarray,
                inputs_at: Callable[[float, np.ndarray, np.ndarray], np.ndarray | None]
                | None) -> np.ndarray:
    """``found``, the set meeting the conditions at ``now``'s state, with its ties
    decided a moment later: the candidates whose force (closed) or acceleration (open)
    is 0 to within the tolerance meet the conditions open or closed alike (a body
    lifted off several contacts, each force reaching 0 at the same instant, where the
    free acceleration is 0 too). Which of them stay closed is the choice that meets
    them at the state :data:`LOOK_AHEAD` later, reached from the tie (the forces of
    the candidates in it are 0, so every such choice moves the same way) by its
    Taylor expansion: the complementarity of their forces' and accelerations' rates
    of change. Else one contact of a set whose forces fall through 0 together would
    open at a time, the others, 0 to rounding, staying closed, then the next one, at
    the same instant without end. Ties still 0 there (a contact pushing with no
    force that stays so) keep ``found``; where no choice holds there (a rough corner
    whose normal force reaches 0 while it needs friction: held it pulls, let go it
    falls into the floor), the problem has no solution from this state
    (:class:`~dalembert.errors.ContactError`), where keeping ``found`` would switch
    at this instant without end."""
    wrong, scale = now.check(found)  # (made by the search: its answer kept)
    tied = now.candidates[np.abs(wrong) <= scale]
    qdd = now.seen[found.tobytes()][0]
    if not len(tied) or qdd is None:
        return found
    full, t, q, qd = now.full, now.t, now.q, now.qd
    h = LOOK_AHEAD * (1.0 + abs(t))
    q_h, qd_h = q + h * qd + h * h / 2 * qdd, qd + h * qdd
    inputs = None if inputs_at is None else full.inputs.copy()
    try:
        if inputs_at is not None:
            later_inputs = inputs_at(t + h, q_h, qd_h)
            if later_inputs is not None:
                full.set_inputs(later_inputs)
        later = _Checker(full, now.gaps, t + h, q_h, qd_h, now.candidates, now.friction)
        fixed = sorted(set(found.tolist()) - set(tied.tolist()))
        where = np.searchsorted(now.candidates, tied)

        def check(chosen: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
            every = np.array(sorted(fixed + chosen.tolist()), dtype=found.dtype)
            wrong, scale = later.check(every)
            return wrong[where], scale[where]

        again = _search(tied, check, np.intersect1d(tied, found))
    finally:
        if inputs is not None:
            full.set_inputs(inputs)
    if again is None:  # no choice holds a moment later: the problem has no solution
        named = _named(now.gaps, np.isin(np.arange(now.gaps.count), tied))
        raise ContactError(
            f"at t={t:.6g} no set of the touching gaps {named} can stay closed: each "
            "choice pulls on a contact or moves one into its obstacle a moment later (a "
            "contact problem without a solution from this state)")
    return np.array(sorted(fixed + again.tolist()), dtype=found.dtype)


def _complementary(full: NumericModel, gaps: Gaps, t: float, q: np.ndarray,
                   v: np.ndarray, before: np.ndarray, candidates: np.ndarray,
                   e: np.ndarray) -> Impact:
    """The impact on a set of the ``candidates`` (gap indices) meeting the
    complementarity conditions (see the module docstring)."""
    restitution = np.zeros(full.m)
    restitution[gaps.rows] = e
    outcome: dict[bytes, Impact] = {}

    def check(chosen: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        acting = gaps.acting(full.m, chosen)
        try:
            after = impact(full, t, q, v, acting, restitution)
        except SingularSystemError:  # dependent contact rows: another set will do
            return np.full(len(candidates), np.inf), np.zeros(len(candidates))
        outcome[chosen.tobytes()] = after
        rates = gaps.rates(full, t, q, after.qd)
        impulses = after.impulses[gaps.rows]
        scale = TOUCH_RTOL * (1.0 + np.abs(impulses).max(initial=0.0)
                              + np.abs(before).max(initial=0.0))
        floor = -e * np.minimum(before, 0.0)  # an open gap's least rate after
        wrong = np.where(np.isin(np.arange(gaps.count), chosen), -impulses, floor - rates)
        return wrong[candidates], np.full(len(candidates), scale)

    start = candidates[before[candidates] < 0]
    found = _search(candidates, check, start)
    if found is None:
        named = _named(gaps, np.isin(np.arange(gaps.count), candidates))
        raise ContactError(f"the impact at t={t:.6g} on the gaps {named} has no solution "
                           "with every impulse pushing and Newton's law met (try the "
                           "other impact_law)")
    return outcome[np.asarray(found, dtype=candidates.dtype).tobytes()]


def _search(candidates: np.ndarray,
            check: Callable[[np.ndarray], tuple[np.ndarray, np.ndarray]],
            start: np.ndarray | None = None) -> np.ndarray | None:
    """A subset of ``candidates`` whose ``check`` shows no violation: pivoting from
    ``start`` (default all) one candidate at a time, then enumeration if that cycles."""
    chosen = np.array(sorted(candidates if start is None else start), dtype=candidates.dtype)
    seen: set[bytes] = set()
    while chosen.tobytes() not in seen:
        seen.add(chosen.tobytes())
        wrong, scale = check(chosen)
        if (wrong <= scale).all():
            return chosen
        worst = candidates[int(np.argmax(wrong - scale))]
        chosen = np.array(sorted(set(chosen.tolist()) ^ {int(worst)}), dtype=candidates.dtype)
    if len(candidates) > MAX_ENUMERATED:
        return None
    for size in range(len(candidates), -1, -1):
        for subset in itertools.combinations(candidates.tolist(), size):
            chosen = np.array(subset, dtype=candidates.dtype)
            wrong, scale = check(chosen)
            if (wrong <= scale).all():
                return chosen
    return None


def _momentum_change(full: NumericModel, t: float, q: np.ndarray, before: np.ndarray,
                     after: np.ndarray) -> np.ndarray:
    """``M (after - before)``."""
    Mv = full.kkt_sparse(t, q, before)[0]
    pattern = full.pattern
    return matvec(pattern.M_rows, pattern.M_cols, Mv, after - before, full.n)


def _named(gaps: Gaps, mask: np.ndarray) -> str:
    return ", ".join(repr(gaps.names[k]) for k in np.flatnonzero(mask))
