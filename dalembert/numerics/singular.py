"""Singular configurations of the constraints: the thresholds and tests both loops share.

At a singular configuration the constraint Jacobian ``A`` loses rank during a run (a
four-bar folding flat, a closed chain stretched straight, a rod whose length goes to
zero). The accelerations stay determined where the physics determines them, but the
multipliers grow without bound (like ``1 / distance``), the step-size controller
creeps towards the rank drop, and the projection after a step may land on another
branch of ``psi = 0``. Both simulation loops, in C and in Python, measure the
conditioning of the kept rows after every step and take the same decisions from it,
with the thresholds below:

- The measure is the smallest *pivot ratio* of the Gram matrix ``A A^T`` of the kept
  rows, factored by Cholesky in a fixed order (the rows inside one body first, then
  the others in the band order of the C loop): each row's pivot against its diagonal
  is the squared sine of its angle to the rows before it; with each row's diagonal
  against its value at the initial state (a constraint whose gradient vanishes). It
  is ``(sigma_min / sigma_max)^2``-like, and cheap: one band factorization.
- Below :data:`NEAR` squared the next step is *careful*: every evaluation factors the
  Gram matrix first, and a row whose pivot ratio falls below :data:`TRUNCATE` squared
  is not enforced in that solve (its multiplier is zero: the rank-revealing, minimum-
  norm treatment of dependent rows, for a moment); the velocity projection works in
  the kinetic-energy metric, so that the rows coming back change the energy to second
  order only. The multipliers stay bounded; the accelerations are those of the rows
  that still determine them.
- A projection that changes a velocity by more than :data:`JUMP_RTOL` of the largest
  velocity (plus :data:`JUMP_ATOL_FACTOR` times the velocities' ``atol``) is a jump to
  another branch, not a correction: the step is rejected and taken again
  :data:`JUMP_SHRINK` times shorter, at most :data:`JUMP_TRIES` times.
- A run whose careful steps stop advancing stops with a diagnosis: more than
  :data:`COLLAPSE_STEPS` careful steps in a row whose mean step is below
  :data:`COLLAPSE_RATIO` of the step before the approach, or more than
  :data:`EPISODE_STEPS` careful steps in a row.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

#: Rows whose pivot ratio is below ``TRUNCATE**2`` are not enforced (while careful).
TRUNCATE = 1e-5
#: A step that ends with a pivot ratio below ``NEAR**2`` makes the next one careful; the
#: run then counts as near a singular configuration (said in its message).
NEAR = 1e-3
#: A velocity changed by more than this fraction of the largest one is a jump.
JUMP_RTOL = 1e-3
#: ... plus this many times the velocities' absolute tolerance.
JUMP_ATOL_FACTOR = 1e3
#: A rejected jump retakes the step this many times shorter ...
JUMP_SHRINK = 4.0
#: ... at most this many times.
JUMP_TRIES = 12
#: Careful steps in a row after which a collapsed step size stops the run.
COLLAPSE_STEPS = 200
#: A mean step over the last :data:`COLLAPSE_STEPS` below this fraction of the step
#: before the approach is a collapse.
COLLAPSE_RATIO = 1e-6
#: Careful steps in a row that stop the run whatever their size (a crawl).
EPISODE_STEPS = 20000
#: Rows named in a message, at most.
NAMED = 6


def is_jump(before: np.ndarray, after: np.ndarray, atol: float) -> bool:
    """Whether a projection from velocities ``before`` to ``after`` jumped: the C loop's
    ``jumped`` (``runge_kutta.c``), the same formula.

    Parameters
    ----------
    before, after
        The velocities before and after the projection.
    atol
        The largest absolute tolerance on the velocities.

    Examples
    --------
    >>> is_jump(np.array([1.0, 0.0]), np.array([1.0, 1e-9]), 1e-12)
    False
    >>> is_jump(np.array([1.0, 0.0]), np.array([0.0, 1.0]), 1e-12)
    True
    """
    change = float(np.abs(after - before).max(initial=0.0))
    speed = max(float(np.abs(before).max(initial=0.0)), float(np.abs(after).max(initial=0.0)))
    return change > JUMP_RTOL * speed + JUMP_ATOL_FACTOR * atol


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
        The rows involved (largest first), how many singular values are below, and the
        smallest singular value over the largest.

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
    return [names[i] for i in involved], len(low), ratio


def named(rows: Sequence[str]) -> str:
    """``"a, b, c"``, at most :data:`NAMED` of them, with how many more.

    >>> named(["r1", "r2"])
    'r1, r2'
    >>> named([f"r{k}" for k in range(9)])
    'r0, r1, r2, r3, r4, r5 and 3 more'
    """
    shown = ", ".join(rows[:NAMED])
    return shown + (f" and {len(rows) - NAMED} more" if len(rows) > NAMED else "")
