"""An impact: the velocity jump at one instant, from the KKT matrix on the active rows.

At an impact the positions do not move and the velocities jump by an impulse along the
normals of the rows that act at that instant (a contact closing, and every constraint
that holds through it). Newton's law of restitution sets each acting row's rate after
the impact, ``g+ = A v+ + b = -e (A v- + b)`` (``e = 0``: plastic, the rate stops;
``e = 1``: elastic, it reverses; a bilateral constraint holds, its rate 0 before and
after), and the impulse ``Lambda`` is what it takes:

    [ M  A^T ] [  v+     ]   [ M v-             ]
    [ A   0  ] [ -Lambda ] = [ -e (A v- + b) - b ]

on the acting rows: one solve through the same KKT factorization as the dynamics
(:mod:`dalembert.solvers.kkt.factorization`), its other rows made inactive. All acting
rows are solved at once (a simultaneous impact); whether each contact's impulse pushes
(``Lambda >= 0`` for a gap ``g >= 0``) is for the caller to check: a row that would
pull is separating, and leaving it out is the complementarity step of the contact
layer above.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..codegen.compiled import NumericModel
from .kkt.factorization import active_rows, kkt_factorization
from .kkt.sparse import matvec


@dataclass(frozen=True)
class Impact:
    """The result of :func:`impact`.

    Attributes
    ----------
    qd
        The velocities after the impact.
    impulses
        ``Lambda`` by constraint row (0 on the rows that do not act).
    generalized_impulse
        ``A^T Lambda = M (qd+ - qd-)``, by coordinate.
    energy_lost
        The kinetic energy lost, ``T- - T+`` (0 for an elastic impact, negative if the
        restitution given gains energy).
    """

    qd: np.ndarray
    impulses: np.ndarray
    generalized_impulse: np.ndarray
    energy_lost: float


def impact(num: NumericModel, t: float, q: np.ndarray, qd: np.ndarray,
           acting: np.ndarray, restitution: np.ndarray | float = 0.0) -> Impact:
    """The velocities after an impact on the rows ``acting`` (see
    :mod:`dalembert.solvers.impact`).

    Parameters
    ----------
    num
        The compiled equations bound to parameter values.
    t, q, qd
        The instant, the positions and the velocities before the impact.
    acting
        The constraint rows that act at the impact: a boolean mask over the rows or
        their indices.
    restitution
        Newton's coefficient ``e``: one value for every acting row, or one per
        constraint row (a bilateral row's is irrelevant when its rate is 0 before).

    Raises
    ------
    ValueError
        ``acting`` names no row of the model, or ``restitution`` has the wrong shape.

    Examples
    --------
    A ball (unit mass) falling at 2 m/s while moving at 1 m/s along a floor ``y >= 0``,
    ``e = 0.5``:

    >>> from dalembert import Holonomic, System, coordinates
    >>> x, y = coordinates("x y")
    >>> ball = System([x, y], kinetic=(x.diff()**2 + y.diff()**2) / 2,
    ...               constraints=[Holonomic(y, name="floor")])
    >>> after = impact(ball.numeric(), 0.0, np.zeros(2), np.array([1.0, -2.0]), [0], 0.5)
    >>> after.qd, after.impulses, after.energy_lost
    (array([1., 1.]), array([3.]), 1.5)
    """
    n, m, pattern = num.n, num.m, num.pattern
    q, qd = np.asarray(q, dtype=float), np.asarray(qd, dtype=float)
    mask = active_rows(np.asarray(acting), m)
    e = np.asarray(restitution, dtype=float)
    if e.shape not in ((), (m,)) or not np.isfinite(e).all():
        raise ValueError(f"the restitution must be one finite number or one per constraint "
                         f"row ({m}); got {restitution!r}")
    e = np.broadcast_to(e, (m,))
    Mv, _, Av, _ = num.kkt_sparse(t, q, qd)
    _, b = num.velocity_sparse(t, q)
    momentum = matvec(pattern.M_rows, pattern.M_cols, Mv, qd, n)
    rate = matvec(pattern.A_rows, pattern.A_cols, Av, qd, m) + b
    kkt = kkt_factorization(pattern)
    kkt.factor(np.concatenate([Mv, Av]), mask)
    after, impulses = kkt.solve(np.concatenate([momentum, -e * rate - b]))
    change = after - qd
    generalized = matvec(pattern.M_rows, pattern.M_cols, Mv, change, n)
    energy_lost = -float(change @ (momentum + 0.5 * generalized))
    return Impact(after, impulses, generalized, energy_lost)
