"""Singular configurations of the constraints: the thresholds and tests both loops share.

At a singular configuration the constraint Jacobian ``A`` loses rank during a run (a
four-bar folding flat, a closed chain stretched straight, a rod whose length goes to
zero). The multipliers grow without bound (like ``1 / distance``), and the step-size
controller may creep towards the rank drop with ever smaller steps. Both simulation
loops, in C and in Python, watch the steps with the same thresholds, here, and take
the same decision from them (:class:`~dalembert.solvers.singular.watch.StepCollapse`):

- a state is *near a singular configuration* when the smallest singular value of the
  kept rows of ``A`` (scaled to unit length) is below :data:`NEAR` times the largest;
  after every step a band Cholesky screen (:data:`SCREEN`) decides whether to measure
  it, and near one the steps are careful (:mod:`~dalembert.solvers.singular.careful`: what
  they leave out, :data:`TRUNCATE` and :data:`GAP`; when they are retaken,
  :data:`JUMP` and :data:`JUMP_RETRIES`);
- the steps have *collapsed* when the last :data:`COLLAPSE_STEPS` (or more) of them
  advanced on average less than :data:`COLLAPSE_RATIO` of the mean step before them.

A collapse near a singular configuration (there, also a row whose norm fell below
:data:`NEAR` times its norm at the start: a constraint whose gradient vanishes) ends
the run with a diagnosis naming the time and the rows involved
(:func:`near_dependent_rows`, a dense SVD taken only then). At the start, the degrees
of freedom are counted with ``RANK_RTOL`` (:mod:`.rank`), and singular values between
it and :data:`NEAR` make the count ambiguous (said in the report).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

#: Singular values below this fraction of the largest: near a rank drop.
NEAR = 1e-3
#: Models with more constraint rows get no dense measure of the degrees of freedom at the
#: start when no row is dependent: its cost grows as rows^2 x coordinates (seconds for a
#: 256-link chain).
DENSE_ROWS = 400
#: While careful, the combinations of rows with singular values below this fraction of
#: the largest are left out.
TRUNCATE = 1e-5
#: ... and with them every larger one under ``NEAR`` within this factor of the one
#: before (a cluster of singular values falling together is left out at once).
GAP = 20.0
#: A smallest pivot of the rows' Gram matrix (its band Cholesky factorization, rows of
#: unit length) below this asks for its eigenvalues: the cheap screen both loops take
#: after every step (the C loop from the projection's factorization).
SCREEN = (10 * NEAR) ** 2
#: The steps are watched over windows of at least this many steps ...
COLLAPSE_STEPS = 500
#: ... and have collapsed when their mean is below this fraction of the mean before.
COLLAPSE_RATIO = 1e-3
#: Steps that collapsed away from any singular configuration *run away* when, in this
#: many windows in a row, each window's mean step is smaller than the last ...
RUNAWAY_WINDOWS = 3
#: ... and at that mean the rest of the run would take more than this many steps (some
#: quantity of the model grows without bound as the time nears a finite limit: the run
#: would crawl toward it for hours).
RUNAWAY_STEPS = 1e8
#: Steps that collapsed away from any singular configuration have *stalled* when, in
#: ``RUNAWAY_WINDOWS`` windows in a row, shrinking or not, the rest of the run would
#: take more than this many steps at their mean (days in Python, hours in C): a stiff
#: stretch an explicit method cannot step through, or a force that is not smooth.
STALL_STEPS = 1e10
#: A projection that moves a step's end by more than this many times the step's
#: tolerance (its error norm; an ordinary step's correction stays under 1, and near a
#: singular configuration an exact projection's grows like the drift over the
#: smallest singular value: 1e3..1e5) has jumped onto another branch of the
#: constraints, whose distance there is about that singular value itself: the step
#: is taken again, shorter, ...
JUMP = 1e6
#: ... at most this many times (each a quarter of the one before).
JUMP_RETRIES = 8
#: Rows named in a message, at most.
NAMED = 6


def near_dependent_rows(A: np.ndarray, names: Sequence[str],
                        below: float = NEAR) -> tuple[list[str], int, float]:
    """The rows taking part in the near dependencies of ``A``: those with a large entry
    in a left singular vector whose singular value is below ``below`` times the largest.

    Parameters
    ----------
    A
        The constraint Jacobian (kept rows), dense.
    names
        One name per row.
    below
        Singular values below this fraction of the largest count as a rank drop.

    Returns
    -------
    names, drop, ratio
        The rows involved (largest part first), how many singular values are below,
        and the smallest singular value over the largest.

    Examples
    --------
    >>> rows, drop, ratio = near_dependent_rows(np.array([[1.0, 0.0], [1.0, 1e-7]]), "ab")
    >>> rows, drop, f"{ratio:.1e}"
    (['a', 'b'], 1, '5.0e-08')
    """
    if A.shape[0] == 0:
        return [], 0, 1.0
    u, s, _ = np.linalg.svd(A, full_matrices=True)
    s = np.concatenate([s, np.zeros(A.shape[0] - len(s))])
    largest = s[0] if s[0] > 0 else 1.0
    low = np.flatnonzero(s < below * largest)
    ratio = float(s[-1] / largest)
    if len(low) == 0:
        return [], 0, ratio
    weight = np.abs(u[:, low]).max(axis=1)
    involved = np.flatnonzero(weight > 0.1 * weight.max())
    involved = involved[np.argsort(-weight[involved], kind="stable")]
    return [names[int(i)] for i in involved], len(low), ratio


def named(rows: Sequence[str]) -> str:
    """``"a, b, c"``, at most :data:`NAMED` of them, with how many more.

    >>> named(["r1", "r2"])
    'r1, r2'
    >>> named([f"r{k}" for k in range(9)])
    'r0, r1, r2, r3, r4, r5 and 3 more'
    """
    shown = ", ".join(rows[:NAMED])
    return shown + (f" and {len(rows) - NAMED} more" if len(rows) > NAMED else "")
