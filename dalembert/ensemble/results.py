"""The result of an ensemble: labelled arrays, a summary table, reductions, a retry.

:attr:`EnsembleResult.dataset` is an ``xarray.Dataset`` over ``case``, ``time``,
``coordinate`` and ``constraint`` (in memory, or read lazily from the Zarr store or
netCDF file it was written to); :attr:`EnsembleResult.summary` a pandas DataFrame,
one row per case: its columns of the case table, status, message, where it ended,
its energy error and residuals, its final values, its time, when it started and
its worker.
:meth:`EnsembleResult.quantile` and :meth:`EnsembleResult.mean` reduce over the
cases that succeeded, time by time; on a stored ensemble they run chunk by chunk
(Dask), so the client never holds every trajectory.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..errors import EnsembleError
from .faults import CODE, SUCCESS, CaseOutcome

#: Bytes of one block of a reduction over all cases (the time axis is cut to fit).
REDUCTION_BLOCK_BYTES = 64 * 2**20


@dataclass
class EnsembleResult:
    """What :func:`~dalembert.ensemble.simulate_many` returns.

    Attributes
    ----------
    dataset
        The arrays (``xarray.Dataset``); variables ``q``, ``qd``, ``multipliers``,
        ``constraint_forces``, ``energy``, residuals and outputs over
        ``(case, time[, coordinate | constraint | input])``, per-case ``status`` (codes, named
        in its attributes), ``t_end``, ``energy_error``, ``seconds``, and the case
        table's columns as coordinates along ``case``.
    summary
        One row per case (pandas DataFrame indexed by case): the case table's columns,
        ``status``, ``message``, the case's numbers (``t_end``, ``energy_error``, its
        largest residuals, ``nfev``, its final values, and for each event function
        the time it first occurred, ``t_event_<name>``, NaN if it did not, and how
        often, ``n_events_<name>``), ``seconds`` it took, when it ``started`` (UTC)
        and on which ``worker``, its ``warnings``.
    scheduler
        What ran the cases (``"serial"``, ``"threads"``, ``"dask"``).
    interrupted
        Whether the run was interrupted (the cases it did not reach are ``"not-run"``).
    """

    dataset: Any
    summary: Any
    scheduler: str
    interrupted: bool = False
    _rerun: Callable[..., EnsembleResult] | None = field(default=None, repr=False)
    #: The Zarr store or netCDF file the dataset is read from, if any.
    store: Any = field(default=None, repr=False)

    @property
    def failed(self) -> list[int]:
        """The cases that did not succeed (failed, error, lost, interrupted, not run)."""
        ok = self.summary["status"].isin(sorted(SUCCESS))
        return [int(i) for i in self.summary.index[~ok]]

    @property
    def succeeded(self) -> np.ndarray:
        """A boolean mask over cases: those that reached the end (or a terminal event)."""
        return np.isin(self.dataset["status"].values, [CODE[s] for s in SUCCESS])

    def retry(self, cases: Sequence[int] | None = None, **changes: Any) -> EnsembleResult:
        """Run the failed cases again (or ``cases``) and return the whole ensemble updated.

        Parameters
        ----------
        cases
            Case numbers to run again (default: :attr:`failed`); new values are a
            new ensemble (``simulate_many`` with a new case table).
        changes
            ``simulate_many`` keywords to change for the retry (``rtol=...``,
            ``scheduler=...``, ``client=...``, ``method="Radau"``...).

        Returns
        -------
        EnsembleResult
            Every case: those run again with their new outcome, the others as they
            were (a store is updated in place).
        """
        if self._rerun is None:
            raise ValueError("this result cannot be retried (it was not made by simulate_many)")
        return self._rerun(self, self.failed if cases is None else cases, changes)

    def quantile(self, variable: str, q: Sequence[float] | float = (0.05, 0.5, 0.95),
                 **selection: Any) -> Any:
        """Quantiles over the cases that succeeded, at each output time.

        Parameters
        ----------
        variable
            A variable of :attr:`dataset` (``"q"``, ``"energy"``, an output...).
        q
            The quantile(s), in [0, 1].
        selection
            ``dataset.sel`` arguments, e.g. ``coordinate="link16_z"``.

        Returns
        -------
        xarray.DataArray
            Over ``quantile`` (for a sequence ``q``) and ``time`` (and the variable's
            other dimensions left).
        """
        data = self._successful(variable, selection)
        return self._computed(lambda: data.quantile(q, dim="case").compute(), variable)

    def mean(self, variable: str, **selection: Any) -> Any:
        """The mean over the cases that succeeded, at each output time (see :meth:`quantile`)."""
        data = self._successful(variable, selection)
        return self._computed(lambda: data.mean("case").compute(), variable)

    def _computed(self, compute: Callable[[], Any], variable: str) -> Any:
        """``compute()``; reading a damaged store raises an error naming its chunk."""
        if self.store is None:
            return compute()
        try:
            return compute()
        except EnsembleError:  # a damaged chunk named where it was read (store.guarded)
            raise
        except Exception as exc:  # the codec's or file's own error
            from .store import damaged_store

            raise damaged_store(self.store, variable, exc) from exc

    def _successful(self, variable: str, selection: dict[str, Any]) -> Any:
        data = self.dataset[variable]
        if selection:
            data = data.sel(**selection)
        data = data.isel(case=np.flatnonzero(self.succeeded))
        if data.chunks:  # lazily read: all cases in one block, time cut to fit
            per_time = data.dtype.itemsize * data.sizes["case"] * int(
                np.prod([n for d, n in data.sizes.items() if d not in ("case", "time")]))
            steps = max(1, REDUCTION_BLOCK_BYTES // max(per_time, 1))
            data = data.chunk({"case": -1, "time": min(steps, data.sizes["time"])})
        return data

    def __repr__(self) -> str:
        counts = self.summary["status"].value_counts()
        told = ", ".join(f"{n} {s}" for s, n in counts.items())
        return (f"EnsembleResult({len(self.summary)} cases: {told}; scheduler="
                f"{self.scheduler!r}{'; interrupted' if self.interrupted else ''})")


class SummaryRows:
    """The summary's rows, filled in as the cases finish.

    Each case's record is read into the summary's columns as it arrives and dropped:
    the client keeps columns, not a record per case.

    Parameters
    ----------
    indices
        The cases of the run, in increasing order (its rows, in that order).

    Examples
    --------
    >>> import pandas as pd
    >>> rows = SummaryRows([0, 1])
    >>> rows.add(CaseOutcome(1, "finished", numbers={"t_end": 1.0}))
    >>> rows.missing()
    [0]
    >>> rows.add(CaseOutcome(0, "error", "ValueError: m = -1 is negative"))
    >>> table = rows.table(pd.DataFrame({"m": [-1.0, 1.0]}))
    >>> table[["m", "status", "t_end"]].values.tolist()
    [[-1.0, 'error', nan], [1.0, 'finished', 1.0]]
    """

    def __init__(self, indices: Sequence[int]) -> None:
        self.indices = np.asarray(indices, dtype=np.int64)
        if np.any(np.diff(self.indices) <= 0):
            raise ValueError("SummaryRows takes the cases in increasing order")
        n = len(self.indices)
        self.filled = np.zeros(n, dtype=bool)
        self.text = {name: np.full(n, "", dtype=object)
                     for name in ("status", "message", "worker", "warnings")}
        self.seconds, self.started = np.full(n, np.nan), np.full(n, np.nan)
        #: the cases' numbers, a column per name in the order they are first met: every
        #: case's names come in one order (a case that reached no output time has no
        #: final values), so the columns do not depend on the order the cases finish in
        self.numbers = np.full((n, 0), np.nan)
        self.columns: dict[str, int] = {}
        self._last: tuple[tuple[str, ...], np.ndarray] = ((), np.zeros(0, dtype=np.intp))

    def add(self, outcome: CaseOutcome) -> None:
        """Read one case's record into its row."""
        row = int(np.searchsorted(self.indices, outcome.index))
        if self.filled[row]:  # a record again (a retry): nothing of the first one stays
            self.numbers[row] = np.nan
        self.filled[row] = True
        for name, column in self.text.items():
            column[row] = getattr(outcome, name)
        self.seconds[row], self.started[row] = outcome.seconds, outcome.started
        names = tuple(outcome.numbers)
        places = self._places(names)  # first: new names widen self.numbers
        self.numbers[row, places] = np.fromiter(outcome.numbers.values(), dtype=float,
                                                count=len(names))

    def _places(self, names: tuple[str, ...]) -> np.ndarray:
        """The columns of ``names`` (new ones added); most cases have the last case's."""
        if names != self._last[0]:
            new = [name for name in names if name not in self.columns]
            if new:
                first = len(self.columns)
                self.columns.update(zip(new, range(first, first + len(new))))
                self.numbers = np.hstack([self.numbers,
                                          np.full((len(self.indices), len(new)), np.nan)])
            self._last = names, np.array([self.columns[name] for name in names], dtype=np.intp)
        return self._last[1]

    def missing(self) -> list[int]:
        """The cases no record has come for yet."""
        return [int(i) for i in self.indices[~self.filled]]

    def table(self, cases: Any) -> Any:
        """The summary DataFrame: ``cases`` (the case table's rows of these cases), then
        each case's record."""
        import pandas as pd

        table = pd.DataFrame({
            **{name: cases[name].to_numpy() for name in cases.columns},
            "status": self.text["status"], "message": self.text["message"],
            **{name: self.numbers[:, j] for name, j in self.columns.items()},
            "seconds": self.seconds,
            "started": pd.to_datetime(self.started, unit="s", utc=True),
            "worker": self.text["worker"], "warnings": self.text["warnings"]})
        table.index.name = "case"
        return table
