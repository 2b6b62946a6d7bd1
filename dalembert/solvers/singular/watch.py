"""Watching a run for steps that collapse, near a singular configuration or not.

Both loops (:mod:`~dalembert.solvers.running.loop`: step by step in Python, or stretches of
steps in C) note their progress after every unit of work in a :class:`StepCollapse`,
with the thresholds of :mod:`dalembert.numerics.singular`. When the steps have
collapsed, the loop asks the function :func:`singular_diagnosis` makes whether the
state is near a singular configuration of the constraints, and if so stops with a
message naming the time and the rows that lose rank: within a few thousand steps of
the creep starting, instead of crawling for minutes. Otherwise, when the steps keep
shrinking so that the rest of the run would take more than
:data:`~dalembert.numerics.singular.RUNAWAY_STEPS` (:meth:`StepCollapse.runaway`),
something in the model grows without bound as the time nears a limit (a prescribed
motion or an input that diverges): the loop stops with what
:func:`runaway_diagnosis` names as growing fastest.
"""

from __future__ import annotations

from collections import deque
from collections.abc import Callable, Sequence

import numpy as np

from ...codegen.compiled import NumericModel
from ...numerics.singular import (
    COLLAPSE_RATIO,
    COLLAPSE_STEPS,
    NEAR,
    RUNAWAY_STEPS,
    RUNAWAY_WINDOWS,
    STALL_STEPS,
    named,
    near_dependent_rows,
)

#: ``singular(t, y)``: a sentence on the singular configuration at ``(t, y)``, or ``""``.
Singularity = Callable[[float, np.ndarray], str]
#: ``runaway(t, y)``: a sentence on what in the model grew most since the start, or ``""``.
Runaway = Callable[[float, np.ndarray], str]


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
        #: The mean step of the last window :meth:`note` looked at.
        self.window_step = 0.0
        self._shrinking: list[float] = []  # the mean steps of the windows running away
        self._stalled = 0  # windows in a row with more than STALL_STEPS left

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
        self.window_step = abs(t - t_w) / (steps - n_w)
        return self.window_step < COLLAPSE_RATIO * before

    def runaway(self, t: float, t_bound: float) -> float | None:
        """After a collapse no singular configuration explains (:meth:`note` said so):
        the steps the rest of the run would take at the last window's mean step, once
        that exceeded :data:`~dalembert.numerics.singular.RUNAWAY_STEPS` in
        :data:`~dalembert.numerics.singular.RUNAWAY_WINDOWS` windows in a row, each
        window's mean step smaller than the last; else ``None``.

        A short stiff stretch that the steps come out of is not a runaway: its windows
        stop shrinking, and the count starts again.

        Parameters
        ----------
        t
            The time reached.
        t_bound
            The end of the run.

        Examples
        --------
        >>> watch = StepCollapse(0.0)
        >>> watch.note(0.5, 1000)               # steps of 5e-4
        False
        >>> t, steps = 0.5, 1000
        >>> for width in (1e-9, 1e-10, 1e-11):  # windows of 600 steps, each 10x shorter
        ...     t, steps = t + width, steps + 600
        ...     print(watch.note(t, steps), watch.runaway(t, 1.0) is not None)
        ...     watch.quiet(steps)
        True False
        True False
        True True
        """
        remaining = self._remaining(t, t_bound)
        if remaining <= RUNAWAY_STEPS or (self._shrinking and
                                          self.window_step >= self._shrinking[-1]):
            self._shrinking = []
        if remaining > RUNAWAY_STEPS:
            self._shrinking.append(self.window_step)
        return remaining if len(self._shrinking) >= RUNAWAY_WINDOWS else None

    def stalled(self, t: float, t_bound: float) -> float | None:
        """After a collapse no singular configuration explains (:meth:`note` said so):
        the steps the rest of the run would take at the last window's mean step, once
        that exceeded :data:`~dalembert.numerics.singular.STALL_STEPS` in
        :data:`~dalembert.numerics.singular.RUNAWAY_WINDOWS` windows in a row, the
        steps shrinking or not; else ``None``.

        Parameters
        ----------
        t
            The time reached.
        t_bound
            The end of the run.

        Examples
        --------
        >>> watch = StepCollapse(0.0)
        >>> watch.note(0.5, 1000)               # steps of 5e-4
        False
        >>> t, steps = 0.5, 1000
        >>> for _ in range(3):                  # windows of 600 steps of 1e-12
        ...     t, steps = t + 6e-10, steps + 600
        ...     print(watch.note(t, steps), watch.stalled(t, 1.0) is not None)
        ...     watch.quiet(steps)
        True False
        True False
        True True
        """
        remaining = self._remaining(t, t_bound)
        self._stalled = self._stalled + 1 if remaining > STALL_STEPS else 0
        return remaining if self._stalled >= RUNAWAY_WINDOWS else None

    def _remaining(self, t: float, t_bound: float) -> float:
        """The steps to ``t_bound`` at the last window's mean step."""
        return abs(t_bound - t) / self.window_step if self.window_step > 0 else float("inf")

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
        q = num.layout.q(np.asarray(y, dtype=float))
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


#: A quantity is named as growing when it is this many times its size at the start
#: (or, for one that started at zero, this many times the start's typical size).
_GREW = 100.0


def runaway_diagnosis(num: NumericModel, constraint_names: Sequence[str] | None,
                      coordinate_names: Sequence[str], t0: float,
                      y0: np.ndarray) -> Runaway:
    """The function saying what in ``num`` grew most between the start and a state: the
    prescribed rates of the constraints (``-b`` of ``A qd + b = 0``: a driver's),
    the generalized forces, the velocities.

    Parameters
    ----------
    num
        The compiled equations bound to parameter values.
    constraint_names, coordinate_names
        The names of the constraint rows (default: ``row 0``, ``row 1``...) and of
        the coordinates.
    t0, y0
        The start: time and state ``[q, qd]``.

    Examples
    --------
    >>> from dalembert import Holonomic, System, coordinates, t
    >>> (x,) = coordinates("x")
    >>> driven = System([x], kinetic=x.diff() ** 2 / 2,
    ...                 constraints=[Holonomic(x - 1 / (1 - t), name="drive")])
    >>> runaway = runaway_diagnosis(driven.numeric(), ["drive"], ["x"], 0.0,
    ...                             np.array([1.0, 1.0]))
    >>> runaway(0.999, np.array([1000.0, 1e6]))
    'the prescribed rate of drive (-b of its row) grew from 1 to 1e+06'
    """
    n, layout = num.n, num.layout
    if constraint_names is None:
        constraint_names = [f"row {k}" for k in range(num.m)]
    labels = ([f"the prescribed rate of {name} (-b of its row)" for name in constraint_names]
              + [f"the generalized force on {name}" for name in coordinate_names]
              + [f"the velocity {name}_dot" for name in coordinate_names])

    def sizes(t: float, y: np.ndarray) -> np.ndarray:
        q, qd = layout.split(y)
        b = num.velocity_sparse(t, q)[1] if num.m else np.zeros(0)
        f = num.kkt_sparse(t, q, qd)[1]
        return np.abs(np.concatenate([b, f, qd]))

    start = sizes(t0, np.asarray(y0, dtype=float))
    floor = max(float(np.max(start, initial=0.0)), 1.0) * 1e-3

    def runaway(t: float, y: np.ndarray) -> str:
        with np.errstate(all="ignore"):
            now = sizes(t, np.asarray(y, dtype=float))
            growth = now / np.maximum(start, floor)
        growth[~np.isfinite(growth)] = np.inf
        # a prescribed rate or a force that grows is a cause; the velocities follow it
        causes = len(labels) - n
        order = [int(k) for k in np.argsort(-growth[:causes], kind="stable")
                 if growth[k] > _GREW][:2]
        if not order:
            order = [causes + int(k) for k in np.argsort(-growth[causes:], kind="stable")
                     if growth[causes + k] > _GREW][:1]
        return "; ".join(f"{labels[k]} grew from {start[k]:.2g} to {now[k]:.2g}"
                         for k in order)

    return runaway
