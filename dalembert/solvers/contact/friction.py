"""Coulomb friction in the event-driven mode: each closed contact sticks or slides.

A closed contact with a finite coefficient ``mu`` either **sticks**, its sliding
velocities held at 0 by rows of the segment's model (a rough contact's rows) with a
force as large as that takes while it stays in the cone ``|lambda_t| <= mu lambda_n``,
or **slides**, its friction force ``F = -mu lambda_n d`` along the sliding direction
``d``. A sliding contact's force depends on its normal multiplier, so the KKT matrix
of the segment is not symmetric:

    M qdd = f + A^T lambda + sum_k D_k lambda_k,    D_k = -mu_k A_t(k)^T d_k,

with ``A_t(k)`` the contact's sliding velocities' rows. It is solved with the one
symmetric factorization of the rows that hold (bilateral, closed gaps, held sliding
velocities) by a low-rank correction: the solution without friction and one solve
per sliding velocity (its response per unit normal force of friction along it), then
a ``k x k`` system for the normal forces (:func:`solve_sliding`).
The segment's model takes the friction forces as inputs
(:func:`~dalembert.model.constraints.friction_inputs`), which :class:`SlidingForces`
gives at each state.

A body resting on more contacts than it needs (a box on its four corners: rank 3 of
four normal rows) holds them with fewer independent rows; the rows that depend on the
others are left out of the factorization (:func:`acting_rows`), and every multiplier
of the closed set is then the minimum-norm one giving the same constraint force
``A^T lambda`` (the projection onto the range of the set's rows, as a segment's run
reports them). On a rigid body these are the loads of equal springs at the contacts,
linear in their positions; a sliding contact's friction ``-mu lambda_n d`` takes that
``lambda_n``, a linear map of the kept rows' multipliers, so the normal forces still
solve one linear system. The friction the held contacts exert together is shared by
:func:`held_forces` in proportion to these loads, each using the same fraction of its
cone where their rows allow it (they reach their cones together).

A segment ends (terminal events, located to rounding) where a sticking contact's
force reaches the cone (it slips) and where a sliding contact's sliding velocity,
along its direction at the segment's start, reaches 0 (it stops, and sticks if the
force that takes lies in the cone). In the plane a sliding direction is constant
within a segment, so the friction force is smooth there and the stop is found to
rounding; in space the direction turns with the motion, and a segment also ends if
it turns by a right angle.

At a switch :func:`choose_friction` decides: a contact sliding goes on sliding; one
at rest sticks if its sticking force lies in the cone. Otherwise, with one sliding
velocity, it slides in the direction that force cannot hold (``d = -lambda_t /
|lambda_t|``); with two (or three of rank 2), it and every other contact at rest like
it start to slide from rest together, their friction from then on Coulomb's law at
the level of accelerations (:func:`onset_friction`): each holds, or slides along its
acceleration, all decided at once, until it slides faster than a small speed. Its
direction is the direction of the excess force only where the contact's tangential
mass is isotropic (a cylinder lying on a floor, rolling one way and sliding the other,
is not).
"""

from __future__ import annotations

from collections.abc import Callable, Container, Sequence
from dataclasses import dataclass, field

import numpy as np

from ...codegen.compiled import NumericModel
from ...errors import SingularSystemError
from ...model.constraints import ClosedGaps
from ...numerics.rank import RANK_RTOL, dependent_rows
from ..impact import Impact
from ..kkt.factorization import KKTFactorization, kkt_factorization
from ..kkt.sparse import matvec
from .gaps import FORCE_RTOL, TOUCH_RTOL, Gaps, row_rates
from .impulses import contact_impulses

#: :func:`onset_friction`'s Newton method: its most iterations (from the last found, the
#: work of 3 or fewer in 92% of the solves of three random pushes of a box), and the
#: difference step of its accelerations' Jacobian (in the units of ``u``, at most 1).
ONSET_ITERATIONS = 100
ONSET_STEP = 1e-7
#: ``G`` (dimensionless) within this many ulps of 0 is a solution (its rounding reaches
#: 1e-13 on a box's four corners).
ONSET_ROUNDING = 1024
#: The shortest fraction of a Newton step its line search tries.
ONSET_SMALLEST_STEP = 2.0**-20
#: Where no step lowers ``G`` any more (its rounding: 5e-13 measured on a box coming to
#: rest on its corners, one of them at its cone), ``G`` within this of 0 is a solution.
ONSET_STALLED = 1e-10
#: Whole Newton steps taken where no fraction of one lowers ``|G|`` (at most, per solve).
ONSET_FREE_STEPS = 3


@dataclass
class Friction:
    """How each frictional gap acts where it is closed: held (rough, or sticking) or
    sliding along a unit direction of its sliding velocities.

    Attributes
    ----------
    held
        Gaps whose sliding velocities are held at 0 (rough ones always).
    directions
        The sliding direction of each sliding gap (a unit vector, one entry per
        sliding velocity).
    """

    held: set[int] = field(default_factory=set)
    directions: dict[int, np.ndarray] = field(default_factory=dict)

    def of(self, closed: Sequence[int]) -> ClosedGaps:
        """The closed set ``closed`` with this friction."""
        return ClosedGaps(tuple(closed), tuple(k for k in closed if k in self.held),
                          tuple(k for k in closed if k in self.directions))


def sliding_velocity(full: NumericModel, gaps: Gaps, k: int, t: float, q: np.ndarray,
                     qd: np.ndarray) -> np.ndarray:
    """The sliding velocities of gap ``k`` (its tangent rows' rates in ``full``)."""
    return row_rates(full, t, q, qd)[gaps.tangents[k]]


def acting_rows(full: NumericModel, gaps: Gaps, t: float, q: np.ndarray,
                which: ClosedGaps) -> np.ndarray:
    """The rows of ``full`` that act with the closed set ``which`` (a boolean mask),
    the gap rows and held sliding velocities that depend on the rows before them left
    out. A body resting on several contacts holds them all with fewer independent
    rows (a box on two corners in the plane, on four in space): its contact forces
    are not unique, and a solve with these rows alone leaves 0 on the others;
    :func:`solve_sliding` gives every row of the set its minimum-norm multiplier, as a
    segment's run does (:func:`held_forces` shares the friction of held ones)."""
    mask = gaps.acting(full.m, np.array(which.closed, dtype=int), which.held)
    contact = np.flatnonzero(mask[gaps.first:]) + gaps.first
    if len(contact) < 2:
        return mask
    Av, _ = full.velocity_sparse(t, q)
    A = full.pattern.dense_A(Av)
    order = np.concatenate([np.arange(gaps.first), contact])  # bilateral rows first
    for i in dependent_rows(A[order]):
        if order[i] >= gaps.first:
            mask[order[i]] = False
    return mask


def held_forces(full: NumericModel, gaps: Gaps, t: float, q: np.ndarray,
                which: ClosedGaps, lam: np.ndarray) -> dict[int, np.ndarray]:
    """The friction forces of the held gaps of ``which`` (rough or sticking), from the
    multipliers ``lam`` of every row of ``full``: where their rows are dependent, the
    friction they exert together (``A_t^T lambda_t``, unique) is shared in proportion
    to their normal forces, the least-squares distribution weighted by ``1 / lambda_n``
    (with one sliding velocity per contact and equal rows, each contact then uses the
    same fraction of its cone), which is the unique one where they are independent.

    Examples
    --------
    Two corners of a box sliding along one row, pressed by 3 and 1, holding 2 in all:

    >>> from dalembert import System, Unilateral, coordinates
    >>> x, y = coordinates("x y")
    >>> both = System([x, y], kinetic=(x.diff()**2 + y.diff()**2) / 2, constraints=[
    ...     Unilateral(y, "a", friction=0.5, tangents=[x.diff()]),
    ...     Unilateral(y, "b", friction=0.5, tangents=[x.diff()])])
    >>> full = both._closed(ClosedGaps((0, 1), held=(0, 1))).numeric()
    >>> gaps = Gaps.of(both.definition.unilateral, 0, [0.0, 0.0])
    >>> lam = np.array([3.0, 1.0, 1.0, 1.0])
    >>> {k: f.round(12).tolist() for k, f in held_forces(full, gaps, 0.0, np.zeros(2),
    ...                                                  ClosedGaps((0, 1), (0, 1)), lam).items()}
    {0: [1.5], 1: [0.5]}
    """
    held = [k for k in which.held if len(gaps.tangents[k])]
    if not held:
        return {}
    rows = np.concatenate([gaps.tangents[k] for k in held]).astype(int)
    Av, _ = full.velocity_sparse(t, q)
    A = full.pattern.dense_A(Av)[rows]
    normal = np.concatenate([np.full(len(gaps.tangents[k]), max(lam[gaps.first + k], 0.0))
                             for k in held])
    root = np.sqrt(normal)
    share = root * np.linalg.lstsq(A.T * root, A.T @ lam[rows], rcond=RANK_RTOL)[0]
    out, at = {}, 0
    for k in held:
        out[k] = share[at:at + len(gaps.tangents[k])]
        at += len(gaps.tangents[k])
    return out


def solve_sliding(full: NumericModel, gaps: Gaps, t: float, q: np.ndarray,
                  qd: np.ndarray, which: ClosedGaps, directions: dict[int, np.ndarray],
                  kkt: KKTFactorization | None = None,
                  values: tuple[np.ndarray, ...] | None = None,
                  acting: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """``qdd`` and the multipliers of every row of ``full`` (0 on the rows that do
    not act) with the gaps ``which.closed`` closed, the sliding velocities of
    ``which.held`` held and the gaps ``which.sliding`` sliding along ``directions``
    (see the module docstring); the sliding gaps' friction forces in their tangent
    rows' places. Where rows of the set depend on the others (:func:`acting_rows`),
    its multipliers are the minimum-norm ones with the same ``A^T lambda``, and a
    sliding gap's friction is ``mu`` times its minimum-norm normal force (held
    friction shared by load: :func:`held_forces`).

    Parameters
    ----------
    full, gaps
        The model with every gap a row and its sliding velocities after them.
    t, q, qd
        The state (the inputs as ``full`` holds them).
    which
        The rows acting and the sliding gaps.
    directions
        Each sliding gap's unit direction.
    kkt
        A factorization object of ``full``'s pattern to reuse (made if ``None``).
    values
        ``full.kkt_sparse(t, q, qd)`` if the caller has it.
    acting
        The rows that act (:func:`acting_rows`) if the caller has them.

    Raises
    ------
    SingularSystemError
        The rows that act are dependent.
    """
    return _Responses(full, gaps, t, q, qd, which, kkt, values, acting).solve(directions)


class _Responses:
    """:func:`solve_sliding` at one state for any sliding friction: the KKT matrix
    factored, the solve without friction, and each sliding gap's tangent rows' responses
    per unit normal force of friction along them, so that each trial is small dense
    algebra (the normal forces by a ``k x k`` system). ``kkt`` holds this
    factorization only until it is factored again."""

    def __init__(self, full: NumericModel, gaps: Gaps, t: float, q: np.ndarray,
                 qd: np.ndarray, which: ClosedGaps, kkt: KKTFactorization | None = None,
                 values: tuple[np.ndarray, ...] | None = None,
                 acting: np.ndarray | None = None) -> None:
        Mv, f, Av, c = values if values is not None else full.kkt_sparse(t, q, qd)
        kkt = kkt or kkt_factorization(full.pattern)
        if acting is None:
            acting = acting_rows(full, gaps, t, q, which)
        kkt.factor(np.concatenate([Mv, Av]), acting)
        # dependent rows left out: every multiplier the minimum-norm one (a linear map of
        # the kept rows' ones, so the sliding contacts' normal forces stay linear below)
        spread = _minimum_norm(full, gaps, Av, which, acting)
        qdd0, lam0 = kkt.solve(np.concatenate([f, c]))
        self.qdd0, self.lam0 = qdd0, spread(lam0)
        pattern, zeros = full.pattern, np.zeros(full.m)
        self.gaps, self.sliding = gaps, which.sliding
        tangents = [gaps.tangents[k] for k in which.sliding]
        #: the sliding gaps' tangent rows, and each one's gap (its place among them)
        self.rows = np.concatenate([np.zeros(0, dtype=int), *tangents]).astype(int)
        self.owner = np.repeat(np.arange(len(tangents)), [len(r) for r in tangents])
        self.normal = gaps.first + np.array(which.sliding, dtype=int)
        self.mu = np.zeros(0) if gaps.friction is None else \
            gaps.friction[np.array(which.sliding, dtype=int)]
        responses = []
        for j, row in enumerate(self.rows):  # friction -mu A_t^T along row j
            weights = zeros.copy()
            weights[row] = -self.mu[self.owner[j]]
            force = matvec(pattern.A_cols, pattern.A_rows, Av, weights, full.n)
            qdd_j, lam_j = kkt.solve(np.concatenate([force, zeros]))
            responses.append((qdd_j, spread(lam_j)))
        self.qdd_rows = np.array([r[0] for r in responses]).reshape(len(self.rows), full.n)
        self.lam_rows = np.array([r[1] for r in responses]).reshape(len(self.rows), full.m)

        def accelerations(qdd: np.ndarray) -> np.ndarray:  # A qdd on the tangent rows
            return matvec(pattern.A_rows, pattern.A_cols, Av, qdd, full.m)[self.rows]

        #: the tangent rows' accelerations without friction and per unit of each row's
        self.a0 = accelerations(qdd0) - c[self.rows]
        self.T = np.array([accelerations(x) for x in self.qdd_rows]).reshape(
            len(self.rows), len(self.rows)).T

    def columns(self, k: int) -> np.ndarray:
        """The places of sliding gap ``k``'s tangent rows among :attr:`rows`."""
        return np.flatnonzero(self.owner == self.sliding.index(k))

    def normal_forces(self, u: np.ndarray) -> np.ndarray:
        """The sliding gaps' normal forces with friction ``-mu N u`` (``u`` by tangent
        row): ``(I - R) N = N_0``."""
        k = len(self.sliding)
        R = np.zeros((k, k))
        np.add.at(R.T, self.owner, self.lam_rows[:, self.normal] * u[:, None])
        try:
            return np.linalg.solve(np.eye(k) - R, self.lam0[self.normal])
        except np.linalg.LinAlgError as exc:  # their normal forces are not unique
            raise SingularSystemError("the sliding contacts' normal rows are dependent") \
                from exc

    def solve(self, directions: dict[int, np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
        """``qdd`` and the multipliers with each sliding gap's friction along
        ``directions`` (``-mu N d``)."""
        if not self.sliding:
            return self.qdd0, self.lam0
        u = np.concatenate([directions[k] for k in self.sliding])
        N = self.normal_forces(u)
        weights = N[self.owner] * u
        qdd = self.qdd0 + weights @ self.qdd_rows
        lam = self.lam0 + weights @ self.lam_rows
        for k, mu, n_k in zip(self.sliding, self.mu, N):
            lam[self.gaps.tangents[k]] = -mu * n_k * directions[k]
        return qdd, lam

    def at(self, u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The tangent rows' accelerations and the sliding gaps' normal forces with
        friction ``-mu N u`` (``u`` by tangent row)."""
        N = self.normal_forces(u)
        return self.a0 + self.T @ (N[self.owner] * u), N


def _minimum_norm(full: NumericModel, gaps: Gaps, Av: np.ndarray, which: ClosedGaps,
                  acting: np.ndarray) -> Callable[[np.ndarray], np.ndarray]:
    """The map from multipliers on the rows ``acting`` (0 on the rest) to the
    minimum-norm ones over every row of the closed set ``which`` with the same force
    ``A^T lambda``: the projection onto the range of those rows' ``A`` (a segment's
    run reports these); the identity where no row of the set was left out."""
    rows = np.flatnonzero(gaps.acting(full.m, np.array(which.closed, dtype=int), which.held))
    rank = int(np.count_nonzero(acting[rows]))
    if rank == len(rows):
        return lambda lam: lam
    A = full.pattern.dense_A(Av)[rows]
    U = np.linalg.svd(A, full_matrices=False)[0][:, :rank]  # the range of A

    def spread(lam: np.ndarray) -> np.ndarray:
        out = lam.copy()
        out[rows] = U @ (U.T @ lam[rows])
        return out
    return spread


def current_direction(s: np.ndarray, start: np.ndarray) -> np.ndarray:
    """The sliding direction of sliding velocities ``s`` in a segment that started
    sliding along ``start``: ``s / |s|``, kept at ``start`` where ``s`` no longer runs
    along it (past its stop, where an integrator's trial stage may look), so the
    friction force stays smooth up to the stop."""
    size = float(np.linalg.norm(s))
    if size == 0.0 or float(s @ start) <= 0.0:
        return start
    return s / size


class SlidingForces:
    """The friction forces of a segment's sliding gaps at a state, as the inputs of the
    model of its closed set (a :class:`~dalembert.inputs.InputSignal` source).

    Parameters
    ----------
    full
        The model with every gap a row (a run's own copy: its inputs are set here).
    gaps
        Where its gaps are.
    which
        The segment's closed set.
    starts
        Each sliding gap's direction at the current segment's start (read at each
        call: one object serves every segment with this set).
    onset
        The sliding gaps that start to slide from rest in the current segment (as
        ``starts``), which take :func:`onset_friction`.
    user
        The user's inputs at a state (the held sample, if sampled; ``None``: the
        model has none).
    """

    def __init__(self, full: NumericModel, gaps: Gaps, which: ClosedGaps,
                 starts: dict[int, np.ndarray], onset: Container[int],
                 user: Callable[[float, np.ndarray, np.ndarray], np.ndarray | None]) -> None:
        self.full, self.gaps, self.which = full, gaps, which
        self.starts, self.onset, self.user = starts, onset, user
        self.kkt = kkt_factorization(full.pattern)
        #: The rows acting, found at the first state (which held rows depend on the
        #: others does not change while the set is closed).
        self.acting: np.ndarray | None = None
        #: The last onset friction found, by gap (see :meth:`restart`).
        self.last: dict[int, np.ndarray] = {}

    def restart(self) -> None:
        """Forget the last onset friction found (a segment starts)."""
        self.last.clear()

    def __call__(self, t: float, q: np.ndarray, qd: np.ndarray) -> np.ndarray:
        full, gaps, which = self.full, self.gaps, self.which
        inputs = self.user(t, q, qd)
        if inputs is not None:
            full.set_inputs(inputs)
        rates = row_rates(full, t, q, qd)
        directions = {k: current_direction(rates[gaps.tangents[k]], self.starts[k])
                      for k in which.sliding}
        if self.acting is None:
            self.acting = acting_rows(full, gaps, t, q, which)
        starting = [k for k in which.sliding if k in self.onset]
        if starting:
            directions.update({k: self.last.get(k, self.starts[k]) for k in starting})
            directions = onset_friction(full, gaps, t, q, qd, which, directions, starting,
                                        self.kkt, self.acting)
            self.last.update({k: directions[k] for k in starting})
        _, lam = solve_sliding(full, gaps, t, q, qd, which, directions, self.kkt,
                               acting=self.acting)
        return np.concatenate([lam[gaps.tangents[k]] for k in which.sliding])


def friction_at(full: NumericModel, gaps: Gaps, t: float, q: np.ndarray,
                qd: np.ndarray) -> Friction:
    """The friction of every gap as its velocities show it: a finite one sliding (its
    direction) where its sliding velocities are not 0, else held, as a rough one."""
    if gaps.friction is None:
        return Friction()
    mu = gaps.friction
    speed = TOUCH_RTOL * (1.0 + np.abs(qd).max(initial=0.0))
    rates = row_rates(full, t, q, qd)
    found = Friction(set(gaps.rough))
    for k in np.flatnonzero((mu > 0) & (mu < np.inf)):
        s = rates[gaps.tangents[k]]
        size = float(np.linalg.norm(s))
        if size > speed:
            found.directions[int(k)] = s / size
        else:
            found.held.add(int(k))
    return found


def choose_friction(full: NumericModel, gaps: Gaps, t: float, q: np.ndarray,
                    qd: np.ndarray, closed: tuple[int, ...], start: Friction,
                    slipping: int | None = None) -> Friction:
    """Which closed frictional gaps stick and which slide from ``(t, q, qd)`` on (see
    the module docstring): where a held one of ``start`` has a sticking force that leaves
    the cone (the worst first; ``slipping``, a gap whose force has just reached it),
    it slides: with one sliding velocity alone, against that force; with two (or three
    of rank 2) with every held one like it, from rest, their friction and directions
    from :func:`onset_friction`.

    Parameters
    ----------
    full, gaps
        The model with every gap a row and its sliding velocities.
    t, q, qd
        The state after the switch.
    closed
        The closed gaps.
    start
        The friction as the velocities show it (:func:`friction_at`).
    slipping
        A held gap made to slide (its sticking force on the cone).

    Examples
    --------
    A unit block at rest on a floor, pushed along it by 4 N against ``mu g = 2.943``:

    >>> from dalembert import System, Unilateral, coordinates
    >>> x, y = coordinates("x y")
    >>> block = System([x, y], kinetic=(x.diff()**2 + y.diff()**2) / 2,
    ...                potential=9.81 * y - 4.0 * x,
    ...                constraints=[Unilateral(y, "floor", friction=0.3, tangents=[x.diff()])])
    >>> full = block._closed(ClosedGaps((0,), held=(0,))).numeric()
    >>> gaps = Gaps.of(block.definition.unilateral, 0, [0.0])
    >>> rest = np.zeros(2)
    >>> chosen = choose_friction(full, gaps, 0.0, rest, rest, (0,),
    ...                          friction_at(full, gaps, 0.0, rest, rest))
    >>> chosen.held, chosen.directions
    (set(), {0: array([1.])})
    """
    assert gaps.friction is not None
    mu = gaps.friction
    chosen = Friction(set(start.held), dict(start.directions))
    resting = [k for k in closed if k in chosen.held and mu[k] < np.inf]
    kkt = kkt_factorization(full.pattern)
    # where a contact slips, the others on the cone with it slip too (a body on several
    # contacts whose shared force reaches their cones at once): else each would slip
    # alone at the same instant, the others holding, one after another without end
    at_limit = slipping is not None
    while resting:
        which = chosen.of(closed)
        _, lam = solve_sliding(full, gaps, t, q, qd, which, chosen.directions, kkt)
        forces = held_forces(full, gaps, t, q, which, lam)
        size_of = 1.0 + np.abs(lam).max(initial=0.0)
        allowed = -TOUCH_RTOL * size_of if at_limit else FORCE_RTOL * size_of
        excess = {k: np.linalg.norm(forces[k]) - mu[k] * lam[gaps.first + k]
                  for k in resting}
        if slipping in excess:
            excess[slipping] = np.inf
        worst = max(excess, key=excess.__getitem__)
        force = forces[worst]
        size = float(np.linalg.norm(force))
        if excess[worst] <= allowed or size == 0.0:
            break
        # a contact with two sliding velocities (or three of rank 2) slips with every
        # resting one like it: which of them then holds and which slides, and along
        # what, is Coulomb's law at the level of accelerations, all at once
        # (onset_friction); one by one, each holding the others, a body's corners
        # slipped in turn and then crept on directions of no acceleration
        group = [k for k in resting if len(gaps.tangents[k]) in (2, 3)] \
            if len(gaps.tangents[worst]) in (2, 3) else [worst]
        for k in group:  # from the share of its cone it held (onset_friction's start)
            cone = mu[k] * lam[gaps.first + k]
            chosen.held.discard(k)
            chosen.directions[k] = -force / size if k == worst else \
                -forces[k] / cone if cone > 0.0 else np.zeros(len(gaps.tangents[k]))
            resting.remove(k)
        slipping = None
    started = [k for k in chosen.directions
               if k not in start.directions and len(gaps.tangents[k]) in (2, 3)]
    if started:
        guesses = {k: chosen.directions[k] for k in started}
        found = onset_friction(full, gaps, t, q, qd, chosen.of(closed), chosen.directions,
                               started, kkt)
        for k in started:  # its direction: where it slides, or where its force holds it
            u = next((d for d in (found[k], guesses[k]) if np.linalg.norm(d) > 0.0),
                     np.eye(len(gaps.tangents[k]))[0])  # (no force: any direction)
            chosen.directions[k] = u / np.linalg.norm(u)
    return chosen


def sliding_plane(full: NumericModel, gaps: Gaps, t: float, q: np.ndarray, qd: np.ndarray,
                  k: int) -> np.ndarray | None:
    """An orthonormal basis (columns) of the plane gap ``k``'s sliding velocities
    span: the identity with two of them; with three of rank 2 (a contact's sliding
    velocity in world components, as between two spheres) the leading left singular
    vectors of their rows of ``A``; ``None`` for other counts or ranks (their
    direction at an onset is then not sought).

    Parameters
    ----------
    full, gaps
        The model with every gap a row and its sliding velocities.
    t, q, qd
        The state (the inputs as ``full`` holds them).
    k
        The gap.

    Examples
    --------
    >>> from dalembert import System, Unilateral, coordinates
    >>> x, y, z = coordinates("x y z")
    >>> ball = System([x, y, z], kinetic=(x.diff()**2 + y.diff()**2 + z.diff()**2) / 2,
    ...               potential=9.81 * z, constraints=[Unilateral(z, "floor",
    ...               friction=0.3, tangents=[x.diff(), y.diff(), x.diff() + y.diff()])])
    >>> full = ball._closed(ClosedGaps((0,), held=(0,))).numeric()
    >>> gaps = Gaps.of(ball.definition.unilateral, 0, [0.0])
    >>> E = sliding_plane(full, gaps, 0.0, np.zeros(3), np.zeros(3), 0)
    >>> E.shape, bool(np.allclose(E.T @ E, np.eye(2)))
    ((3, 2), True)
    """
    rows = gaps.tangents[k]
    if len(rows) == 2:
        return np.eye(2)
    if len(rows) != 3:
        return None
    Av, _ = full.velocity_sparse(t, q)  # (the rows only: no KKT values)
    U, sigma, _ = np.linalg.svd(full.pattern.dense_A(Av)[rows])
    if sigma[1] <= RANK_RTOL * sigma[0] or sigma[2] > RANK_RTOL * sigma[0]:
        return None
    return U[:, :2]


def onset_friction(full: NumericModel, gaps: Gaps, t: float, q: np.ndarray,
                   qd: np.ndarray, which: ClosedGaps, directions: dict[int, np.ndarray],
                   starting: Sequence[int], kkt: KKTFactorization | None = None,
                   acting: np.ndarray | None = None) -> dict[int, np.ndarray]:
    """The friction of the gaps ``starting``, at rest, as Coulomb's law at the level
    of accelerations gives it: each either holds (its tangential acceleration 0, its
    force inside its cone) or slides along its acceleration, its force on the rim
    against it (``a_t = s d``, ``s > 0``, friction ``-mu lambda_n d``), all at once.
    For given normal forces that is the minimum of a convex function of the
    accelerations (Gauss's least constraint with the friction's dissipation), so the
    accelerations are unique even where the forces are not (a box held on four
    corners at their cones). Solved by a semismooth Newton method from
    ``directions`` (:func:`_coulomb_onset`); where it finds no solution, each one's
    friction opposes its sliding velocity (where that is not 0), which cannot add
    energy.

    Why not the sliding velocity's direction ``v / |v|``: near ``v = 0`` that turns
    at a rate of about ``|a_t| / |v|`` towards this one wherever the contact's
    tangential mass is anisotropic (a cylinder rolling one way and sliding the
    other), a stiffness without bound that stalls an explicit method at the onset,
    and where ``v`` is rounding's it points anywhere (the corners of a box). The
    motion follows this friction within ``O(|v|)`` there (its slow manifold), so a
    segment takes it while ``|v|`` is below a small speed
    (:data:`~dalembert.solvers.contact.gaps.ONSET_RTOL`), then ``v / |v|``.

    Parameters
    ----------
    full, gaps
        The model with every gap a row and its sliding velocities.
    t, q, qd
        The state (the inputs as ``full`` holds them).
    which
        The closed set, the gaps ``starting`` sliding (each with two sliding
        velocities, or three of rank 2: :func:`sliding_plane`).
    directions
        Each sliding gap's direction (those of ``starting``: where to start from).
    starting
        The gaps starting to slide.
    kkt
        A factorization object of ``full``'s pattern to reuse.
    acting
        The rows that act (:func:`acting_rows`) if the caller has them.

    Returns
    -------
    dict
        ``directions`` with those of ``starting`` replaced by ``u``, their friction
        being ``-mu lambda_n u``: a unit vector where the gap slides, shorter (by the
        fraction of its cone it uses) where it holds.

    Examples
    --------
    A cylinder (``I = m r^2 / 2``) lying on a floor, its axis along ``y``, pushed at
    its axis by 12 N at 0.5 rad from ``x``: along ``x`` its contact point has three
    times the inverse mass it has along ``y``, so it slides at 42.8 degrees, not
    along the excess force (58.6 degrees); pushed by 2 N its contact holds and it
    rolls along ``x``, the friction ``(push_x / 3, push_y)`` back (0.38 of its cone):

    >>> from dalembert import System, Unilateral, coordinates
    >>> x, y, z, th = coordinates("x y z theta")
    >>> def cylinder(push):
    ...     push = push * np.array([np.cos(0.5), np.sin(0.5)])
    ...     return System([x, y, z, th], kinetic=(x.diff()**2 + y.diff()**2
    ...                   + z.diff()**2) / 2 + 0.02 / 2 * th.diff()**2,
    ...                   potential=9.81 * z - push[0] * x - push[1] * y,
    ...                   constraints=[Unilateral(z - 0.2, "floor", friction=0.3,
    ...                       tangents=[x.diff() + 0.2 * th.diff(), y.diff()])])
    >>> which = ClosedGaps((0,), sliding=(0,))
    >>> q, rest = np.array([0.0, 0.0, 0.2, 0.0]), np.zeros(4)
    >>> for push in (12.0, 2.0):
    ...     system = cylinder(push)
    ...     full = system._closed(ClosedGaps((0,), held=(0,))).numeric()
    ...     gaps = Gaps.of(system.definition.unilateral, 0, [0.0])
    ...     u = onset_friction(full, gaps, 0.0, q, rest, which, {0: np.zeros(2)}, [0])[0]
    ...     print(round(float(np.linalg.norm(u)), 4),
    ...           round(float(np.degrees(np.arctan2(u[1], u[0]))), 4))
    1.0 42.8019
    0.3817 58.61
    """
    return _onset_solution(full, gaps, t, q, qd, which, directions, starting,
                           _Responses(full, gaps, t, q, qd, which, kkt, acting=acting))


def _onset_solution(full: NumericModel, gaps: Gaps, t: float, q: np.ndarray,
                    qd: np.ndarray, which: ClosedGaps, directions: dict[int, np.ndarray],
                    starting: Sequence[int], problem: _Responses
                    ) -> dict[int, np.ndarray]:
    """:func:`onset_friction` on the responses ``problem`` at its state."""
    planes = [sliding_plane(full, gaps, t, q, qd, k) for k in starting]
    if any(plane is None for plane in planes):
        return dict(directions)
    cols = [problem.columns(k) for k in starting]
    u = np.concatenate([directions[k] for k in which.sliding]).astype(float)
    found = _coulomb_onset(problem, [which.sliding.index(k) for k in starting], cols,
                           [E for E in planes if E is not None], u)
    if found is not None:
        return {**directions, **{k: found[c] for k, c in zip(starting, cols)}}
    # none found: friction against each one's sliding velocity, which cannot add energy
    # (kept at its start where it is 0)
    rates = row_rates(full, t, q, qd)
    kept = dict(directions)
    for k in starting:
        s = rates[gaps.tangents[k]]
        size = float(np.linalg.norm(s))
        if size > 0.0:
            kept[k] = s / size
    return kept


def onset_holding(full: NumericModel, gaps: Gaps, t: float, q: np.ndarray, qd: np.ndarray,
                  which: ClosedGaps, directions: dict[int, np.ndarray],
                  starting: Sequence[int]) -> tuple[int, ...]:
    """The gaps of ``starting`` that Coulomb's law at the level of accelerations holds
    (:func:`onset_friction`): their tangential acceleration 0, to
    :data:`~dalembert.solvers.contact.gaps.TOUCH_RTOL` relative to the accelerations
    without friction (where their forces are not unique, some hold at their cones).

    Parameters
    ----------
    full, gaps, t, q, qd, which, directions, starting
        As :func:`onset_friction`'s.

    Examples
    --------
    The cylinder of :func:`onset_friction`'s example rolls on its holding contact when
    pushed by 2 N and slides when pushed by 12 N:

    >>> from dalembert import System, Unilateral, coordinates
    >>> x, y, z, th = coordinates("x y z theta")
    >>> for push in (2.0, 12.0):
    ...     push = push * np.array([np.cos(0.5), np.sin(0.5)])
    ...     cylinder = System([x, y, z, th], kinetic=(x.diff()**2 + y.diff()**2
    ...                       + z.diff()**2) / 2 + 0.02 / 2 * th.diff()**2,
    ...                       potential=9.81 * z - push[0] * x - push[1] * y,
    ...                       constraints=[Unilateral(z - 0.2, "floor", friction=0.3,
    ...                           tangents=[x.diff() + 0.2 * th.diff(), y.diff()])])
    ...     full = cylinder._closed(ClosedGaps((0,), held=(0,))).numeric()
    ...     gaps = Gaps.of(cylinder.definition.unilateral, 0, [0.0])
    ...     rest = np.zeros(4)
    ...     print(onset_holding(full, gaps, 0.0, np.array([0.0, 0.0, 0.2, 0.0]), rest,
    ...                         ClosedGaps((0,), sliding=(0,)), {0: np.zeros(2)}, [0]))
    (0,)
    ()
    """
    problem = _Responses(full, gaps, t, q, qd, which)
    found = _onset_solution(full, gaps, t, q, qd, which, directions, starting, problem)
    a, _ = problem.at(np.concatenate([found[k] for k in which.sliding]).astype(float))
    scale = 1.0 + float(np.abs(problem.a0).max(initial=0.0))
    return tuple(k for k in starting
                 if np.abs(a[problem.columns(k)]).max(initial=0.0) <= TOUCH_RTOL * scale)


def _coulomb_onset(problem: _Responses, contacts: list[int], cols: list[np.ndarray],
                   planes: list[np.ndarray], u: np.ndarray) -> np.ndarray | None:
    """``u`` (by tangent row) with the onset contacts' entries solving Coulomb's law at
    the level of accelerations, or ``None``: semismooth Newton's method on ``G(x) = x -
    proj(x + rho a(x))`` from ``u``, ``x`` each contact's ``u`` in its plane, ``proj``
    onto the unit disk, each contact's ``rho`` the inverse of the largest eigenvalue
    of its block (so that ``G`` is well scaled). ``G`` is 0 just where the law holds:
    inside the disk with ``a = 0`` (it holds), or on its rim with ``a`` along ``x``
    (it slides against its acceleration). Its generalized Jacobian ``I - P (I + rho
    da/dx)``, ``P`` the projection's (the identity inside, ``(I - z z^T / |z|^2) /
    |z|`` outside), ``da/dx`` by forward differences; the step the minimum-norm least
    squares one (where a body's forces are not unique, ``da/dx`` is singular), halved
    until ``|G|`` falls (undamped, the steps of a box coming to rest on its corners
    swung between 1e-3 and 1e2 without end). Where no fraction lowers it, ``x`` is a
    solution if ``G`` is within :data:`ONSET_STALLED` of 0; else a whole step is taken
    all the same (:data:`ONSET_FREE_STEPS` per solve), then the projection's own step
    (``x`` to the point projected, a step of the fixed-point iteration) where that
    lowers ``|G|``."""
    p = len(contacts)
    eps = np.finfo(float).eps

    def unpack(x: np.ndarray) -> np.ndarray:
        out = u.copy()
        for c in range(p):
            out[cols[c]] = planes[c] @ x[2 * c:2 * c + 2]
        return out

    def accelerations(x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        a, N = problem.at(unpack(x))
        return np.concatenate([planes[c].T @ a[cols[c]] for c in range(p)]), N

    def natural(x: np.ndarray, a: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``G``, the projected point and ``P`` at ``x`` with accelerations ``a``."""
        z = x + rho * a
        proj, P = z.copy(), np.zeros((2 * p, 2 * p))
        for c in range(p):
            part = z[2 * c:2 * c + 2]
            size = float(np.hypot(*part))
            if size > 1.0:
                unit = part / size
                proj[2 * c:2 * c + 2] = unit
                P[2 * c:2 * c + 2, 2 * c:2 * c + 2] = (np.eye(2) - np.outer(unit, unit)) / size
            else:
                P[2 * c:2 * c + 2, 2 * c:2 * c + 2] = np.eye(2)
        return x - proj, proj, P

    x = np.concatenate([planes[c].T @ u[cols[c]] for c in range(p)])
    a, N = accelerations(x)
    rho = np.ones(2 * p)
    for c, i in enumerate(contacts):  # its block: da/dx of its own u, -mu N E^T T E
        block = -planes[c].T @ problem.T[np.ix_(cols[c], cols[c])] @ planes[c] * N[i]
        top = float(np.abs(np.linalg.eigvalsh((block + block.T) / 2)).max())
        rho[2 * c:2 * c + 2] = 1.0 / top if top > 0.0 else 1.0
    G, proj, P = natural(x, a)
    free = ONSET_FREE_STEPS
    for _ in range(ONSET_ITERATIONS):
        if np.abs(G).max() <= ONSET_ROUNDING * eps:
            return unpack(proj)
        da = np.column_stack([(accelerations(x + ONSET_STEP * e)[0] - a) / ONSET_STEP
                              for e in np.eye(2 * p)])
        J = np.eye(2 * p) - P @ (np.eye(2 * p) + rho[:, None] * da)
        step = np.linalg.lstsq(J, -G, rcond=None)[0]
        if not np.all(np.isfinite(step)):
            return None
        size, fraction = float(np.linalg.norm(G)), 1.0
        while True:
            trial = x + fraction * step
            a_trial = accelerations(trial)[0]
            G_trial, proj_trial, P_trial = natural(trial, a_trial)
            if float(np.linalg.norm(G_trial)) < (1.0 - 1e-4 * fraction) * size:
                break
            fraction /= 2
            if fraction < ONSET_SMALLEST_STEP:
                if np.abs(G).max() <= ONSET_STALLED:  # its rounding, where it is that near
                    return unpack(proj)
                # else a whole step all the same (a few: Newton's method often recovers),
                # then the projection's own step, x -> proj
                trial = x + step if free else proj
                free -= 1
                a_trial = accelerations(trial)[0]
                G_trial, proj_trial, P_trial = natural(trial, a_trial)
                if free < 0 and not float(np.linalg.norm(G_trial)) < size:
                    return None
                break
        x, a, G, proj, P = trial, a_trial, G_trial, proj_trial, P_trial
    return None


def coulomb_impact(full: NumericModel, gaps: Gaps, t: float, q: np.ndarray,
                   qd: np.ndarray, candidates: np.ndarray, e: np.ndarray) -> Impact:
    """An impact on the gaps ``candidates`` with Coulomb friction: normal impulses
    ``P_n >= 0`` setting each acting gap's rate after to ``-e`` times its rate before
    (Newton's law; free to open faster), each contact's tangential impulse in the disk
    of radius ``mu P_n``, stopping its sliding or opposing the sliding it leaves
    (Moreau's impact law), as the time-stepping mode's impulses are found
    (:func:`~dalembert.solvers.contact.impulses.contact_impulses`, the bilateral rows
    holding).

    Parameters
    ----------
    full, gaps
        The model with every gap a row and its sliding velocities.
    t, q, qd
        The instant and the state before.
    candidates
        The gaps that may act (indices).
    e
        Newton's coefficient of every gap (0 where it does not approach).
    """
    n, m, pattern = full.n, full.m, full.pattern
    Mv, _, Av, _ = full.kkt_sparse(t, q, qd)
    _, b = full.velocity_sparse(t, q)
    kkt = kkt_factorization(pattern)
    kkt.factor(np.concatenate([Mv, Av]), gaps.acting(m, np.zeros(0, dtype=int)))
    found = contact_impulses(gaps, kkt, pattern.dense_A(Av), b, candidates, qd, qd, e)
    after = qd + found.velocity
    impulses = np.zeros(m)
    impulses[found.rows] = found.impulse
    lost = float(full.energies(t, q, qd)[0] - full.energies(t, q, after)[0])
    return Impact(after, impulses, matvec(pattern.A_cols, pattern.A_rows, Av, impulses, n),
                  lost)
