"""Contact impulses from the Delassus matrix: the complementarity problems of a
time step and of an impact with friction.

With the bilateral rows held by one KKT factorization, a unit impulse on each contact
row (normal, then the sliding velocities of each contact) changes the velocities by
one solve each; the Delassus matrix ``W = A_c K^-1 A_c^T`` maps impulses to the
contact rows' velocities. The impulses ``P`` then solve, with ``w = W P + q``,

- without friction, the LCP ``0 <= P  _|_  w >= 0`` (:func:`solve_lcp`, exact);
- with Coulomb friction, the normal LCP together with each contact's tangential
  impulse in the disk of radius ``mu`` times its normal one, sticking or opposing the
  sliding it leaves (:func:`solve_friction`).

Both the time-stepping mode's steps and the event-driven mode's impacts on frictional
contacts (Moreau's impact law) solve them (:func:`contact_impulses`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ...errors import ContactError
from ..kkt.factorization import KKTFactorization
from .gaps import TOUCH_RTOL, Gaps

#: Principal pivots of :func:`solve_lcp` per contact before it gives up.
PIVOTS_PER_CONTACT = 50
#: Projected Gauss-Seidel sweeps of :func:`solve_friction` before it gives up.
MAX_SWEEPS = 10_000
#: :func:`solve_friction` ends where the velocities are within this of where its sweeps
#: take them (relative to their size: :func:`_settled`) and the laws hold to
#: ``RESIDUAL_RTOL`` there (:func:`_residual`).
VELOCITY_RTOL, RESIDUAL_RTOL = 1e-14, 1e-10


@dataclass(frozen=True)
class ContactImpulses:
    """The impulses on a set of contact rows and what they do.

    Attributes
    ----------
    rows
        The rows (the contacts' normals, then their sliding velocities).
    impulse
        The impulse on each of ``rows``.
    velocity
        The velocity change they make, the bilateral rows held.
    reaction
        The impulses they make on every row of the KKT system (the bilateral ones'
        reactions among them).
    """

    rows: np.ndarray
    impulse: np.ndarray
    velocity: np.ndarray
    reaction: np.ndarray


def contact_impulses(gaps: Gaps, kkt: KKTFactorization, A: np.ndarray, b: np.ndarray,
                     contacts: np.ndarray, before: np.ndarray, free: np.ndarray,
                     restitution: np.ndarray, start: np.ndarray | None = None
                     ) -> ContactImpulses:
    """The impulses on the gaps ``contacts`` (and their sliding velocities, with
    friction) that leave each acting gap's rate at ``-e`` times its rate ``before``
    (Newton's law; an open one free to move away), from the velocities ``free`` they
    act on (see the module docstring).

    Parameters
    ----------
    gaps
        Where the gaps are, their sliding velocities and friction.
    kkt
        The KKT factorization with the bilateral rows active.
    A, b
        The rows of the model with every gap (dense) and their ``b``.
    contacts
        The gaps that may act (indices).
    before
        The velocities whose gap rates Newton's law reverses.
    free
        The velocities without the contact impulses.
    restitution
        Newton's coefficient of every gap.
    start
        Impulses on every row to start the friction's sweeps from (the step before's;
        ``None``: 0).

    Examples
    --------
    A unit mass at a floor, falling at 1 with e = 0.5, takes the impulse 1.5:

    >>> from dalembert.solvers.kkt.factorization import kkt_factorization
    >>> from dalembert import System, Unilateral, coordinates
    >>> (y,) = coordinates("y")
    >>> full = System([y], kinetic=y.diff()**2 / 2,
    ...               constraints=[Unilateral(y, "floor")]).with_gaps_closed().numeric()
    >>> gaps = Gaps(("floor",), 0, np.array([0.5]), np.array([1e-6]))
    >>> kkt = kkt_factorization(full.pattern)
    >>> Mv, _, Av, _ = full.kkt_sparse(0.0, np.zeros(1), np.array([-1.0]))
    >>> kkt.factor(np.concatenate([Mv, Av]), np.zeros(1, dtype=bool))
    >>> v = np.array([-1.0])
    >>> found = contact_impulses(gaps, kkt, full.pattern.dense_A(Av), np.zeros(1),
    ...                          np.array([0]), v, v, gaps.restitution)
    >>> found.impulse.tolist(), (v + found.velocity).tolist()
    ([1.5], [0.5])
    """
    n = len(free)
    normal = gaps.first + contacts
    sliding = [gaps.tangents[k] if gaps.tangents else np.zeros(0, dtype=int)
               for k in contacts]
    rows = np.concatenate([normal, *sliding]).astype(int)
    unit = np.zeros((n + A.shape[0], len(rows)))
    unit[:n] = A[rows].T  # a unit impulse on each row
    response, reaction = kkt.solve(unit)  # the velocity change and the rows' impulses
    W = A[rows] @ response
    q = A[rows] @ free + b[rows]
    rate = A[normal] @ before + b[normal]
    q[:len(normal)] += restitution[contacts] * np.minimum(rate, 0.0)  # Newton's law
    if len(rows) == len(normal):  # no friction: the exact LCP
        impulse = solve_lcp(W, q)
    else:
        assert gaps.friction is not None  # tangent rows come with coefficients
        groups, at = [], len(normal)
        for tangents in sliding:
            groups.append(np.arange(at, at + len(tangents)))
            at += len(tangents)
        # a rough contact grips with any impulse its normal one allows (none without one)
        mu = np.minimum(gaps.friction[contacts], np.finfo(float).max)
        impulse = solve_friction(W, q, mu, groups,
                                 None if start is None else start[rows])
    return ContactImpulses(rows, impulse, response @ impulse, reaction @ impulse)


def solve_lcp(W: np.ndarray, q: np.ndarray) -> np.ndarray:
    """``P >= 0`` with ``w = W P + q >= 0`` and ``P . w = 0`` (``W`` symmetric positive
    semidefinite: a Delassus matrix), by Murty's principal pivoting with the least-index
    rule (finite for positive definite ``W``).

    Parameters
    ----------
    W
        The ``(k, k)`` matrix.
    q
        The ``k`` constants.

    Raises
    ------
    ContactError
        No solution found (a singular ``W`` whose pivoting cycles).

    Examples
    --------
    >>> solve_lcp(np.array([[2.0, 1.0], [1.0, 2.0]]), np.array([-3.0, 1.0]))
    array([1.5, 0. ])
    """
    k = len(q)
    chosen = np.zeros(k, dtype=bool)
    scale = TOUCH_RTOL * (1.0 + np.abs(q).max(initial=0.0))
    for _ in range(PIVOTS_PER_CONTACT * max(k, 1)):
        P = np.zeros(k)
        if chosen.any():
            sub = W[np.ix_(chosen, chosen)]
            P[chosen] = np.linalg.lstsq(sub, -q[chosen], rcond=None)[0]
        w = W @ P + q
        wrong = np.where(chosen, -scale > P, w < -scale)
        if not wrong.any():
            return np.maximum(P, 0.0)
        first = int(np.argmax(wrong))
        chosen[first] = not chosen[first]
    raise ContactError(f"the contact impulses of a step ({k} contacts) were not found: "
                       "principal pivoting did not end")


def solve_friction(W: np.ndarray, q: np.ndarray, mu: np.ndarray,
                   tangents: list[np.ndarray], start: np.ndarray | None = None
                   ) -> np.ndarray:
    """The contact impulses with Coulomb friction: ``k`` normal impulses first (an LCP
    as in :func:`solve_lcp`), then each contact's tangential ones, in the disk of
    radius ``mu`` times its normal one and opposing the sliding velocity ``w`` they
    leave, or holding it at 0 (sticking): ``w = W P + q`` (:class:`_Disk`). Solved by
    projected Gauss-Seidel over the contacts (each contact's tangential block at once),
    from ``start`` (0 by default), until the velocities ``w`` are within
    :data:`VELOCITY_RTOL` of where the sweeps take them (the changes still to come
    counted at the rate they fall: :func:`_settled`) and they satisfy the laws
    (:func:`_residual`).

    It stops on the velocities, which the laws fix, not on the impulses: where those
    are not unique (a box on four coplanar corners: four normal rows of rank 3, eight
    tangent rows of rank 3) the impulses returned are the sweeps' iterate from
    ``start`` at that point, one of the solutions; the velocities, and the total force
    and moment they make, are the same for every one.

    Parameters
    ----------
    W, q
        The Delassus matrix over the normal rows then the tangent rows, and the
        velocities without impulses (Newton's law folded into the normal ones).
    mu
        Each contact's coefficient.
    tangents
        Each contact's tangent rows' places in ``W`` (empty without friction).
    start
        The impulses to start the sweeps from (``None``: 0); where the impulses are not
        unique, which solution is returned depends on it.

    Raises
    ------
    ContactError
        No convergence in :data:`MAX_SWEEPS` sweeps.

    Examples
    --------
    A unit mass pressed on a floor with an impulse 1 (its normal velocity -1 without
    impulse), sliding at 2: friction 0.5 takes 0.5 of its speed; at 0.1 m/s it sticks:

    >>> W = np.eye(2)
    >>> solve_friction(W, np.array([-1.0, 2.0]), np.array([0.5]), [np.array([1])])
    array([ 1. , -0.5])
    >>> solve_friction(W, np.array([-1.0, 0.1]), np.array([0.5]), [np.array([1])])
    array([ 1. , -0.1])
    """
    P, _, change = _sweeps(W, q, mu, tangents, start)
    if P is None:
        raise ContactError(f"the contact impulses with friction of a step ({len(mu)} "
                           f"contacts) did not converge in {MAX_SWEEPS} sweeps (their "
                           f"velocities still changed by {change:.1e} of their size in "
                           "the last)")
    return P


def _sweeps(W: np.ndarray, q: np.ndarray, mu: np.ndarray, tangents: list[np.ndarray],
            start: np.ndarray | None = None) -> tuple[np.ndarray | None, int, float]:
    """:func:`solve_friction`'s sweeps: the impulses (``None``: no convergence), how
    many sweeps were made, and the velocities' change in the last relative to their
    size."""
    k = len(mu)
    P = np.zeros(len(q)) if start is None else np.array(start, dtype=float)
    P[:k] = np.maximum(P[:k], 0.0)  # a start's normal ones pushing (the sweeps then
    # put each tangential one in its disk)
    diagonal = np.diag(W).tolist()
    normal_rows, normal_q = [W[c] for c in range(k)], q[:k].tolist()
    # each contact's tangential rows without its own columns (the velocities the
    # others leave it) and its block decomposed, once per solve: a sweep needs them for
    # every contact, and redoing that each sweep was most of its cost
    blocks: list[tuple[slice | np.ndarray, np.ndarray, np.ndarray, _Disk] | None] = []
    for rows in tangents:
        if not len(rows):
            blocks.append(None)
            continue
        others = W[rows].copy()
        others[:, rows] = 0.0
        contiguous = bool(np.all(np.diff(rows) == 1))
        place = slice(int(rows[0]), int(rows[-1]) + 1) if contiguous else rows
        blocks.append((place, others, q[rows], _Disk(W[np.ix_(rows, rows)])))
    w, scale, change = W @ P + q, float(np.abs(q).max(initial=0.0)), math.inf
    size = np.abs(W)
    for sweep in range(1, MAX_SWEEPS + 1):
        for c in range(k):
            if diagonal[c] > 0:
                P[c] = max(0.0, P[c] - (normal_rows[c] @ P + normal_q[c]) / diagonal[c])
            block = blocks[c]
            if block is not None:
                place, others, q_rows, disk = block
                rest = others @ P + q_rows
                P[place] = disk.impulse(rest.tolist(), mu[c] * P[c])
        before, w = w, W @ P + q
        scale = max(scale, float(np.abs(w).max(initial=0.0)))
        last, change = change, float(np.abs(w - before).max(initial=0.0))
        if _settled(change, last, scale, size @ np.abs(P)) and (
                _residual(W, w, P, mu, tangents) <= RESIDUAL_RTOL * scale):
            return P, sweep, change / max(scale, np.finfo(float).tiny)
    return None, MAX_SWEEPS, change / max(scale, np.finfo(float).tiny)


def _settled(change: float, last: float, scale: float, sizes: np.ndarray) -> bool:
    """Whether the velocities are where the sweeps take them, to ``VELOCITY_RTOL`` of
    ``scale`` (the largest velocity seen): their ``change`` over the last sweep
    (``last`` over the one before) within their rounding (``sizes``: ``|W| |P|``), or
    within the tolerance with the changes still to come, ``change r / (1 - r)`` at the
    rate ``r = change / last`` (Gauss-Seidel converges linearly), too."""
    if change <= 8 * np.finfo(float).eps * (scale + float(sizes.max(initial=0.0))):
        return True
    tolerance = VELOCITY_RTOL * scale
    rate = change / last if last > 0.0 else math.inf
    return change <= tolerance and rate < 1.0 and change * rate <= tolerance * (1 - rate)


def _residual(W: np.ndarray, w: np.ndarray, P: np.ndarray, mu: np.ndarray,
              tangents: list[np.ndarray]) -> float:
    """How far the impulses ``P`` and their velocities ``w = W P + q`` are from the
    laws, as a velocity: each normal row's ``min(d P, w)`` (``d`` its diagonal), each
    contact's ``d (p - proj(p - w / d))``, ``p`` its tangential impulse and ``w`` its
    sliding velocity, ``proj`` onto its disk, ``d`` its block's largest diagonal. It is
    0 just where the laws hold: ``p`` inside the disk with ``w = 0`` (sticking) or on
    its rim against ``w`` (sliding)."""
    k = len(mu)
    diagonal = np.diag(W)
    worst = float(np.abs(np.minimum(P[:k] * diagonal[:k], w[:k])).max(initial=0.0))
    for c, rows in enumerate(tangents):
        d = float(diagonal[rows].max(initial=0.0))
        if d <= 0.0:
            continue
        radius = mu[c] * P[c]
        trial = P[rows] - w[rows] / d
        size = float(np.linalg.norm(trial))
        if size > radius:
            trial = trial * (radius / size)
        worst = max(worst, d * float(np.abs(P[rows] - trial).max()))
    return worst


class _Disk:
    """One contact's tangential law, its block ``B = V diag(values) V^T`` decomposed
    once per solve, :meth:`impulse` once per sweep. In plain floats: a block has 1 or
    2 rows, where each array operation costs more than its arithmetic."""

    def __init__(self, block: np.ndarray):
        values, vectors = np.linalg.eigh(block)
        self.vectors: list[list[float]] = vectors.tolist()
        # the least-squares sticking impulse leaves out the small eigenvalues, as a
        # least-squares solve's cutoff leaves out the small singular values
        cutoff = np.finfo(float).eps * len(values) * float(np.abs(values).max())
        self.inverse = [1.0 / v if abs(v) > cutoff else 0.0 for v in values.tolist()]
        self.values = [max(v, 0.0) for v in values.tolist()]

    def impulse(self, rest: list[float], radius: float) -> list[float]:
        """The tangential impulse ``p``: sticking (``B p + rest = 0``, least squares)
        if that lies in the disk of ``radius``, else on its rim opposing the sliding
        velocity it leaves, ``p = -radius w / |w|``, ``w = B p + rest``. Not the
        sticking impulse scaled onto the rim: with an anisotropic ``B`` (a box's
        corner, whose rotation couples its two tangents) that one pushes askew, yawing
        a sliding box and braking it by less than ``mu N``. With ``p = -w / s``
        (``s = |w| / radius``): ``p = -(s + B)^-1 rest``, whose size falls with ``s``;
        ``s`` by Newton's method on ``1 / |p(s)| = 1 / radius`` (concave in ``s``: from
        below it does not overshoot), kept in a bisection's bracket.

        >>> disk, rest = _Disk(np.diag([1.0, 4.0])), [2.0, 2.0]
        >>> p = np.array(disk.impulse(rest, 0.1))
        >>> w = np.diag([1.0, 4.0]) @ p + rest
        >>> bool(np.allclose(p, -0.1 * w / np.linalg.norm(w), rtol=0, atol=1e-15))
        True
        """
        if radius <= 0.0:
            return [0.0] * len(rest)
        if len(rest) == 2:  # in space: the same, written out
            return self._two(rest, radius)
        along = [sum(row[j] * r for row, r in zip(self.vectors, rest))
                 for j in range(len(rest))]  # V^T rest
        stick = [a * u for a, u in zip(along, self.inverse)]
        if math.hypot(*stick) <= radius:
            return self._back(stick, -1.0)
        values = self.values
        low, high = 0.0, math.hypot(*rest) / radius  # at high: |p| <= radius
        s = 0.0 if min(values) > 0.0 else high / 2  # (a singular B: |p(0)| unbounded)
        for _ in range(200):
            term = [a / (s + v) for a, v in zip(along, values)]
            size = math.hypot(*term)
            low, high = (s, high) if size > radius else (low, s)
            slope = sum(t * t / (s + v) for t, v in zip(term, values)) / size**3
            step = s + (1.0 / radius - 1.0 / size) / slope  # slope: d(1 / size)/ds
            if step == s:
                break
            s = step if low < step < high else (low + high) / 2
            if s in (low, high):
                break
        term = [a / (s + v) for a, v in zip(along, values)]
        return self._back(term, -radius / math.hypot(*term))  # on the rim to rounding

    def _two(self, rest: list[float], radius: float) -> list[float]:
        """:meth:`impulse` for two rows, its sums written out (a third of the time)."""
        (v00, v01), (v10, v11) = self.vectors
        r0, r1 = rest
        a0, a1 = v00 * r0 + v10 * r1, v01 * r0 + v11 * r1  # V^T rest
        t0, t1 = a0 * self.inverse[0], a1 * self.inverse[1]
        if math.hypot(t0, t1) <= radius:  # sticking
            return [-(v00 * t0 + v01 * t1), -(v10 * t0 + v11 * t1)]
        l0, l1 = self.values
        low, high = 0.0, math.hypot(r0, r1) / radius
        s = 0.0 if min(l0, l1) > 0.0 else high / 2
        for _ in range(200):
            t0, t1 = a0 / (s + l0), a1 / (s + l1)
            size = math.hypot(t0, t1)
            low, high = (s, high) if size > radius else (low, s)
            slope = (t0 * t0 / (s + l0) + t1 * t1 / (s + l1)) / size**3
            step = s + (1.0 / radius - 1.0 / size) / slope
            if step == s:
                break
            s = step if low < step < high else (low + high) / 2
            if s in (low, high):
                break
        t0, t1 = a0 / (s + l0), a1 / (s + l1)
        factor = -radius / math.hypot(t0, t1)
        return [factor * (v00 * t0 + v01 * t1), factor * (v10 * t0 + v11 * t1)]

    def _back(self, along: list[float], factor: float) -> list[float]:
        """``factor V along``."""
        return [factor * sum(v * a for v, a in zip(row, along)) for row in self.vectors]
