"""Index tables of the native KKT solve, computed once from the sparsity pattern.

``M`` splits into diagonal blocks (the connected components of its pattern: one
per rigid body, one per particle coordinate). Each constraint row meets a few
blocks; the part of row ``r`` inside block ``b`` is a *pair*, stored as a dense
vector of the block's size. The Schur complement ``S = A Mt^-1 A^T`` couples two
rows when they meet a common block, so its pattern is known here: the rows are
put in a bandwidth-reducing order (reverse Cuthill-McKee) and each product
``z_i . z_j`` (``z = L^-1 a`` with the block's Cholesky factor ``L``) gets its
place in the band once. The 1 x 1 blocks without a row of their own (particles,
planar bodies) are common and cheap, so they get flat tables of their own: looping
over them block by block cost more in branching than in arithmetic.

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
from scipy.sparse.csgraph import connected_components, reverse_cuthill_mckee

from ...codegen.compiled import SparsePattern

#: Largest block of ``M`` factored dense (a rigid body has 7 coordinates).
BLOCK_MAX = 64
#: Largest half bandwidth of ``S`` (a chain of quaternion links needs 6-11).
BAND_MAX = 64


class NotApplicable(ValueError):
    """The pattern does not suit the native solve (the reason is the message)."""


@dataclass(frozen=True)
class SchurStructure:
    """Tables read by ``runtime.c`` (``dl_model``); all ``int64`` arrays."""

    block_start: np.ndarray   # n_blocks + 1: first slot of each block
    slot_coord: np.ndarray    # n: global coordinate of each slot
    block_mat: np.ndarray     # n_blocks + 1: offset of each block's nb x nb matrix
    M_at: np.ndarray          # nM: place of each M value in the block matrices
    pair_row: np.ndarray      # n_pairs: constraint row of each pair
    pair_block: np.ndarray    # n_pairs: block of each pair
    pair_vec: np.ndarray      # n_pairs + 1: offset of each pair's vector
    A_at: np.ndarray          # nA: place of each A value in the pair vectors
    block_pairs: np.ndarray   # n_blocks + 1: block b's pairs are bp[b]..bp[b+1]-1
    internal: np.ndarray      # n_pairs: 1 when the row meets no other block
    row_pos: np.ndarray       # m: place of each row in the band order
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

    @property
    def n_blocks(self) -> int:
        return len(self.block_start) - 1

    def arrays(self) -> dict[str, np.ndarray]:
        return {f.name: getattr(self, f.name) for f in fields(self) if f.name != "kd"}


def schur_structure(pattern: SparsePattern) -> SchurStructure:
    """The tables for ``pattern``; :class:`NotApplicable` when a block or the band is
    too wide for dense block factors and a band Cholesky to pay off. Computed once per
    pattern (the verdict included)."""
    found = pattern.remember("schur_structure", lambda: _structure_or_reason(pattern))
    if isinstance(found, NotApplicable):
        raise found
    return found


def _structure_or_reason(pattern: SparsePattern) -> SchurStructure | NotApplicable:
    try:
        return _structure(pattern)
    except NotApplicable as reason:
        return reason


def _structure(pattern: SparsePattern) -> SchurStructure:
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
    pairs = _pairs(pattern, block, sizes, local)
    row_pos, kd = _band_order(pattern.m, pairs["pair_row"], pairs["pair_block"])
    if kd > BAND_MAX:
        raise NotApplicable(f"the constraints couple too widely for a band solve "
                            f"(half bandwidth {kd}, at most {BAND_MAX})")
    gram = _gram(pairs["pair_row"], pairs["block_pairs"], row_pos, kd)
    unit = _unit_blocks(sizes, block_start, block_mat, pairs, gram)
    return SchurStructure(block_start=block_start, slot_coord=slot_coord, block_mat=block_mat,
                          M_at=M_at, row_pos=row_pos, kd=kd, **pairs, **gram, **unit)


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


def _pairs(pattern: SparsePattern, block: np.ndarray, sizes: np.ndarray,
           local: np.ndarray) -> dict[str, np.ndarray]:
    m = max(pattern.m, 1)
    entry_block = block[pattern.A_cols]
    keys = entry_block * m + pattern.A_rows
    unique, entry_pair = np.unique(keys, return_inverse=True)
    pair_block, pair_row = unique // m, unique % m
    pair_vec = np.concatenate([[0], np.cumsum(sizes[pair_block])])
    block_pairs = np.searchsorted(pair_block, np.arange(len(sizes) + 1))
    per_row = np.bincount(pair_row, minlength=pattern.m)
    return {
        "pair_row": pair_row.astype(np.int64), "pair_block": pair_block.astype(np.int64),
        "pair_vec": pair_vec.astype(np.int64),
        "A_at": (pair_vec[entry_pair.reshape(-1)] + local[pattern.A_cols]).astype(np.int64),
        "block_pairs": block_pairs.astype(np.int64),
        "internal": (per_row[pair_row] == 1).astype(np.int64),
    }


def _unit_blocks(sizes: np.ndarray, block_start: np.ndarray, block_mat: np.ndarray,
                 pairs: dict[str, np.ndarray],
                 gram: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
    """The tables of the flat loops over the 1 x 1 blocks without internal rows: their
    pairs' vectors are single values, their products ``z_i . z_j`` single products."""
    pair_block, vec = pairs["pair_block"], pairs["pair_vec"]
    internal = np.bincount(pair_block, weights=pairs["internal"], minlength=len(sizes)) > 0
    unit = (sizes == 1) & ~internal
    pair = np.flatnonzero(unit[pair_block])
    gram_block = np.repeat(np.arange(len(sizes)), np.diff(gram["gram_start"]))
    product = np.flatnonzero(unit[gram_block])
    # a block's k-th product is (i, j), j <= i, row by row: k = i (i + 1) / 2 + j
    k = product - gram["gram_start"][gram_block[product]]
    i = ((np.sqrt(8 * k + 1) - 1) // 2).astype(np.int64)
    first = pairs["block_pairs"][gram_block[product]]
    tables = {
        "unit": unit, "unit_slot": block_start[:-1][unit], "unit_mat": block_mat[:-1][unit],
        "unit_pair_vec": vec[pair], "unit_pair_row": pairs["pair_row"][pair],
        "unit_pair_slot": block_start[pair_block[pair]],
        "unit_pair_mat": block_mat[pair_block[pair]],
        "unit_gram_target": gram["gram_target"][product],
        "unit_gram_i": vec[first + i], "unit_gram_j": vec[first + k - i * (i + 1) // 2],
    }
    return {name: np.asarray(table, dtype=np.int64) for name, table in tables.items()}


def _band_order(m: int, pair_row: np.ndarray, pair_block: np.ndarray) -> tuple[np.ndarray, int]:
    """Rows in reverse Cuthill-McKee order of ``S``'s pattern, and its half bandwidth."""
    if m == 0:
        return np.zeros(0, dtype=np.int64), 0
    incidence = sps.csr_matrix((np.ones(len(pair_row)), (pair_row, pair_block)),
                               shape=(m, int(pair_block.max(initial=0)) + 1))
    coupling = (incidence @ incidence.T).tocsr()
    order = reverse_cuthill_mckee(coupling, symmetric_mode=True)
    row_pos = np.empty(m, dtype=np.int64)
    row_pos[order] = np.arange(m)
    coo = coupling.tocoo()
    kd = int(np.abs(row_pos[coo.row] - row_pos[coo.col]).max(initial=0))
    return row_pos, kd


def _gram(pair_row: np.ndarray, block_pairs: np.ndarray, row_pos: np.ndarray,
          kd: int) -> dict[str, np.ndarray]:
    """Per block, the band place of each product ``z_i . z_j`` (``j <= i``) of its pairs,
    block after block, ``i`` then ``j`` (the order ``runtime.c`` walks them)."""
    counts = np.diff(block_pairs)
    sizes = counts * (counts + 1) // 2
    gram_start = np.concatenate([[0], np.cumsum(sizes)]).astype(np.int64)
    target = np.zeros(gram_start[-1], dtype=np.int64)
    for size in np.unique(counts[counts > 0]):
        blocks = np.flatnonzero(counts == size)
        i, j = np.tril_indices(size)
        pi = row_pos[pair_row[block_pairs[blocks][:, None] + i]]
        pj = row_pos[pair_row[block_pairs[blocks][:, None] + j]]
        hi, lo = np.maximum(pi, pj), np.minimum(pi, pj)
        target[gram_start[blocks][:, None] + np.arange(len(i))] = hi * (kd + 1) + (hi - lo)
    return {"gram_start": gram_start, "gram_target": target}
