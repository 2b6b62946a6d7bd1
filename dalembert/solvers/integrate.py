"""Step-by-step integration with SciPy's solvers, projection after each step.

This mirrors :func:`scipy.integrate.solve_ivp` (``t_span``, ``t_eval``,
``dense_output``, ``events``, ``rtol``/``atol``, any ``OdeSolver`` method) and adds
what constrained dynamics needs: after every accepted step the state is projected
back onto the constraint manifold and the solver restarts from the projected
state; output points between steps are interpolated and projected too. A failure
or Ctrl-C ends the loop but keeps every step computed so far.

What runs where: with events, dense output, no projection or a solver of SciPy's
own, each step goes through Python (:meth:`OdeSolver.step`, the projection,
the outputs, the restart). A solver that can run whole stretches of this loop
itself (``stretch_runner``: the native Runge-Kutta solvers of
:mod:`dalembert.solvers.native`, with their own projection) does so in C, in
calls of a fraction of a second; a step it cannot finish (a failure, or a
projection it leaves to the Python projector) is then taken here, step by step.
Both ways give the same steps, evaluations and states (tested).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np
from scipy.integrate import BDF, DOP853, LSODA, RK23, RK45, OdeSolver, Radau
from scipy.integrate._ivp.rk import RungeKutta
from scipy.optimize import brentq

from ..errors import DalembertError
from .step_control import CONTROLLED, ControlledSteps, controlled_class

METHODS: dict[str, type[OdeSolver]] = {
    "RK23": RK23, "RK45": RK45, "DOP853": DOP853, "Radau": Radau, "BDF": BDF, "LSODA": LSODA,
}

Projector = Callable[[float, np.ndarray], np.ndarray]

#: Whether a solver's own loop over whole stretches of steps is used where it applies
#: (switched off only to compare with the step-by-step loop).
_RUN_STRETCHES = True


@dataclass
class IntegrationResult:
    """Raw output of :func:`integrate`: states ``y`` (rows) at times ``t``."""

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


def solver_class(method: str | type[OdeSolver]) -> type[OdeSolver]:
    """The SciPy solver for a method name (or an ``OdeSolver`` subclass)."""
    if isinstance(method, type) and issubclass(method, OdeSolver):
        return method
    if method not in METHODS:
        raise ValueError(f"unknown method {method!r}; choose one of {', '.join(METHODS)}")
    return METHODS[method]


def integrate(
    fun: Callable,
    t_span: Sequence[float],
    y0: np.ndarray,
    *,
    method: str | type[OdeSolver] = "DOP853",
    t_eval: np.ndarray | None = None,
    dense_output: bool = False,
    events: Sequence[Callable] = (),
    project: Projector | None = None,
    progress: bool = False,
    step_control: str = "PI",
    **options: object,
) -> IntegrationResult:
    """Integrate ``y' = fun(t, y)`` like ``solve_ivp``, projecting after each step.

    ``step_control`` picks the explicit Runge-Kutta methods' step-size controller
    (:mod:`~dalembert.solvers.step_control`); other solvers keep their own."""
    cls = controlled_class(solver_class(method), step_control)
    if issubclass(cls, ControlledSteps):
        options["step_control"] = step_control
    if project is not None and cls is LSODA:
        raise ValueError(
            "LSODA cannot be restarted from a projected state; use 'Radau' or 'BDF' for "
            "stiff problems, or stabilization='baumgarte'"
        )
    t0, tf = map(float, t_span)
    if cls in (Radau, BDF) and options.get("jac") is None:
        options["jac"] = finite_difference_jacobian(fun)
    solver = cls(fun, t0, np.asarray(y0, dtype=float), tf, **options)
    run = _Run(solver, t_eval, events, project, dense_output)
    bar = _progress_bar(t0, tf) if progress else None
    try:
        while run.status is None:
            run.advance()
            if bar is not None:
                bar.update(abs(run.t_reached - bar.n_t))
                bar.n_t = run.t_reached
    except KeyboardInterrupt:
        run.interrupt()
    finally:
        if bar is not None:
            bar.close()
    return run.result(_method_name(cls))


def _method_name(cls: type[OdeSolver]) -> str:
    """SciPy's name for its solvers' controlled and native versions."""
    if issubclass(cls, ControlledSteps):
        return next(c.__name__ for c in cls.__mro__ if c in CONTROLLED)
    return cls.__name__


def finite_difference_jacobian(fun: Callable) -> Callable:
    """Forward-difference Jacobian with a fixed relative step, for Radau and BDF.

    SciPy's own ``num_jac`` grows its step by 10x at every call for a column that
    does not change ``fun`` (a position entering only through a linear constraint).
    After ~300 Jacobians the step overflows, and BDF then crawls with tiny steps.

    >>> jac = finite_difference_jacobian(lambda t, y: np.array([y[1], -4.0 * y[0]]))
    >>> np.round(jac(0.0, np.array([1.0, 0.0])), 6)
    array([[ 0.,  1.],
           [-4.,  0.]])
    """

    def jac(t: float, y: np.ndarray) -> np.ndarray:
        f0 = np.asarray(fun(t, y), dtype=float)
        J = np.empty((f0.size, y.size))
        for j in range(y.size):
            h = np.sqrt(np.finfo(float).eps) * max(1.0, abs(y[j]))
            shifted = y.copy()
            shifted[j] += h
            J[:, j] = (np.asarray(fun(t, shifted), dtype=float) - f0) / (shifted[j] - y[j])
        return J

    return jac


class _Run:
    """State of one integration: the solver, recorded outputs, events."""

    def __init__(self, solver, t_eval, events, project, dense_output):
        self.solver = solver
        self.direction = solver.direction if solver.direction != 0 else 1.0
        self.project = project
        self.events = list(events or ())
        self.dense_output = dense_output
        self.t_eval = None if t_eval is None else np.asarray(t_eval, dtype=float)
        if self.t_eval is not None:
            #: Output times as increasing numbers in the direction of integration.
            self._t_eval_ahead = self.direction * self.t_eval
            if np.any(np.diff(self._t_eval_ahead) < 0):
                raise ValueError("t_eval must be sorted in the direction of integration")
        self.status: str | None = None
        self.message = ""
        self.n_projections = 0
        self.n_steps = 0
        #: The time the recorded solution reaches (a terminal event stops before solver.t).
        self.t_reached = solver.t
        self.ts: list[float] = []
        self.ys: list[np.ndarray] = []
        self.segments: list[tuple[float, float, Callable]] = []
        self.t_events = [[] for _ in self.events]
        self.y_events = [[] for _ in self.events]
        self.g = [float(e(solver.t, solver.y)) for e in self.events]
        self.event_counts = [0 for _ in self.events]
        self.stretches = self._stretch_runner()
        self._record_start()

    def _stretch_runner(self):
        """The solver's runner of whole stretches of steps, where it applies."""
        make = getattr(self.solver, "stretch_runner", None)
        if make is None or not _RUN_STRETCHES or self.project is None or self.events \
                or self.dense_output:
            return None
        return make(self.t_eval, self.project)

    def _record_start(self) -> None:
        t0, y0 = self.solver.t, self.solver.y.copy()
        if self.t_eval is None or np.any(self.t_eval == t0):
            self.ts.append(t0)
            self.ys.append(y0)

    def stop(self, status: str, message: str) -> None:
        self.status, self.message = status, message

    def interrupt(self) -> None:
        """Ctrl-C: stop, keeping what was done (a stretch run in C too)."""
        self._absorb()
        self.stop("interrupted", f"interrupted by the user at t={self.solver.t:.6g}")

    def advance(self) -> None:
        if self.stretches is None:
            return self._advance_one()
        ran = self.stretches.run()
        self._absorb()
        if not ran:  # C left the next step to the step-by-step loop
            return self._advance_one()
        if self.solver.status == "finished":
            self.stop("finished", "the integration reached the end of t_span")

    def _absorb(self) -> None:
        """Take over the steps and outputs of the last stretch run in C."""
        taken = self.stretches.take() if self.stretches is not None else None
        if taken is None:
            return
        steps, t, y = taken
        self.n_steps += steps
        self.n_projections += steps
        self.t_reached = self.solver.t
        self.ts.extend(t.tolist())
        self.ys.extend(y)

    def _advance_one(self) -> None:
        """One step the step-by-step way: step, project, events, outputs, restart."""
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
            _restart_from(solver, y_new)
        if self.status is None and solver.status == "finished":
            self.stop("finished", "the integration reached the end of t_span")

    def _project_step(self, t: float) -> np.ndarray:
        """The new state, projected (the solver restarts from it after the outputs)."""
        solver = self.solver
        if self.project is None:
            return solver.y.copy()
        self.n_projections += 1
        return self.project(t, solver.y).copy()

    def _interpolator(self, t_new: float, y_new: np.ndarray) -> Callable:
        """``state(s)`` within the step; the solver's interpolant is made on first use
        (only steps with an output time or an event pay for it) and must be, as with
        any SciPy solver, before the next step or restart."""
        solver, project = self.solver, self.project
        made: list[Callable] = []

        def interpolant() -> Callable:
            if not made:
                made.append(solver.dense_output())
            return made[0]

        def state(s: float) -> np.ndarray:
            if s == t_new:
                return y_new
            y = interpolant()(s)
            return project(s, y) if project is not None else y

        state.interpolant = interpolant
        return state

    def _handle_events(self, t_old, t_new, y_new, state) -> float | None:
        """Locate sign changes of the event functions; return a terminal time if any."""
        hits = []
        for k, event in enumerate(self.events):
            g_new = float(event(t_new, y_new))
            if _crossed(self.g[k], g_new, getattr(event, "direction", 0)):
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


def _restart_from(solver: OdeSolver, y: np.ndarray) -> None:
    """Continue the solver from a projected state (the change is at tolerance level).

    An explicit Runge-Kutta solver is not asked for ``f = [qd, qdd]`` again: ``qd`` is
    the state's, and ``qdd`` its last stage's, at the end before the projection. That
    ``qdd`` differs from the one at the projected state by about the projection's
    change ``d``, the size of the step's local error, and enters the next step
    multiplied by ``h``: a local error ``O(h d)``, an order above the step's own (the
    energy error of the benchmark's 16-link chain changes in its fourth digit). One
    evaluation per step saved: 6% of them with DOP853.
    """
    solver.y = y.copy()
    if isinstance(solver, BDF):
        solver.D[0] = y
    elif isinstance(solver, RungeKutta):
        n = y.size // 2  # y = [q, qd]
        solver.f = np.concatenate([y[n:], solver.f[n:]])
    elif hasattr(solver, "f"):
        solver.f = solver.fun(solver.t, solver.y)


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
        k = min(np.searchsorted(self.ends, s), len(self.segments) - 1)
        return self.segments[k][2](s)


def _progress_bar(t0: float, tf: float):
    from tqdm.auto import tqdm

    bar = tqdm(total=abs(tf - t0), unit="s", desc="simulating", bar_format=(
        "{desc}: {percentage:3.0f}%|{bar}| t={n:.3g}/{total:.3g} [{elapsed}<{remaining}]"))
    bar.n_t = t0
    return bar
