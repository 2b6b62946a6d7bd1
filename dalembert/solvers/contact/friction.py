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
per sliding contact, then a ``k x k`` system for the normal forces (:func:`solve_sliding`).
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
at rest sticks if its sticking force lies in the cone, and otherwise slides in the
direction its contact point accelerates in under the friction that opposes it
(:func:`slip_direction`): with one sliding velocity the direction that force cannot
hold (``d = -lambda_t / |lambda_t|``); with two, the unit ``d`` with ``a_t(d)``
along ``d``, a root in its angle, which is the direction of the excess only where
the contact's tangential mass is isotropic (a cylinder lying on a floor, rolling one
way and sliding the other, is not).
"""

from __future__ import annotations

from collections.abc import Callable, Container, Sequence
from dataclasses import dataclass, field

import numpy as np
from scipy.optimize import brentq

from ...codegen.compiled import NumericModel
from ...errors import SingularSystemError
from ...model.constraints import ClosedGaps
from ...numerics.rank import RANK_RTOL, dependent_rows
from ..impact import Impact
from ..kkt.factorization import KKTFactorization, kkt_factorization
from ..kkt.sparse import matvec
from .gaps import FORCE_RTOL, TOUCH_RTOL, Gaps, row_rates
from .impulses import contact_impulses

#: Samples of the slip direction's angle per half turn, to bracket its roots
#: (:func:`slip_direction`).
SLIP_SAMPLES = 24
#: :func:`consistent_directions`' Newton method: the difference step of its Jacobian
#: and the largest step it takes (radians: a start direction found with the other
#: contacts held may be half a radian off), and its most iterations (it converges in
#: two or three from the last directions found).
CONSISTENT_STEP = 1e-7
CONSISTENT_TURN = 1.0
CONSISTENT_ITERATIONS = 12


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


def friction_directions(full: NumericModel, gaps: Gaps, k: int, Av: np.ndarray,
                        d: np.ndarray) -> np.ndarray:
    """``-mu A_t^T d``: the generalized force of gap ``k``'s friction per unit normal
    force, sliding along ``d`` (``Av``: the values of ``full``'s rows)."""
    pattern = full.pattern
    weights = np.zeros(full.m)
    weights[gaps.tangents[k]] = d
    assert gaps.friction is not None
    return -gaps.friction[k] * matvec(pattern.A_cols, pattern.A_rows, Av, weights, full.n)


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
    return _sliding_solver(full, gaps, t, q, qd, which, kkt, values, acting)(directions)


def _sliding_solver(full: NumericModel, gaps: Gaps, t: float, q: np.ndarray,
                    qd: np.ndarray, which: ClosedGaps, kkt: KKTFactorization | None = None,
                    values: tuple[np.ndarray, ...] | None = None,
                    acting: np.ndarray | None = None
                    ) -> Callable[[dict[int, np.ndarray]], tuple[np.ndarray, np.ndarray]]:
    """:func:`solve_sliding` at one state for any sliding directions: the KKT matrix
    factored and the solve without friction made once, each call then one solve per
    sliding gap (the searches for directions try many at one state). ``kkt`` holds
    this factorization only until it is factored again."""
    Mv, f, Av, c = values if values is not None else full.kkt_sparse(t, q, qd)
    kkt = kkt or kkt_factorization(full.pattern)
    if acting is None:
        acting = acting_rows(full, gaps, t, q, which)
    kkt.factor(np.concatenate([Mv, Av]), acting)
    qdd0, lam0 = kkt.solve(np.concatenate([f, c]))
    # dependent rows left out: every multiplier the minimum-norm one (a linear map of
    # the kept rows' ones, so the sliding contacts' normal forces stay linear below)
    spread = _minimum_norm(full, gaps, Av, which, acting)
    lam0 = spread(lam0)
    sliding = which.sliding
    zeros = np.zeros(full.m)
    normal = gaps.first + np.array(sliding, dtype=int)
    friction = gaps.friction

    def solve(directions: dict[int, np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
        qdd, lam = qdd0, lam0
        if not sliding:
            return qdd, lam
        assert friction is not None  # (sliding gaps have coefficients)
        D = [friction_directions(full, gaps, k, Av, directions[k]) for k in sliding]
        responses = [(qdd_k, spread(lam_k)) for qdd_k, lam_k in
                     (kkt.solve(np.concatenate([d, zeros])) for d in D)]
        # lambda_n = lambda0_n + R N with N = lambda_n: (I - R) N = lambda0_n
        R = np.array([lam_k[normal] for _, lam_k in responses]).T
        try:
            N = np.linalg.solve(np.eye(len(sliding)) - R, lam[normal])
        except np.linalg.LinAlgError as exc:  # their normal forces are not unique
            raise SingularSystemError("the sliding contacts' normal rows are dependent") \
                from exc
        for n_k, (qdd_k, lam_k) in zip(N, responses):
            qdd = qdd + n_k * qdd_k
            lam = lam + n_k * lam_k
        for k, n_k in zip(sliding, N):
            lam[gaps.tangents[k]] = -friction[k] * n_k * directions[k]
        return qdd, lam

    return solve


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
        ``starts``), which take :func:`consistent_directions`.
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
        #: The last consistent direction found, by gap (see :meth:`restart`).
        self.last: dict[int, np.ndarray] = {}

    def restart(self) -> None:
        """Forget the last consistent directions (a segment starts)."""
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
            directions = consistent_directions(full, gaps, t, q, qd, which, directions,
                                               starting, self.kkt, self.acting)
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
    the module docstring): the held ones of ``start`` whose sticking force leaves the
    cone slide, one at a time, the worst first, along :func:`slip_direction`;
    ``slipping``, a gap whose force has just reached the cone, slides.

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
        chosen.held.discard(worst)
        chosen.directions[worst] = -force / size  # sliding, for the set slip_direction sees
        chosen.directions[worst] = slip_direction(full, gaps, t, q, qd, chosen.of(closed),
                                                  chosen.directions, worst, -force / size,
                                                  kkt)
        resting.remove(worst)
        slipping = None
    # each found with the others fixed as they were then: together (the corners of a
    # body, whose contact points' accelerations are coupled)
    started = [k for k in chosen.directions
               if k not in start.directions and len(gaps.tangents[k]) in (2, 3)]
    if len(started) > 1:
        chosen.directions = consistent_directions(full, gaps, t, q, qd, chosen.of(closed),
                                                  chosen.directions, started, kkt)
    return chosen


def slip_direction(full: NumericModel, gaps: Gaps, t: float, q: np.ndarray,
                   qd: np.ndarray, which: ClosedGaps, directions: dict[int, np.ndarray],
                   k: int, guess: np.ndarray, kkt: KKTFactorization | None = None
                   ) -> np.ndarray:
    """The direction in which gap ``k``, at rest, starts to slide with the closed set
    ``which`` (``k`` among its sliding gaps, the others' directions in
    ``directions``): the unit ``d`` along which its tangential acceleration points
    under its friction force ``-mu lambda_n d`` (``a_t(d) = s d``, ``s > 0``), the
    normal force and every other force solved with it (:func:`solve_sliding`).

    With one sliding velocity that is ``guess``, the direction of the sticking force
    the contact cannot hold (``-lambda_t / |lambda_t|``), and so it is where the
    contact's tangential mass (the block ``W_tt`` of its sliding velocities in the
    Delassus matrix) is isotropic. With two it is a root in the angle of ``d``: the
    cross product of ``d`` and ``a_t(d)``, sampled around the circle, its sign
    changes where ``a_t . d > 0`` refined by Brent's method; the root nearest
    ``guess`` is taken (at a contact whose force has just reached its cone, ``a_t``
    is 0 along ``guess``, which is then the root: the onset there). Three of rank 2
    (world components, as between two spheres) are searched alike in their plane
    (:func:`sliding_plane`). Other counts keep ``guess``, as does a contact whose
    ``a_t`` does not depend on ``d`` (other held rows fix its contact point) or that
    has no such root.

    Parameters
    ----------
    full, gaps
        The model with every gap a row and its sliding velocities.
    t, q, qd
        The state (the inputs as ``full`` holds them).
    which
        The closed set, ``k`` sliding.
    directions
        Each sliding gap's unit direction (``k``'s is replaced by the trial ones).
    k
        The gap starting to slide.
    guess
        The direction of its excess sticking force (a unit vector).
    kkt
        A factorization object of ``full``'s pattern to reuse.

    Examples
    --------
    A cylinder (``I = m r^2 / 2``) lying on a floor, its axis along ``y``, pushed at
    its axis by 12 N at 0.5 rad from ``x``: along ``x`` its contact point has three
    times the inverse mass it has along ``y``, so it slides at 42.8 degrees, not
    along the excess force (58.6 degrees):

    >>> from dalembert import System, Unilateral, coordinates
    >>> x, y, z, th = coordinates("x y z theta")
    >>> push = 12.0 * np.array([np.cos(0.5), np.sin(0.5)])
    >>> cylinder = System([x, y, z, th], kinetic=(x.diff()**2 + y.diff()**2
    ...                   + z.diff()**2) / 2 + 0.02 / 2 * th.diff()**2,
    ...                   potential=9.81 * z - push[0] * x - push[1] * y,
    ...                   constraints=[Unilateral(z - 0.2, "floor", friction=0.3,
    ...                       tangents=[x.diff() + 0.2 * th.diff(), y.diff()])])
    >>> which = ClosedGaps((0,), sliding=(0,))
    >>> full = cylinder._closed(ClosedGaps((0,), held=(0,))).numeric()
    >>> gaps = Gaps.of(cylinder.definition.unilateral, 0, [0.0])
    >>> q, rest = np.array([0.0, 0.0, 0.2, 0.0]), np.zeros(4)
    >>> excess = np.array([push[0] / 3, push[1]]) / np.hypot(push[0] / 3, push[1])
    >>> d = slip_direction(full, gaps, 0.0, q, rest, which, {0: excess}, 0, excess)
    >>> round(float(np.degrees(np.arctan2(d[1], d[0]))), 4)
    42.8019
    """
    plane = sliding_plane(full, gaps, t, q, qd, k)
    if plane is None:
        return guess
    rates = _row_accelerations(full, gaps, t, q, qd, which, directions, kkt)
    rows = gaps.tangents[k]

    def accel(angle: float) -> np.ndarray:
        return plane.T @ rates({k: plane @ _unit(angle)})[rows]

    def cross(angle: float) -> float:
        a = accel(angle)
        return float(np.cos(angle) * a[1] - np.sin(angle) * a[0])

    inplane = plane.T @ guess
    start = float(np.arctan2(inplane[1], inplane[0]))
    # a whole turn centred on the guess, which is a sample (a root there is exact)
    angles = start + np.linspace(-np.pi, np.pi, 2 * SLIP_SAMPLES + 1)
    sampled = [accel(a) for a in angles]
    signs = [float(np.cos(a) * v[1] - np.sin(a) * v[0]) for a, v in zip(angles, sampled)]
    scale = 1.0 + max(float(np.linalg.norm(v)) for v in sampled)
    if max(float(np.linalg.norm(v - sampled[0])) for v in sampled) <= TOUCH_RTOL * scale:
        # its friction does not move it (other held rows fix its contact point): any
        # root would be rounding's
        return guess
    roots = []
    for i in range(len(angles) - 1):
        f0, f1 = signs[i], signs[i + 1]
        if f0 == 0.0 or f0 * f1 < 0.0:
            angle = angles[i] if f0 == 0.0 else \
                brentq(cross, angles[i], angles[i + 1], xtol=1e-15, rtol=1e-15)
            # sliding along d, not against it (a_t = s d with s < 0 is no solution)
            if float(accel(angle) @ _unit(angle)) >= -TOUCH_RTOL * scale:
                roots.append(float(angle))
    if not roots:  # no direction it can slide in (a contact problem without a solution)
        return guess
    best = min(roots, key=lambda a: abs(a - start))
    return plane @ _unit(best)


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


def consistent_directions(full: NumericModel, gaps: Gaps, t: float, q: np.ndarray,
                          qd: np.ndarray, which: ClosedGaps,
                          directions: dict[int, np.ndarray], starting: Sequence[int],
                          kkt: KKTFactorization | None = None,
                          acting: np.ndarray | None = None) -> dict[int, np.ndarray]:
    """The directions of the friction of the gaps ``starting`` while they start to
    slide from rest together: the unit ``d_k`` along which each one's tangential
    acceleration points (``a_t(k) = s_k d_k``, ``s_k >= 0``, as
    :func:`slip_direction` finds one at its onset, the others held), all at once,
    by Newton's method on their angles from ``directions`` (the last ones found).

    Why not the sliding velocity's direction ``v / |v|``: near ``v = 0`` that turns
    at a rate of about ``|a_t| / |v|`` towards this one wherever the contact's
    tangential mass is anisotropic (a cylinder rolling one way and sliding the
    other), a stiffness without bound that stalls an explicit method at the onset,
    and where ``v`` is rounding's it points anywhere (the corners of a box). The
    motion follows this direction within ``O(|v|)`` there (its slow manifold), so a
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
        Each sliding gap's unit direction (those of ``starting``: near the ones
        sought).
    starting
        The gaps starting to slide.
    kkt
        A factorization object of ``full``'s pattern to reuse.
    acting
        The rows that act (:func:`acting_rows`) if the caller has them.

    Returns
    -------
    dict
        ``directions`` with those of ``starting`` replaced (kept where Newton's
        method finds no such directions near them).

    Examples
    --------
    The cylinder of :func:`slip_direction`'s example, from a direction 0.2 rad off:

    >>> from dalembert import System, Unilateral, coordinates
    >>> x, y, z, th = coordinates("x y z theta")
    >>> push = 12.0 * np.array([np.cos(0.5), np.sin(0.5)])
    >>> cylinder = System([x, y, z, th], kinetic=(x.diff()**2 + y.diff()**2
    ...                   + z.diff()**2) / 2 + 0.02 / 2 * th.diff()**2,
    ...                   potential=9.81 * z - push[0] * x - push[1] * y,
    ...                   constraints=[Unilateral(z - 0.2, "floor", friction=0.3,
    ...                       tangents=[x.diff() + 0.2 * th.diff(), y.diff()])])
    >>> which = ClosedGaps((0,), sliding=(0,))
    >>> full = cylinder._closed(ClosedGaps((0,), held=(0,))).numeric()
    >>> gaps = Gaps.of(cylinder.definition.unilateral, 0, [0.0])
    >>> q, rest = np.array([0.0, 0.0, 0.2, 0.0]), np.zeros(4)
    >>> near = np.array([np.cos(0.95), np.sin(0.95)])
    >>> d = consistent_directions(full, gaps, 0.0, q, rest, which, {0: near}, [0])[0]
    >>> round(float(np.degrees(np.arctan2(d[1], d[0]))), 4)
    42.8019
    """
    planes = [sliding_plane(full, gaps, t, q, qd, k) for k in starting]
    if any(plane is None for plane in planes):
        return dict(directions)
    E = [plane for plane in planes if plane is not None]
    accelerations = _row_accelerations(full, gaps, t, q, qd, which, directions, kkt, acting)
    rows = [gaps.tangents[k] for k in starting]

    def residual(angles: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Each one's ``a_t`` across its direction, and along it."""
        rates = accelerations({k: e @ _unit(angle)
                               for k, e, angle in zip(starting, E, angles)})
        a = np.array([e.T @ rates[r] for e, r in zip(E, rows)])
        return np.cos(angles) * a[:, 1] - np.sin(angles) * a[:, 0], \
            np.cos(angles) * a[:, 0] + np.sin(angles) * a[:, 1]

    inplane = [e.T @ directions[k] for e, k in zip(E, starting)]
    angles = np.array([np.arctan2(d[1], d[0]) for d in inplane])
    for _ in range(CONSISTENT_ITERATIONS):
        across, along = residual(angles)
        J = np.column_stack([(residual(angles + CONSISTENT_STEP * e)[0] - across)
                             / CONSISTENT_STEP for e in np.eye(len(angles))])
        step = np.linalg.lstsq(J, -across, rcond=None)[0]
        if not np.all(np.isfinite(step)) or np.abs(step).max() > CONSISTENT_TURN:
            break  # not near such directions: keep the last ones
        angles = angles + step
        if np.abs(step).max() <= 4 * np.finfo(float).eps * (1.0 + np.abs(angles).max()):
            if np.all(along >= -TOUCH_RTOL * (1.0 + np.abs(along).max())):
                return {**directions, **{k: e @ _unit(a)
                                         for k, e, a in zip(starting, E, angles)}}
            break
    if len(starting) == 1:  # the whole search around the circle
        (k,) = starting
        return {**directions, k: slip_direction(full, gaps, t, q, qd, which, directions, k,
                                                directions[k], kkt)}
    return dict(directions)


def _unit(angle: float) -> np.ndarray:
    return np.array([np.cos(angle), np.sin(angle)])


def _row_accelerations(full: NumericModel, gaps: Gaps, t: float, q: np.ndarray,
                       qd: np.ndarray, which: ClosedGaps, directions: dict[int, np.ndarray],
                       kkt: KKTFactorization | None, acting: np.ndarray | None = None
                       ) -> Callable[[dict[int, np.ndarray]], np.ndarray]:
    """``rates(trial)``: the rates of change of the rates of every row of ``full``
    (``A qdd - c``; a sliding velocity's is its contact point's tangential
    acceleration) with the closed set ``which``, the sliding gaps along ``directions``
    but those of ``trial`` along theirs."""
    values = full.kkt_sparse(t, q, qd)
    _, _, Av, c = values
    pattern = full.pattern
    solve = _sliding_solver(full, gaps, t, q, qd, which, kkt, values, acting)

    def rates(trial: dict[int, np.ndarray]) -> np.ndarray:
        qdd, _ = solve({**directions, **trial})
        return matvec(pattern.A_rows, pattern.A_cols, Av, qdd, full.m) - c

    return rates


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
