"""Where the batches of cases run: here, on threads, or on Dask workers.

Each backend takes batches (case numbers with their rows), yields each batch's
outcome as it finishes (:meth:`Backend.completed`, a
:class:`~dalembert.ensemble.faults.BatchOutcome`) and, when the ensemble is
interrupted, stops and hands over what finished meanwhile (:meth:`Backend.stop`).

- :class:`Serial` runs them in order in the caller's process.
- :class:`Threads` runs them on a thread pool sharing the one System: the C loop
  releases the GIL during its stretches of steps, the Python around it does not, so
  the threads take turns for their Python (:mod:`dalembert.solvers.native.turns`).
- :class:`Dask` runs them on a ``dask.distributed`` cluster: a ``LocalCluster``
  of processes it starts and stops, or the ``Client`` given (any cluster). The
  model, its compiled code and the shared settings travel as one package
  (:mod:`~dalembert.ensemble.model`), which each worker process prepares once. A
  batch whose worker died is run again by the scheduler (as often as its
  ``allowed-failures`` lets it); if its workers died each time, each of its cases
  runs once more, alone, so that only a culprit is lost (recorded as ``"lost"``). A
  client on the scheduler's machine takes results straight from the workers, not
  relayed by the scheduler.
"""

from __future__ import annotations

import logging
import os
import threading
import warnings
from collections.abc import Generator, Sequence
from concurrent.futures import FIRST_COMPLETED, Future, ThreadPoolExecutor, wait
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..errors import EnsembleError
from ..system import System
from .faults import BatchOutcome, error_outcome, lost_outcome
from .model import ModelPackage, package, prepared
from .worker import CaseSettings, run_batch


@dataclass(frozen=True)
class Batch:
    """Cases run by one task: their numbers and rows of the case table."""

    indices: np.ndarray
    rows: np.ndarray


class Interrupted(KeyboardInterrupt):
    """Ctrl-C during a batch run here: carries the cases finished before it."""

    def __init__(self, done: BatchOutcome) -> None:
        super().__init__()
        self.done = done


def run_here(system: System, settings: CaseSettings, batch: Batch,
             names: Sequence[str]) -> BatchOutcome:
    """Run ``batch`` in this process; a Ctrl-C ends it with :class:`Interrupted`.

    A Ctrl-C during a simulation ends that simulation (it returns what it computed,
    status ``"interrupted"``): the batch stops there too.
    """
    done = run_batch(system, settings, batch.indices, batch.rows, names)
    if done.interrupted:
        raise Interrupted(done)
    return done


class Backend:
    """Runs batches; :attr:`workers` is how many run at once."""

    name = "backend"
    workers = 1

    def completed(self, batches: Sequence[Batch]) -> Generator[BatchOutcome, None, None]:
        raise NotImplementedError

    def stop(self) -> list[BatchOutcome]:
        """Stop after an interruption; the outcomes finished but not yet yielded."""
        return []

    def close(self) -> None:
        return None


class Serial(Backend):
    """In the caller's process, batch after batch."""

    name = "serial"

    def __init__(self, system: System, settings: CaseSettings, names: Sequence[str]) -> None:
        self.system, self.settings, self.names = system, settings, names
        self._left: list[BatchOutcome] = []

    def completed(self, batches: Sequence[Batch]) -> Generator[BatchOutcome, None, None]:
        for batch in batches:
            for i in range(len(batch.indices)):  # case by case: the progress bar moves
                try:
                    yield run_here(self.system, self.settings,
                                   Batch(batch.indices[i:i + 1], batch.rows[i:i + 1]),
                                   self.names)
                except Interrupted as stop:
                    self._left = [stop.done]
                    raise KeyboardInterrupt from None

    def stop(self) -> list[BatchOutcome]:
        left, self._left = self._left, []
        return left


class Threads(Backend):
    """On a pool of threads sharing the System (its code is loaded first, once)."""

    name = "threads"

    def __init__(self, system: System, settings: CaseSettings, names: Sequence[str],
                 workers: int | None) -> None:
        self.system, self.settings, self.names = system, settings, names
        self.workers = workers or os.cpu_count() or 1
        system.compiled  # noqa: B018 - made once, before the threads share it
        self._stop = threading.Event()
        self._turns = threading.Lock()  # the threads take turns for their Python
        self._pool = ThreadPoolExecutor(self.workers, thread_name_prefix="dalembert-case")
        self._futures: set[Future] = set()

    def completed(self, batches: Sequence[Batch]) -> Generator[BatchOutcome, None, None]:
        # The cases' warnings are not recorded: catch_warnings in the threads would
        # race on the process-wide filters; they are silenced here, once, instead.
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            self._futures = {self._pool.submit(run_batch, self.system, self.settings,
                                               b.indices, b.rows, self.names, self._stop,
                                               False, self._turns) for b in batches}
            while self._futures:
                done, _ = wait(self._futures, return_when=FIRST_COMPLETED)
                for future in done:
                    self._futures.discard(future)
                    yield future.result()

    def stop(self) -> list[BatchOutcome]:
        self._stop.set()  # running batches end after their current case
        for future in self._futures:
            future.cancel()
        left = [future.result() for future in self._futures if not future.cancelled()]
        self._futures = set()
        return left

    def close(self) -> None:
        self._pool.shutdown(wait=True, cancel_futures=True)


#: A Dask worker's threads take turns for their Python (one lock per process).
_TURNS = threading.Lock()


def run_packed(pack: ModelPackage, indices: np.ndarray, rows: np.ndarray,
               names: Sequence[str]) -> BatchOutcome:
    """A Dask task: one batch, on the System and settings of ``pack`` (prepared once
    per worker process). On a worker running several tasks at once (threads), the
    cases' warnings are left to the worker's log: recording them is not thread-safe."""
    system, settings = prepared(pack)
    try:
        from distributed import get_worker

        threads = get_worker().state.nthreads
    except (ImportError, ValueError, AttributeError):  # not on a Dask worker
        threads = 1
    return run_batch(system, settings, indices, rows, names, record_warnings=threads == 1,
                     turns=_TURNS if threads > 1 else None)


class Dask(Backend):
    """On a ``dask.distributed`` cluster: the ``client`` given, or a ``LocalCluster`` of
    ``workers`` single-threaded processes started here (and closed by :meth:`close`)."""

    name = "dask"

    def __init__(self, system: System, settings: CaseSettings, names: Sequence[str],
                 client: Any = None, workers: int | None = None) -> None:
        distributed = _distributed()
        self.names, self._own = names, None
        if client is None:
            try:
                self._own = distributed.LocalCluster(
                    n_workers=workers or os.cpu_count() or 1, threads_per_worker=1,
                    processes=True, dashboard_address=None, silence_logs=logging.ERROR)
            except Exception as exc:  # Dask's own message says little about the usual cause
                raise EnsembleError(
                    f"could not start a local Dask cluster ({type(exc).__name__}: {exc}). In "
                    "a script, the code that runs the ensemble must be under "
                    "`if __name__ == '__main__':` (each worker process imports the script); "
                    "or pass scheduler='serial' or 'threads'") from exc
            client = distributed.Client(self._own)
        self.client = client
        threads = client.nthreads()
        self.workers = max(1, sum(threads.values()))
        # Results straight from the workers when the scheduler runs on this machine
        # (what it reaches, this client reaches): relayed by it, every byte of them
        # would cross two more sockets in the client's process (where a local cluster's
        # scheduler runs). A remote cluster's workers may not be reachable from here:
        # there the client's own setting holds.
        self.direct = client.direct_to_workers
        if self.direct is None:
            self.direct = _on_this_machine(client.scheduler.address)
        # Each task carries the package (about 0.2 MB for a 16-link chain) rather than
        # a scattered copy: data scattered to workers dies with them, and a worker
        # prepares a package once however many tasks bring it (and _submit sends it
        # once per call, not once per task).
        self.package = package(system, settings)
        self._pending: dict[Any, Batch] = {}

    def completed(self, batches: Sequence[Batch]) -> Generator[BatchOutcome, None, None]:
        distributed = _distributed()
        pending = self._pending
        pending.update(zip(self._submit(batches), batches))
        found = distributed.as_completed(list(pending))
        # The cases of a batch whose worker died (a batch of one case too) run again one
        # at a time, each alone among the suspects: a case queued on the same worker as
        # the culprit dies with it, so two suspects in flight together could both be
        # taken for culprits. A suspect that dies again is lost.
        suspects: list[Batch] = []
        suspect: Any = None

        def next_suspect() -> None:
            nonlocal suspect
            suspect = None
            if suspects:
                single = suspects.pop(0)
                suspect = self._submit([single])[0]
                pending[suspect] = single
                found.add(suspect)

        for future in found:
            batch = pending.pop(future)
            alone = future is suspect
            if alone:
                next_suspect()
            if future.status == "finished":
                yield self.client.gather(future, direct=self.direct)
                continue
            # waits: a result held by a worker that died after it finished is computed
            # again, and then is there
            exc = future.exception()
            if exc is None and future.status == "finished":
                yield self.client.gather(future, direct=self.direct)
                continue
            if isinstance(exc, distributed.KilledWorker) and not alone:
                suspects += [Batch(batch.indices[i:i + 1], batch.rows[i:i + 1])
                             for i in range(len(batch.indices))]
                if suspect is None:
                    next_suspect()
            elif isinstance(exc, distributed.KilledWorker):
                yield BatchOutcome([lost_outcome(int(batch.indices[0]), str(exc))])
            else:  # the task itself failed (e.g. the model could not be prepared there)
                why = exc if exc is not None else RuntimeError(f"the task ended {future.status}")
                yield BatchOutcome([error_outcome(int(i), why, 0.0, "") for i in batch.indices])

    def _submit(self, batches: Sequence[Batch]) -> list[Any]:
        """One task per batch, all in one graph: pickled once, it holds the package
        once, and so does the scheduler (submitted one by one, each task's copy would
        be pickled and held apart, in this client and in the scheduler)."""
        if not batches:
            return []
        k = len(batches)
        return self.client.map(run_packed, [self.package] * k, [b.indices for b in batches],
                               [b.rows for b in batches], [self.names] * k, pure=False)

    def stop(self) -> list[BatchOutcome]:
        left: list[BatchOutcome] = []
        for future in list(self._pending):
            if future.status == "finished":
                left.append(self.client.gather(future, direct=self.direct))
            else:
                future.cancel()
        self._pending.clear()
        return left

    def close(self) -> None:
        if self._own is not None:
            self.client.close()
            self._own.close()


def _on_this_machine(address: str) -> bool:
    """Whether a Dask address is of this machine (loopback, or in this process)."""
    import ipaddress

    from distributed.comm import get_address_host

    if address.startswith("inproc://"):
        return True
    try:
        host = get_address_host(address)
    except ValueError:
        return False
    if host in ("localhost", ""):
        return True
    try:
        return ipaddress.ip_address(host).is_loopback
    except ValueError:  # a host name
        return False


def _distributed() -> Any:
    try:
        import distributed
    except ImportError as exc:  # pragma: no cover - Dask comes with the extra
        raise ImportError("running an ensemble on Dask needs dask.distributed: pip install "
                          "'dalembert[ensemble]' (or scheduler='serial' / 'threads')") from exc
    return distributed
