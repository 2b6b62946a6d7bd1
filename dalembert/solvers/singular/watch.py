"""Watching a run for steps that collapse near a singular configuration.

Both loops (:mod:`~dalembert.solvers.running.loop`: step by step in Python, or stretches of
steps in C) note their progress after every unit of work in a :class:`StepCollapse`,
with the thresholds of :mod:`dalembert.numerics.singular`. When the steps have
collapsed, the loop asks the function :func:`singular_diagnosis` makes whether the
state is near a singular configuration of the constraints, and if so stops with a
message naming the time and the rows that lose rank: within a few thousand steps of
the creep starting, instead of crawling for minutes.
"""

from __future__ import annotations

from collections import deque
from collections.abc import Callable, Sequence

import numpy as np

from ...codegen.compiled import NumericModel
from ...numerics.singular import COLLAPSE_RATIO, COLLAPSE_STEPS, NEAR, named, near_dependent_rows

#: ``singular(t, y)``: a sentence on the singular configuration at ``(t, y)``, or ``""``.
Singularity = Callable[[float, np.ndarray], str]


class StepCollapse:
    """Progress ``(t, steps)`` noted after each unit of work; :meth:`note` says when the
    last :data:`~dalembert.numerics.singular.COLLAPSE_STEPS` steps or more advanced, on
    average, less than ``COLLAPSE_RATIO`` of the mean step before them.

    Parameters
    ----------
    t0
        The start time.

    Examples
    --------
    >>> watch = StepCollapse(0.0)
    >>> watch.note(1.0, 100)          # steps of 1e-2
    False
    >>> watch.note(1.0 + 1e-9, 700)   # 600 more steps of ~1e-12
    True
    """

    def __init__(self, t0: float) -> None:
        self.t0 = t0
        self._marks: deque[tuple[float, int]] = deque([(t0, 0)])
        self._quiet_until = 0

    def note(self, t: float, steps: int) -> bool:
        marks = self._marks
        marks.append((t, steps))
        # the latest mark at least COLLAPSE_STEPS steps back opens the window
        while len(marks) > 2 and marks[1][1] <= steps - COLLAPSE_STEPS:
            marks.popleft()
        t_w, n_w = marks[0]
        if n_w == 0 or steps - n_w < COLLAPSE_STEPS or steps < self._quiet_until:
            return False
        before = abs(t_w - self.t0) / n_w
        return abs(t - t_w) / (steps - n_w) < COLLAPSE_RATIO * before

    def quiet(self, steps: int) -> None:
        """No collapse reported before ``COLLAPSE_STEPS`` more steps (the state was not
        singular: the next look is a window later)."""
        self._quiet_until = steps + COLLAPSE_STEPS


def singular_diagnosis(num: NumericModel, constraint_names: Sequence[str] | None = None,
                       kept: np.ndarray | None = None,
                       q0: np.ndarray | None = None) -> Singularity:
    """The function saying whether a state ``y = [q, qd]`` of ``num`` is near a singular
    configuration of its constraints, and which rows lose rank there.

    Parameters
    ----------
    num
        The compiled equations bound to parameter values.
    constraint_names
        The constraint rows' names (default: ``row 0``, ``row 1``...).
    kept
        The independent rows at the start (``None``: all).
    q0
        The initial positions: a row whose norm falls below ``NEAR`` times its norm
        there is named too (a constraint whose gradient vanishes).

    Examples
    --------
    >>> from dalembert.examples import load
    >>> pendulum = load("pendulum").build()
    >>> singular = singular_diagnosis(pendulum.numeric(), ["rod"], q0=np.array([1.0, 0.0]))
    >>> singular(0.0, np.array([1.0, 0.0, 0.0, 1.0]))
    ''
    >>> singular(0.0, np.array([1e-9, 0.0, 0.0, 1.0]))  # doctest: +ELLIPSIS
    'near a singular configuration: the norm of rod fell to 1e-09 of its initial value...'
    """
    rows = np.arange(num.m) if kept is None else np.asarray(kept)
    names = list(constraint_names) if constraint_names is not None else \
        [f"row {k}" for k in range(num.m)]
    kept_names = [names[int(k)] for k in rows]
    pattern = num.pattern

    def norms(q: np.ndarray) -> np.ndarray:  # from the sparse values: no dense A
        Av = num.velocity_sparse(0.0, q)[0]
        return np.sqrt(np.bincount(pattern.A_rows, weights=Av**2, minlength=num.m))[rows]

    norm0 = None if q0 is None else norms(np.asarray(q0, dtype=float))

    def singular(t: float, y: np.ndarray) -> str:
        if num.m == 0:
            return ""
        q = np.asarray(y, dtype=float)[:num.n]
        A = pattern.dense_A(num.velocity_sparse(t, q)[0])[rows]
        if norm0 is not None:
            with np.errstate(divide="ignore", invalid="ignore"):
                shrunk = np.flatnonzero(np.linalg.norm(A, axis=1) < NEAR * norm0)
            if len(shrunk):
                k = int(shrunk[0])
                ratio = np.linalg.norm(A[k]) / norm0[k]
                return (f"near a singular configuration: the norm of {kept_names[k]} fell "
                        f"to {ratio:.1g} of its initial value (its gradient vanishes: a "
                        "length or distance going to zero)" +
                        (f"; also {named([kept_names[int(i)] for i in shrunk[1:]])}"
                         if len(shrunk) > 1 else ""))
        involved, drop, ratio = near_dependent_rows(A, kept_names)
        if not drop:
            return ""
        return (f"near a singular configuration: the constraint Jacobian is {drop} short of "
                f"full rank there (smallest singular value {ratio:.1e} of the largest), the "
                f"rows losing rank: {named(involved)}; the multipliers grow without bound "
                "there (a linkage folding flat, a chain stretched straight)")

    return singular
