"""Session fixtures of the solver tests: the pendulum and its minimal-coordinate reference."""

from __future__ import annotations

import pytest
from pendulum_case import build_pendulum, reference_solution

from dalembert import System


@pytest.fixture(scope="session")
def pendulum() -> System:
    return build_pendulum()


@pytest.fixture(scope="session")
def reference():
    return reference_solution()


@pytest.fixture
def time_bound():
    """``with time_bound(seconds):`` fails the test if the block runs longer: a
    ``TimeoutError`` where Python gets control, and where it does not (a loop in C
    that never returns) the whole process ends with the tracebacks after 10 s more,
    so that a regression fails instead of hanging the suite."""
    import contextlib
    import faulthandler
    import signal

    def alarm(signum, frame):
        raise TimeoutError("the time bound of the test was exceeded")

    @contextlib.contextmanager
    def bound(seconds: float):
        previous = signal.signal(signal.SIGALRM, alarm)
        signal.setitimer(signal.ITIMER_REAL, seconds)
        faulthandler.dump_traceback_later(seconds + 10, exit=True)
        try:
            yield
        finally:
            faulthandler.cancel_dump_traceback_later()
            signal.setitimer(signal.ITIMER_REAL, 0)
            signal.signal(signal.SIGALRM, previous)

    return bound
