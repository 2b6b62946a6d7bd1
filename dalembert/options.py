"""The options of a simulation: one declared table, checked once, turned into typed values.

:data:`SIMULATE_PARAMETERS` declares the forms each run option of
:meth:`System.simulate <dalembert.System.simulate>` may take. Its rows are bound to
``simulate``'s signature and to :func:`simulation_options`'s
(:func:`dalembert.rules.checked_keywords`: a keyword without its row, or a row without
its keyword, fails the import) and checked once, at whichever of them is called (one
uniform message, "The 'rtol' parameter of simulate must be ...; got ...").
:func:`simulation_options` then applies the rules that tie two options together. What
comes out is a :class:`SimulationOptions` made of typed values (a :class:`Baumgarte`
stabilization holding its gain, a :class:`StepControl` holding its tolerances), which
the layers below trust.

>>> options = simulation_options((0, 1), stabilization="baumgarte", baumgarte_gain=20.0)
>>> options.stabilization
Baumgarte(gain=20.0)
>>> simulation_options((0, 1), rtol=float("inf"))  # doctest: +ELLIPSIS
Traceback (most recent call last):
...
ValueError: The 'rtol' parameter of simulate must be a finite positive number ...; got inf.
"""

from __future__ import annotations

import inspect
import math
import warnings
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Literal

import numpy as np

from .errors import StiffStabilizationWarning, user_stacklevel
from .inputs import InputSignal, input_signal
from .rules import (
    NONE,
    Boolean,
    Callables,
    CheckedWhereUsed,
    IsNone,
    Items,
    OneOf,
    PositiveInteger,
    PositiveNumber,
    Rule,
    SolverClass,
    Times,
    Tolerance,
    checked_keywords,
)

if TYPE_CHECKING:
    from scipy.integrate import OdeSolver

#: SciPy's solvers by the names ``solve_ivp`` knows them by (``scipy.integrate`` is
#: imported when a simulation is set up, not with dalembert: it is a large import),
#: ``"IDA"`` (SUNDIALS IDA on the stabilized index-2 form, :class:`IDA`) and ``"auto"``
#: (DOP853, switching to Radau where the problem is stiff, :class:`Switching`).
METHODS: tuple[str, ...] = ("RK23", "RK45", "DOP853", "Radau", "BDF", "LSODA", "IDA",
                            "auto")
#: The methods that are implicit (stiff solvers): their default tolerances are looser.
IMPLICIT_METHODS: tuple[str, ...] = ("Radau", "BDF", "LSODA", "IDA")

Backend = Literal["auto", "c", "python"]
StepController = Literal["PI", "scipy"]
RedundantConstraints = Literal["minimum-norm", "error"]
VelocityProjection = Literal["kinetic-energy", "least-change"]
#: How an impact on several touching contacts is resolved (dalembert.solvers.contact.laws).
ImpactLaw = Literal["sequential", "simultaneous"]
#: How a run with unilateral constraints goes (dalembert.solvers.contact).
ContactMode = Literal["event-driven", "time-stepping"]

BACKENDS: tuple[Backend, ...] = ("auto", "c", "python")
STEP_CONTROLS: tuple[StepController, ...] = ("PI", "scipy")
REDUNDANT_MODES: tuple[RedundantConstraints, ...] = ("minimum-norm", "error")
VELOCITY_PROJECTIONS: tuple[VelocityProjection, ...] = ("kinetic-energy", "least-change")
IMPACT_LAWS: tuple[ImpactLaw, ...] = ("sequential", "simultaneous")
CONTACT_MODES: tuple[ContactMode, ...] = ("event-driven", "time-stepping")
#: The time-stepping contact mode's step when none is given.
DEFAULT_CONTACT_STEP = 1e-3
STABILIZATIONS = ("projection", "baumgarte", None)
#: The Baumgarte gain when ``stabilization="baumgarte"`` is given without one.
DEFAULT_BAUMGARTE_GAIN = 10.0


# --------------------------------------------------------------------------- typed values


class IDA:
    """``method="IDA"``: SUNDIALS IDA (through scikit-sundae) on the stabilized index-2
    (GGL) form of the equations, :mod:`dalembert.solvers.ida`.

    The method's typed value, not an ``OdeSolver``: it integrates a DAE in ``[q, v,
    lambda, mu]``, not ``y' = F(t, y)``, and keeps to the constraints by its form (no
    projection). Events, dense output and inputs are not supported with it yet.
    """


@dataclass(frozen=True)
class Switching:
    """``method="auto"``: the run starts with DOP853 (the options' ``method``) and
    switches to Radau where Hairer's test finds the problem stiff and Radau's steps pay
    (:mod:`dalembert.solvers.running.switching`).

    Parameters
    ----------
    rtol, atol
        Radau's tolerances: the ones given, or its defaults where none were.
    """

    rtol: float | np.ndarray
    atol: float | np.ndarray


@dataclass(frozen=True)
class Tolerances:
    """Default tolerances of a kind of method.

    Parameters
    ----------
    rtol, atol
        The relative and absolute tolerances.
    """

    rtol: float
    atol: float


#: The default ``rtol``/``atol`` by kind of method, the one place they are set. The
#: explicit methods run at 1e-11/1e-13: a step of DOP853 (order 8) costs little and a
#: digit about 30% more steps, so the default is close to rounding. An implicit method
#: pays a Newton iteration and a factorization per step at a lower order: at 1e-11 it
#: is slow (issue 34: Radau took 43.9 s for 0.2 s of a stiff pendulum) for digits its
#: default mostly gives already, so they default to 1e-8/1e-10 (docs/design.md, "Stiff
#: mechanisms", has the measurements: car axis, a stiff spring).
DEFAULT_TOLERANCES: dict[str, Tolerances] = {
    "explicit": Tolerances(1e-11, 1e-13),
    "implicit": Tolerances(1e-8, 1e-10),
}


@dataclass(frozen=True)
class Projection:
    """Project positions, then velocities, onto the constraints after every step."""


@dataclass(frozen=True)
class Baumgarte:
    """Replace ``A qdd = c`` by ``A qdd = c - 2 w (A qd + b) - w^2 psi`` (``w = gain``).

    A constraint error then obeys the critically damped ``e'' + 2 w e' + w^2 e = 0``;
    choose ``w`` a few times above the fastest motion of interest and well below
    ``1 / step``.
    """

    gain: float


#: ``None``: the raw index-1 formulation (the drift is left alone).
Stabilization = Projection | Baumgarte | None


@dataclass(frozen=True)
class StepControl:
    """The step-size controller with its tolerances and step limits (``solve_ivp``'s)."""

    controller: StepController = "PI"
    rtol: float | np.ndarray = 1e-11
    atol: float | np.ndarray = 1e-13
    first_step: float | None = None
    max_step: float = math.inf

    def solver_options(self) -> dict[str, object]:
        """The keywords of a SciPy ``OdeSolver`` these values stand for."""
        options: dict[str, object] = {"rtol": self.rtol, "atol": self.atol,
                                      "max_step": self.max_step}
        if self.first_step is not None:
            options["first_step"] = self.first_step
        return options


@dataclass(frozen=True)
class Output:
    """What the integration records: times, dense output, events, a progress bar."""

    t_eval: np.ndarray | None = None
    dense_output: bool = False
    events: tuple[Callable, ...] = ()
    progress: bool = False


@dataclass(frozen=True)
class SimulationOptions:
    """Every option of one simulation, checked (see :func:`simulation_options`)."""

    t_span: tuple[float, float]
    method: type[OdeSolver] | type[IDA]
    step: StepControl = field(default_factory=StepControl)
    stabilization: Stabilization = field(default_factory=Projection)
    output: Output = field(default_factory=Output)
    backend: Backend = "auto"
    redundant_constraints: RedundantConstraints = "minimum-norm"
    velocity_projection: VelocityProjection = "kinetic-energy"
    #: The inputs' values along the run (:mod:`dalembert.inputs`), or ``None``.
    inputs: InputSignal | None = None
    #: Seconds (wall clock) the integration may run, or ``None``: no limit.
    timeout: float | None = None
    #: How impacts on several touching contacts are resolved (unilateral constraints).
    impact_law: ImpactLaw = "sequential"
    #: Event-driven (exact) or time-stepping (Moreau-Jean, for many contacts).
    contact_mode: ContactMode = "event-driven"
    #: The time-stepping mode's step.
    contact_step: float = DEFAULT_CONTACT_STEP
    #: ``method="auto"``'s switching to an implicit method, or ``None``.
    switching: Switching | None = None


# --------------------------------------------------------------------------- the table

#: ``redundant_constraints`` of a System, a run, an equilibrium.
REDUNDANT_CONSTRAINTS: list[Rule] = [OneOf(REDUNDANT_MODES)]
#: Parameter values overriding a model's: checked as they are read, against the model's
#: names (a ParameterError naming the key).
PARAMETER_VALUES: list[Rule] = [CheckedWhereUsed("a dict {parameter: value} or None")]
#: Coordinates held fixed: checked as they are read, against the model's coordinates (an
#: InitialConditionError naming the entry).
FIXED: list[Rule] = [CheckedWhereUsed("a sequence of coordinates or None")]
#: The values of a model's inputs (:func:`dalembert.inputs.input_signal` checks them
#: against the model's inputs).
INPUT_VALUES: list[Rule] = [CheckedWhereUsed("input values (see dalembert.inputs)")]

#: ``None`` for a tolerance: the method's default (:func:`default_tolerances`).
METHOD_DEFAULT = IsNone("None (the method's default)")

#: Every option of ``simulate`` that makes its :class:`SimulationOptions` (but the
#: inputs, whose form depends on the model) and the forms it may take.
SIMULATE_PARAMETERS: dict[str, list[Rule]] = {
    "method": [OneOf(METHODS), SolverClass()],
    "rtol": [Tolerance(), METHOD_DEFAULT],
    "atol": [Tolerance(), METHOD_DEFAULT],
    "step_control": [OneOf(STEP_CONTROLS)],
    "first_step": [PositiveNumber(), NONE],
    "max_step": [PositiveNumber(infinite=True)],
    "stabilization": [OneOf(STABILIZATIONS)],
    "baumgarte_gain": [PositiveNumber(), NONE],
    "backend": [OneOf(BACKENDS)],
    "native": [Boolean(), NONE],
    "redundant_constraints": REDUNDANT_CONSTRAINTS,
    "velocity_projection": [OneOf(VELOCITY_PROJECTIONS)],
    "dense_output": [Boolean()],
    "progress": [Boolean()],
    "events": [Callables()],
    "t_eval": [Times(), NONE],
    "sample_time": [PositiveNumber(), NONE],
    "timeout": [PositiveNumber(), NONE],
    "impact_law": [OneOf(IMPACT_LAWS)],
    "contact_mode": [OneOf(CONTACT_MODES)],
    "contact_step": [PositiveNumber(), NONE],
}

#: The keywords of :func:`simulation_options`: ``simulate``'s run options and what the
#: System tells of its model.
OPTIONS_PARAMETERS: dict[str, list[Rule]] = {
    **SIMULATE_PARAMETERS,
    "inputs": INPUT_VALUES,
    "state_size": [PositiveInteger(), NONE],
    "input_names": [Items()],
}


def run_options(arguments: Mapping[str, object]) -> dict[str, object]:
    """The run options (:func:`simulation_options`'s keywords that ``simulate`` takes)
    among a call's ``arguments``: what a function taking them as parameters of its own
    passes on, so that an option added to the table reaches the run with no other edit.

    Parameters
    ----------
    arguments
        A call's arguments by name.

    Examples
    --------
    >>> run_options({"self": None, "q0": [1.0], "rtol": 1e-9, "inputs": None})
    {'rtol': 1e-09, 'inputs': None}
    """
    return {name: value for name, value in arguments.items()
            if name in OPTIONS_PARAMETERS and name not in ("state_size", "input_names")}


# --------------------------------------------------------------------------- the door


@checked_keywords(OPTIONS_PARAMETERS, caller="simulate")
def simulation_options(
    t_span: Sequence[float],
    *,
    t_eval: Sequence[float] | np.ndarray | None = None,
    method: str | type[OdeSolver] = "auto",
    rtol: float | Sequence[float] | np.ndarray | None = None,
    atol: float | Sequence[float] | np.ndarray | None = None,
    step_control: StepController = "PI",
    first_step: float | None = None,
    max_step: float = math.inf,
    stabilization: Literal["projection", "baumgarte"] | None = "projection",
    baumgarte_gain: float | None = None,
    backend: Backend = "auto",
    native: bool | None = None,
    redundant_constraints: RedundantConstraints = "minimum-norm",
    velocity_projection: VelocityProjection = "kinetic-energy",
    events: Sequence[Callable] = (),
    dense_output: bool = False,
    progress: bool = False,
    inputs: object = None,
    sample_time: float | None = None,
    timeout: float | None = None,
    impact_law: ImpactLaw = "sequential",
    contact_mode: ContactMode = "event-driven",
    contact_step: float | None = None,
    state_size: int | None = None,
    input_names: Sequence[str] = (),
) -> SimulationOptions:
    """Check the keywords of ``simulate`` once and turn them into typed values.

    Parameters
    ----------
    t_span, t_eval, method, first_step, max_step, events, dense_output
        As in :func:`scipy.integrate.solve_ivp`; ``method`` may also be ``"IDA"``
        (:class:`IDA`) or ``"auto"`` (the default, :class:`Switching`).
    rtol, atol
        As in :func:`scipy.integrate.solve_ivp`; ``None``: the method's defaults
        (:func:`default_tolerances`; with ``"auto"``, each method's own).
    step_control
        The explicit Runge-Kutta methods' step-size controller, ``"PI"`` or
        ``"scipy"`` (:mod:`dalembert.solvers.steppers.scipy_ivp`).
    stabilization, baumgarte_gain
        ``"projection"``, ``"baumgarte"`` (with a finite positive gain, default 10) or
        ``None``; a gain with another stabilization is an error.
    backend
        ``"auto"`` (the C loop where it applies), ``"c"`` (required) or ``"python"``.
    native
        Deprecated alias of ``backend``: ``True`` is ``"c"``, ``False`` ``"python"``.
    redundant_constraints
        ``"minimum-norm"`` or ``"error"`` for dependent constraints.
    velocity_projection
        How initial velocities are made consistent: ``"kinetic-energy"`` (the
        velocities after a perfectly plastic impact onto the constraints) or
        ``"least-change"`` (the nearest velocities in the Euclidean sense).
    progress
        Show a progress bar.
    inputs, sample_time
        The values of the model's inputs and the period of their zero-order hold
        (:func:`dalembert.inputs.input_signal`).
    timeout
        Seconds on the wall clock the integration may run (``None``: no limit). It is
        checked between steps (in the C loop between its stretches of steps, a
        fraction of a second each): a run past it stops there with status
        ``"timeout"``, returning what it computed. A user's function (an input, an
        event) that itself never returns is stopped half a second after the limit
        (:mod:`~dalembert.solvers.running.watchdog`), unless it is blocked in a C call
        (``time.sleep``): then when that call returns.
    impact_law
        How an impact on several touching unilateral constraints is resolved:
        ``"sequential"`` or ``"simultaneous"`` (:mod:`dalembert.solvers.contact.laws`).
    contact_mode, contact_step
        ``"event-driven"`` (exact: every impact located and resolved) or
        ``"time-stepping"`` (Moreau-Jean steps of ``contact_step``, default 1e-3: for
        many contacts; :mod:`dalembert.solvers.contact.time_stepping`). A step without
        the time-stepping mode is an error.
    state_size
        The length of the state ``[q, qd]`` (twice the coordinates), when known: an
        array of tolerances must have one entry per state entry.
    input_names
        The model's inputs.

    >>> simulation_options((0, 2), method="RK45", rtol=1e-8).step.rtol
    1e-08
    >>> simulation_options((0, 2), method="Radau").step
    StepControl(controller='PI', rtol=1e-08, atol=1e-10, first_step=None, max_step=inf)
    >>> simulation_options((0, 2), atol=[1e-9, 1e-9], state_size=4)  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    ValueError: The 'atol' parameter of simulate must be ... or an array of 4 of them ...
    """
    # each keyword has been checked against its row of OPTIONS_PARAMETERS at the door
    check_events(events)
    if state_size is not None:
        _check_tolerance_sizes({"rtol": rtol, "atol": atol}, state_size)
    span = _time_span(t_span)
    if first_step is not None and first_step > abs(span[1] - span[0]):
        raise ValueError(f"first_step={first_step!r} is longer than t_span {span}; give a "
                         "first step inside the span, or leave it None")
    import scipy.integrate  # here, not when dalembert is imported: a large import

    solver: type[OdeSolver] | type[IDA]
    switching = None
    if method == "IDA":
        solver = IDA
        _check_ida(rtol, stabilization, backend, events, dense_output, inputs,
                   sample_time)
    elif method == "auto":  # the default; DOP853 at its defaults, Radau at its own
        if step_control != "PI":
            raise ValueError(f"step_control={step_control!r} gives one explicit method's "
                             "steps; give it with that method (method='DOP853', 'RK45' "
                             "...): method='auto', the default, watches DOP853's steps "
                             "for stiffness under step_control='PI'")
        solver = scipy.integrate.DOP853
        implicit = DEFAULT_TOLERANCES["implicit"]
        switching = Switching(_tolerance(implicit.rtol if rtol is None else rtol),
                              _tolerance(implicit.atol if atol is None else atol))
    else:
        solver = getattr(scipy.integrate, method) if isinstance(method, str) else method
    defaults = default_tolerances(solver)
    rtol = defaults.rtol if rtol is None else rtol
    atol = defaults.atol if atol is None else atol
    if stabilization == "projection" and solver is scipy.integrate.LSODA:
        raise ValueError(
            "LSODA cannot be restarted from a projected state; use 'Radau' or 'BDF' for "
            "stiff problems, or stabilization='baumgarte'"
        )
    if contact_step is not None and contact_mode != "time-stepping":
        raise ValueError(f"contact_step={contact_step!r} is the time-stepping contact "
                         "mode's step; give contact_mode='time-stepping' with it, or leave "
                         "it None")
    if contact_step is not None and contact_step > abs(span[1] - span[0]):
        raise ValueError(f"contact_step={contact_step!r} is longer than t_span {span}")
    stabilized = _stabilization(stabilization, baumgarte_gain)
    _warn_stiff_gain(stabilized, solver, span)
    return SimulationOptions(
        t_span=span,
        method=solver,
        step=StepControl(step_control, _tolerance(rtol), _tolerance(atol),
                         None if first_step is None else float(first_step), float(max_step)),
        stabilization=stabilized,
        output=Output(_times(t_eval, span), bool(dense_output), tuple(events), bool(progress)),
        backend=_backend(backend, native),
        redundant_constraints=redundant_constraints,
        velocity_projection=velocity_projection,
        inputs=input_signal(inputs, input_names,
                            None if sample_time is None else float(sample_time), span),
        timeout=None if timeout is None else float(timeout),
        impact_law=impact_law,
        contact_mode=contact_mode,
        contact_step=DEFAULT_CONTACT_STEP if contact_step is None else float(contact_step),
        switching=switching,
    )


def default_tolerances(method: type[OdeSolver] | type[IDA]) -> Tolerances:
    """The default ``rtol`` and ``atol`` of a method (:data:`DEFAULT_TOLERANCES`):
    SciPy's implicit solvers (and their subclasses) and :class:`IDA` are implicit,
    every other method explicit.

    Parameters
    ----------
    method
        The method's class.

    Examples
    --------
    >>> from scipy.integrate import BDF, DOP853
    >>> default_tolerances(DOP853), default_tolerances(BDF), default_tolerances(IDA)
    (Tolerances(rtol=1e-11, atol=1e-13), Tolerances(rtol=1e-08, atol=1e-10), \
Tolerances(rtol=1e-08, atol=1e-10))
    """
    import scipy.integrate

    implicit = tuple(getattr(scipy.integrate, name) for name in IMPLICIT_METHODS
                     if name != "IDA")
    if method is IDA or issubclass(method, implicit):
        return DEFAULT_TOLERANCES["implicit"]
    return DEFAULT_TOLERANCES["explicit"]


def _check_ida(rtol: float | Sequence[float] | np.ndarray | None,
               stabilization: str | None, backend: Backend, events: Sequence[Callable],
               dense_output: bool, inputs: object, sample_time: float | None) -> None:
    """What ``method="IDA"`` does not take (yet), refused naming it; without
    scikit-sundae an ``ImportError`` saying what to install."""
    refused = [
        (rtol is not None and np.ndim(rtol) > 0, "an array of 'rtol' (IDA takes one "
         "relative tolerance; give a number, and an array of 'atol' if needed)"),
        (stabilization != "projection", f"stabilization={stabilization!r} (IDA keeps "
         "to the constraints by the stabilized index-2 form itself; leave "
         "stabilization at its default)"),
        (backend == "c", "backend='c' (IDA runs in SUNDIALS' own loop, calling the "
         "model's generated functions)"),
        (bool(events), "events (not supported with IDA yet; use 'Radau' or 'DOP853')"),
        (dense_output, "dense_output (not supported with IDA yet; give t_eval)"),
        (inputs is not None or sample_time is not None, "inputs (not supported with "
         "IDA yet; use 'Radau' or 'DOP853')"),
    ]
    for found, what in refused:
        if found:
            raise ValueError(f"method='IDA' cannot take {what}")
    import importlib.util

    if importlib.util.find_spec("sksundae") is None:  # at the door, not at the run
        raise ImportError("method='IDA' needs scikit-sundae (SUNDIALS IDA): "
                          "pip install 'dalembert[stiff]' or pip install scikit-sundae")


def check_events(events: Sequence[Callable]) -> None:
    """Raise a ``ValueError`` naming the first event function that cannot be called as
    ``event(t, q, qd)`` or ``event(t, q, qd, lam)`` (at the door: else it fails at the
    run's first step, a one-point failed run).

    A function whose signature cannot be read (some builtins) is accepted; a
    ``functools.partial``, a callable object and ``*args`` are read as Python calls them.

    Parameters
    ----------
    events
        The event functions (callables, checked before).

    Examples
    --------
    >>> check_events([lambda t, q, qd: q[0], lambda t, q, qd, lam: lam[0]])
    >>> check_events([lambda t: t - 1.0])  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    ValueError: The 'events' parameter of simulate: event 0 ('<lambda>') takes (t), so ...
    >>> def hit(t, q, qd):
    ...     return q[0]
    >>> hit.terminal = "yes"
    >>> check_events([hit])  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    ValueError: The 'events' parameter of simulate: event 0 ('hit') has terminal='yes'; ...
    """
    for k, event in enumerate(events):
        name = getattr(event, "__name__", type(event).__name__)
        _check_event_attributes(k, name, event)
        try:
            signature = inspect.signature(event)
        except (TypeError, ValueError):  # a builtin without a signature: accepted
            continue
        if any(_binds(signature, size) for size in (3, 4)):
            continue
        raise ValueError(
            f"The 'events' parameter of simulate: event {k} ({name!r}) takes {signature}, "
            "so it cannot be called as event(t, q, qd) or event(t, q, qd, lam); give it "
            "the parameters t, q, qd (and lam for the multipliers)")


def _check_event_attributes(k: int, name: str, event: Callable) -> None:
    """``terminal`` (``solve_ivp``'s: a bool, or how many occurrences end the run) and
    ``direction`` (a finite number), where the event sets them."""
    where = f"The 'events' parameter of simulate: event {k} ({name!r})"
    terminal = getattr(event, "terminal", False)
    if not (isinstance(terminal, (bool, np.bool_)) or
            (isinstance(terminal, (int, np.integer)) and terminal >= 0)):
        raise ValueError(f"{where} has terminal={terminal!r}; give True (the first "
                         "occurrence ends the run), False, or the number of occurrences "
                         "that ends it")
    direction = getattr(event, "direction", 0)
    if isinstance(direction, bool) or not isinstance(direction, (int, float, np.number)) \
            or not math.isfinite(direction):
        raise ValueError(f"{where} has direction={direction!r}; give a number: positive "
                         "(events where it goes from negative to positive), negative, or 0 "
                         "(both)")


def _binds(signature: inspect.Signature, size: int) -> bool:
    """Whether ``size`` positional arguments fit ``signature``."""
    try:
        signature.bind(*range(size))
    except TypeError:
        return False
    return True


def _check_tolerance_sizes(tolerances: Mapping[str, object], size: int) -> None:
    """An array of tolerances holds one per state entry (positions, then velocities)."""
    for name, value in tolerances.items():
        array = np.asarray(value, dtype=float)
        if array.ndim == 1 and array.size != size:
            raise ValueError(
                f"The {name!r} parameter of simulate must be a finite positive number or an "
                f"array of {size} of them (one per position, then one per velocity); got "
                f"{value!r}."
            )


def _time_span(t_span: Sequence[float]) -> tuple[float, float]:
    if isinstance(t_span, (str, bytes)):  # "10" would be read as (1.0, 0.0)
        raise ValueError(f"t_span must be two numbers (t0, tf), got the string {t_span!r}")
    try:
        t0, tf = (float(v) for v in t_span)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"t_span must be two numbers (t0, tf), got {t_span!r}") from exc
    if not (math.isfinite(t0) and math.isfinite(tf)) or t0 == tf:
        raise ValueError(f"t_span must be two different finite times, got {t_span!r}")
    return t0, tf


def _tolerance(value: float | Sequence[float] | np.ndarray) -> float | np.ndarray:
    array = np.asarray(value, dtype=float)
    return float(array) if array.ndim == 0 else array


def _stabilization(name: str | None, gain: float | None) -> Stabilization:
    if name == "baumgarte":
        return Baumgarte(DEFAULT_BAUMGARTE_GAIN if gain is None else float(gain))
    if gain is not None:
        raise ValueError(f"baumgarte_gain={gain!r} is given with stabilization={name!r}; "
                         "the gain applies only to stabilization='baumgarte'")
    return Projection() if name == "projection" else None


#: Steps an explicit method would need over ``t_span`` for the Baumgarte gain alone
#: beyond which the gain is said to make the equations stiff.
STIFF_GAIN_STEPS = 1e5


def _warn_stiff_gain(stabilization: Stabilization, solver: type[OdeSolver],
                     span: tuple[float, float]) -> None:
    """Warn when the Baumgarte gain ``w`` alone forces an explicit method's steps below
    about ``3 / w`` (the constraint error's modes decay at the rate ``w``) for more than
    :data:`STIFF_GAIN_STEPS` steps over ``t_span``."""
    import scipy.integrate

    if not isinstance(stabilization, Baumgarte) or not issubclass(
            solver, (scipy.integrate.RK23, scipy.integrate.RK45, scipy.integrate.DOP853)):
        return
    w = stabilization.gain
    steps = abs(span[1] - span[0]) * w / 3
    if steps > STIFF_GAIN_STEPS:
        warnings.warn(
            f"baumgarte_gain={w:g} makes the constraint errors decay in {1 / w:.1g} s: "
            f"the explicit method {solver.__name__} must take steps about that short, some "
            f"{steps:.1e} of them over t_span. Choose a gain a few times the fastest motion "
            "of interest, or an implicit method (method='Radau')",
            StiffStabilizationWarning, stacklevel=user_stacklevel())


def _backend(backend: Backend, native: bool | None) -> Backend:
    if native is None:
        return backend
    meant: Backend = "c" if native else "python"
    warnings.warn(f"simulate(native={native!r}) is deprecated; use backend={meant!r}",
                  DeprecationWarning, stacklevel=user_stacklevel())
    if backend != "auto":
        raise ValueError(f"native={native!r} and backend={backend!r} are both given; "
                         "give backend only")
    return meant


def _times(t_eval: Sequence[float] | np.ndarray | None,
           t_span: tuple[float, float]) -> np.ndarray | None:
    if t_eval is None:
        return None
    try:
        times = np.asarray(t_eval, dtype=float)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"t_eval must be an array of times, got {t_eval!r}") from exc
    if times.ndim != 1 or not np.all(np.isfinite(times)):
        bad = np.flatnonzero(~np.isfinite(times.ravel()))
        where = f" (not finite at index {bad[0]})" if len(bad) else ""
        raise ValueError(f"t_eval must be a 1-D array of finite times inside t_span{where}")
    lo, hi = min(t_span), max(t_span)
    if np.any((times < lo) | (times > hi)):
        raise ValueError(f"t_eval must be a 1-D array of times inside t_span {t_span}")
    if np.any(np.diff(times) * np.sign(t_span[1] - t_span[0]) <= 0):
        raise ValueError("t_eval must be strictly ordered in the direction of integration")
    return times
