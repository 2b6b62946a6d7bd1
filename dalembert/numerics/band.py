"""A bandwidth-reducing order of a symmetric sparsity pattern (reverse Cuthill-McKee).

One ordering for both banded solves: the Python loop's band LU of the KKT matrix
(:mod:`dalembert.solvers.kkt.sparse`) and the C loop's band Cholesky of the Schur
complement (:mod:`dalembert.solvers.native.structure`). Two candidates are
compared and the narrower band is kept: SciPy's reverse Cuthill-McKee (each
component started at a node of least degree) and one whose components start at a
pseudo-peripheral node (George and Liu), often several unknowns narrower on long
chains, where SciPy's start sits in the middle of a link.

>>> path = np.array([3, 0, 4, 1, 2])          # a path numbered at random
>>> rows = np.concatenate([path[:-1], path[1:]])
>>> cols = np.concatenate([path[1:], path[:-1]])
>>> bandwidth(rows, cols, band_order(rows, cols, 5))
1
"""

from __future__ import annotations

import hashlib

import numpy as np
import scipy.sparse as sps
from scipy.sparse.csgraph import reverse_cuthill_mckee

#: Orders remembered (least recently made dropped first).
CACHED_ORDERS = 32


def band_order(rows: np.ndarray, cols: np.ndarray, size: int,
               peripheral_from: int = 0) -> np.ndarray:
    """A permutation ``perm`` of ``0..size-1`` (``perm[k]``: the unknown placed at ``k``)
    giving the pattern ``(rows, cols)`` a narrow band.

    Remembered for recent patterns: one simulation orders the same pattern several
    times (dynamics, projection, initial checks), and the peripheral search costs
    about a second at ten thousand unknowns.

    Parameters
    ----------
    rows, cols
        The entries of a symmetric pattern (each ``(i, j)`` with its ``(j, i)``);
        duplicates are allowed.
    size
        The number of unknowns.
    peripheral_from
        The pseudo-peripheral candidate is tried only from this many unknowns on
        (below, SciPy's order is kept: a caller whose results were fixed with it keeps
        their rounding where the band hardly costs).

    Returns
    -------
    numpy.ndarray
        ``intp`` array, SciPy's order unless the other candidate's band is narrower.
    """
    key = hashlib.sha1(np.asarray(rows, dtype=np.int64).tobytes() + b"|"
                       + np.asarray(cols, dtype=np.int64).tobytes()
                       + f"|{size}|{peripheral_from}".encode()).hexdigest()
    perm = _ORDERS.get(key)
    if perm is None:
        perm = _find_band_order(rows, cols, size, peripheral_from)
        _ORDERS[key] = perm
        while len(_ORDERS) > CACHED_ORDERS:
            _ORDERS.pop(next(iter(_ORDERS)))
    return perm


_ORDERS: dict[str, np.ndarray] = {}


def bandwidth(rows: np.ndarray, cols: np.ndarray, perm: np.ndarray) -> int:
    """The half bandwidth ``max |i - j|`` of the entries in the order ``perm``.

    Parameters
    ----------
    rows, cols
        The entries of the pattern.
    perm
        ``perm[k]``: the unknown placed at ``k``.
    """
    inverse = np.empty(len(perm), dtype=np.intp)
    inverse[perm] = np.arange(len(perm))
    return int(np.abs(inverse[rows] - inverse[cols]).max(initial=0))


def _find_band_order(rows: np.ndarray, cols: np.ndarray, size: int,
                     peripheral_from: int) -> np.ndarray:
    if not len(rows):
        return np.arange(size, dtype=np.intp)
    graph = sps.csr_matrix((np.ones(len(rows)), (rows, cols)), shape=(size, size))
    graph.sum_duplicates()
    candidates = [reverse_cuthill_mckee(graph, symmetric_mode=True).astype(np.intp)]
    if size >= peripheral_from:
        candidates.append(_peripheral_rcm(graph))
    # min keeps the first of equal widths: SciPy's order on a tie
    return min(candidates, key=lambda perm: bandwidth(rows, cols, perm))


def _peripheral_rcm(graph: sps.csr_matrix) -> np.ndarray:
    """Reverse Cuthill-McKee, each connected component started at a pseudo-peripheral node."""
    indptr, indices = graph.indptr, graph.indices
    degree = np.diff(indptr)
    seen = np.zeros(graph.shape[0], dtype=bool)
    order: list[int] = []
    for root in np.argsort(degree, kind="stable").tolist():
        if seen[root]:
            continue
        start, eccentricity = root, -1
        while True:  # the far end of a breadth-first search, until it stops receding
            levels = _levels(indptr, indices, start)
            if len(levels) - 1 <= eccentricity:
                break
            eccentricity = len(levels) - 1
            start = min(levels[-1], key=lambda v: degree[v])
        component = [start]
        seen[start] = True
        for v in component:  # Cuthill-McKee: neighbours by increasing degree
            new = [u for u in indices[indptr[v]:indptr[v + 1]].tolist() if not seen[u]]
            new.sort(key=lambda u: degree[u])
            seen[new] = True
            component.extend(new)
        order.extend(reversed(component))
    return np.array(order, dtype=np.intp)


def _levels(indptr: np.ndarray, indices: np.ndarray, start: int) -> list[list[int]]:
    """Breadth-first levels from ``start``."""
    levels, seen = [[start]], {start}
    while True:
        nxt = []
        for v in levels[-1]:
            for u in indices[indptr[v]:indptr[v + 1]].tolist():
                if u not in seen:
                    seen.add(u)
                    nxt.append(u)
        if not nxt:
            return levels
        levels.append(nxt)
