"""Typed caches of what the solvers compute from a sparsity pattern alone.

A model simulated many times, by many threads, has one
:class:`~dalembert.codegen.compiled.SparsePattern`; the index maps, orders and
solver structures made from it are made once and shared. Each kind of such value is
one :class:`PatternCache` declared at module level by the module that owns it (so a
reader sees what is cached, and its type, where it is used), keyed by the pattern's
identity and, for a value that depends on a set of constraint rows too, by those rows.

The values are shared by every run and thread of the model: a cache stores only
values that are not changed once made (read-only arrays, frozen objects, solvers
that hold index maps only). Two threads asking at once may both make a value; one is
kept, and both are equal.
"""

from __future__ import annotations

import threading
import weakref
from collections.abc import Callable
from typing import Generic, TypeVar

import numpy as np

from ..codegen.compiled import SparsePattern

T = TypeVar("T")


class PatternCache(Generic[T]):
    """One value of type ``T`` per pattern (and set of rows), made on first use.

    Values live as long as their pattern (the cache holds the pattern weakly).

    Parameters
    ----------
    make
        ``make(pattern, rows)``: the value for ``pattern``, ``rows`` (a 1-D integer
        array, or ``None``) as :meth:`get` was given them.
    what
        What the values are (for a reader, and in ``repr``).

    Examples
    --------
    >>> pattern = SparsePattern(1, 0, np.zeros(1, int), np.zeros(1, int),
    ...                         np.zeros(0, int), np.zeros(0, int))
    >>> sizes = PatternCache(lambda p, rows: p.n + p.m, "the KKT size")
    >>> sizes.get(pattern), sizes.get(pattern) is sizes.get(pattern)
    (1, True)
    """

    def __init__(self, make: Callable[[SparsePattern, np.ndarray | None], T],
                 what: str) -> None:
        self._make = make
        self.what = what
        self._values: weakref.WeakKeyDictionary[SparsePattern, dict[bytes | None, T]] = \
            weakref.WeakKeyDictionary()
        self._lock = threading.Lock()  # guards the dictionaries, not the making

    def __repr__(self) -> str:
        return f"PatternCache({self.what!r})"

    def get(self, pattern: SparsePattern, rows: np.ndarray | None = None) -> T:
        """The value for ``pattern`` and ``rows`` (made now if it is not yet).

        Parameters
        ----------
        pattern
            The sparsity pattern (by identity).
        rows
            The constraint rows the value depends on (integer indices), or ``None``.
        """
        key = None if rows is None else np.asarray(rows, dtype=np.intp).tobytes()
        values = self._values.get(pattern)
        if values is not None:
            found = values.get(key, _MISSING)
            if found is not _MISSING:
                return found  # type: ignore[return-value]
        made = self._make(pattern, None if rows is None else np.asarray(rows, dtype=np.intp))
        with self._lock:
            return self._values.setdefault(pattern, {}).setdefault(key, made)


_MISSING = object()


def read_only(array: np.ndarray) -> np.ndarray:
    """``array``, made read-only (a value shared by runs and threads), returned.

    >>> read_only(np.zeros(2)).flags.writeable
    False
    """
    array.flags.writeable = False
    return array
