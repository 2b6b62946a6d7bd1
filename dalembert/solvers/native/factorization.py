"""The C runtime's KKT solve as a :class:`~dalembert.solvers.kkt.factorization.KKTFactorization`.

``dl_kkt_factor`` factors the KKT matrix with the C loop's own factorization (the one
its right-hand side uses, :mod:`dalembert.solvers.native`: block Cholesky of ``M`` with
the rows inside a block folded in, band ``LDL^T`` of the Schur complement
``A Mt^-1 A^T``) for the values on the pattern and a set of active rows;
``dl_kkt_solve`` solves it for many right-hand sides. The tables (a ``dl_model``,
:mod:`.structure`, all rows) are made once per pattern and shared; the factors (a
``dl_data``) belong to the object.

>>> import numpy as np
>>> from dalembert.codegen.compiled import SparsePattern
>>> pattern = SparsePattern(2, 1, np.array([0, 1]), np.array([0, 1]),
...                         np.array([0, 0]), np.array([0, 1]))
>>> kkt = SchurFactorization(pattern)
>>> kkt.factor(np.ones(4))
>>> kkt.solve(np.array([0.0, -2.0, 0.0]))
(array([ 1., -1.]), array([1.]))
"""

from __future__ import annotations

import ctypes

import numpy as np

from ...codegen.c_backend import CompileError
from ...codegen.compiled import SparsePattern
from ...errors import SingularSystemError
from ..kkt.factorization import SINGULAR_MESSAGE, Backend, KKTFactorization
from . import library
from .structure import NotApplicable, SchurStructure, model_struct, schur_structure, work_sizes

_MESSAGES = {
    library.SINGULAR_MASS: "a block of the mass matrix is singular even with the active "
                           "constraints inside it folded in: " + SINGULAR_MESSAGE,
    library.SINGULAR_CONSTRAINTS: SINGULAR_MESSAGE,
}


def schur_applies(pattern: SparsePattern) -> bool:
    """Whether :class:`SchurFactorization` serves ``pattern``: the runtime compiles and
    the blocks and band are narrow enough (:func:`.structure.schur_structure`).

    >>> import numpy as np
    >>> from dalembert.codegen.compiled import SparsePattern
    >>> pattern = SparsePattern(1, 0, np.zeros(1, int), np.zeros(1, int),
    ...                         np.zeros(0, int), np.zeros(0, int))
    >>> schur_applies(pattern)
    True
    """
    try:
        library.runtime()
        schur_structure(pattern)
    except (CompileError, NotApplicable):
        return False
    return True


class _SharedModel:
    """The ``dl_model`` of a pattern (its structure's tables as ``int64`` arrays C reads),
    made once per pattern and shared by every factorization over it: C only reads it."""

    def __init__(self, pattern: SparsePattern, structure: SchurStructure) -> None:
        self._arrays = {name: np.ascontiguousarray(a, dtype=np.int64)
                        for name, a in structure.arrays().items()}
        self.model = model_struct(structure, pattern,
                                  {name: a.ctypes.data for name, a in self._arrays.items()})


class SchurFactorization(KKTFactorization):
    """The C block/Schur factorization (module docstring).

    Raises :class:`~dalembert.solvers.native.structure.NotApplicable` (saying why) for
    a pattern it does not serve and :class:`~dalembert.codegen.c_backend.CompileError`
    without the runtime; :func:`schur_applies` asks first. The pattern's ``dl_model`` is
    shared; the factors (a ``dl_data``) are the object's own.

    Parameters
    ----------
    pattern
        The sparsity pattern of ``M`` and ``A``.
    """

    backend = Backend.SCHUR

    def __init__(self, pattern: SparsePattern) -> None:
        super().__init__(pattern)
        self.lib = library.runtime()
        s = self.structure = schur_structure(pattern)
        self._shared = pattern.remember("native kkt factorization model",
                                        lambda: _SharedModel(pattern, s))
        n, m = self.n, self.m
        sizes = {"blocks": int(s.block_mat[-1]), "a": int(s.pair_vec[-1]), "u": n,
                 **work_sizes(s, n, m)}
        # zeroed: the pair vectors' slots no value of A lands in stay zero (load_pairs)
        self._work = {name: np.zeros(max(size, 1)) for name, size in sizes.items()}
        self._mask = np.zeros(max(m, 1), dtype=np.uint8)
        data = library.Data(conditioning=np.inf)
        for name, array in self._work.items():
            owner, _, field = name.rpartition(".")
            setattr(data.factor if owner else data, field, array.ctypes.data)
        data.factor.mask = self._mask.ctypes.data
        self._data = data
        self._at = (ctypes.addressof(self._shared.model), ctypes.addressof(self._data))

    def _factor(self, values: np.ndarray, active: np.ndarray) -> None:
        values = np.ascontiguousarray(values, dtype=float)
        mask = np.ascontiguousarray(active, dtype=np.uint8)
        status = self.lib.dl_kkt_factor(*self._at, values.ctypes.data, mask.ctypes.data)
        if status != library.OK:
            raise SingularSystemError(_MESSAGES.get(status, f"native runtime error {status}"))

    def _stacked(self, rhs: np.ndarray) -> np.ndarray:
        size = self.n + self.m
        columns = np.ascontiguousarray(rhs.reshape(size, -1).T)  # one right-hand side a row
        out = np.empty_like(columns)
        status = self.lib.dl_kkt_solve(*self._at, columns.shape[0], columns.ctypes.data,
                                       size, out.ctypes.data)
        if status != library.OK:
            raise SingularSystemError(_MESSAGES.get(status, f"native runtime error {status}"))
        z = out.T if rhs.ndim == 2 else out[0]
        z[self.n:] *= -1.0  # [x; -lambda], as the other backends
        return z
