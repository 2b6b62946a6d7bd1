"""The simulation loops: one contract, a Python loop and a loop of C stretches.

A loop owns one SciPy ``OdeSolver`` and turns its steps into a constrained
simulation: after every accepted step the state is projected back onto the
constraints and the solver restarts from the projected state; output points between
steps are interpolated and projected too; events are located on the projected
interpolant. The contract, documented on :class:`SimulationLoop` the way SciPy's
``OdeSolver`` documents its own, is small: :meth:`~SimulationLoop.advance` until
:attr:`~SimulationLoop.status` is set, :meth:`~SimulationLoop.interrupt` on
Ctrl-C, then :meth:`~SimulationLoop.result`. Which loop runs is decided once, by
the simulation plan (:mod:`dalembert.solvers.plan`).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np
from scipy.integrate import OdeSolver

from ..errors import DalembertError
from .native.run import StretchRunner
from .scipy_ivp import restart_second_order

Projector = Callable[[float, np.ndarray], np.ndarray]


@dataclass
class IntegrationResult:
    """Raw output of a loop: states ``y`` (rows) at times ``t``."""

    t: np.ndarray
    y: np.ndarray
    status: str
    message: str
    stats: dict[str, int]
    t_events: list[np.ndarray] = field(default_factory=list)
    y_events: list[np.ndarray] = field(default_factory=list)
    sol: Callable | None = None

    @property
    def success(self) -> bool:
        return self.status in ("finished", "event")


class SimulationLoop:
    """The contract of a simulation loop.

    A loop is made from a solver positioned at the start (and what to record);
    then

    - :meth:`advance` does one unit of work (one step, or a stretch of steps) and
      records its outputs; it sets :attr:`status` when the run ends (``"finished"``,
      ``"event"`` for a terminal event, ``"failed"``) with :attr:`message`;
    - :meth:`interrupt` ends the run on Ctrl-C, keeping everything done so far,
      even if the Ctrl-C landed inside :meth:`advance`;
    - :attr:`t_reached` is the time the recorded solution reaches (for a progress
      bar);
    - :meth:`result` gives the :class:`IntegrationResult`, at any time.
    """

    status: str | None
    message: str
    t_reached: float

    def advance(self) -> None:
        raise NotImplementedError

    def interrupt(self) -> None:
        raise NotImplementedError

    def result(self, method_name: str) -> IntegrationResult:
        raise NotImplementedError


class PythonLoop(SimulationLoop):
    """The loop in Python: each step through :meth:`OdeSolver.step`, then the
    projection, the events, the outputs and the restart."""

    def __init__(self, solver: OdeSolver, t_eval: np.ndarray | None = None,
                 events: Sequence[Callable] = (), project: Projector | None = None,
                 dense_output: bool = False) -> None:
        self.solver = solver
        self.direction = solver.direction if solver.direction != 0 else 1.0
        self.project = project
        self.events = list(events or ())
        self.dense_output = dense_output
        self.t_eval = None if t_eval is None else np.asarray(t_eval, dtype=float)
        if self.t_eval is not None:
            #: Output times as increasing numbers in the direction of integration.
            self._t_eval_ahead = self.direction * self.t_eval
        self.status: str | None = None
        self.message = ""
        self.n_projections = 0
        self.n_steps = 0
        #: The time the recorded solution reaches (a terminal event stops before solver.t).
        self.t_reached = solver.t
        self.ts: list[float] = []
        self.ys: list[np.ndarray] = []
        self.segments: list[tuple[float, float, Callable]] = []
        self.t_events: list[list[float]] = [[] for _ in self.events]
        self.y_events: list[list[np.ndarray]] = [[] for _ in self.events]
        self.g = [float(e(solver.t, solver.y)) for e in self.events]
        self.event_counts = [0 for _ in self.events]
        self._record_start()

    def _record_start(self) -> None:
        t0, y0 = self.solver.t, self.solver.y.copy()
        if self.t_eval is None or np.any(self.t_eval == t0):
            self.ts.append(t0)
            self.ys.append(y0)

    def stop(self, status: str, message: str) -> None:
        self.status, self.message = status, message

    def interrupt(self) -> None:
        self.stop("interrupted", f"interrupted by the user at t={self.solver.t:.6g}")

    def advance(self) -> None:
        """One step: step, project, events, outputs, restart."""
        solver = self.solver
        try:
            message = solver.step()
        except DalembertError as exc:
            return self.stop("failed", f"integration failed at t={solver.t:.6g}: {exc}")
        if solver.status == "failed":
            return self.stop(
                "failed",
                f"integration failed at t={solver.t:.6g}: {str(message).rstrip('.')}. "
                "The problem may be "
                "stiff (try method='Radau' or 'BDF') or the mechanism near a singular "
                "configuration",
            )
        t_old, t_new = solver.t_old, solver.t
        self.n_steps += 1
        try:
            y_new = self._project_step(t_new)
        except DalembertError as exc:
            return self.stop("failed", f"projection failed at t={t_new:.6g}: {exc}")
        state = self._interpolator(t_new, y_new)
        t_stop = self._handle_events(t_old, t_new, y_new, state)
        if t_stop is not None:
            t_new, y_new = t_stop, state(t_stop)
        self._record(t_old, t_new, y_new, state)
        self.t_reached = t_new
        if self.dense_output:
            state.interpolant()  # made now, from this step's solver state
            self.segments.append((t_old, t_new, state))
        if self.project is not None and self.status is None:
            restart_second_order(solver, y_new)
        if self.status is None and solver.status == "finished":
            self.stop("finished", "the integration reached the end of t_span")

    def _project_step(self, t: float) -> np.ndarray:
        """The new state, projected (the solver restarts from it after the outputs)."""
        solver = self.solver
        if self.project is None:
            return solver.y.copy()
        self.n_projections += 1
        return self.project(t, solver.y).copy()

    def _interpolator(self, t_new: float, y_new: np.ndarray) -> _StepState:
        return _StepState(self.solver, self.project, t_new, y_new)

    def _handle_events(self, t_old: float, t_new: float, y_new: np.ndarray,
                       state: _StepState) -> float | None:
        """Locate sign changes of the event functions; return a terminal time if any."""
        hits = []
        for k, event in enumerate(self.events):
            g_new = float(event(t_new, y_new))
            if _crossed(self.g[k], g_new, getattr(event, "direction", 0)):
                from scipy.optimize import brentq  # only once an event fires: slow import

                root = brentq(lambda s, e=event: float(e(s, state(s))), t_old, t_new,
                              xtol=4 * np.finfo(float).eps)
                hits.append((root, k))
            self.g[k] = g_new
        terminal_time = None
        for root, k in sorted(hits, key=lambda h: self.direction * h[0]):
            if terminal_time is not None:
                break
            self.t_events[k].append(root)
            self.y_events[k].append(state(root))
            self.event_counts[k] += 1
            limit = int(getattr(self.events[k], "terminal", False))
            if limit and self.event_counts[k] >= limit:
                terminal_time = root
                self.stop("event", f"a terminal event occurred at t={root:.6g}")
        return terminal_time

    def _record(self, t_old, t_new, y_new, state) -> None:
        if self.t_eval is None:
            self.ts.append(t_new)
            self.ys.append(y_new)
            return
        d = self.direction
        lo, hi = np.searchsorted(self._t_eval_ahead, [d * t_old, d * t_new], side="right")
        for s in self.t_eval[lo:hi]:
            self.ts.append(float(s))
            self.ys.append(state(float(s)))

    def result(self, method_name: str) -> IntegrationResult:
        solver = self.solver
        n_state = solver.y.size
        stats = {"nfev": solver.nfev, "njev": solver.njev, "nlu": solver.nlu,
                 "n_steps": self.n_steps, "n_projections": self.n_projections}
        stats = {k: int(v) for k, v in stats.items() if v is not None}
        y = np.array(self.ys) if self.ys else np.empty((0, n_state))
        return IntegrationResult(
            t=np.array(self.ts), y=y, status=self.status or "failed",
            message=self.message or f"{method_name} stopped", stats=stats,
            t_events=[np.array(v) for v in self.t_events],
            y_events=[np.array(v).reshape(-1, n_state) for v in self.y_events],
            sol=_PiecewiseSolution(self.segments) if self.dense_output else None,
        )


class _StepState:
    """``state(s)`` within the last step, projected; the solver's interpolant is made
    on first use (only steps with an output time or an event pay for it) and must be,
    as with any SciPy solver, before the next step or restart."""

    def __init__(self, solver: OdeSolver, project: Projector | None, t_new: float,
                 y_new: np.ndarray) -> None:
        self.solver, self.project, self.t_new, self.y_new = solver, project, t_new, y_new
        self._interpolant: Callable[[float], np.ndarray] | None = None

    def interpolant(self) -> Callable[[float], np.ndarray]:
        if self._interpolant is None:
            self._interpolant = self.solver.dense_output()
        return self._interpolant

    def __call__(self, s: float) -> np.ndarray:
        if s == self.t_new:
            return self.y_new
        y = self.interpolant()(s)
        return self.project(s, y) if self.project is not None else y


class StretchLoop(PythonLoop):
    """The loop in C: whole stretches of steps (step, projection, outputs at
    ``t_eval``, restart) run by a :class:`~.native.run.StretchRunner`, returning to
    Python every fraction of a second; a step C cannot finish is taken the Python
    way. Only for a native Runge-Kutta solver with its native projection, no events
    and no dense output (the plan checks). Same steps and states as
    :class:`PythonLoop` (tested).
    """

    def __init__(self, solver: OdeSolver, t_eval: np.ndarray | None,
                 project: Projector) -> None:
        super().__init__(solver, t_eval, (), project, False)
        self.runner = StretchRunner(solver, self.t_eval)

    def advance(self) -> None:
        ran = self.runner.run()
        self._absorb()
        if not ran:  # C left the next step to the step-by-step loop
            return super().advance()
        if self.solver.status == "finished":
            self.stop("finished", "the integration reached the end of t_span")

    def interrupt(self) -> None:
        self._absorb()  # a stretch run in C before the Ctrl-C is kept
        super().interrupt()

    def _absorb(self) -> None:
        """Take over the steps and outputs of the last stretch run in C."""
        taken = self.runner.take()
        if taken is None:
            return
        steps, t, y = taken
        self.n_steps += steps
        self.n_projections += steps
        self.t_reached = self.solver.t
        self.ts.extend(t.tolist())
        self.ys.extend(y)


def _crossed(g_old: float, g_new: float, direction: float) -> bool:
    up = g_old < 0 <= g_new
    down = g_old > 0 >= g_new
    if direction > 0:
        return up
    if direction < 0:
        return down
    return up or down


class _PiecewiseSolution:
    """Dense output over all steps; ``sol(t)`` accepts a scalar or an array of times."""

    def __init__(self, segments: list[tuple[float, float, Callable]]):
        self.segments = segments
        self.ends = np.array([max(a, b) for a, b, _ in segments])
        self.t_min = min((min(a, b) for a, b, _ in segments), default=np.nan)
        # Not ``ends.max(initial=nan)``: that is always NaN, rejecting every time.
        self.t_max = max(self.ends, default=np.nan)
        order = np.argsort(self.ends)
        self.segments = [segments[i] for i in order]
        self.ends = self.ends[order]

    def __call__(self, t: float | np.ndarray) -> np.ndarray:
        times = np.atleast_1d(np.asarray(t, dtype=float))
        out = np.array([self._one(s) for s in times])
        return out[0] if np.ndim(t) == 0 else out.T

    def _one(self, s: float) -> np.ndarray:
        if not self.segments or not (self.t_min <= s <= self.t_max):
            raise ValueError(f"t={s} is outside the integrated interval")
        k = min(int(np.searchsorted(self.ends, s)), len(self.segments) - 1)
        return self.segments[k][2](s)
