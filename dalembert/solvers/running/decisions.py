"""The decisions :func:`~.plan.plan_simulation` composes, each a small typed value.

Each function takes what its decision depends on and returns what it decided (with
the reason, where there is one to give): the constraint rows kept, the stabilization,
the loop (C or Python), the solver class and its options, whether stretches of steps
run in C.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import numpy as np
from scipy.integrate import OdeSolver, Radau

from ...codegen.compiled import NumericModel
from ...options import IDA, Backend, Baumgarte, Output, Projection, SimulationOptions
from ..initialization import InitializationReport
from ..native import NATIVE_METHODS, NativeRadau, NotApplicable, native_solver
from ..native.screens import screenable
from ..steppers.scipy_ivp import ControlledSteps, LinearizedRadau, controlled_class

Loop = Literal["c", "python"]


def kept_rows(initial: InitializationReport) -> np.ndarray | None:
    """The constraint rows a run solves for (``None``: all of them).

    Rows that depend on the others at the initial configuration only (a singular one:
    the rank is higher nearby) are all kept: the careful steps leave the dependency out
    while it lasts, where dropping a row for good would let it go.

    Parameters
    ----------
    initial
        The consistent initial state, with its rank report.
    """
    rank = initial.rank
    return rank.kept if rank is not None and rank.rank_nearby is None else None


@dataclass(frozen=True)
class Stabilization:
    """How a run keeps to the constraints.

    Parameters
    ----------
    gain
        The Baumgarte gain (0 without Baumgarte's terms).
    projection
        Whether each step is projected onto the constraints.

    Examples
    --------
    >>> from dalembert.options import simulation_options
    >>> choose_stabilization(simulation_options((0.0, 1.0)))
    Stabilization(gain=0.0, projection=True)
    """

    gain: float
    projection: bool


def choose_stabilization(options: SimulationOptions) -> Stabilization:
    """The stabilization ``options`` ask for (see :class:`Stabilization`); with IDA none
    (its stabilized index-2 form keeps to the constraints)."""
    if options.method is IDA:
        return Stabilization(0.0, False)
    stabilization = options.stabilization
    gain = stabilization.gain if isinstance(stabilization, Baumgarte) else 0.0
    return Stabilization(gain, isinstance(stabilization, Projection))


@dataclass(frozen=True)
class LoopChoice:
    """Where a run's right-hand side and projections run.

    Parameters
    ----------
    loop
        ``"c"`` or ``"python"``.
    why_python
        Why the C loop does not apply (empty if it runs, or ``backend="python"``).
    """

    loop: Loop
    why_python: str


def choose_loop(num: NumericModel, y0: np.ndarray, t0: float, gain: float,
                kept: np.ndarray | None, backend: Backend,
                method: type[OdeSolver] | type[IDA] | None = None) -> LoopChoice:
    """The C loop where it applies and ``backend`` allows, else the Python loop (and
    with IDA, which runs in SUNDIALS' own loop).

    Whether it applies is tried: a C solver of the model is made and solves at the
    initial state (each run then makes its own, :func:`~.run_data.start_run`).

    Parameters
    ----------
    num
        The run's model.
    y0, t0
        The initial state and time (the C loop is checked there).
    gain
        The Baumgarte gain.
    kept
        The constraint rows solved for (``None``: all).
    backend
        ``"auto"``, ``"c"`` or ``"python"``.
    method
        The method (``IDA``: not the C loop).

    Raises
    ------
    ValueError
        ``backend="c"`` where the C loop does not apply (saying why).
    """
    if backend == "python":
        return LoopChoice("python", "")
    if method is IDA:
        return LoopChoice("python", "method='IDA' runs in SUNDIALS' own loop")
    try:
        native_solver(num, y0, t0, gain, kept)
    except NotApplicable as exc:
        if backend == "c":
            raise ValueError(f"backend='c', but the C loop does not apply: {exc}") from exc
        return LoopChoice("python", str(exc))
    return LoopChoice("c", "")


@dataclass(frozen=True)
class SolverChoice:
    """The class that steps and its options, and the Python one of the same method.

    Parameters
    ----------
    solver
        The ``OdeSolver`` class that steps (stepping in C where the loop is).
    options
        Its keyword arguments (a run adds its C solver and, for the implicit methods,
        a Jacobian of its right-hand side).
    stepper
        The C stepper of the method where the C loop runs, else ``None``.
    python_solver, python_options
        The method's solver stepping in Python, and its keyword arguments (the careful
        steps of a run stepping in C take it).
    """

    solver: type[OdeSolver] | type[IDA]
    options: dict[str, object]
    stepper: type[OdeSolver] | None
    python_solver: type[OdeSolver] | type[IDA]
    python_options: dict[str, object]


def choose_solver(options: SimulationOptions, native: bool,
                  exact_jacobian: bool = True) -> SolverChoice:
    """SciPy's method under the chosen step-size controller, or its C stepper where the
    C loop runs and has one (Radau's where its exact Jacobian applies).

    Parameters
    ----------
    options
        The checked options.
    native
        Whether the C loop runs.
    exact_jacobian
        Whether the right-hand side is the KKT system's alone (no Baumgarte terms, no
        inputs computed from the state at every evaluation), so that the residuals'
        exact Jacobians give its Jacobian.
    """
    step = options.step
    if issubclass(options.method, IDA):  # its options are the StepControl itself
        return SolverChoice(IDA, {}, None, IDA, {})
    solver = controlled_class(options.method, step.controller)
    if solver is Radau:  # its Newton systems on the KKT structure (run_data.py)
        solver = LinearizedRadau
    solver_options = step.solver_options()
    python_options = dict(solver_options)
    stepper = NATIVE_METHODS.get(options.method) if native else None
    if native and solver is LinearizedRadau and exact_jacobian:
        stepper = NativeRadau
    if stepper is not None:
        solver = stepper
    if issubclass(solver, ControlledSteps):
        solver_options["step_control"] = step.controller
    python_solver = controlled_class(options.method, step.controller)
    if issubclass(python_solver, ControlledSteps):
        python_options["step_control"] = step.controller
    return SolverChoice(solver, solver_options, stepper, python_solver, python_options)


def choose_stretches(stepper: type[OdeSolver] | None, projection: bool,
                     output: Output) -> bool:
    """Whether whole stretches of steps run in C: with a C stepper, the C loop's
    projection, no dense output, and no events but those C screens
    (:func:`~dalembert.solvers.native.screens.screenable`; with rows dropped as
    dependent too, whose screens of multipliers C gives the minimum-norm ones).

    >>> from dalembert.options import simulation_options
    >>> choose_stretches(None, True, simulation_options((0.0, 1.0)).output)
    False
    """
    return stepper is not None and projection and not output.dense_output \
        and screenable(output.events)
