"""Index tables of the native KKT solve, computed once from the sparsity pattern.

``M`` splits into diagonal blocks (the connected components of its pattern: one
per rigid body, one per particle coordinate). Each constraint row meets a few
blocks; the part of row ``r`` inside block ``b`` is a *pair*, stored as a dense
vector of the block's size. The Schur complement ``S = A Mt^-1 A^T`` couples two
rows when they meet a common block, so its pattern is known here: the rows are
put in a bandwidth-reducing order (reverse Cuthill-McKee) and each product
``z_i . z_j`` (``z = L^-1 a`` with the block's Cholesky factor ``L``) gets its
place in the band once. A row inside one block (*internal*: a quaternion's unit
norm) couples nothing outside it, so it is eliminated inside its block, before
the band is made: its pairs come first in their block, and the band holds only
the other rows (a chain of quaternion links: 3 rows per link instead of 4). The
1 x 1 blocks without a row of their own (particles, planar bodies) are common and
cheap, so they get flat tables of their own: looping over them block by block cost
more in branching than in arithmetic.

>>> from dalembert.codegen.compiled import SparsePattern
>>> pattern = SparsePattern(3, 1, np.arange(3), np.arange(3), np.array([0, 0]),
...                         np.array([0, 2]))
>>> s = schur_structure(pattern)
>>> s.block_start.tolist(), s.pair_row.tolist(), s.kd
([0, 1, 2, 3], [0, 0], 0)
"""

from __future__ import annotations

from dataclasses import dataclass, fields

import numpy as np
import scipy.sparse as sps
from scipy.sparse.csgraph import connected_components

from ...codegen.compiled import SparsePattern
from ...numerics.band import band_order
from . import library

#: Largest block of ``M`` factored dense (a rigid body has 7 coordinates).
BLOCK_MAX = 64
#: Largest half bandwidth of ``S`` (a chain of quaternion links needs 6-11).
BAND_MAX = 64


class NotApplicable(ValueError):
    """The pattern does not suit the native solve (the reason is the message).

    Internal control flow, never seen by a user: the plan
    (:func:`~dalembert.solvers.running.plan.plan_simulation`) catches it and runs the
    Python loop, keeping the message as the reason the C loop does not apply
    (``backend="c"`` turns that reason into a user error)."""


@dataclass(frozen=True)
class SchurStructure:
    """Tables read by the C runtime (``dl_model`` in ``runtime.h``); all ``int64`` arrays."""

    block_start: np.ndarray   # n_blocks + 1: first slot of each block
    slot_coord: np.ndarray    # n: global coordinate of each slot
    block_mat: np.ndarray     # n_blocks + 1: offset of each block's nb x nb matrix
    M_at: np.ndarray          # nM: place of each M value in the block matrices
    pair_row: np.ndarray      # n_pairs: constraint row of each pair
    pair_block: np.ndarray    # n_pairs: block of each pair
    pair_vec: np.ndarray      # n_pairs + 1: offset of each pair's vector
    A_at: np.ndarray          # nA: place of each A value in the pair vectors
    block_pairs: np.ndarray   # n_blocks + 1: block b's pairs are bp[b]..bp[b+1]-1
    block_external: np.ndarray  # n_blocks: block b's internal pairs are bp[b]..be[b]-1
    elim_at: np.ndarray       # n_pairs + 1: an internal pair's elimination factors
    elim_blocks: np.ndarray   # the blocks with internal pairs
    row_pos: np.ndarray       # m: place of each row in the band order (-1: internal)
    band_row: np.ndarray      # the row at each place of the band
    dropped_rows: np.ndarray  # the dependent rows left out of the solve (see schur_structure)
    gram_start: np.ndarray    # n_blocks + 1: block b's products are gram_target[gs[b]:gs[b+1]]
    gram_target: np.ndarray   # band place of each product z_i . z_j of a block's pairs
    # 1 x 1 blocks without internal rows (a particle's or a planar body's coordinate),
    # solved in flat loops: the flag per block; per such block its slot and matrix place;
    # per pair its vector, row, slot and matrix place; per product z_i z_j its band place
    # and the two vectors
    unit: np.ndarray
    unit_slot: np.ndarray
    unit_mat: np.ndarray
    unit_pair_vec: np.ndarray
    unit_pair_row: np.ndarray
    unit_pair_slot: np.ndarray
    unit_pair_mat: np.ndarray
    unit_gram_target: np.ndarray
    unit_gram_i: np.ndarray
    unit_gram_j: np.ndarray
    kd: int                   # half bandwidth of S
    n_dropped_pairs: int      # the dropped rows' pairs, after the others in the pair tables

    @property
    def n_blocks(self) -> int:
        return len(self.block_start) - 1

    @property
    def n_pairs(self) -> int:
        """The pairs of the rows solved for (the dropped rows' pairs follow them)."""
        return len(self.pair_row) - self.n_dropped_pairs

    def arrays(self) -> dict[str, np.ndarray]:
        """The tables the C runtime reads (``row_pos`` is folded into the others)."""
        return {f.name: getattr(self, f.name) for f in fields(self)
                if f.name not in ("kd", "row_pos", "n_dropped_pairs")}


def schur_structure(pattern: SparsePattern, kept: np.ndarray | None = None) -> SchurStructure:
    """The tables for ``pattern``; :class:`NotApplicable` when a block or the band is
    too wide for dense block factors and a band Cholesky to pay off. Computed once per
    pattern and set of kept rows (the verdict included).

    Parameters
    ----------
    pattern
        The sparsity pattern of ``M`` and ``A``.
    kept
        The independent constraint rows when some are dependent (see
        :func:`~dalembert.numerics.rank.constraint_rank`), else ``None``. The other
        rows are *dropped*: left out of the blocks' eliminations and of the band, so
        the solve and the projections work on the kept rows alone. Their pairs are
        still tabled, after the kept ones, so that ``A`` is loaded whole and the
        dropped rows' residuals can be checked.
    """
    rows = None if kept is None else np.asarray(kept, dtype=np.int64)
    key = ("schur_structure", None if rows is None else rows.tobytes())
    found = pattern.remember(key, lambda: _structure_or_reason(pattern, rows))
    if isinstance(found, NotApplicable):
        raise found
    return found


def _structure_or_reason(pattern: SparsePattern,
                         kept: np.ndarray | None) -> SchurStructure | NotApplicable:
    try:
        return _structure(pattern, kept)
    except NotApplicable as reason:
        return reason


def _structure(pattern: SparsePattern, kept: np.ndarray | None) -> SchurStructure:
    block, sizes = _blocks(pattern)
    if sizes.max(initial=0) > BLOCK_MAX:
        raise NotApplicable(f"the mass matrix couples {sizes.max()} coordinates in one block "
                            f"(at most {BLOCK_MAX})")
    block_start = np.concatenate([[0], np.cumsum(sizes)])
    slot_coord = np.lexsort((np.arange(pattern.n), block))
    local = np.empty(pattern.n, dtype=np.int64)
    local[slot_coord] = np.arange(pattern.n) - block_start[block[slot_coord]]
    block_mat = np.concatenate([[0], np.cumsum(sizes**2)])
    rows, cols = pattern.M_rows, pattern.M_cols
    M_at = block_mat[block[rows]] + local[rows] * sizes[block[rows]] + local[cols]
    dropped = np.zeros(pattern.m, dtype=bool)
    if kept is not None:
        dropped[:] = True
        dropped[kept] = False
    pairs, internal, n_solved = _pairs(pattern, block, sizes, local, dropped)
    # the solve sees the kept rows' pairs only
    solved = {**pairs, "pair_row": pairs["pair_row"][:n_solved],
              "pair_block": pairs["pair_block"][:n_solved],
              "pair_vec": pairs["pair_vec"][:n_solved + 1]}
    row_pos, band_row, kd = _band_order(pattern.m, solved, ~internal, dropped)
    if kd > BAND_MAX:
        raise NotApplicable(f"the constraints couple too widely for a band solve "
                            f"(half bandwidth {kd}, at most {BAND_MAX})")
    gram = _gram(solved["pair_row"], pairs["block_external"], pairs["block_pairs"], row_pos, kd)
    unit = _unit_blocks(sizes, block_start, block_mat, solved, gram)
    return SchurStructure(block_start=block_start, slot_coord=slot_coord, block_mat=block_mat,
                          M_at=M_at, row_pos=row_pos, band_row=band_row, kd=kd, **pairs,
                          dropped_rows=np.flatnonzero(dropped).astype(np.int64),
                          n_dropped_pairs=len(pairs["pair_row"]) - n_solved, **gram, **unit)


def _blocks(pattern: SparsePattern) -> tuple[np.ndarray, np.ndarray]:
    """Block of each coordinate (numbered by smallest coordinate) and block sizes."""
    n = pattern.n
    graph = sps.coo_matrix((np.ones(len(pattern.M_rows)), (pattern.M_rows, pattern.M_cols)),
                           shape=(n, n))
    _, labels = connected_components(graph, directed=False)
    first = np.full(labels.max(initial=-1) + 1, n)
    np.minimum.at(first, labels, np.arange(n))
    renumber = np.empty_like(first)
    renumber[np.argsort(first)] = np.arange(len(first))
    block = renumber[labels].astype(np.int64)
    return block, np.bincount(block, minlength=len(first)).astype(np.int64)


def _pairs(pattern: SparsePattern, block: np.ndarray, sizes: np.ndarray, local: np.ndarray,
           dropped: np.ndarray) -> tuple[dict[str, np.ndarray], np.ndarray, int]:
    """The (row, block) pairs' tables, the mask of the internal pairs (a kept row inside
    one block) and the number of kept rows' pairs. The kept rows' pairs come first,
    block by block, a block's internal pairs first; the dropped rows' pairs follow
    (only ``pair_row``, ``pair_block``, ``pair_vec`` and ``A_at`` cover them)."""
    m = max(pattern.m, 1)
    entry_block = block[pattern.A_cols]
    keys = entry_block * m + pattern.A_rows
    unique, entry_pair = np.unique(keys, return_inverse=True)
    pair_block, pair_row = unique // m, unique % m
    out = dropped[pair_row]
    internal = ~out & (np.bincount(pair_row[~out], minlength=pattern.m)[pair_row] == 1)
    # block by block, the internal pairs first (the pivots eliminated first), by row
    order = np.lexsort((pair_row, ~internal, pair_block, out))
    place = np.empty_like(order)
    place[order] = np.arange(len(order))
    pair_block, pair_row, internal = pair_block[order], pair_row[order], internal[order]
    pair_vec = np.concatenate([[0], np.cumsum(sizes[pair_block])])
    n_solved = int(np.count_nonzero(~out))
    solved_block = pair_block[:n_solved]
    block_pairs = np.searchsorted(solved_block, np.arange(len(sizes) + 1))
    n_internal = np.bincount(solved_block, weights=internal[:n_solved],
                             minlength=len(sizes)).astype(int)
    # an internal pair's factors: 1 / z_i.z_i, then one alpha per later pair of its block
    later = block_pairs[solved_block + 1] - np.arange(n_solved) - 1
    elim_at = np.concatenate([[0], np.cumsum(np.where(internal[:n_solved], 1 + later, 0))])
    tables = {
        "pair_row": pair_row, "pair_block": pair_block, "pair_vec": pair_vec,
        "A_at": pair_vec[place[entry_pair.reshape(-1)]] + local[pattern.A_cols],
        "block_pairs": block_pairs, "block_external": block_pairs[:-1] + n_internal,
        "elim_at": elim_at, "elim_blocks": np.flatnonzero(n_internal),
    }
    tables = {name: np.asarray(table, dtype=np.int64) for name, table in tables.items()}
    return tables, internal[:n_solved], n_solved


def _unit_blocks(sizes: np.ndarray, block_start: np.ndarray, block_mat: np.ndarray,
                 pairs: dict[str, np.ndarray],
                 gram: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
    """The tables of the flat loops over the 1 x 1 blocks without internal rows: their
    pairs' vectors are single values, their products ``z_i . z_j`` single products."""
    pair_block, vec = pairs["pair_block"], pairs["pair_vec"]
    unit = (sizes == 1) & (pairs["block_external"] == pairs["block_pairs"][:-1])
    pair = np.flatnonzero(unit[pair_block])
    gram_block = np.repeat(np.arange(len(sizes)), np.diff(gram["gram_start"]))
    product = np.flatnonzero(unit[gram_block])
    # a block's k-th product is (i, j), j <= i, row by row: k = i (i + 1) / 2 + j
    k = product - gram["gram_start"][gram_block[product]]
    i = ((np.sqrt(8 * k + 1) - 1) // 2).astype(np.int64)
    first = pairs["block_external"][gram_block[product]]
    tables = {
        "unit": unit, "unit_slot": block_start[:-1][unit], "unit_mat": block_mat[:-1][unit],
        "unit_pair_vec": vec[pair], "unit_pair_row": pairs["pair_row"][pair],
        "unit_pair_slot": block_start[pair_block[pair]],
        "unit_pair_mat": block_mat[pair_block[pair]],
        "unit_gram_target": gram["gram_target"][product],
        "unit_gram_i": vec[first + i], "unit_gram_j": vec[first + k - i * (i + 1) // 2],
    }
    return {name: np.asarray(table, dtype=np.int64) for name, table in tables.items()}


def _band_order(m: int, pairs: dict[str, np.ndarray], external: np.ndarray,
                dropped: np.ndarray) -> tuple[np.ndarray, np.ndarray, int]:
    """The band's rows (all but the internal and the dropped ones; a row without pairs
    stays, and makes ``S`` singular, as it should) in a bandwidth-reducing order of
    ``S``'s pattern: each row's place (-1 for a row not in the band), the row at each
    place, the half bandwidth."""
    row_pos = np.full(m, -1, dtype=np.int64)
    in_band = np.ones(m, dtype=bool)
    in_band[pairs["pair_row"][~external]] = False
    in_band[dropped] = False
    kept = np.flatnonzero(in_band)
    if len(kept) == 0:
        return row_pos, kept.astype(np.int64), 0
    local = np.full(m, -1, dtype=np.int64)  # the place among the kept rows
    local[kept] = np.arange(len(kept))
    rows, blocks = local[pairs["pair_row"][external]], pairs["pair_block"][external]
    incidence = sps.csr_matrix((np.ones(len(rows)), (rows, blocks)),
                               shape=(len(kept), int(blocks.max(initial=0)) + 1))
    coupling = (incidence @ incidence.T).tocoo()
    order = band_order(coupling.row, coupling.col, len(kept))
    place = np.empty(len(kept), dtype=np.int64)
    place[order] = np.arange(len(kept))
    row_pos[kept] = place
    kd = int(np.abs(place[coupling.row] - place[coupling.col]).max(initial=0))
    return row_pos, kept[order].astype(np.int64), kd


def _gram(pair_row: np.ndarray, first: np.ndarray, block_pairs: np.ndarray,
          row_pos: np.ndarray, kd: int) -> dict[str, np.ndarray]:
    """Per block, the band place of each product ``z_i . z_j`` (``j <= i``) of its
    external pairs (``first[b]`` on), block after block, ``i`` then ``j`` (the order
    ``kkt.c`` walks them)."""
    counts = block_pairs[1:] - first
    sizes = counts * (counts + 1) // 2
    gram_start = np.concatenate([[0], np.cumsum(sizes)]).astype(np.int64)
    target = np.zeros(gram_start[-1], dtype=np.int64)
    for size in np.unique(counts[counts > 0]):
        blocks = np.flatnonzero(counts == size)
        i, j = np.tril_indices(size)
        pi = row_pos[pair_row[first[blocks][:, None] + i]]
        pj = row_pos[pair_row[first[blocks][:, None] + j]]
        hi, lo = np.maximum(pi, pj), np.minimum(pi, pj)
        target[gram_start[blocks][:, None] + np.arange(len(i))] = hi * (kd + 1) + (hi - lo)
    return {"gram_start": gram_start, "gram_target": target}


def model_struct(s: SchurStructure, pattern: SparsePattern,
                 address: dict[str, int]) -> library.Model:
    """A ``dl_model`` with ``s``'s sizes and tables (``address[name]``: where C reads
    each of :meth:`SchurStructure.arrays`); the caller fills in the rest (functions,
    holonomic rows, stabilization, the dropped rows' tolerance)."""
    model = library.Model(n=pattern.n, m=pattern.m, nM=len(pattern.M_rows),
                          nA=len(pattern.A_rows), n_blocks=s.n_blocks, n_pairs=s.n_pairs,
                          kd=s.kd, n_dropped_pairs=s.n_dropped_pairs,
                          n_dropped=len(s.dropped_rows), n_elim_blocks=len(s.elim_blocks),
                          m_band=len(s.band_row), n_unit=len(s.unit_slot),
                          n_unit_pairs=len(s.unit_pair_vec),
                          n_unit_gram=len(s.unit_gram_target))
    for name in s.arrays():
        setattr(model, name, address[name])
    return model


def work_sizes(s: SchurStructure, n: int, m: int) -> dict[str, int]:
    """The sizes of the factorization's work arrays in a ``dl_data`` (the KKT values'
    buffers, the projections' and the steps' apart); ``factor.*`` are
    ``dl_data.factor``'s."""
    units = len(s.unit_slot)
    return {"y": int(s.pair_vec[-1]), "S": len(s.band_row) * (s.kd + 1), "r": len(s.band_row),
            "elim": int(s.elim_at[-1]), "unit_mass": units, "unit_root": units,
            "factor.fold": s.n_pairs, "factor.rows": m}
