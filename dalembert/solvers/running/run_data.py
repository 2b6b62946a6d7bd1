"""One run's data: everything a run writes, made fresh from a constant plan.

A :class:`~dalembert.solvers.running.plan.SimulationPlan` holds the decisions and the
model, and nothing a run changes; :func:`start_run` makes a :class:`RunData` for one
run (as MuJoCo's ``mjData`` beside its ``mjModel``, Pinocchio's ``Data`` beside its
``Model``):

- its own parameter vector, where the inputs are written
  (:meth:`~dalembert.codegen.compiled.NumericModel.for_run`);
- the C loop's per-run ``dl_data`` (a :class:`~dalembert.solvers.native.NativeSolver`:
  work arrays, the KKT factorization record, the inputs' callback) over the constant
  ``dl_model`` every run of the model shares;
- the careful steps' state near singular configurations (truncations, passages);
- the functions built on these: the right-hand side, the projection after each step,
  the outputs, the events, the diagnoses of a failing run.

So one plan can run in several threads at once, each run with its own data, and a run's
segments (:mod:`~dalembert.solvers.running.segments`) share one data: the inputs a
segment holds and the careful steps' passages carry from one segment to the next.
"""

from __future__ import annotations

import inspect
import time
from collections.abc import Callable
from dataclasses import dataclass
from functools import partial, update_wrapper
from typing import TYPE_CHECKING

import numpy as np
from scipy.integrate import BDF, OdeSolver, Radau

from ...codegen.compiled import NumericModel
from ...errors import SingularSystemError
from ...inputs import InputSignal
from ...numerics.state_layout import StateLayout
from ...options import IDA
from ..dynamics import first_order_rhs
from ..ggl import GGLForm
from ..ida import integrate_ida
from ..jacobian import first_order_jacobian
from ..native import NativeRadau, NativeSolver
from ..newton import Linearize, dense_linearization, kkt_linearization
from ..outputs import evaluate_outputs
from ..projection import StepProjector
from ..singular.careful import CarefulModel, CarefulSteps, Outputs
from ..singular.watch import Runaway, Singularity, runaway_diagnosis, singular_diagnosis
from ..state import accelerations_at
from ..steppers.scipy_ivp import LinearizedRadau
from .integrate import IntegrationResult, finite_difference_jacobian, integrate
from .nonfinite import Diagnosis, nonfinite_diagnosis
from .switching import DETECTOR, StiffSwitch
from .watchdog import Watchdog

if TYPE_CHECKING:
    from .plan import SimulationPlan


@dataclass(frozen=True)
class RunData:
    """The data of one run of a plan (see :mod:`~dalembert.solvers.running.run_data`).

    Attributes
    ----------
    plan
        The plan it runs.
    num
        The model with the run's own parameter vector (the inputs written into it).
    native
        The C loop's per-run solver, or ``None`` (the Python loop).
    careful_model
        The careful steps' state near singular configurations, or ``None``.
    rhs, project, outputs
        ``rhs(t, y)``; ``project(t, y)`` after each step (``None`` without the
        projection); ``outputs(t, y, dynamics=True)`` the trajectory's derived arrays.
    events
        The events as ``event(t, y)``, with their ``terminal``/``direction``.
    solver_options
        The solver's keyword arguments for this run (the C stepper's solver, the
        implicit methods' Jacobian added to the plan's).
    diagnose, singular, runaway, careful
        What the loops are given to name the cause of a failing run and to step
        through singular configurations (:func:`~.integrate.integrate`).
    deadline
        The ``time.monotonic()`` past which the run stops (the options' ``timeout``
        from the run's start, shared by its segments), or ``None``.
    watchdog
        The deadline's :class:`~.watchdog.Watchdog` (armed while a segment integrates:
        it stops a function of the user's that never returns), or ``None``.
    implicit_options
        ``method="auto"``'s implicit solver's keyword arguments, or ``None``.
    """

    plan: SimulationPlan
    num: NumericModel
    native: NativeSolver | None
    careful_model: CarefulModel | None
    rhs: Callable[[float, np.ndarray], np.ndarray]
    project: Callable[[float, np.ndarray], np.ndarray] | None
    outputs: Outputs
    events: tuple[Callable, ...]
    solver_options: dict[str, object]
    diagnose: Diagnosis
    singular: Singularity | None
    runaway: Runaway | None
    careful: CarefulSteps | None
    deadline: float | None = None
    watchdog: Watchdog | None = None
    implicit_options: dict[str, object] | None = None

    def hold_inputs(self, values: np.ndarray) -> None:
        """Hold the inputs at ``values`` for the evaluations from now on (a sampled
        input's segment)."""
        self.num.set_inputs(values)

    def integrate(self, t_span: tuple[float, float], y0: np.ndarray,
                  t_eval: np.ndarray | None, progress: bool) -> IntegrationResult:
        """Integrate from ``y0`` (consistent) over ``t_span``: the raw states and
        statistics, with the plan's solver, events and dense output.

        Parameters
        ----------
        t_span
            ``(t0, tf)``, the whole run's or a segment's.
        y0
            The state ``[q, qd]`` at ``t0``.
        t_eval
            The times to record (``None``: every step).
        progress
            Show a progress bar.
        """
        out = self.plan.options.output
        solver = self.plan.solver
        if issubclass(solver, IDA):  # SUNDIALS' loop, on the GGL form
            return integrate_ida(GGLForm(self.num, self.plan.kept), t_span, y0, t_eval,
                                 self.plan.options.step, self.deadline)
        if self.careful_model is not None:
            self.careful_model.restart(t_span[0], self.num.layout.split(y0)[0])
        return integrate(
            self.rhs, t_span, y0, method=solver, t_eval=t_eval,
            dense_output=out.dense_output, events=self.events, project=self.project,
            progress=progress, stretches=self.plan.stretches, diagnose=self.diagnose,
            singular=self.singular, careful=self.careful, runaway=self.runaway,
            deadline=self.deadline, watchdog=self.watchdog, switch=self._switch(t_span[0]),
            **self.solver_options)

    def _switch(self, t0: float) -> StiffSwitch | None:
        """``method="auto"``'s switching for the segment starting at ``t0`` (its memory
        is the segment's)."""
        implicit, options = self.plan.implicit, self.implicit_options
        if implicit is None or options is None:
            return None
        explicit, explicit_options = self.plan.solver, dict(self.solver_options)
        if issubclass(explicit, IDA):
            return None
        explicit_class: type[OdeSolver] = explicit  # (closures keep no narrowing)
        explicit_options.pop("detector", None)  # the switch arms it after a wait

        def make_implicit(t: float, y: np.ndarray, t_bound: float,
                          h_abs: float) -> OdeSolver:
            if self.native is not None and implicit is NativeRadau:
                self.native.generate("residual_jacobians")  # on the first switch only
            first = min(h_abs, abs(t_bound - t)) if h_abs > 0 else None
            return implicit(self.rhs, t, y, t_bound, **options, first_step=first)

        def make_explicit(t: float, y: np.ndarray, t_bound: float,
                          h_abs: float) -> OdeSolver:
            first = min(h_abs, abs(t_bound - t)) if h_abs > 0 else None
            return explicit_class(self.rhs, t, y, t_bound,
                                  **{**explicit_options, "first_step": first})

        return StiffSwitch(make_implicit, make_explicit, t0=t0)

    def passages(self) -> str:
        """The warning naming the singular configurations the run passed (empty if none)."""
        return self.careful_model.warning() if self.careful_model is not None else ""

    def segment(self, t_span: tuple[float, float], y0: np.ndarray,
                t_eval: np.ndarray | None, progress: bool) -> RunSegment:
        """One smooth segment of the run (:mod:`~dalembert.solvers.running.segments`)."""
        return RunSegment(self, t_span, y0, t_eval, progress)


@dataclass(frozen=True)
class RunSegment:
    """A segment of a run: its span, start and output times over the run's data."""

    data: RunData
    t_span: tuple[float, float]
    y0: np.ndarray
    t_eval: np.ndarray | None
    progress: bool

    def run(self) -> IntegrationResult:
        """Integrate the segment."""
        return self.data.integrate(self.t_span, self.y0, self.t_eval, self.progress)

    def outputs(self, t: np.ndarray, y: np.ndarray, dynamics: bool = True
                ) -> dict[str, np.ndarray]:
        """The derived arrays at the segment's points."""
        return self.data.outputs(t, y, dynamics=dynamics)


def start_run(plan: SimulationPlan) -> RunData:
    """The data of a new run of ``plan``: its parameter vector, its C data, its careful
    steps' state, and the functions over them.

    Parameters
    ----------
    plan
        The plan (constant: any number of runs may start from it, in any threads).

    Examples
    --------
    >>> from dalembert.examples import load
    >>> system = load("pendulum").build()
    >>> plan = system.plan((0.0, 1.0), {"x": 1.0, "y": 0.0}, backend="python")
    >>> first, second = start_run(plan), start_run(plan)
    >>> first.num.p is second.num.p, first.integrate((0.0, 1.0), plan.y0, None, False).status
    (False, 'finished')
    """
    options, initial, num = plan.options, plan.initial, plan.num.for_run()
    kept, gain, projection = plan.kept, plan.gain, plan.projection
    native = NativeSolver(num, gain, kept) if plan.loop == "c" else None
    if native is not None and plan.stepper is NativeRadau:  # its Newton matrices need them
        native.generate("residual_jacobians")
    # inputs at every evaluation (a sampled signal is held: its segments set the values)
    inputs = options.inputs
    signal = inputs if inputs is not None and inputs.sample_time is None else None
    if native is not None:
        native.set_inputs(signal)
    rows = initial.rank.names if initial.rank is not None else None
    careful = None
    if projection and num.m:  # near a singular configuration: careful steps in Python
        careful = CarefulModel(num, kept, first_order_rhs(num, 0.0, kept),
                               native.project if native is not None else
                               StepProjector(num, kept), options.t_span, rows,
                               (options.step.rtol, options.step.atol))
    stepping_in_c = plan.stepper is not None
    rhs, project, outputs = _functions(num, native, careful, signal, gain, projection,
                                       kept, stepping_in_c and not plan.stretches)
    solver_options = dict(plan.solver_options)
    if stepping_in_c:
        solver_options["native"] = native
    if plan.solver is LinearizedRadau:
        solver_options["linearize"] = _linearization(num, rhs, kept, gain, signal)
    implicit_options = None
    switching = options.switching
    if switching is not None and plan.implicit is not None:  # method="auto"
        solver_options["detector"] = DETECTOR
        implicit_options = {**options.step.solver_options(), "rtol": switching.rtol,
                            "atol": switching.atol}
        implicit_options.pop("first_step", None)
        if plan.implicit is NativeRadau:
            implicit_options["native"] = native
        else:
            implicit_options["linearize"] = _linearization(num, rhs, kept, gain, signal)
    elif plan.solver in (Radau, BDF):
        solver_options["jac"] = _jacobian(num, rhs, kept, gain, signal)
    steps = None
    # careful steps: in the Python loop's own solver, or in one of the same method
    # stepping in Python (a solver stepping in C; Radau on the exact Jacobian, which is
    # not the careful right-hand side's; "auto", whose Radau may be running there);
    # not for the implicit solvers with the C rhs
    if careful is not None and (stepping_in_c or native is None):
        careful_rhs = _with_inputs(num, signal, careful.rhs)
        apart = stepping_in_c or plan.solver is LinearizedRadau or implicit_options is not None
        steps = CarefulSteps(careful, partial(_careful_solver, plan.python_solver,
                                              careful_rhs, options.t_span[1],
                                              plan.python_options)
                             if apart else None)
    if careful is not None:
        outputs = careful.outputs(outputs, signal)
    t0, y0 = options.t_span[0], plan.y0
    deadline = None if options.timeout is None else time.monotonic() + options.timeout
    return RunData(
        plan=plan, num=num, native=native, careful_model=careful, rhs=rhs,
        project=project, outputs=outputs,
        events=tuple(_state_event(e, num.layout, partial(_multipliers, num, signal, native))
                     for e in options.output.events), solver_options=solver_options,
        diagnose=nonfinite_diagnosis(num, initial.names, rows, gain, rhs),
        singular=singular_diagnosis(num, rows, kept, initial.q) if num.m else None,
        runaway=runaway_diagnosis(num, rows, initial.names, t0, y0), careful=steps,
        deadline=deadline, watchdog=None if deadline is None else Watchdog(deadline),
        implicit_options=implicit_options)


def _functions(num: NumericModel, native: NativeSolver | None, careful: CarefulModel | None,
               signal: InputSignal | None, gain: float, projection: bool,
               kept: np.ndarray | None, measured: bool
               ) -> tuple[Callable[[float, np.ndarray], np.ndarray],
                          Callable[[float, np.ndarray], np.ndarray] | None, Outputs]:
    """The run's ``rhs``, projection after each step and outputs: the C loop's, the
    careful steps' (which measure after each step; ``measured``: a C stepper's steps
    one by one) or the Python loop's."""
    if native is not None:
        project = native.project if projection else None
        if careful is not None and measured:  # measured after each step
            project = careful.project
        return native.rhs, project, native.outputs
    outputs = partial(evaluate_outputs, num, kept=kept, inputs=signal)
    if careful is not None:
        return _with_inputs(num, signal, careful.rhs), careful.project, outputs
    rhs = _with_inputs(num, signal, first_order_rhs(num, gain, kept))
    return rhs, StepProjector(num, kept) if projection else None, outputs


def _jacobian(num: NumericModel, rhs: Callable[[float, np.ndarray], np.ndarray],
              kept: np.ndarray | None, gain: float, signal: InputSignal | None
              ) -> Callable[[float, np.ndarray], np.ndarray]:
    """The implicit solvers' Jacobian: exact (:mod:`~dalembert.solvers.jacobian`) where
    the right-hand side is the KKT system's alone, else forward differences of ``rhs``
    (Baumgarte's terms, and inputs computed from the state at every evaluation, whose
    derivatives the exact one leaves out)."""
    if gain == 0.0 and signal is None:
        return first_order_jacobian(num, kept)
    return finite_difference_jacobian(rhs)


#: Up to this many state components Radau factors the dense ``I - c J`` (with the
#: exact ``J``): a few per cent to a third faster than the KKT-structured systems on
#: chains of up to 16 planar links (96 components), which above it are faster and grow
#: linearly where the dense LU grows as the cube (docs/design.md, "Radau's Newton
#: systems").
DENSE_STATE_MAX = 128


def _linearization(num: NumericModel, rhs: Callable[[float, np.ndarray], np.ndarray],
                   kept: np.ndarray | None, gain: float, signal: InputSignal | None
                   ) -> Linearize:
    """Radau's Newton systems: with the exact Jacobian where it applies (see
    :func:`_jacobian`), dense up to ``DENSE_STATE_MAX`` state components, else on the
    KKT structure (:mod:`~dalembert.solvers.newton`: the size and sparsity of the KKT
    matrix, a step linear in the mechanism); with the dense forward-difference
    Jacobian where it does not."""
    if gain != 0.0 or signal is not None or 2 * num.n <= DENSE_STATE_MAX:
        return dense_linearization(_jacobian(num, rhs, kept, gain, signal))
    return kkt_linearization(num, kept)


def _careful_solver(cls: type[OdeSolver], rhs: Callable, t_bound: float,
                    options: dict[str, object], t: float, y: np.ndarray,
                    h_abs: float) -> OdeSolver:
    """A Python solver of the run's method and tolerances at ``(t, y)``, its first
    step ``h_abs`` (the careful steps of the C loop, :mod:`~dalembert.solvers.singular.careful`)."""
    first = min(h_abs, abs(t_bound - t)) if h_abs > 0 else None
    return cls(rhs, t, y, t_bound, **{**options, "first_step": first})


def _with_inputs(num: NumericModel, signal: InputSignal | None,
                 rhs: Callable[[float, np.ndarray], np.ndarray]
                 ) -> Callable[[float, np.ndarray], np.ndarray]:
    """``rhs`` with the inputs set from ``signal`` at each state first."""
    if signal is None:
        return rhs
    layout = num.layout

    def with_inputs(t: float, y: np.ndarray) -> np.ndarray:
        num.set_inputs(signal(t, *layout.split(y)))
        return rhs(t, y)

    return with_inputs


def _multipliers(num: NumericModel, signal: InputSignal | None, native: NativeSolver | None,
                 t: float, q: np.ndarray, qd: np.ndarray) -> np.ndarray:
    """The multipliers at a state, for an event function that asks for them: in C where
    the run is (its inputs as its evaluations set them, minimum-norm where rows are
    dependent), else, or where C's factorization fails there (its dependent rows no
    longer dependent), solved in Python."""
    if native is not None:
        try:
            return native.outputs(np.array([t]), np.concatenate([q, qd])[None, :])[
                "multipliers"][0]
        except SingularSystemError:
            pass
    if signal is not None:
        num.set_inputs(signal(t, q, qd))
    return accelerations_at(num, t, q, qd)[1]


def takes_multipliers(event: Callable) -> bool:
    """Whether ``event`` is ``event(t, q, qd, lam)`` (four positional parameters).

    >>> takes_multipliers(lambda t, q, qd, lam: lam[0]), takes_multipliers(lambda t, q, qd: 1)
    (True, False)
    """
    try:
        parameters = inspect.signature(event).parameters.values()
    except (TypeError, ValueError):
        return False
    positional = [p for p in parameters if p.kind in (p.POSITIONAL_ONLY,
                                                      p.POSITIONAL_OR_KEYWORD)]
    return len(positional) >= 4


def _state_event(event: Callable, layout: StateLayout,
                 multipliers: Callable[[float, np.ndarray, np.ndarray], np.ndarray]
                 ) -> Callable:
    """Adapt ``event(t, q, qd)`` or ``event(t, q, qd, lam)`` (the multipliers at the state)
    to SciPy's ``event(t, y)``, keeping its attributes and its name (messages name it).
    The event gets copies: what it is given is the run's state, and a function may well
    change its arguments for its own use."""
    if takes_multipliers(event):
        def wrapped(t: float, y: np.ndarray) -> float:
            q, qd = layout.split(y)
            return event(t, q.copy(), qd.copy(), multipliers(t, q, qd))
    else:
        def wrapped(t: float, y: np.ndarray) -> float:
            q, qd = layout.split(y)
            return event(t, q.copy(), qd.copy())

    update_wrapper(wrapped, event)
    wrapped.terminal = getattr(event, "terminal", False)  # type: ignore[attr-defined]
    wrapped.direction = getattr(event, "direction", 0)  # type: ignore[attr-defined]
    return wrapped
