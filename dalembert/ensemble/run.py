"""``simulate_many``: one model, many cases, one labelled result.

Everything is checked here, once, before any case runs (the case table's columns,
``simulate``'s options, the base state and parameters, what to keep, the store);
then the cases are cut into batches, run by a backend
(:mod:`~dalembert.ensemble.backends`), written as they finish
(:mod:`~dalembert.ensemble.store`) and summed up
(:mod:`~dalembert.ensemble.results`).
"""

from __future__ import annotations

import math
import multiprocessing
import os
import time
import warnings
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any, Literal

import numpy as np

from ..errors import EnsembleError, EnsembleWarning, user_stacklevel
from ..model.parameters import parameter_values
from ..model.values import CoordinateValues, coordinate_values
from ..options import PARAMETER_VALUES
from ..rules import (
    NONE,
    Boolean,
    CheckedWhereUsed,
    Function,
    OneOf,
    PositiveInteger,
    Rule,
    check_parameters,
    checked_keywords,
)
from ..system import System
from .backends import Backend, Batch, Dask, Interrupted, Serial, Threads, run_here
from .cases import CaseTable, read_cases
from .faults import SUCCESS, BatchOutcome, CaseOutcome, not_run_outcome
from .results import EnsembleResult, SummaryRows
from .store import Layout, check_store, sink
from .worker import DEFAULT_KEEP, QUANTITIES, CaseSettings, Output

Scheduler = Literal["auto", "serial", "threads", "processes", "dask"]
SCHEDULERS = ("auto", "serial", "threads", "processes", "dask")
#: ``scheduler="auto"`` runs the first case here. If it ran in the C loop, whose
#: stretches release the GIL, the others run on threads (one per core) when they would
#: take longer than :data:`AUTO_THREADS_SECONDS` alone: threads start at once and
#: measured faster than local processes on two cores (bench/README.md, "Ensembles":
#: the 16-link chain's 1,000 cases). A case in the Python loop
#: holds the GIL, and the others go to a local cluster of processes when they would
#: take longer than :data:`AUTO_PARALLEL_SECONDS`: a cluster's first results come
#: 4-6 s after it is asked for on two cores (start 1.7-2.2 s, each worker's import of
#: dalembert 2-3 s and preparation of the model 0.6 s), which two workers win back
#: from about 10 s of work.
AUTO_PARALLEL_SECONDS = 10.0
AUTO_THREADS_SECONDS = 0.5
#: Batches per worker when the batch size is chosen: enough to balance the load,
#: few enough that a task's overhead (milliseconds) is small against its cases.
BATCHES_PER_WORKER = 4
#: The most cases in one batch (and one chunk of a store along ``case``).
MAX_BATCH = 64
#: The last round of batches is cut in this many parts. Cutting every batch smaller
#: would cost a task's hand-over more often; at the end, where a worker that has
#: finished waits for the others, a whole batch left on one worker keeps them waiting
#: longest (measured in bench/README.md, "Ensembles").
LAST_ROUND_PARTS = 4
#: Output times when none are given.
DEFAULT_POINTS = 101
#: ``simulate`` keywords that an ensemble sets itself or cannot store.
_NOT_OPTIONS = {"q0": "q0=", "qd0": "qd0=", "parameters": "parameters=",
                "dense_output": "nothing (a dense output cannot be stored; keep outputs "
                                "at t_eval)",
                "progress": "progress= of simulate_many (one bar for the ensemble)"}


#: The keywords of :func:`simulate_many` (``simulate``'s own are checked by
#: ``System.check_options``). Those checked where used depend on the model or on another
#: keyword.
SIMULATE_MANY_PARAMETERS: dict[str, list[Rule]] = {
    "q0": [CheckedWhereUsed("initial positions, as simulate's q0")],
    "qd0": [CheckedWhereUsed("initial velocities, as simulate's qd0")],
    "t_eval": [CheckedWhereUsed("output times, as simulate's t_eval")],
    "parameters": PARAMETER_VALUES,
    "initial_state": [Function(), NONE],
    "case_inputs": [Function(), NONE],
    "outputs": [CheckedWhereUsed("a dict {name: f(system, traj)}")],
    "keep": [CheckedWhereUsed("trajectory quantities")],
    "scheduler": [OneOf(SCHEDULERS)],
    "client": [CheckedWhereUsed("a dask.distributed.Client or None")],
    "workers": [PositiveInteger(), NONE],
    "batch_size": [PositiveInteger(), NONE],
    "store": [CheckedWhereUsed("a path ending in .zarr or .nc, or None")],
    "overwrite": [Boolean()],
    "progress": [Boolean()],
}


@checked_keywords(SIMULATE_MANY_PARAMETERS, error=EnsembleError)
def simulate_many(
    system: System,
    t_span: Sequence[float],
    cases: CaseTable,
    *,
    q0: CoordinateValues = None,
    qd0: CoordinateValues = None,
    t_eval: Sequence[float] | np.ndarray | None = None,
    parameters: Mapping[Any, object] | None = None,
    initial_state: Callable[[dict[str, float]], Any] | None = None,
    case_inputs: Callable[[dict[str, float]], Any] | None = None,
    outputs: Mapping[str, Output] | None = None,
    keep: Sequence[str] = DEFAULT_KEEP,
    scheduler: Scheduler = "auto",
    client: Any = None,
    workers: int | None = None,
    batch_size: int | None = None,
    store: str | os.PathLike | None = None,
    overwrite: bool = False,
    progress: bool = True,
    **options: Any,
) -> EnsembleResult:
    """Simulate ``system`` once per case and gather the results, labelled.

    Each case is a row of ``cases``: values of parameters, initial coordinates
    (``x``) and velocities (``x_dot``), inputs, or variables of ``initial_state`` or
    ``case_inputs``. A case is exactly ``system.simulate(t_span, q0, qd0,
    parameters=..., t_eval=t_eval, **options)`` with its values, wherever it runs, so
    it gives the same answer serially, on threads or on any Dask cluster. A case that
    fails is recorded with its status and message and the others go on; Ctrl-C returns
    what finished.

    Parameters
    ----------
    system
        The model (its code is compiled once, here, and sent to workers with it).
    t_span
        ``(t0, tf)``, shared by every case.
    cases
        A pandas DataFrame, a list of dicts or a dict of columns (:func:`grid`,
        :func:`sample` make them). Its column names must be parameters,
        coordinates or ``<coordinate>_dot``, inputs (held at the case's value along
        its run; ``inputs=`` then gives the other inputs, as a dict), or variables
        ``initial_state`` or ``case_inputs`` read. Cases are numbered by their
        position, 0 to n - 1: a DataFrame's own index is not kept.
    q0, qd0
        The initial state of every case (a dict by coordinate or a sequence), before
        the case's own columns replace entries of it.
    t_eval
        The output times every case reports (default: 101 evenly spaced).
    parameters
        Parameter values for every case, before the case's own columns.
    initial_state
        ``f(case) -> (q0, qd0)``: the initial state from a case's values (a dict by
        column), e.g. a mechanism's state from an angle. Runs where the case runs:
        for Dask, it must be picklable (a module-level function, or any function
        cloudpickle takes).
    case_inputs
        ``f(case) -> inputs``: the inputs of a case from its values, in any form
        ``simulate``'s ``inputs=`` takes, e.g. a controller with the case's gains
        (``lambda case: {"u": controller(case["kp"], case["kd"])}``); instead of
        ``inputs=``.
        Its columns are case variables, as ``initial_state``'s; input columns are
        then held on top of what it gives (a dict by input). Picklable for Dask.
    outputs
        Derived quantities to keep, ``name -> f(system, traj)`` giving one number
        per output time (a tip position...); ``system`` is the worker's copy.
    keep
        Trajectory quantities to keep per time: any of ``q``, ``qd``, ``qdd``,
        ``multipliers``, ``constraint_forces``, ``energy``, ``kinetic_energy``,
        ``potential_energy``, ``jacobi_integral``, ``position_residual``,
        ``velocity_residual``, ``inputs`` (the values applied, over an ``input``
        dimension) (default: the first six but ``qdd``, and the residuals).
        Without ``qdd``, ``multipliers``, ``constraint_forces`` and ``outputs`` no KKT
        system is solved at the output times.
    scheduler
        ``"auto"`` (default: the first case runs here; the others run on threads if it
        ran in the C loop and they would take over :data:`AUTO_THREADS_SECONDS`
        alone, on a Dask ``LocalCluster`` of one process per core if it ran in the
        Python loop and they would take over :data:`AUTO_PARALLEL_SECONDS`, else here
        too), ``"serial"``, ``"threads"``,
        ``"processes"`` (a local Dask cluster) or ``"dask"`` (the ``client`` given).
        On ``"serial"`` and ``"threads"`` the cases run in this process: a crash
        in a case (a segmentation fault in a user's C extension or ctypes code
        called from an input, event or ``initial_state`` function) ends this
        process and every case with it; on ``"processes"`` and ``"dask"`` only
        that case is lost (status ``"lost"``). ``"auto"`` may choose threads for
        such code: choose ``"processes"`` for code that may crash.
    client
        A ``dask.distributed.Client`` of any cluster (implies ``scheduler="dask"``).
    workers
        Threads or local processes (default: one per core).
    batch_size
        Cases per task (default: about four tasks per worker, at most 64); also the
        chunk of a store along ``case``.
    store
        A path ending in ``.zarr`` or ``.nc``: the arrays are written there as cases
        finish and read back lazily, so the client holds one block at a time. If
        the store cannot be written midway (a full disk), every case is kept in
        memory from then on and returned there, with an
        :class:`~dalembert.errors.EnsembleWarning` naming the store.
    overwrite
        Replace an existing ``store``: a file, or a folder only if it is a store
        ``simulate_many`` wrote (it holds the marker file ``.dalembert-ensemble``) or
        empty; another folder is refused, not removed. A netCDF file is replaced by a new file: a
        result still reading the old one keeps its data. A Zarr store is read by
        path: a result still reading the one replaced (an earlier ensemble's
        ``dataset``) reads the new one's arrays from then on.
    progress
        A progress bar (tqdm; it appears once the ensemble has run two seconds).
    options
        ``simulate``'s other keywords (``rtol``, ``method``, ``backend``...), checked
        once here. ``timeout=`` is each case's limit in seconds: a case whose
        simulation runs past it stops between two steps and is recorded with status
        ``"timeout"`` and the part it computed; the others go on. A function of yours
        that itself never returns is stopped half a second after the limit, on every
        scheduler: an input or an event as the simulation's limit, ``initial_state``,
        ``case_inputs`` or an output function each after ``timeout`` seconds of its
        own (the case ``"timeout"``, an output's values NaN). One blocked in a C call
        (``time.sleep``, a read without a time limit) is stopped when that returns.

    Returns
    -------
    EnsembleResult
        ``.dataset`` (xarray), ``.summary`` (pandas), ``.failed``, ``.retry()``,
        ``.quantile()``, ``.mean()``. Failed, lost or unreached cases raise an
        :class:`~dalembert.errors.EnsembleWarning` saying how many and why.

    Raises
    ------
    EnsembleError
        A case column that names nothing, no cases, a bad scheduler, keep, output
        or store; ``ValueError`` for ``simulate``'s options, as ``simulate`` does.

    Examples
    --------
    The pendulum's period grows with its length; four lengths, run here:

    >>> from dalembert.examples import load
    >>> from dalembert.ensemble import grid
    >>> pendulum = load("pendulum").build()
    >>> result = simulate_many(pendulum, (0, 1), grid(l=[0.5, 1.0, 1.5, 2.0]),
    ...                        initial_state=lambda case: ({"x": 0.1 * case["l"],
    ...                                                     "y": -case["l"]}, None),
    ...                        scheduler="serial", progress=False)
    >>> result.dataset["q"].dims, result.summary["status"].tolist()
    (('case', 'time', 'coordinate'), ['finished', 'finished', 'finished', 'finished'])
    """
    if getattr(multiprocessing.current_process(), "_inheriting", False):
        # a spawned process importing the main script (as multiprocessing's own check)
        raise EnsembleError(
            "simulate_many was called while a worker process was importing the script that "
            "started it: put the script's code under `if __name__ == '__main__':`")
    arguments = dict(q0=q0, qd0=qd0, t_eval=t_eval, parameters=parameters,
                     initial_state=initial_state, case_inputs=case_inputs, outputs=outputs,
                     keep=keep,
                     scheduler=scheduler, client=client, workers=workers,
                     batch_size=batch_size, progress=progress, **options)
    run = _Run(system, t_span, cases, arguments, store, overwrite)
    return run.execute(list(range(len(run.cases))), None)


class _Run:
    """One ensemble's checked inputs; :meth:`execute` runs some of its cases."""

    def __init__(self, system: System, t_span: Sequence[float], cases: CaseTable,
                 arguments: dict[str, Any], store: str | os.PathLike | None,
                 overwrite: bool) -> None:
        self.system, self.t_span, self.arguments = system, t_span, arguments
        self.store = None if store is None else Path(store)
        self.overwrite = overwrite
        a = dict(arguments)
        self._input_names = tuple(u.name for u in system.inputs)
        reads = a.pop("initial_state")
        self.cases = read_cases(cases, [p.name for p in system.parameters],
                                system.coordinate_names,
                                reads if reads is not None else a.get("case_inputs"),
                                self._input_names)
        self.settings = self._settings(a)

    def _settings(self, a: dict[str, Any]) -> CaseSettings:
        names = self.system.coordinate_names
        self.scheduler = _scheduler(a.pop("scheduler"), a.pop("client"))
        self.client = self.arguments["client"]
        workers, batch_size = a.pop("workers"), a.pop("batch_size")
        self.workers = None if workers is None else int(workers)
        self.batch_size = None if batch_size is None else int(batch_size)
        self.progress = a.pop("progress")
        q0, qd0, t_eval = a.pop("q0"), a.pop("qd0"), a.pop("t_eval")
        parameters, outputs, keep = a.pop("parameters"), a.pop("outputs"), a.pop("keep")
        initial_state = self.arguments["initial_state"]
        for name, instead in _NOT_OPTIONS.items():
            if name in a:
                raise EnsembleError(f"simulate_many takes no {name}= per simulation; use "
                                    f"{instead}")
        case_inputs = a.pop("case_inputs")
        if case_inputs is not None:
            a["inputs"] = _inputs_of_cases(case_inputs, a.get("inputs"), self._input_names)
        if self.cases.columns.inputs:
            a["inputs"] = _with_case_inputs(a.get("inputs"), self.cases.columns.inputs)
        # simulate's own checks and messages, once for every case
        checked = self.system.check_options(self.t_span, **{**a, "t_eval": t_eval})
        if checked.output.t_eval is None:
            checked = self.system.check_options(self.t_span, **{
                **a, "t_eval": np.linspace(*checked.t_span, DEFAULT_POINTS)})
        _check_samples(checked)
        keep = _keep(keep)
        if "inputs" in keep and not self._input_names:
            raise EnsembleError("keep names 'inputs', but the model declares no inputs")
        outputs = _outputs(outputs, keep)
        return CaseSettings(
            checked.t_span, np.asarray(checked.output.t_eval, dtype=float), checked,
            coordinate_values(q0, names, "q0"), coordinate_values(qd0, names, "qd0"),
            parameter_values(self.system.parameters, parameters, coordinates=names,
                             inputs=self._input_names), self.cases.columns,
            initial_state, keep, outputs, case_inputs)

    # -- running ---------------------------------------------------------------------
    def execute(self, indices: list[int], before: EnsembleResult | None) -> EnsembleResult:
        """Run the cases ``indices``; ``before``: the result a retry updates."""
        if before is None and self.store is not None:
            check_store(self.store, self.overwrite)  # before anything runs or starts
        rows = SummaryRows(indices)
        scheduler, first = self.scheduler, BatchOutcome([])
        if scheduler == "auto":
            scheduler, first = self._auto(indices)
        chunk = self.batch_size or _batch_size(len(indices), self._workers(scheduler))
        layout = Layout(self.cases.table, self.settings.t_eval, self.system.coordinate_names,
                        self.system.constraint_names, self._input_names, self.settings.keep,
                        tuple(self.settings.outputs), chunk)
        if self.store is None:
            _check_memory(layout)
        out = sink(layout, self.store, indices, self.overwrite,
                   None if before is None else before.dataset)
        self._take(first, rows, out, None)  # the case auto ran here
        interrupted = first.interrupted
        bar = _bar(len(indices), self.progress)
        bar.update(len(first.cases))
        backend: Backend | None = None
        try:
            if not interrupted:
                backend = self._backend(scheduler)
                todo = rows.missing()
                found = backend.completed(_batches(todo, chunk, self.cases.values,
                                                    backend.workers))
                try:
                    for done in found:
                        self._take(done, rows, out, bar)
                        if done.interrupted:
                            raise KeyboardInterrupt  # Ctrl-C inside a simulation here
                finally:
                    found.close()
        except KeyboardInterrupt:
            interrupted = True
            if backend is not None:
                for done in backend.stop():
                    self._take(done, rows, out, bar)
        finally:
            if backend is not None:
                backend.close()
            bar.close()
        for i in rows.missing():
            rows.add(not_run_outcome(i))
        name = scheduler if backend is None else backend.name
        return self._result(indices, rows, out, name, interrupted, before)

    def _workers(self, scheduler: str) -> int:
        """How many cases run at once on ``scheduler`` (to size the batches)."""
        if scheduler == "serial":
            return 1
        if scheduler == "dask":
            return max(1, sum(self.client.nthreads().values()))
        return self.workers or os.cpu_count() or 1

    def _auto(self, todo: list[int]) -> tuple[str, BatchOutcome]:
        """Run the first case here, and choose where the others run from its time."""
        if len(todo) < 2 or (os.cpu_count() or 1) < 2:
            return "serial", BatchOutcome([])
        start = time.perf_counter()
        try:
            done = run_here(self.system, self.settings,
                            Batch(np.array(todo[:1]), self.cases.values[todo[:1]]),
                            list(self.cases.table.columns))
        except KeyboardInterrupt as stop:  # execute() stops at once on this record
            done = stop.done if isinstance(stop, Interrupted) else BatchOutcome([], {}, True)
            if not done.cases:
                done.cases.append(CaseOutcome(todo[0], "interrupted", "interrupted by the user"))
            return "serial", done
        rest = (time.perf_counter() - start) * (len(todo) - 1)
        if done.cases[0].in_c:
            return ("threads" if rest > AUTO_THREADS_SECONDS else "serial"), done
        return ("processes" if rest > AUTO_PARALLEL_SECONDS else "serial"), done

    def _backend(self, scheduler: str) -> Backend:
        names = list(self.cases.table.columns)
        if scheduler == "serial":
            return Serial(self.system, self.settings, names)
        if scheduler == "threads":
            return Threads(self.system, self.settings, names, self.workers)
        return Dask(self.system, self.settings, names,
                    self.client if scheduler == "dask" else None, self.workers)

    def _take(self, done: BatchOutcome, rows: SummaryRows, out: Any, bar: Any) -> None:
        out.write(done)  # the arrays: the client keeps each case's summary row only
        for o in done.cases:
            rows.add(o)
        if bar is not None:
            bar.update(len(done.cases))

    def _result(self, indices: list[int], rows: SummaryRows, out: Any, scheduler: str,
                interrupted: bool, before: EnsembleResult | None) -> EnsembleResult:
        dataset = out.dataset()
        if before is None:
            summary = rows.table(self.cases.table)
        else:
            retried = rows.table(self.cases.table.iloc[indices])
            retried.index = indices
            retried.index.name = "case"
            summary = before.summary.copy()
            for column in retried.columns:  # a column may be new (first final values)
                if column not in summary.columns:
                    summary[column] = np.nan
            summary.loc[indices, retried.columns] = retried
        _warn(summary.loc[indices], interrupted)
        return EnsembleResult(dataset, summary, scheduler, interrupted, self._retry, out.stored)

    def _retry(self, before: EnsembleResult, indices: list[int],
               changes: dict[str, Any]) -> EnsembleResult:
        check_parameters({k: v for k, v in changes.items() if k in SIMULATE_MANY_PARAMETERS},
                         SIMULATE_MANY_PARAMETERS, "retry", EnsembleError)
        fixed = {"t_eval", "keep", "outputs", "cases", "store"} & set(changes)
        if fixed:
            raise EnsembleError(f"retry cannot change {', '.join(sorted(fixed))} (the results' "
                                "layout); run simulate_many again for that")
        indices = _case_numbers(indices)
        for i in indices:
            if not 0 <= i < len(self.cases):
                raise EnsembleError(f"retry: there is no case {i} (cases 0..{len(self.cases) - 1})")
        again = _Run(self.system, self.t_span, self.cases.table, {**self.arguments, **changes},
                     self.store, self.overwrite)
        return again.execute(sorted(set(indices)), before)


#: The most samples of a zero-order hold (``sample_time``) over a case's span: their
#: instants are listed before the run (8 bytes each).
MAX_SAMPLES = 10**8


def _check_samples(checked: Any) -> None:
    """Refuse a ``sample_time`` that makes more than :data:`MAX_SAMPLES` samples per
    case: each case would fail allocating their instants (or take days)."""
    signal = checked.inputs
    period = None if signal is None else signal.sample_time
    if period is None:
        return
    t0, tf = checked.t_span
    samples = abs(tf - t0) / period
    if samples > MAX_SAMPLES:
        raise EnsembleError(
            f"sample_time={period:g} over t_span ({t0}, {tf}) makes {samples:.0f} samples per "
            f"case, more than the {MAX_SAMPLES} a run may have; give a larger sample_time")


def _check_memory(layout: Layout) -> None:
    """Refuse results held in memory that would not fit in this machine's memory (they
    would fail to be allocated, or swap, before the first case runs)."""
    values = sum(math.prod(shape) for _, shape in layout.variables().values())
    need = 8 * values
    try:
        have = os.sysconf("SC_PHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
    except (AttributeError, ValueError, OSError):  # not known here
        return
    if need > have:
        raise EnsembleError(
            f"the results of {layout.size} cases at {len(layout.t_eval)} output times would "
            f"take {_bytes(need)} in memory, more than this machine's {_bytes(have)}: pass "
            "store='results.zarr' (written as cases finish, read back lazily), or keep= fewer "
            "quantities, fewer output times (t_eval=) or fewer cases")


def _bytes(n: float) -> str:
    for unit in ("B", "kB", "MB", "GB", "TB"):
        if n < 1000:
            return f"{n:.1f} {unit}"
        n /= 1000
    return f"{n:.1f} PB"


def _case_numbers(cases: Any) -> list[int]:
    """``retry``'s ``cases`` as case numbers, or an error saying what they are not."""
    try:
        found = list(cases)
    except TypeError:
        found = [cases]  # one item, maybe one number
    for item in found:
        if isinstance(item, (bool, np.bool_)) or not isinstance(item, (int, np.integer)):
            raise EnsembleError(
                f"retry takes case numbers (cases=[0, 3]), got {item!r}: it runs cases of "
                "this ensemble again; for new values, run simulate_many again with a new "
                "case table")
    return [int(i) for i in found]


def _warn(summary: Any, interrupted: bool) -> None:
    bad = summary[~summary["status"].isin(sorted(SUCCESS))]
    if not len(bad):
        return
    counts = ", ".join(f"{n} {s}" for s, n in bad["status"].value_counts().items())
    first = bad.iloc[0]
    head = (f"the ensemble was interrupted: {counts} of {len(summary)} cases"
            if interrupted else f"{len(bad)} of {len(summary)} cases did not succeed ({counts})")
    warnings.warn(f"{head}; the first, case {bad.index[0]}: {first['message']}. "
                  "result.failed lists them, result.summary says why, result.retry() runs "
                  "them again", EnsembleWarning, stacklevel=user_stacklevel())


def _batches(indices: list[int], chunk: int, values: np.ndarray, workers: int) -> list[Batch]:
    """Consecutive cases of one chunk per batch (a chunk of the store is then written
    from one place), but the last round, one batch per worker, in
    :data:`LAST_ROUND_PARTS` parts: the ensemble's end then waits on its slowest
    worker for a part of a batch, not a whole one."""
    groups: dict[int, list[int]] = {}
    for i in indices:
        groups.setdefault(i // chunk, []).append(i)
    found = list(groups.values())
    if workers > 1:
        found[-workers:] = [list(part) for group in found[-workers:]
                            for part in np.array_split(group, min(LAST_ROUND_PARTS, len(group)))]
    return [Batch(np.array(g), values[g]) for g in found]


def _batch_size(cases: int, workers: int) -> int:
    return max(1, min(MAX_BATCH, math.ceil(cases / (workers * BATCHES_PER_WORKER))))


def _scheduler(scheduler: Any, client: Any) -> str:
    if client is not None:
        if not all(callable(getattr(client, name, None)) for name in ("submit", "nthreads")):
            hint = (f"; for scheduler={client!r} write scheduler={client!r}"
                    if isinstance(client, str) and client in SCHEDULERS else "")
            raise EnsembleError("client must be a dask.distributed.Client, got "
                                f"{type(client).__name__} {client!r}{hint}")
        if scheduler not in ("auto", "dask"):
            raise EnsembleError(f"a client is given with scheduler={scheduler!r}; a client "
                                "runs the cases on its cluster (scheduler='dask')")
        return "dask"
    if scheduler == "dask":
        raise EnsembleError("scheduler='dask' needs client=dask.distributed.Client(...); "
                            "scheduler='processes' starts a local cluster")
    return scheduler


def _inputs_of_cases(case_inputs: Any, inputs: object,
                     names: Sequence[str]) -> dict[str, object]:
    """``simulate``'s ``inputs=`` for the checks at the door when each case makes its
    own (``case_inputs``, called where the case runs): every input at 0 here."""
    if inputs is not None:
        raise EnsembleError("give the inputs once (inputs=) or per case (case_inputs=), "
                            "not both")
    if not names:
        raise EnsembleError("case_inputs is given, but the model declares no inputs")
    return dict.fromkeys(names, 0.0)


def _with_case_inputs(inputs: object, columns: Sequence[str]) -> dict[str, object]:
    """``simulate``'s ``inputs=`` completed with the inputs case ``columns`` give, as a
    dict by input, for the checks at the door: those at 0 here, each case holding its
    own value (:meth:`~dalembert.inputs.InputSignal.holding`, which checks it)."""
    if inputs is None:
        inputs = {}
    if not isinstance(inputs, Mapping):
        raise EnsembleError(
            f"the case columns give the input(s) {', '.join(columns)}; inputs= must then "
            f"be a dict by input for the model's other inputs, or left out, got "
            f"{type(inputs).__name__}")
    return {**inputs, **dict.fromkeys(columns, 0.0)}  # later keys win, named by symbol too


def _keep(keep: Any) -> tuple[str, ...]:
    if isinstance(keep, str):
        keep = (keep,)
    found = tuple(keep)
    for name in found:
        if name not in QUANTITIES:
            raise EnsembleError(f"keep names {name!r}, which is not a trajectory quantity "
                                f"(they are {', '.join(QUANTITIES)})")
    return tuple(dict.fromkeys(found))


def _outputs(outputs: Any, keep: tuple[str, ...]) -> dict[str, Output]:
    if outputs is None:
        return {}
    if not isinstance(outputs, Mapping):
        raise EnsembleError("outputs must be a dict {name: f(system, traj)}")
    for name, fn in outputs.items():
        if not isinstance(name, str) or not name.isidentifier():
            raise EnsembleError(f"output names must be identifiers, got {name!r}")
        if name in QUANTITIES or name in keep:
            raise EnsembleError(f"the output {name!r} has the name of a trajectory quantity; "
                                "rename it")
        if not callable(fn):
            raise EnsembleError(f"the output {name!r} must be a function f(system, traj)")
    return dict(outputs)


def _bar(total: int, show: bool) -> Any:
    from tqdm.auto import tqdm

    return tqdm(total=total, unit="case", disable=not show, delay=2.0, desc="ensemble")
