"""One simulation's plan: every decision about how it runs, made in one place.

:func:`plan_simulation` takes the checked options (:mod:`dalembert.options`), the
bound numeric model and the consistent initial state, and decides once (each decision
a function of :mod:`.decisions` returning a typed value)

- the loop: in C (:mod:`dalembert.solvers.native`: the right-hand side, the steps
  and the projection in C) where it applies and ``backend`` allows, else in Python,
  with the reason the C loop does not apply;
- the solver class: SciPy's method, under the chosen step-size controller
  (:mod:`~dalembert.solvers.steppers.scipy_ivp`), stepping in C where the loop is;
- whether whole stretches of steps run in C (:class:`~.loop.StretchLoop`): with
  the C loop's projection and neither events nor dense output;
- the right-hand side, the projection after each step and the trajectory's outputs.

The resulting :class:`SimulationPlan` is a frozen dataclass: :meth:`System.run
<dalembert.System.run>` executes it, and a variant is ``dataclasses.replace(plan,
stretches=False)`` (the step-by-step loop, same results to rounding). Its run's state
is not all per run yet: the plan holds the run's model (its own parameter vector,
where the inputs are written), the C loop's solver and the careful steps' model, which
:meth:`SimulationPlan.run` restarts; one plan runs in one thread at a time.

Both loops give the same trajectory to rounding (tested).
"""

from __future__ import annotations

import inspect
from collections.abc import Callable
from dataclasses import dataclass, field
from functools import partial, update_wrapper

import numpy as np
from scipy.integrate import BDF, OdeSolver, Radau

from ...codegen.compiled import NumericModel
from ...inputs import InputSignal
from ...numerics.state_layout import StateLayout
from ...options import SimulationOptions
from ..dynamics import first_order_rhs
from ..initialization import InitializationReport
from ..native import NativeSolver
from ..outputs import evaluate_outputs
from ..projection import StepProjector
from ..singular.careful import CarefulModel, CarefulSteps, Outputs
from ..singular.watch import Runaway, Singularity, runaway_diagnosis, singular_diagnosis
from ..state import accelerations_at
from .decisions import (
    Loop,
    choose_loop,
    choose_solver,
    choose_stabilization,
    choose_stretches,
    kept_rows,
)
from .integrate import IntegrationResult, finite_difference_jacobian, integrate
from .nonfinite import Diagnosis, nonfinite_diagnosis


@dataclass(frozen=True)
class SimulationPlan:
    """How one simulation runs (see :mod:`dalembert.solvers.running.plan`).

    Attributes
    ----------
    options
        The checked options it was made from.
    initial
        The consistent initial state and what making it consistent changed.
    loop
        ``"c"`` or ``"python"``: where the right-hand side and projections run.
    why_python
        Why the C loop does not apply (empty if it runs, or ``backend="python"``).
    solver
        The ``OdeSolver`` class that steps.
    solver_options
        Its keyword arguments (tolerances, step limits, controller, Jacobian...).
    stretches
        Whether whole stretches of steps run in C.
    rhs, project, outputs
        ``rhs(t, y)``; ``project(t, y)`` after each step (``None`` without the
        projection); ``outputs(t, y)`` the trajectory's derived arrays.
    events
        The events as ``event(t, y)``, with their ``terminal``/``direction``.
    parameters
        The parameter vector the model's functions read (the model's parameter
        values first).
    diagnose
        ``diagnose(t, y)``: what is not finite at a state, for the message of a run
        that meets a NaN or an infinity (:mod:`~dalembert.solvers.running.nonfinite`).
    singular
        ``singular(t, y)``: the singular configuration of the constraints at a state,
        for the message of a run whose steps collapse there
        (:mod:`~dalembert.solvers.singular.watch`).
    careful
        The careful steps near a singular configuration
        (:mod:`~dalembert.solvers.singular.careful`):
        in the Python loop, its ``rhs`` and ``project``; the C loop takes them the Python
        way. ``None`` without them.
    runaway
        ``runaway(t, y)``: what in the model grew most since the start, for the message
        of a run whose steps keep shrinking toward a limit time
        (:mod:`~dalembert.solvers.singular.watch`).
    """

    options: SimulationOptions
    initial: InitializationReport = field(repr=False)
    loop: Loop
    why_python: str
    solver: type[OdeSolver]
    solver_options: dict[str, object] = field(repr=False)
    stretches: bool
    rhs: Callable[[float, np.ndarray], np.ndarray] = field(repr=False)
    project: Callable[[float, np.ndarray], np.ndarray] | None = field(repr=False)
    outputs: Outputs = field(repr=False)
    events: tuple[Callable, ...] = field(repr=False)
    diagnose: Diagnosis = field(repr=False)
    singular: Singularity | None = field(repr=False, default=None)
    careful: CarefulSteps | None = field(repr=False, default=None)
    runaway: Runaway | None = field(repr=False, default=None)
    parameters: np.ndarray = field(repr=False, default_factory=lambda: np.zeros(0))
    num: NumericModel | None = field(repr=False, default=None)
    #: When the run must stop (``time.monotonic()``; set by ``System.run`` from the
    #: options' ``timeout``), or ``None``.
    deadline: float | None = field(repr=False, default=None)

    @property
    def y0(self) -> np.ndarray:
        """The consistent initial state ``[q0, qd0]``."""
        return StateLayout(len(self.initial.q)).join(self.initial.q, self.initial.qd)

    def run(self) -> IntegrationResult:
        """Integrate: the raw states and statistics (``System.run`` adds the rest)."""
        out = self.options.output
        if self.careful is not None:
            self.careful.model.restart(self.options.t_span[0], self.initial.q)
        return integrate(
            self.rhs, self.options.t_span, self.y0, method=self.solver, t_eval=out.t_eval,
            dense_output=out.dense_output, events=self.events, project=self.project,
            progress=out.progress, stretches=self.stretches, diagnose=self.diagnose,
            singular=self.singular, careful=self.careful, runaway=self.runaway,
            deadline=self.deadline, **self.solver_options)


def plan_simulation(num: NumericModel, initial: InitializationReport,
                    options: SimulationOptions) -> SimulationPlan:
    """Decide how a simulation of ``num`` from ``initial`` runs under ``options``.

    Parameters
    ----------
    num
        The compiled equations bound to parameter values.
    initial
        The consistent initial state (with the independent constraint rows, when
        some are dependent).
    options
        The checked options (:func:`dalembert.options.simulation_options`).

    Raises
    ------
    ValueError
        ``backend="c"`` where the C loop does not apply (saying why).

    Examples
    --------
    >>> from dalembert.options import simulation_options
    >>> from dalembert.examples import load
    >>> system = load("pendulum").build()
    >>> state = system.consistent_initial_state({"x": 1.0, "y": 0.0})
    >>> plan = plan_simulation(system.numeric(), state,
    ...                        simulation_options((0.0, 1.0), backend="python"))
    >>> plan.loop, plan.solver.__name__, plan.stretches
    ('python', 'ControlledDOP853', False)
    """
    num = num.for_run()  # the run's inputs go in its own parameter vector
    t0, y0 = options.t_span[0], num.layout.join(initial.q, initial.qd)
    kept = kept_rows(initial)
    stabilization = choose_stabilization(options)
    gain, projection = stabilization.gain, stabilization.projection
    loop = choose_loop(num, y0, t0, gain, kept, options.backend)
    native = loop.native
    # inputs at every evaluation (a sampled signal is held: its caller sets the values)
    signal = options.inputs if options.inputs and options.inputs.sample_time is None else None
    if native is not None:
        native.set_inputs(signal)
    chosen = choose_solver(options, native)
    solver, solver_options, stepper = chosen.solver, chosen.options, chosen.stepper
    stretches = choose_stretches(stepper, projection, options.output)
    rows = initial.rank.names if initial.rank is not None else None
    careful = None
    if projection and num.m:  # near a singular configuration: careful steps in Python
        careful = CarefulModel(num, kept, first_order_rhs(num, 0.0, kept),
                               native.project if native is not None else
                               StepProjector(num, kept), options.t_span, rows,
                               (options.step.rtol, options.step.atol))
    rhs, project, outputs = _functions(num, native, careful, signal, gain, projection,
                                       kept, stepper is not None and not stretches)
    if solver in (Radau, BDF):
        solver_options["jac"] = finite_difference_jacobian(rhs)
    steps = None
    # careful steps: in the Python loop's own solver, or (a solver stepping in C) in one
    # of the same method stepping in Python; not for the implicit solvers with the C rhs
    if careful is not None and (stepper is not None or native is None):
        careful_rhs = _with_inputs(num, signal, careful.rhs)
        steps = CarefulSteps(careful, partial(_careful_solver, chosen.python_solver,
                                              careful_rhs, options.t_span[1],
                                              chosen.python_options)
                             if stepper is not None else None)
    if careful is not None:
        outputs = careful.outputs(outputs, signal)
    return SimulationPlan(
        options=options, initial=initial, loop=loop.loop,
        why_python=loop.why_python, solver=solver, solver_options=solver_options,
        stretches=stretches, rhs=rhs, project=project, outputs=outputs,
        events=tuple(_state_event(e, num.layout, partial(_multipliers, num, signal))
                     for e in options.output.events), parameters=num.p, num=num,
        diagnose=nonfinite_diagnosis(num, initial.names, rows, gain, rhs),
        singular=singular_diagnosis(num, rows, kept, initial.q) if num.m else None,
        careful=steps, runaway=runaway_diagnosis(num, rows, initial.names, t0, y0))


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


def _multipliers(num: NumericModel, signal: InputSignal | None, t: float, q: np.ndarray,
                 qd: np.ndarray) -> np.ndarray:
    """The multipliers at a state, for an event function that asks for them."""
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
