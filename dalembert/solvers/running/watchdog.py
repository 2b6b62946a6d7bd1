"""The time limit of a run inside the functions it calls: a watchdog per run.

``simulate(timeout=)`` is checked by the loop between its units of work (a step, a
stretch of C steps): a run whose own work takes too long stops there. A function of
the user's that never returns (an input ``while True: ...``, an event waiting on a
socket) never gives the loop that chance. A :class:`Watchdog` does: armed by the thread
that runs (:meth:`Watchdog.armed`), once the deadline plus :data:`GRACE` has passed it
raises :class:`~dalembert.errors.TimeLimitExceeded` in that thread, asynchronously
(CPython's ``PyThreadState_SetAsyncExc``: it lands at the next Python instruction the
thread runs, in any thread, where a signal reaches only the main thread). The run
catches it as it catches Ctrl-C: it ends with status ``"timeout"``, keeping every step
completed before (:func:`~dalembert.solvers.running.integrate.integrate`).

The grace leaves the loop's own check to stop a run whose work is only slow (a C
stretch lasts a twentieth of a second); the exception is raised again every
:data:`GRACE` while the watchdog stays armed (a function may catch it with a bare
``except:``). A function blocked in a C call (``time.sleep``, a read without a time
limit) gets it only when that call returns: Python code runs no instruction meanwhile.

One thread per process (:class:`_Monitor`, started on first use, a daemon) serves every
armed watchdog: arming one is an entry in a table, not a thread per run or per step.
"""

from __future__ import annotations

import ctypes
import os
import sys
import threading
import time
from collections.abc import Iterator
from contextlib import AbstractContextManager, contextmanager, nullcontext
from types import TracebackType

from ...errors import TimeLimitExceeded

#: Seconds past a deadline before the exception is raised in the run's thread, and
#: between two raises while the run has not ended.
GRACE = 0.5

#: ``PyThreadState_SetAsyncExc(thread, exception)``: our own prototypes, not
#: ``ctypes.pythonapi``'s shared attributes (another library may set other ones).
_RAISE = ctypes.PYFUNCTYPE(ctypes.c_int, ctypes.c_ulong, ctypes.py_object)(
    ("PyThreadState_SetAsyncExc", ctypes.pythonapi))
_CLEAR = ctypes.PYFUNCTYPE(ctypes.c_int, ctypes.c_ulong, ctypes.c_void_p)(
    ("PyThreadState_SetAsyncExc", ctypes.pythonapi))


class Watchdog:
    """The time limit of one run, raised in its thread past the deadline.

    Parameters
    ----------
    deadline
        The ``time.monotonic()`` the run may take until; the exception comes
        :data:`GRACE` after it, in the thread that armed the watchdog.

    Examples
    --------
    A function that never returns, stopped:

    >>> from dalembert.errors import TimeLimitExceeded
    >>> dog = Watchdog(time.monotonic() + 0.05)
    >>> try:
    ...     with dog.armed():
    ...         while True:
    ...             pass
    ... except TimeLimitExceeded:
    ...     stopped = True
    >>> stopped, dog.fired
    (True, True)
    """

    def __init__(self, deadline: float) -> None:
        self.deadline = deadline
        #: Whether the exception has been raised in the run's thread (at least once).
        self.fired = False
        self._thread: int | None = None
        self._next = deadline + GRACE

    @contextmanager
    def armed(self) -> Iterator[None]:
        """Watch the calling thread for the block: past the deadline (and the grace) the
        block gets :class:`~dalembert.errors.TimeLimitExceeded`. On leaving, a raise
        not yet delivered is withdrawn, so that none lands after the block."""
        _monitor().arm(self, threading.get_ident())
        try:
            yield
        finally:
            self.disarm()

    def disarm(self) -> None:
        """Stop watching (idempotent). One raised while this runs is absorbed here: the
        block it was meant for has ended already."""
        while True:
            try:
                _monitor().disarm(self)
                return
            except TimeLimitExceeded:  # delivered just now: the monitor is disarmed next
                continue

    def due(self, now: float) -> float | None:
        """When the exception is next due, if armed (the monitor's table)."""
        return self._next if self._thread is not None else None

    def fire(self, now: float) -> None:
        """Raise the exception in the run's thread (the monitor holds its lock)."""
        if self._thread is None:
            return
        _RAISE(self._thread, TimeLimitExceeded)
        self.fired = True
        self._next = now + GRACE


class _Monitor:
    """The one thread that raises the exceptions of every armed :class:`Watchdog` of
    this process, sleeping until the next one is due (or a new one is armed)."""

    def __init__(self) -> None:
        self._lock = threading.Condition()
        self._armed: dict[int, Watchdog] = {}
        self._thread: threading.Thread | None = None

    def arm(self, dog: Watchdog, thread: int) -> None:
        with self._lock:
            dog._thread = thread
            self._armed[id(dog)] = dog
            if self._thread is None:
                self._thread = threading.Thread(target=self._watch, daemon=True,
                                                name="dalembert-watchdog")
                self._thread.start()
            self._lock.notify()

    def disarm(self, dog: Watchdog) -> None:
        with self._lock:
            self._armed.pop(id(dog), None)
            thread, dog._thread = dog._thread, None
            if dog.fired and thread is not None:
                _CLEAR(thread, None)  # a raise still pending is withdrawn

    def _watch(self) -> None:
        with self._lock:
            while True:
                now = time.monotonic()
                for dog in list(self._armed.values()):
                    due = dog.due(now)
                    if due is not None and due <= now:
                        dog.fire(now)
                dues = [d for d in (dog.due(now) for dog in self._armed.values())
                        if d is not None]
                self._lock.wait(max(min(dues) - time.monotonic(), 0.0) if dues else None)


def watching(watchdog: Watchdog | None) -> AbstractContextManager[None]:
    """``watchdog`` armed over a block, or nothing (a run without a time limit).

    Parameters
    ----------
    watchdog
        The run's watchdog, or ``None``.

    Examples
    --------
    >>> with watching(None):
    ...     pass
    """
    return watchdog.armed() if watchdog is not None else nullcontext()


_state: dict[int, _Monitor] = {}


def _monitor() -> _Monitor:
    """This process's monitor (a forked child makes its own: threads do not survive a
    fork)."""
    pid = os.getpid()
    monitor = _state.get(pid)
    if monitor is None:
        monitor = _state.setdefault(pid, _Monitor())
    return monitor


def where_stopped(exc: BaseException) -> str:
    """The function of the user's that was running when ``exc`` landed, as
    ``"name (file:line)"``: the innermost frame of its traceback outside dalembert and
    the libraries it runs on, or ``""``.

    Parameters
    ----------
    exc
        The exception, with its traceback.

    Examples
    --------
    >>> def spin():
    ...     raise TimeLimitExceeded
    >>> try:
    ...     spin()
    ... except TimeLimitExceeded as exc:
    ...     where_stopped(exc).startswith("spin (")
    True
    """
    found = ""
    tb: TracebackType | None = exc.__traceback__
    while tb is not None:
        code = tb.tb_frame.f_code
        if not _library(code.co_filename):
            found = f"{code.co_name} ({os.path.basename(code.co_filename)}:{tb.tb_lineno})"
        tb = tb.tb_next
    return found


_OWN = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__)))) + os.sep
_LIBRARIES = tuple({os.path.dirname(os.path.abspath(os.__file__)) + os.sep,
                    *(os.path.abspath(p) + os.sep for p in sys.path
                      if p.endswith("site-packages"))})


def _library(filename: str) -> bool:
    """Whether a frame's file is dalembert's, the standard library's or an installed
    package's (NumPy, SciPy): not the user's function."""
    path = os.path.abspath(filename)
    return path.startswith(_OWN) or path.startswith(_LIBRARIES) or filename.startswith("<frozen")
