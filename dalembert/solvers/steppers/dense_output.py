"""Dense output of a constrained simulation: every step's interpolant, kept compactly.

``traj.sol(t)`` is the interpolant of the step holding ``t``, projected onto the
constraints (the solution between two projected step ends). Keeping a SciPy
``DenseOutput`` object per step costs about a kilobyte of Python objects and array
headers beside the numbers themselves. For the explicit Runge-Kutta methods,
:class:`DenseRecorder` keeps only the numbers, one row per step in one growing
float64 array: the step's start and end times, its start state and the
interpolant's coefficient rows (``2 + 8 n_state`` doubles for DOP853,
``2 + 5 n_state`` for RK45, ``2 + 4 n_state`` for RK23); its
:class:`DenseSolution` evaluates many times at once (the steps found by
``searchsorted``, the polynomials over all of them in NumPy), with the arithmetic of
SciPy's interpolants. The interpolants of the other solvers (Radau, BDF, LSODA)
are kept as SciPy makes them.

The state at a step's end is the recorded one (the projected end the next step
started from), so ``sol`` at an output time on a step end returns exactly the
recorded state.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from .scipy_ivp import interpolant_form

Projector = Callable[[float, np.ndarray], np.ndarray]

#: The first capacity of the array, in steps, and its growth factor when full.
FIRST_CAPACITY, GROWTH = 64, 1.5


class DenseRecorder:
    """The interpolants of the steps taken so far, in the order of integration.

    Parameters
    ----------
    t0, y0
        The start (the solution there before any step is taken).
    direction
        +1 or -1: the direction of integration.
    project
        ``project(t, y)`` applied to interpolated states, or ``None``.

    Examples
    --------
    >>> from scipy.integrate import RK45
    >>> solver = RK45(lambda t, y: -y, 0.0, np.ones(1), 1.0)
    >>> recorder = DenseRecorder(0.0, np.ones(1), 1.0, None)
    >>> while solver.status == "running":
    ...     _ = solver.step()
    ...     recorder.add(solver.t_old, solver.t, solver.dense_output(), solver.y.copy())
    >>> sol = recorder.solution()
    >>> bool(abs(sol(0.5)[0] - np.exp(-0.5)) < 1e-3), bool(sol(1.0)[0] == solver.y[0])
    (True, True)
    """

    def __init__(self, t0: float, y0: np.ndarray, direction: float,
                 project: Projector | None) -> None:
        self.t0, self.y0, self.n_state = t0, y0, y0.size
        self.direction, self.project = direction, project
        self.kind: str | None = None  # "power", "dop853" or "objects": from the first step
        self.count = 0
        self._buffer = np.empty((0, 0))
        self._objects: list[tuple[float, float, Callable, np.ndarray]] = []
        self._final: np.ndarray | None = None  # the state at the last step's end

    def __len__(self) -> int:
        return self.count

    def add(self, t_old: float, t_new: float, dense: Callable, y_end: np.ndarray) -> None:
        """Record the step ``t_old -> t_new``: its interpolant ``dense`` (what the
        solver's ``dense_output()`` returned) and the state recorded at ``t_new``."""
        form = interpolant_form(dense)
        width = None if form is None else 2 + self.n_state * (1 + len(form[2]))
        if self.count == 0:  # the first step (or all forgotten): its form decides
            self.kind = "objects" if form is None else form[0]
            if width is not None and self._buffer.shape[1] != width:
                self._buffer = np.empty((0, 0))
        elif self.kind != "objects" and (form is None or form[0] != self.kind
                                         or self._buffer.shape[1] != width):
            self._as_objects()  # another solver's steps from here (method="auto")
        if self.kind == "objects" or form is None:  # kept as made
            del self._objects[self.count:]
            self._objects.append((t_old, t_new, dense, y_end))
        else:
            _, y_old, rows = form
            if self.count == len(self._buffer):
                self._grow(2 + self.n_state * (1 + len(rows)))
            row = self._buffer[self.count]
            row[0], row[1] = t_old, t_new
            row[2:2 + self.n_state] = y_old
            row[2 + self.n_state:] = np.ravel(rows)
        self._final = y_end
        self.count += 1

    def _as_objects(self) -> None:
        """Keep the steps recorded in the table as interpolants of their own (one
        :class:`DenseSolution` each), so that steps of another form can follow."""
        k, n = self.count, self.n_state
        if k:
            table = self._buffer[:k]
            rows = table[:, 2 + n:].reshape(k, -1, n)
            assert self._final is not None
            ends = np.vstack([table[1:, 2:2 + n], self._final[None, :]])
            self._objects = [(float(r[0]), float(r[1]), DenseSolution(
                self.direction, r[:1], r[1:2], ends[i:i + 1], None, kind=str(self.kind),
                starts=r[None, 2:2 + n], rows=rows[i:i + 1]), ends[i].copy())
                for i, r in enumerate(table)]
        self.kind = "objects"

    def _grow(self, width: int) -> None:
        capacity = max(FIRST_CAPACITY, int(GROWTH * len(self._buffer)))
        grown = np.empty((capacity, width))
        if self.count:
            grown[: self.count] = self._buffer[: self.count]
        self._buffer = grown

    def truncate(self, count: int) -> None:
        """Forget the steps after the first ``count`` (a step left half-recorded)."""
        if count >= self.count:
            return
        if self.kind == "objects":
            self._final = self._objects[count - 1][3] if count else None
        else:  # a step's end is where the next one started
            self._final = self._buffer[count, 2:2 + self.n_state].copy() if count else None
        self.count = count

    def solution(self) -> DenseSolution:
        """``sol(t)`` over the steps recorded so far (only ``t0`` before the first)."""
        k, n = self.count, self.n_state
        if k == 0:
            t0 = np.array([self.t0])
            return DenseSolution(self.direction, t0, t0, self.y0[None, :], self.project)
        if self.kind == "objects":
            steps = self._objects[:k]
            t_old = np.array([s[0] for s in steps])
            t_new = np.array([s[1] for s in steps])
            ends = np.array([s[3] for s in steps]).reshape(k, n)
            return DenseSolution(self.direction, t_old, t_new, ends, self.project,
                                 objects=[s[2] for s in steps])
        table = self._buffer[:k].copy()
        assert self._final is not None
        rows = table[:, 2 + n:].reshape(k, -1, n)
        return DenseSolution(self.direction, table[:, 0], table[:, 1], self._final[None, :],
                             self.project, kind=self.kind or "objects",
                             starts=table[:, 2:2 + n], rows=rows)


class DenseSolution:
    """``sol(t)``: the state at a time or an array of times (shape ``(n_state,)`` or
    ``(n_state, len(t))``, as SciPy's ``OdeSolution``), within ``[t_min, t_max]``.

    Made by :meth:`DenseRecorder.solution`. ``ends`` holds the state at each step's
    end, or with ``starts`` (the steps' start states) only the last step's: the others
    end where the next one starts.
    """

    def __init__(self, direction: float, t_old: np.ndarray, t_new: np.ndarray,
                 ends: np.ndarray, project: Projector | None, *, kind: str = "objects",
                 starts: np.ndarray | None = None, rows: np.ndarray | None = None,
                 objects: list[Callable] | None = None) -> None:
        self.direction, self.project, self.kind = direction, project, kind
        self.t_old, self.t_new, self.ends = t_old, t_new, ends
        self.starts, self.rows, self.objects = starts, rows, objects
        self._ahead = direction * t_new  # increasing
        span = np.concatenate([t_old[:1], t_new])
        self.t_min, self.t_max = float(span.min()), float(span.max())

    def __call__(self, t: float | np.ndarray) -> np.ndarray:
        times = np.asarray(t, dtype=float)
        if times.ndim > 1:
            raise ValueError("t must be a time or a 1-D array of times")
        flat = np.atleast_1d(times)
        outside = ~((self.t_min <= flat) & (flat <= self.t_max))
        if outside.any():
            raise ValueError(f"t={flat[outside][0]} is outside the integrated interval")
        ahead = self.direction * flat
        k = np.minimum(np.searchsorted(self._ahead, ahead), len(self._ahead) - 1)
        out = np.empty((len(flat), self.ends.shape[1]))
        at_end = ahead == self._ahead[k]
        out[at_end] = self._end_states(k[at_end])
        inside = np.flatnonzero(~at_end)
        if len(inside):
            states = self._interpolate(k[inside], flat[inside])
            if self.project is not None:
                states = np.array([self.project(s, y) for s, y in zip(flat[inside], states)])
            out[inside] = states
        return out[0] if times.ndim == 0 else out.T

    def _end_states(self, k: np.ndarray) -> np.ndarray:
        if self.starts is None:
            return self.ends[k]
        last = len(self.t_new) - 1
        return np.where((k == last)[:, None], self.ends[-1], self.starts[np.minimum(k + 1, last)])

    def _interpolate(self, k: np.ndarray, s: np.ndarray) -> np.ndarray:
        """The unprojected interpolants of steps ``k`` at times ``s``, one row each."""
        if self.objects is not None:
            return np.array([self.objects[i](si) for i, si in zip(k, s)])
        assert self.rows is not None and self.starts is not None
        h = (self.t_new - self.t_old)[k][:, None]
        x = (s[:, None] - self.t_old[k][:, None]) / h
        rows, y_old = self.rows[k], self.starts[k]
        if self.kind == "dop853":  # Dop853DenseOutput's operations
            y = np.zeros_like(y_old)
            for i in range(rows.shape[1]):
                y += rows[:, -1 - i]
                y *= x if i % 2 == 0 else 1 - x
            return y + y_old
        # RkDenseOutput's: y_old + h sum_j R[j] x^(j + 1)
        power, total = x.copy(), np.zeros_like(y_old)
        for j in range(rows.shape[1]):
            total += rows[:, j] * power
            power = power * x
        return h * total + y_old
