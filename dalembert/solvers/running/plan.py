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
  the C loop's projection, no dense output and no events but screened ones;
- the stabilization and the constraint rows kept.

The resulting :class:`SimulationPlan` is constant (a frozen dataclass holding the
bound model, whose values are read-only, and the decisions): each run makes its own
data from it (:func:`~.run_data.start_run`: the parameter vector the inputs are
written into, the C loop's per-run data, the careful steps' state and the functions
over them), so one plan may run in several threads at once. :meth:`System.run
<dalembert.System.run>` executes it, and a variant is ``dataclasses.replace(plan,
stretches=False)`` (the step-by-step loop, same results to rounding).

Both loops give the same trajectory to rounding (tested).
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np
from scipy.integrate import OdeSolver, Radau

from ...codegen.compiled import NumericModel
from ...options import IDA, SimulationOptions
from ..initialization import InitializationReport
from .decisions import (
    Loop,
    choose_loop,
    choose_solver,
    choose_stabilization,
    choose_stretches,
    kept_rows,
)
from .integrate import IntegrationResult
from .run_data import RunData, start_run


@dataclass(frozen=True)
class SimulationPlan:
    """How one simulation runs (see :mod:`dalembert.solvers.running.plan`).

    Attributes
    ----------
    options
        The checked options it was made from.
    initial
        The consistent initial state and what making it consistent changed.
    num
        The compiled equations bound to the run's parameter values (read-only).
    loop
        ``"c"`` or ``"python"``: where the right-hand side and projections run.
    why_python
        Why the C loop does not apply (empty if it runs, or ``backend="python"``).
    solver
        The ``OdeSolver`` class that steps, or ``IDA`` (:mod:`dalembert.solvers.ida`).
    solver_options
        Its keyword arguments (tolerances, step limits, controller...); a run adds
        what is its own (:func:`~.run_data.start_run`).
    stepper
        The C stepper of the method where the C loop runs and has one, else ``None``.
    python_solver, python_options
        The method's solver stepping in Python and its keyword arguments (the careful
        steps of a run stepping in C take it).
    stretches
        Whether whole stretches of steps run in C.
    kept
        The constraint rows solved for (``None``: all).
    gain
        The Baumgarte gain (0: none).
    projection
        Whether each step is projected onto the constraints.
    implicit
        ``method="auto"``'s implicit solver (Radau: in C where its stepper applies),
        ``None`` for another method.
    """

    options: SimulationOptions
    initial: InitializationReport = field(repr=False)
    num: NumericModel = field(repr=False)
    loop: Loop
    why_python: str
    solver: type[OdeSolver] | type[IDA]
    solver_options: dict[str, object] = field(repr=False)
    stepper: type[OdeSolver] | None = field(repr=False)
    python_solver: type[OdeSolver] | type[IDA] = field(repr=False)
    python_options: dict[str, object] = field(repr=False)
    stretches: bool
    kept: np.ndarray | None = field(repr=False)
    gain: float = field(repr=False)
    projection: bool = field(repr=False)
    implicit: type[OdeSolver] | None = field(default=None, repr=False)

    @property
    def y0(self) -> np.ndarray:
        """The consistent initial state ``[q0, qd0]``."""
        return self.num.layout.join(self.initial.q, self.initial.qd)

    @property
    def parameters(self) -> np.ndarray:
        """The parameter vector the model's functions read (the model's parameter
        values first, then the inputs at 0: each run writes its own)."""
        return self.num.p

    def start(self) -> RunData:
        """The data of a new run of this plan (:func:`~.run_data.start_run`)."""
        return start_run(self)

    def run(self) -> IntegrationResult:
        """Integrate in one segment: the raw states and statistics (``System.run``
        adds the rest)."""
        out = self.options.output
        return self.start().integrate(self.options.t_span, self.y0, out.t_eval,
                                      out.progress)


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
    t0, y0 = options.t_span[0], num.layout.join(initial.q, initial.qd)
    kept = kept_rows(initial)
    stabilization = choose_stabilization(options)
    loop = choose_loop(num, y0, t0, stabilization.gain, kept, options.backend,
                       options.method)
    inputs = options.inputs
    exact = stabilization.gain == 0.0 and (inputs is None or inputs.sample_time is not None)
    chosen = choose_solver(options, loop.loop == "c", exact)
    implicit = None
    if options.switching is not None:  # method="auto": the Radau it may switch to
        implicit = choose_solver(replace(options, method=Radau), loop.loop == "c",
                                 exact).solver
    return SimulationPlan(
        options=options, initial=initial, num=num, loop=loop.loop,
        why_python=loop.why_python, solver=chosen.solver, solver_options=chosen.options,
        stepper=chosen.stepper, python_solver=chosen.python_solver,
        python_options=chosen.python_options,
        stretches=choose_stretches(chosen.stepper, stabilization.projection,
                                   options.output),
        kept=kept, gain=stabilization.gain, projection=stabilization.projection,
        implicit=implicit)
