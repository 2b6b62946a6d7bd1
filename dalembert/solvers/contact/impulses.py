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

from dataclasses import dataclass

import numpy as np

from ...errors import ContactError
from ..kkt.factorization import KKTFactorization
from .gaps import TOUCH_RTOL, Gaps

#: Principal pivots of :func:`solve_lcp` per contact before it gives up.
PIVOTS_PER_CONTACT = 50
#: Projected Gauss-Seidel sweeps of :func:`solve_friction` before it gives up.
MAX_SWEEPS = 10_000


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
                     restitution: np.ndarray) -> ContactImpulses:
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
        impulse = solve_friction(W, q, mu, groups)
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
                   tangents: list[np.ndarray]) -> np.ndarray:
    """The contact impulses with Coulomb friction: ``k`` normal impulses first (an LCP
    as in :func:`solve_lcp`), then each contact's tangential ones, in the disk of
    radius ``mu`` times its normal one and opposing the sliding velocity ``w`` they
    leave, or holding it at 0 (sticking): ``w = W P + q`` (:func:`_coulomb`). Solved by projected
    Gauss-Seidel over the contacts (each contact's tangential block at once) until the
    impulses change by less than rounding.

    Parameters
    ----------
    W, q
        The Delassus matrix over the normal rows then the tangent rows, and the
        velocities without impulses (Newton's law folded into the normal ones).
    mu
        Each contact's coefficient.
    tangents
        Each contact's tangent rows' places in ``W`` (empty without friction).

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
    k = len(mu)
    P = np.zeros(len(q))
    diagonal = np.diag(W).copy()
    for _ in range(MAX_SWEEPS):
        before = P.copy()
        for c in range(k):
            if diagonal[c] > 0:
                P[c] = max(0.0, P[c] - (W[c] @ P + q[c]) / diagonal[c])
            rows = tangents[c]
            if len(rows):
                block = W[np.ix_(rows, rows)]
                rest = W[rows] @ P + q[rows] - block @ P[rows]  # without its own
                P[rows] = _coulomb(block, rest, mu[c] * P[c])
        if np.abs(P - before).max(initial=0.0) <= 1e-14 * (1.0 + np.abs(P).max(initial=0.0)):
            return P
    raise ContactError(f"the contact impulses with friction of a step ({k} contacts) did "
                       f"not converge in {MAX_SWEEPS} sweeps")


def _coulomb(block: np.ndarray, rest: np.ndarray, radius: float) -> np.ndarray:
    """One contact's tangential impulse ``p``: sticking (``block p + rest = 0``) if that
    lies in the disk of ``radius``, else on its rim opposing the sliding velocity it
    leaves, ``p = -radius w / |w|``, ``w = block p + rest``. Not the sticking impulse
    scaled onto the rim: with an anisotropic ``block`` (a box's corner, whose rotation
    couples its two tangents) that one pushes askew, yawing a sliding box and
    braking it by less than ``mu N``. With ``p = -w / s`` (``s = |w| / radius``):
    ``p = -(s + block)^-1 rest``, whose size falls with ``s``; ``s`` by bisection.

    >>> block, rest = np.diag([1.0, 4.0]), np.array([2.0, 2.0])
    >>> p = _coulomb(block, rest, 0.1)
    >>> w = block @ p + rest
    >>> bool(np.allclose(p, -0.1 * w / np.linalg.norm(w), rtol=0, atol=1e-15))
    True
    """
    stick = -np.linalg.lstsq(block, rest, rcond=None)[0]
    if np.linalg.norm(stick) <= radius or radius <= 0.0:
        return stick if radius > 0.0 else np.zeros_like(rest)
    values, vectors = np.linalg.eigh(block)
    along = vectors.T @ rest
    low, high = 0.0, float(np.linalg.norm(rest)) / radius  # at high: size <= radius
    for _ in range(200):
        mid = (low + high) / 2
        if mid in (low, high):
            break
        size = np.linalg.norm(along / (mid + np.maximum(values, 0.0)))
        low, high = (mid, high) if size > radius else (low, mid)
    p = -vectors @ (along / (high + np.maximum(values, 0.0)))
    return p * (radius / np.linalg.norm(p))  # on the rim to rounding
