"""What became of each case: its status, its message, and what it computed.

A case never takes the ensemble down. An exception while it is set up or run (a
bad parameter value, a singular KKT matrix at its initial state) is recorded as
``"error"`` with its message; an integration that stops midway is ``"failed"``
with the part computed; a case whose worker process died every time it was tried
is ``"lost"``; a case the ensemble never reached, because it was interrupted, is
``"not-run"``; a case whose simulation ran past its time limit (``timeout=``, checked
between steps) is ``"timeout"``, with the part computed. :data:`SUCCESS` are the
statuses that need no retry.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

#: Every status a case can have, in the order of their codes (the ``status``
#: variable of a stored ensemble holds the code; its attributes name them).
STATUSES = ("finished", "event", "failed", "interrupted", "error", "lost", "not-run",
            "timeout")
#: A case with one of these statuses ran to the end of its span (or a terminal event).
SUCCESS = frozenset({"finished", "event"})
CODE = {name: code for code, name in enumerate(STATUSES)}


@dataclass
class CaseOutcome:
    """One case's result, as a worker sends it back.

    ``arrays`` holds the kept quantities at the output times the case reached
    (``q``, ``qd``, ... ; a case that failed midway has fewer rows, one that raised
    has none) until its batch's blocks take them (:class:`BatchOutcome`); the other
    fields go into the summary table.
    """

    index: int
    status: str
    message: str = ""
    seconds: float = 0.0
    worker: str = ""
    arrays: dict[str, np.ndarray] = field(default_factory=dict)
    numbers: dict[str, float] = field(default_factory=dict)
    warnings: str = ""
    #: It ran in stretches of C steps, which release the GIL (threads run such cases
    #: side by side).
    in_c: bool = False
    #: When it started (seconds since the epoch): with ``seconds`` and ``worker``, the
    #: ensemble's timeline.
    started: float = np.nan

    @property
    def ok(self) -> bool:
        return self.status in SUCCESS


@dataclass
class BatchOutcome:
    """The cases of one batch as they come back from where they ran.

    ``cases`` are their records, in the batch's order, without arrays; ``arrays`` the
    quantities they kept, stacked: one array per name over ``(case, time, ...)`` in
    the order of ``cases``, NaN after the times a case reached and for a case that
    kept nothing (empty when no case of the batch kept anything). A batch's values
    travel and are written as a few blocks, not as every case's own arrays.
    ``interrupted``: a Ctrl-C ended the batch before its last case.
    """

    cases: list[CaseOutcome]
    arrays: dict[str, np.ndarray] = field(default_factory=dict)
    interrupted: bool = False

    @property
    def indices(self) -> np.ndarray:
        return np.fromiter((o.index for o in self.cases), dtype=np.intp, count=len(self.cases))


def error_outcome(index: int, exc: BaseException, seconds: float, worker: str,
                  started: float = np.nan) -> CaseOutcome:
    """The record of a case whose set-up or run raised ``exc`` (named with its class).

    >>> error_outcome(3, ValueError("m = -1 is negative"), 0.0, "").message
    'ValueError: m = -1 is negative'
    """
    return CaseOutcome(index, "error", f"{type(exc).__name__}: {exc}", seconds, worker,
                       started=started)


def lost_outcome(index: int, why: str) -> CaseOutcome:
    """The record of a case whose worker died each time it ran it."""
    return CaseOutcome(index, "lost", f"the worker running this case died ({why}); it was "
                       "tried again and died again: a crash in the case itself (run it alone "
                       "with system.simulate to see), or workers short of memory")


def not_run_outcome(index: int) -> CaseOutcome:
    """The record of a case the ensemble never reached (it was interrupted)."""
    return CaseOutcome(index, "not-run", "not run: the ensemble was interrupted first")
