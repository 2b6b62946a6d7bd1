"""Threads running many simulations at once take turns for their Python.

A simulation's C calls release the GIL, so threads overlap there; its Python (the
set-up, the checks, the results) holds the GIL and runs one thread at a time anyway.
But when two threads are in their Python together, each short C call inside it hands
the GIL to the other thread, and the handing back waits for the operating system to
switch threads: the two crawl through their Python in turns of microseconds (CPython's
"convoy effect"). Here the threads take turns for whole stretches of Python instead:
a thread holds a shared lock while it runs Python (:func:`python_turn`) and lets it go
only around the long C calls (:func:`outside_python`: the C loop's stretches of steps,
the outputs), so the other thread runs its Python meanwhile, uninterrupted.

Measured on the ensemble benchmark's 16-link chain (2 threads on 2 cores, 400 cases,
best of 3): 113-115 runs/s with the turns against 107-110 without. A simulation in the
Python loop (events, dense output, a model without C code) keeps its turn throughout:
its C calls are single evaluations, too short to let go for (such ensembles belong on
processes, where ``scheduler="auto"`` sends them).

:func:`outside_python` does nothing in a thread that holds no turn (a plain
``simulate``), so the C loop calls it whatever runs it.
"""

from __future__ import annotations

import threading
from collections.abc import Iterator
from contextlib import contextmanager

_held = threading.local()


@contextmanager
def python_turn(lock: threading.Lock) -> Iterator[None]:
    """Run the block holding ``lock`` (shared by the threads that take turns), except
    where it calls :func:`outside_python`.

    Parameters
    ----------
    lock
        One lock for every thread that takes turns with this one.

    Examples
    --------
    >>> turns = threading.Lock()
    >>> with python_turn(turns):
    ...     held = turns.locked()
    ...     with outside_python():
    ...         released = not turns.locked()
    >>> held, released, turns.locked()
    (True, True, False)
    """
    before = getattr(_held, "lock", None)
    try:
        try:
            lock.acquire()
        finally:  # marked held at once: see outside_python
            _held.lock = lock
        yield
    finally:
        held = _held.lock is lock  # not if taking it back was interrupted
        _held.lock = before
        if held:
            lock.release()


@contextmanager
def outside_python() -> Iterator[None]:
    """Around a long C call (it releases the GIL): the thread's turn goes to the other
    threads meanwhile, and is taken back after. Nothing outside :func:`python_turn`.

    Examples
    --------
    >>> with outside_python():  # no turn held: nothing to let go
    ...     pass
    """
    lock = getattr(_held, "lock", None)
    if lock is None:
        yield
        return
    lock.release()
    _held.lock = None
    try:
        yield
    finally:
        # An exception raised asynchronously in this thread (a run's watchdog,
        # solvers/running/watchdog.py) lands when a call returns: right after acquire()
        # it is raised inside this try, whose finally marks the lock held, so that
        # python_turn releases it (else the other threads would wait for it forever).
        try:
            lock.acquire()
        finally:
            _held.lock = lock
