"""Running cases where the work is done: one case, or a batch of them, on a System.

:class:`CaseSettings` is what every case shares (the span, output times, the
checked options of ``simulate``, the base initial state and parameters, what to
keep); a case adds its row of the case table. The same function runs a batch in
the caller's process, on a thread or on a Dask worker, so a case gives the same
answer wherever it runs.
"""

from __future__ import annotations

import dataclasses
import functools
import os
import socket
import threading
import time
import warnings
from collections.abc import Callable, Iterator, Mapping, Sequence
from contextlib import contextmanager, nullcontext
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..errors import TimeLimitExceeded
from ..inputs import input_signal
from ..options import SimulationOptions
from ..solvers.native.turns import outside_python, python_turn
from ..solvers.outputs import SOLVED
from ..solvers.running.watchdog import Watchdog, where_stopped
from ..system import System
from ..trajectory import Trajectory
from .cases import CaseColumns
from .faults import BatchOutcome, CaseOutcome, error_outcome

#: Quantities a trajectory has at every output time, and their dimensions beyond
#: ``(case, time)`` (``coordinate``, ``constraint`` or ``input``; none for a scalar).
QUANTITIES: dict[str, tuple[str, ...]] = {
    "q": ("coordinate",), "qd": ("coordinate",), "qdd": ("coordinate",),
    "multipliers": ("constraint",), "constraint_forces": ("coordinate",),
    "energy": (), "kinetic_energy": (), "potential_energy": (), "jacobi_integral": (),
    "position_residual": (), "velocity_residual": (), "inputs": ("input",),
}
#: The quantities that take a solve of the KKT system at each output time.
DYNAMICS = frozenset(SOLVED)
#: Kept unless the caller says otherwise.
DEFAULT_KEEP = ("q", "qd", "multipliers", "constraint_forces", "energy",
                "position_residual", "velocity_residual")

#: ``f(system, traj) -> one number per output time``: a derived quantity to keep.
Output = Callable[[System, Trajectory], Any]


@dataclass(frozen=True)
class CaseSettings:
    """What every case of an ensemble shares.

    Parameters
    ----------
    t_span, t_eval
        The span and the output times (every case reports at these times).
    options
        ``simulate``'s keywords, checked once before the ensemble starts (the span and
        the output times among them).
    q0, qd0
        The base initial state, in coordinate order (case columns override it).
    parameters
        Base parameter values by name (case columns override them).
    columns
        What each case column is (:class:`~dalembert.ensemble.cases.CaseColumns`).
    initial_state
        ``f(case) -> (q0, qd0)``, or ``None``.
    keep
        The trajectory quantities kept per time (names of :data:`QUANTITIES`).
    outputs
        Derived quantities to keep, ``name -> f(system, traj)``.
    case_inputs
        ``f(case) -> inputs`` (any form of ``simulate``'s ``inputs=``), or ``None``:
        the options then hold placeholders for the inputs.
    """

    t_span: tuple[float, float]
    t_eval: np.ndarray
    options: SimulationOptions
    q0: np.ndarray
    qd0: np.ndarray
    parameters: Mapping[str, float]
    columns: CaseColumns
    initial_state: Callable[[dict[str, float]], Any] | None = None
    keep: tuple[str, ...] = DEFAULT_KEEP
    outputs: Mapping[str, Output] = field(default_factory=dict)
    case_inputs: Callable[[dict[str, float]], Any] | None = None

    @property
    def dynamics(self) -> bool:
        """Whether the cases' trajectories need their accelerations, multipliers and
        constraint forces: kept, or maybe read by an output function. Else no KKT system
        is solved at the output times (the summary needs only the energy, the residuals
        and the final state)."""
        return bool(self.outputs) or not DYNAMICS.isdisjoint(self.keep)


def run_batch(system: System, settings: CaseSettings,
              indices: Sequence[int] | np.ndarray, rows: np.ndarray, names: Sequence[str],
              stop: threading.Event | None = None,
              record_warnings: bool = True,
              turns: threading.Lock | None = None) -> BatchOutcome:
    """Run the cases ``indices`` (their values ``rows``, columns ``names``) one after
    the other; each one's failure is recorded and the next one runs. Their arrays
    come back stacked (:class:`~dalembert.ensemble.faults.BatchOutcome`); a Ctrl-C
    here ends the batch with what finished.

    Parameters
    ----------
    system
        The model.
    settings
        What the cases share.
    indices, rows, names
        The cases' numbers, their rows of the case table and its column names.
    stop
        Set when the ensemble is interrupted: the batch ends after the current case.
    record_warnings
        Record each case's warnings in its outcome; ``False`` on threads, where
        ``warnings.catch_warnings`` is not safe (the caller silences them once).
    turns
        On threads, one lock for all of them: they take turns for their Python
        (:mod:`dalembert.solvers.native.turns`), each letting go of it around its long
        C calls.
    """
    worker = f"{socket.gethostname()}:{os.getpid()}"
    done: list[CaseOutcome] = []
    blocks: dict[str, np.ndarray] = {}
    interrupted = False
    try:
        for index, row in zip(indices, rows):
            if stop is not None and stop.is_set():
                break
            case = {name: float(v) for name, v in zip(names, row)}
            with python_turn(turns) if turns is not None else nullcontext():
                outcome = run_case(system, settings, int(index), case, worker, record_warnings)
                place(blocks, outcome, len(done), len(indices), len(settings.t_eval))
            done.append(outcome)
            if outcome.status == "interrupted":  # Ctrl-C inside the simulation
                interrupted = True
                break
    except KeyboardInterrupt:  # Ctrl-C between two simulations
        interrupted = True
    return BatchOutcome(done, {name: block[: len(done)] for name, block in blocks.items()},
                        interrupted)


def place(blocks: dict[str, np.ndarray], outcome: CaseOutcome, row: int, rows: int,
          times: int) -> None:
    """Copy the arrays ``outcome`` kept into row ``row`` of a batch's ``blocks`` (one
    per name over ``(case, time, ...)``, made for ``rows`` cases and ``times`` output
    times by the first case that kept any), NaN where it has no value; its own
    arrays are then dropped. Each case is copied as it finishes, from memory still
    in the processor's cache, not read back at the batch's end.

    Parameters
    ----------
    blocks
        The batch's blocks so far (empty before the first case that kept arrays).
    outcome
        The case.
    row, rows
        Its row, and how many cases the batch has.
    times
        How many output times the ensemble has.

    Examples
    --------
    >>> blocks = {}
    >>> done = [CaseOutcome(0, "error"),
    ...         CaseOutcome(1, "finished", arrays={"energy": np.array([1.0, 1.0])}),
    ...         CaseOutcome(2, "failed", arrays={"energy": np.array([2.0])})]
    >>> for row, outcome in enumerate(done):
    ...     place(blocks, outcome, row, 3, 2)
    >>> blocks["energy"].tolist()
    [[nan, nan], [1.0, 1.0], [2.0, nan]]
    """
    if outcome.arrays and not blocks:
        for name, values in outcome.arrays.items():
            blocks[name] = np.empty((rows, times, *values.shape[1:]))
            blocks[name][:row] = np.nan
    for name, block in blocks.items():
        got = outcome.arrays.get(name)
        reached = 0 if got is None else len(got)
        if reached:
            block[row, :reached] = got
        block[row, reached:] = np.nan
    outcome.arrays = {}


def run_case(system: System, settings: CaseSettings, index: int, case: dict[str, float],
             worker: str = "", record_warnings: bool = True) -> CaseOutcome:
    """One case: its initial state and parameters, its simulation, what is kept.

    Parameters
    ----------
    system
        The model.
    settings
        What the cases share.
    index
        The case's number.
    case
        Its row, ``{column: value}``.
    worker
        Where it runs (for the summary).
    record_warnings
        Keep the warnings the case raises in its outcome (one line each).

    Examples
    --------
    >>> from dalembert.examples import load
    >>> from dalembert.ensemble.cases import CaseColumns
    >>> from dalembert.options import simulation_options
    >>> pendulum = load("pendulum").build()
    >>> options = simulation_options((0.0, 1.0), t_eval=[0.0, 1.0])
    >>> settings = CaseSettings((0.0, 1.0), np.array([0.0, 1.0]), options,
    ...                         np.array([1.0, 0.0]), np.zeros(2), {},
    ...                         CaseColumns(("l",), (), (), ()))
    >>> outcome = run_case(pendulum, settings, 0, {"l": 1.0})
    >>> outcome.status, outcome.arrays["q"].shape
    ('finished', (2, 2))
    """
    start, started = time.perf_counter(), time.time()
    caught: list[warnings.WarningMessage] = []
    with warnings.catch_warnings(record=True) if record_warnings else nullcontext() as got:
        if got is not None:
            warnings.simplefilter("always")
            caught = got
        try:
            with _limited(settings, "initial_state"):
                q0, qd0, parameters = _inputs(system, settings, case)
            with _limited(settings, "case_inputs"):
                options = _options(settings, case)
            # simulate(...) with the options checked at the door
            plan = system.plan_checked(options, q0, qd0, parameters=parameters)
            traj = system.run(plan, dynamics=settings.dynamics)
            arrays, stopped = _kept(system, settings, traj)
        except Exception as exc:  # any failure of one case is recorded, never raised
            return error_outcome(index, exc, time.perf_counter() - start, worker, started)
        except _TimedOut as exc:  # initial_state or case_inputs did not return
            return CaseOutcome(index, "timeout", str(exc), time.perf_counter() - start,
                               worker, started=started)
    seconds = time.perf_counter() - start
    noted = dict.fromkeys(f"{w.category.__name__}: {str(w.message).splitlines()[0]}"
                          for w in caught)
    status, message = (str(traj.status), traj.message) if not stopped else \
        ("timeout", stopped)
    return CaseOutcome(index, status, message, seconds, worker, arrays,
                       _numbers(traj, arrays, settings), "\n".join(noted), plan.stretches,
                       started)


class _TimedOut(BaseException):
    """A case's function of the user's (outside its simulation, which stops its own) kept
    it past ``timeout=``; the message names it."""


@contextmanager
def _limited(settings: CaseSettings, what: str) -> Iterator[None]:
    """Run a function of the user's for a case within the case's time limit
    (``timeout=``, each such function its own): past it (and the watchdog's grace) it
    is stopped (:mod:`~dalembert.solvers.running.watchdog`), raising :class:`_TimedOut`
    naming ``what``. On threads it runs outside the thread's turn for Python
    (:mod:`~dalembert.solvers.native.turns`): while it does not return, the other
    threads' cases go on, their own time limits running (they timed out with it)."""
    limit = settings.options.timeout
    if limit is None:
        yield
        return
    dog = Watchdog(time.monotonic() + limit)
    try:
        with outside_python(), dog.armed():  # (disarmed before the turn is taken back)
            yield
    except TimeLimitExceeded as exc:
        dog.disarm()
        where = where_stopped(exc)
        raise _TimedOut(f"{what} did not return within the case's time limit (timeout="
                        f"{limit:g} s)" + (f": stopped in {where}" if where else "")) \
            from None


def _inputs(system: System, settings: CaseSettings,
            case: dict[str, float]) -> tuple[np.ndarray, np.ndarray, dict[str, float]]:
    """The case's ``q0``, ``qd0`` (coordinate order) and parameter values."""
    from ..model.values import coordinate_values

    names = system.coordinate_names
    q0, qd0 = settings.q0.copy(), settings.qd0.copy()
    if settings.initial_state is not None:
        made = settings.initial_state(dict(case))
        if not (isinstance(made, tuple) and len(made) == 2):
            raise TypeError("initial_state(case) must return (q0, qd0), got "
                            f"{type(made).__name__}")
        q0 = coordinate_values(made[0], names, "q0 from initial_state")
        qd0 = coordinate_values(made[1], names, "qd0 from initial_state")
    at = {name: i for i, name in enumerate(names)}
    cols = settings.columns
    for name in cols.positions:
        q0[at[name]] = case[name]
    for name in cols.velocities:
        qd0[at[name[: -len("_dot")]]] = case[name]
    parameters = dict(settings.parameters)
    parameters.update({name: case[name] for name in cols.parameters})
    return q0, qd0, parameters


def _options(settings: CaseSettings, case: dict[str, float]) -> SimulationOptions:
    """The checked options with the case's inputs: those ``case_inputs`` makes of it,
    and those its columns give held at its values."""
    options, named = settings.options, settings.columns.inputs
    signal = options.inputs
    if signal is None or not (named or settings.case_inputs):
        return options
    if settings.case_inputs is not None:
        made = settings.case_inputs(dict(case))
        if named and isinstance(made, Mapping):  # the columns complete it
            made, named = {**made, **{name: case[name] for name in named}}, ()
        signal = input_signal(made, signal.names, signal.sample_time, settings.t_span)
        assert signal is not None  # the model has inputs
    if named:
        signal = signal.holding({name: case[name] for name in named})
    return dataclasses.replace(options, inputs=signal)


def _kept(system: System, settings: CaseSettings, traj: Trajectory
          ) -> tuple[dict[str, np.ndarray], str]:
    """The kept quantities at the output times ``traj`` reached (a prefix of ``t_eval``),
    and why an output function was stopped at the time limit (its values NaN), or ``""``."""
    k = len(traj.t)
    if not np.array_equal(traj.t, settings.t_eval[:k]):
        raise RuntimeError("the trajectory's times are not the ensemble's output times")
    # views where the trajectory has them (``q``, ``qd``): the batch's blocks copy them
    arrays = {name: np.asarray(getattr(traj, name), dtype=float) for name in settings.keep}
    stopped = ""
    for name, fn in settings.outputs.items():
        try:
            with _limited(settings, f"the output {name!r}"):
                value = np.asarray(fn(system, traj), dtype=float) if k else np.zeros(0)
        except _TimedOut as exc:
            stopped = f"{exc}; the trajectory is kept, the output's values are NaN"
            value = np.full(k, np.nan)
        if value.shape != (k,):
            raise ValueError(f"the output {name!r} must give one number per output time "
                             f"({k}), got shape {value.shape}")
        arrays[name] = value
    return arrays, stopped


def _numbers(traj: Trajectory, arrays: dict[str, np.ndarray],
             settings: CaseSettings) -> dict[str, float]:
    """The case's line of the summary: where it ended, its errors, its final values."""
    numbers: dict[str, float] = {"t_end": float(traj.t[-1]) if len(traj.t) else np.nan}
    e = traj.energy
    if traj.contacts is not None:  # what the impacts took counts as kept
        e = e + traj.contacts.energy_lost_by(traj.t)
        impacts = traj.contacts.impact_times
        numbers["n_impacts"] = float(len(impacts))
        numbers["t_first_impact"] = float(impacts[0]) if len(impacts) else np.nan
    finite = len(e) and np.all(np.isfinite(e))
    numbers["energy_error"] = (float(np.abs(e - e[0]).max() / max(abs(e[0]), 1e-300))
                               if finite else np.nan)
    for name in ("position_residual", "velocity_residual"):
        values = getattr(traj, name)
        numbers[f"max_{name}"] = float(values.max()) if len(values) else np.nan
    numbers["nfev"] = float(traj.stats.get("nfev", np.nan))
    for label, times in zip(event_labels(settings.options.output.events), traj.t_events):
        numbers[f"t_event_{label}"] = float(times[0]) if len(times) else np.nan
        numbers[f"n_events_{label}"] = float(len(times))
    if len(traj.t):
        numbers.update(zip(_final_names(traj.coordinate_names), traj.q[-1].tolist()))
        numbers.update({f"final_{name}": float(arrays[name][-1]) for name in settings.outputs})
    return numbers


def event_labels(events: Sequence[Callable]) -> tuple[str, ...]:
    """How the summary names each event function: by its name, or by its position
    where it has none (a lambda) or shares it with another.

    Parameters
    ----------
    events
        ``simulate``'s event functions.

    Examples
    --------
    >>> def impact(t, q, qd): return q[1]
    >>> event_labels([impact, lambda t, q, qd: q[0]])
    ('impact', '1')
    """
    names = [getattr(event, "__name__", "") for event in events]
    return tuple(name if name.isidentifier() and names.count(name) == 1 else str(k)
                 for k, name in enumerate(names))


@functools.lru_cache(maxsize=8)
def _final_names(names: tuple[str, ...]) -> tuple[str, ...]:
    """The summary's names of the final values of ``names`` (made once per model)."""
    return tuple(f"final_{name}" for name in names)
