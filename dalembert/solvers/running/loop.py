"""The simulation loops: one contract, a Python loop and a loop of C stretches.

A loop owns one SciPy ``OdeSolver`` and turns its steps into a constrained
simulation: after every accepted step the state is projected back onto the
constraints and the solver restarts from the projected state; output points between
steps are interpolated and projected too; events are located on the projected
interpolant. The contract, documented on :class:`SimulationLoop` the way SciPy's
``OdeSolver`` documents its own, is small: :meth:`~SimulationLoop.advance` until
:attr:`~SimulationLoop.status` is set, :meth:`~SimulationLoop.interrupt` on
Ctrl-C, then :meth:`~SimulationLoop.result`. Which loop runs is decided once, by
the simulation plan (:mod:`dalembert.solvers.running.plan`).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np
from scipy.integrate import OdeSolver

from ...errors import DalembertError
from ...numerics.singular import COLLAPSE_RATIO, COLLAPSE_STEPS, JUMP_RETRIES
from ..native.run import stretch_runner
from ..native.screens import screens_of
from ..singular.careful import CarefulSteps, RetakeStep
from ..singular.watch import Runaway, Singularity, StepCollapse
from ..steppers.dense_output import DenseRecorder
from ..steppers.scipy_ivp import (
    hand_over,
    last_stages,
    last_step_size,
    restart,
    restart_second_order,
    roll_back,
    snapshot,
    step_inputs,
    step_size,
)
from .nonfinite import Diagnosis
from .switching import StiffSwitch

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
    #: The exception that ended the run (an event function's), to chain; else ``None``.
    error: BaseException | None = None

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
    - :meth:`interrupt` ends the run on Ctrl-C, keeping every unit of work completed
      so far and none of one the Ctrl-C landed in (no output without its dense
      output, no time without its state);
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


@dataclass(frozen=True)
class _Checkpoint:
    """What a loop had recorded after its last complete unit of work: a Ctrl-C in the
    middle of the next one rolls back to it, so that no output, event or dense-output
    step is left half-recorded (a point without its interpolant, a time without its
    state)."""

    points: int
    events: tuple[int, ...]
    dense_steps: int
    n_steps: int
    n_projections: int
    t_reached: float
    status: str | None
    message: str


class PythonLoop(SimulationLoop):
    """The loop in Python: each step through :meth:`OdeSolver.step`, then the
    projection, the events, the outputs and the restart.

    Before each step the solver's state, derivative and step size are checked: one
    that is not finite ends the run (a NaN step size would be retried forever, a NaN
    state spreads to every later one), with ``diagnose(t, y)`` saying which quantity
    of the model is not finite there (:mod:`~dalembert.solvers.running.nonfinite`). An event
    function that raises or returns a value that is not finite ends the run too,
    keeping the steps before. Steps that collapse near a singular configuration of the
    constraints (``singular(t, y)`` says so, naming the rows) end the run with that
    diagnosis (:mod:`~dalembert.solvers.singular.watch`). A step the careful model
    rejects (:class:`~dalembert.solvers.singular.careful.RetakeStep`: its projection jumped onto
    another branch of the constraints, or it ran too far without the nearly dependent
    ones) is taken again a quarter as long, up to ``JUMP_RETRIES`` times before the
    run stops saying so.
    """

    def __init__(self, solver: OdeSolver, t_eval: np.ndarray | None = None,
                 events: Sequence[Callable] = (), project: Projector | None = None,
                 dense_output: bool = False, diagnose: Diagnosis | None = None,
                 singular: Singularity | None = None,
                 careful: CarefulSteps | None = None,
                 runaway: Runaway | None = None, switch: StiffSwitch | None = None) -> None:
        self.solver = solver
        self.careful = careful
        #: method="auto"'s switching between an explicit and an implicit solver, or None
        self.switch = switch
        self._retired = (0, 0, 0)  # nfev, njev, nlu of the solvers switched away from
        #: The run's own solver and projection (the careful steps swap in others).
        self.native, self.native_project = solver, project
        self._careful_nfev = 0  # the evaluations of the careful solvers before this one
        self.direction = solver.direction if solver.direction != 0 else 1.0
        self.project = project
        self.diagnose = diagnose
        self.singular = singular
        self.runaway = runaway
        self.collapse = StepCollapse(solver.t)
        self.events = list(events or ())
        self.t_eval = None if t_eval is None else np.asarray(t_eval, dtype=float)
        if self.t_eval is not None:
            #: Output times as increasing numbers in the direction of integration.
            self._t_eval_ahead = self.direction * self.t_eval
        self.status: str | None = None
        self.message = ""
        #: The exception that ended the run (an event function's), or ``None``.
        self.error: BaseException | None = None
        self.n_projections = 0
        self.n_steps = 0
        self._retries = 0  # times the step now under way was taken again
        #: The time the recorded solution reaches (a terminal event stops before solver.t).
        self.t_reached = solver.t
        self.ts: list[float] = []
        self.ys: list[np.ndarray] = []
        self.dense = DenseRecorder(solver.t, solver.y.copy(), self.direction, project) \
            if dense_output else None
        self.t_events: list[list[float]] = [[] for _ in self.events]
        self.y_events: list[list[np.ndarray]] = [[] for _ in self.events]
        self.event_counts = [0 for _ in self.events]
        self._record_start()
        self._commit()
        #: The event functions' values at the last step's end (None: one failed).
        self.g = self._event_values(solver.t, solver.y)

    def _record_start(self) -> None:
        t0, y0 = self.solver.t, self.solver.y.copy()
        if self.t_eval is None or np.any(self.t_eval == t0):
            self.ts.append(t0)
            self.ys.append(y0)

    def _commit(self) -> None:
        """Mark everything recorded so far as complete (see :class:`_Checkpoint`)."""
        self._checkpoint = _Checkpoint(
            len(self.ts), tuple(len(v) for v in self.t_events),
            len(self.dense) if self.dense is not None else 0, self.n_steps,
            self.n_projections, self.t_reached, self.status, self.message)

    def stop(self, status: str, message: str) -> None:
        self.status, self.message = status, message
        self._commit()

    def interrupt(self) -> None:
        c = self._checkpoint
        del self.ts[c.points:], self.ys[c.points:]
        for times, states, count in zip(self.t_events, self.y_events, c.events):
            del times[count:], states[count:]
        if self.dense is not None:
            self.dense.truncate(c.dense_steps)
        self.n_steps, self.n_projections, self.t_reached = c.n_steps, c.n_projections, \
            c.t_reached
        if c.status is not None:  # the run had ended before the Ctrl-C
            self.status, self.message = c.status, c.message
        else:
            self.stop("interrupted", f"interrupted by the user at t={self.t_reached:.6g}")

    def advance(self) -> None:
        """One step: step, project, events, outputs, restart; near a singular
        configuration the step is careful (:meth:`_careful_from_here`)."""
        if self._careful_from_here():
            return
        self._step()
        if self.status is None and self.solver is not self.native and self.careful \
                is not None and not self.careful.model.careful:
            self._back_to_native()
        self._switch_if_due()

    def _switch_if_due(self) -> None:
        """Continue with the other method where ``method="auto"``'s switch says so."""
        if self.switch is None or self.status is not None or self.solver is not self.native:
            return
        new = self.switch.after(self.solver, self.n_steps)
        if new is not None:
            self._take_solver(new)

    def _take_solver(self, new: OdeSolver) -> None:
        """Continue the run with ``new`` (made at the solver's state)."""
        old = self.solver
        nfev, njev, nlu = self._retired
        self._retired = (nfev + old.nfev, njev + old.njev, nlu + old.nlu)
        self.solver = self.native = new

    def _careful_from_here(self) -> bool:
        """Take the next steps with the careful solver if the careful model says so (a
        run's own solver that steps in C cannot: ``careful.solver`` makes one of the
        same method and tolerances that steps in Python)."""
        if self.careful is None or self.careful.solver is None or \
                self.solver is not self.native or not self.careful.model.careful:
            return False
        solver = self.solver
        self.solver = self.careful.solver(solver.t, solver.y, step_size(solver))
        self.project = self.careful.model.project
        return True

    def _back_to_native(self) -> None:
        """Hand the run back to its own solver after careful steps."""
        careful, native = self.solver, self.native
        self._careful_nfev += careful.nfev
        hand_over(careful, native, native.fun(careful.t, careful.y))
        self.solver, self.project = native, self.native_project

    def _step(self) -> None:
        solver = self.solver
        if self._inputs_not_finite():
            return
        y_old = solver.y  # the solvers replace it with a new array when they step
        saved = snapshot(solver) if self.project is not None else None  # (RetakeStep)
        try:
            message = solver.step()
        except DalembertError as exc:
            self.error = exc  # chained to the run's warning
            return self._failed(f"integration failed at t={solver.t:.6g}: {exc}")
        if solver.status == "failed":
            return self._step_failed(str(message))
        t_old, t_new = solver.t_old, solver.t
        try:
            y_new = self._project_step(t_new)
        except RetakeStep as rejected:
            return self._retake(saved, abs(t_new - t_old), str(rejected))
        except DalembertError as exc:
            return self.stop("failed", f"projection failed at t={t_new:.6g}: {exc}")
        self._retries = 0
        if not np.all(np.isfinite(y_new)):  # a solver that accepts such a step (LSODA)
            return self._state_not_finite(t_old, y_old, t_new, y_new)
        state = self._interpolator(t_new, y_new)
        events = self._locate_events(t_old, t_new, y_new, state)
        if events is None:  # an event function failed: the step is not kept
            return
        hits, terminal = events
        if terminal is not None:
            t_new, y_new = terminal, state(terminal)
        # the step's records; a Ctrl-C from here to _commit rolls them back
        self.n_steps += 1
        self.n_projections += self.project is not None
        self._record(t_old, t_new, y_new, state)
        for root, k in hits:
            self.t_events[k].append(root)
            self.y_events[k].append(state(root))
        if self.dense is not None:  # the interpolant is made now, from this step's solver
            self.dense.add(t_old, t_new, state.interpolant(), y_new)
        self.t_reached = t_new
        if terminal is not None:
            return self.stop("event", f"a terminal event occurred at t={terminal:.6g}")
        if self.careful is not None and self.careful.model.rhs_changed:
            restart(solver, y_new)  # the last stage's accelerations are not this rhs's
        elif self.project is not None:
            restart_second_order(solver, y_new)
        if solver.status == "finished":
            return self.stop("finished", "the integration reached the end of t_span")
        self._commit()
        self._watch_steps()

    def _retake(self, saved: dict[str, object] | None, h: float, message: str) -> None:
        """Take the step again, a quarter as long; stop where that cannot be (a solver
        whose history cannot be restored) or has been done ``JUMP_RETRIES`` times."""
        if saved is not None and self._retries < JUMP_RETRIES:
            self._retries += 1
            roll_back(self.solver, saved, h / 4)
            return
        self.stop("failed", f"integration stopped at t={self.solver.t_old:.6g}: {message}" +
                  (f", at every step size down to {h:.1e}" if saved is not None else
                   f" ({type(self.solver).__name__} cannot take a step again)") +
                  "; the trajectory up to there is returned")

    def _watch_steps(self) -> None:
        """Stop if the steps have collapsed near a singular configuration, or keep
        shrinking toward a time they would take hours to reach (after a complete unit
        of work: the trajectory so far is kept)."""
        if not self.collapse.note(self.t_reached, self.n_steps):
            return
        solver = self.solver
        found = self.singular(solver.t, solver.y) if self.singular is not None else ""
        if found:
            return self.stop(
                "failed", f"integration stopped at t={solver.t:.6g}: the steps collapsed "
                f"(the last {COLLAPSE_STEPS} or more under {COLLAPSE_RATIO:g} of the mean "
                f"step before, the last {last_step_size(solver) or 0:.1e}) "
                f"{found}. The trajectory up to there is returned; a looser rtol or "
                "another method may get through, or the mechanism may lock here")
        remaining = self.collapse.runaway(solver.t, solver.t_bound)
        growing = ""
        if remaining is not None and self.runaway is not None:
            growing = self.runaway(solver.t, solver.y)
        if growing:
            assert remaining is not None
            return self.stop(
                "failed", f"integration stopped at t={solver.t:.6g}: the steps keep "
                f"shrinking (the last {COLLAPSE_STEPS} or more averaged "
                f"{self.collapse.window_step:.1e}, each window's less than the one before): "
                f"at that size the rest of the run would take {remaining:.1e} steps. "
                f"Something in the model grows without bound as the time nears a limit: "
                f"{growing}")
        left = self.collapse.stalled(solver.t, solver.t_bound)
        if remaining is None and left is None:
            return self.collapse.quiet(self.n_steps)
        self.stop(
            "failed", f"integration stopped at t={solver.t:.6g}: the steps have stalled "
            f"(the last {COLLAPSE_STEPS} or more averaged {self.collapse.window_step:.1e}): "
            f"at that size the rest of the run would take {remaining or left:.1e} steps. "
            "A force that is not smooth there (a sign or an absolute value of a rate: "
            "dry friction is a Unilateral's), a stiff stretch an explicit method cannot "
            "step through (try method=\"Radau\"), or a prescribed motion, an input or a "
            "force growing without bound as the time nears a limit")

    def _failed(self, message: str) -> None:
        """Stop with ``message``, or with what is not finite at the step's start."""
        solver = self.solver
        cause = self.diagnose(solver.t, solver.y) if self.diagnose is not None else ""
        self.stop("failed", f"integration stopped at t={solver.t:.6g}: {cause}" if cause
                  else message)

    def _inputs_not_finite(self) -> bool:
        """Stop if the next step would start from values that are not finite."""
        for name, value in step_inputs(self.solver).items():
            bad = np.isnan(value) if name == "step size" else ~np.isfinite(value)
            if np.any(bad):
                hint = "" if name != "step size" else \
                    " (first_step is NaN, or the derivative at the start is not finite)"
                self._failed(f"integration stopped at t={self.solver.t:.6g}: the {name} is "
                             f"not finite{hint}")
                return True
        return False

    def _state_not_finite(self, t_old: float, y_old: np.ndarray, t_new: float,
                          y_new: np.ndarray) -> None:
        """Stop after a step that ended on a state that is not finite (not kept)."""
        cause = ""
        if self.diagnose is not None:
            cause = self.diagnose(t_old, y_old) or self.diagnose(t_new, y_new)
        self.stop("failed", f"integration stopped at t={t_old:.6g}: the step to "
                  f"t={t_new:.6g} ended on a state that is not finite" +
                  (f"; {cause}" if cause else ""))

    def _step_failed(self, message: str) -> None:
        stages = last_stages(self.solver)
        if stages is not None and not np.all(np.isfinite(stages)):
            return self._failed(
                f"integration stopped at t={self.solver.t:.6g}: the derivative was not "
                "finite within the step at every step size tried, down to the smallest: "
                "the model is undefined or overflows just past this state (a square root "
                "of a negative number, a division by zero...), or the motion runs into a "
                "singularity")
        found = self.singular(self.solver.t, self.solver.y) if self.singular else ""
        self._failed(
            f"integration failed at t={self.solver.t:.6g}: {message.rstrip('.')}. " +
            (f"The state is {found}" if found else "The problem may be stiff (try "
             "method='Radau' or 'BDF') or the mechanism near a singular configuration"))

    def _project_step(self, t: float) -> np.ndarray:
        """The new state, projected (the solver restarts from it after the outputs)."""
        solver = self.solver
        if self.project is None:
            return solver.y.copy()
        return self.project(t, solver.y).copy()

    def _interpolator(self, t_new: float, y_new: np.ndarray) -> _StepState:
        return _StepState(self.solver, self.project, t_new, y_new)

    def _event_values(self, t: float, y: np.ndarray) -> list[float] | None:
        """Each event function at ``(t, y)``; ``None`` (the run stopped) if one fails."""
        values = []
        for k in range(len(self.events)):
            value = self._event_value(k, t, y)
            if value is None:
                return None
            values.append(value)
        return values

    def _event_value(self, k: int, t: float, y: np.ndarray) -> float | None:
        """Event ``k`` at ``(t, y)``; ``None`` (the run stopped) if it raises or returns a
        value that is not finite."""
        event, name = self.events[k], _event_name(self.events[k], k)
        try:
            value = float(event(t, y))
        except Exception as exc:  # the user's function: any error ends the run
            self.error = exc
            said = f": {exc}" if str(exc) else ""
            self.stop("failed", f"{name} raised {type(exc).__name__} at t={t:.6g}{said}")
            return None
        if not np.isfinite(value):
            self.stop("failed", f"{name} returned {value} at t={t:.6g}: an event function "
                      "must return a finite number (its sign changes are the events)")
            return None
        return value

    def _locate_events(self, t_old: float, t_new: float, y_new: np.ndarray,
                       state: _StepState) -> tuple[list[tuple[float, int]], float | None] | None:
        """The events in the step in time order, as ``(time, event)``, and the time of a
        terminal one (where the step is cut); ``None`` if an event function failed."""
        hits = []
        assert self.g is not None
        for k, event in enumerate(self.events):
            g_new = self._event_value(k, t_new, y_new)
            if g_new is None:
                return None
            if _crossed(self.g[k], g_new, getattr(event, "direction", 0)):
                from scipy.optimize import brentq  # only once an event fires: slow import

                def g(s: float, k: int = k) -> float:
                    value = self._event_value(k, s, state(s))
                    if value is None:
                        raise _EventFailed
                    return value

                try:
                    root = brentq(g, t_old, t_new, xtol=4 * np.finfo(float).eps)
                except _EventFailed:
                    return None
                except (ValueError, RuntimeError) as exc:  # no sign change left, no root
                    self.stop("failed", f"{_event_name(event, k)} changed sign between "
                              f"t={t_old:.6g} and t={t_new:.6g}, but its root could not be "
                              f"located there: {exc}")
                    return None
                hits.append((root, k))
            self.g[k] = g_new
        kept, terminal = [], None
        for root, k in sorted(hits, key=lambda h: self.direction * h[0]):
            if terminal is not None:
                break
            kept.append((root, k))
            self.event_counts[k] += 1
            limit = int(getattr(self.events[k], "terminal", False))
            if limit and self.event_counts[k] >= limit:
                terminal = root
        return kept, terminal

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
        probed = self.switch.probe_work if self.switch is not None else (0, 0, 0)
        nfev = solver.nfev + self._careful_nfev + self._retired[0] + probed[0] + \
            (self.native.nfev if solver is not self.native else 0)
        njev, nlu = (None if v is None else v + r + p for v, r, p in
                     zip((solver.njev, solver.nlu), self._retired[1:], probed[1:]))
        stats = {"nfev": nfev, "njev": njev, "nlu": nlu,
                 "n_steps": self.n_steps, "n_projections": self.n_projections}
        if self.switch is not None:
            stats["n_switches"] = len(self.switch.switches)
            stats["n_probes"] = self.switch.probes
        stats = {k: int(v) for k, v in stats.items() if v is not None}
        y = np.array(self.ys) if self.ys else np.empty((0, n_state))
        return IntegrationResult(
            t=np.array(self.ts), y=y, status=self.status or "failed",
            message=self.message or f"{method_name} stopped", stats=stats,
            t_events=[np.array(v) for v in self.t_events],
            y_events=[np.array(v).reshape(-1, n_state) for v in self.y_events],
            sol=self.dense.solution() if self.dense is not None else None, error=self.error,
        )


class _EventFailed(Exception):
    """An event function failed while its root was sought (the run is stopped).

    Internal control flow, never seen by a user: the event's value has already
    stopped the run, saying why; this leaves SciPy's root search (``brentq``), and is
    caught right around it."""


def _event_name(event: Callable, k: int) -> str:
    name = getattr(event, "__name__", None)
    return f"event {k} ({name})" if name and name != "<lambda>" else f"event {k}"


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
    ``t_eval``, restart) run by the runner of
    :func:`~dalembert.solvers.native.run.stretch_runner`, returning to Python every
    fraction of a second; a step C cannot finish is taken the Python
    way (a step from values that are not finite among them: the Python loop then
    stops with its diagnosis), and so is a step whose end a screen of the events
    flags (:mod:`~dalembert.solvers.native.screens`: the Python way locates the
    events in it). Only for a native solver with its native projection, no dense
    output and no events but screened ones (the plan checks). Same steps and
    states as :class:`PythonLoop` (tested). Near a singular configuration (measured
    after every stretch) the steps are taken the Python way, carefully (``careful``,
    :mod:`~dalembert.solvers.singular.careful`), until the state is clear of it.
    """

    def __init__(self, solver: OdeSolver, t_eval: np.ndarray | None,
                 project: Projector, diagnose: Diagnosis | None = None,
                 singular: Singularity | None = None,
                 careful: CarefulSteps | None = None,
                 runaway: Runaway | None = None, switch: StiffSwitch | None = None,
                 events: Sequence[Callable] = ()) -> None:
        super().__init__(solver, t_eval, events, project, False, diagnose, singular, careful,
                         runaway, switch)
        # as they stand at the segment's start; None: not screened in this segment, whose
        # steps are all taken the Python way
        self._screens = screens_of(self.events)
        self.runner = None if self._screens is None else \
            stretch_runner(solver, self.t_eval, self._screens)

    def advance(self) -> None:
        if self.runner is None or self.solver is not self.native or \
                self._careful_from_here():
            return super().advance()  # careful steps, or a solver without stretches in C
        try:
            due = None if self.switch is None else \
                self.switch.steps_to_judgement(self.n_steps)
            ran = self.runner.run() if due is None else self.runner.run(due)
        except DalembertError as exc:  # the inputs' function failed: the steps before kept
            self._absorb()
            self.error = exc  # chained to the run's warning
            return self._failed(f"integration failed at t={self.solver.t:.6g}: {exc}")
        self._absorb()
        if self.events and self.g is not None:  # the events' values where C stopped
            self.g = self._event_values(self.solver.t, self.solver.y)
        if self.status is not None:  # an event function failed there
            return None
        if not ran:  # C left the next step (or a flagged one) to the step-by-step loop
            return super().advance()
        if self.solver.status == "finished":
            return self.stop("finished", "the integration reached the end of t_span")
        if self.runner.near_singular and self.careful is not None:
            solver = self.solver
            model = self.careful.model
            model.measure(solver.t, model.num.layout.q(solver.y))
            if self._careful_from_here():
                return
        self._watch_steps()
        self._switch_if_due()

    def _take_solver(self, new: OdeSolver) -> None:
        self._absorb()  # (taken already after a stretch: nothing twice)
        super()._take_solver(new)
        if self._screens is not None:
            self.runner = stretch_runner(new, self.t_eval, self._screens)

    def interrupt(self) -> None:
        self._absorb()  # a stretch run in C before the Ctrl-C is kept
        super().interrupt()

    def _absorb(self) -> None:
        """Take over the steps and outputs of the last stretch run in C."""
        taken = self.runner.take() if self.runner is not None else None
        if taken is None:
            return
        steps, t, y = taken
        self.n_steps += steps
        self.n_projections += steps
        self.t_reached = self.solver.t
        self.ts.extend(t.tolist())
        self.ys.extend(y)
        self._commit()


def _crossed(g_old: float, g_new: float, direction: float) -> bool:
    up = g_old < 0 <= g_new
    down = g_old > 0 >= g_new
    if direction > 0:
        return up
    if direction < 0:
        return down
    return up or down
