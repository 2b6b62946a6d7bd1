"""Numeric functions of a model, generated once and bound to parameter values.

:func:`compile_equations` turns the symbolic equations into four flat functions
(KKT blocks, velocity-level constraint, position-level constraint, energies),
compiled C when a compiler exists, else NumPy (:mod:`.c_backend` says why, with
numbers). ``M`` and ``A`` come out as the values of a fixed sparsity pattern
(:class:`SparsePattern`, computed once), so an evaluation costs time in
proportion to the nonzeros; dense views are built on request. The functions take
the parameter values as an array, so a :class:`CompiledEquations` is generated
once per System and re-bound to new values at no cost.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import TypeVar

import numpy as np
import sympy as sp

from ..equations.lagrange import Equations
from ..equations.sparse import gradient, nonzero_entries
from ..model.coordinates import t
from . import c_backend

T = TypeVar("T")


@dataclass(frozen=True, eq=False)
class SparsePattern:
    """Fixed sparsity of ``M`` (``n x n``) and ``A`` (``m x n``): row and column of each value.

    The generated functions return only these entries, in this order; the pattern
    is computed once from the symbolic matrices (an entry that is zero symbolically
    is zero at every state). Compared by identity; ``derived`` is where the solvers
    keep what they compute from the pattern alone (index maps, orders), so that a
    model simulated many times computes it once.
    """

    n: int
    m: int
    M_rows: np.ndarray
    M_cols: np.ndarray
    A_rows: np.ndarray
    A_cols: np.ndarray
    derived: dict = field(default_factory=dict, init=False, repr=False)

    def remember(self, key: object, make: Callable[[], T]) -> T:
        """``derived[key]``, made by ``make()`` the first time.

        >>> p = SparsePattern(1, 0, np.zeros(1, int), np.zeros(1, int), np.zeros(0, int),
        ...                   np.zeros(0, int))
        >>> p.remember("size", lambda: 1) + p.remember("size", lambda: 2)
        2
        """
        if key not in self.derived:
            self.derived[key] = make()
        return self.derived[key]

    def dense_M(self, values: np.ndarray) -> np.ndarray:
        M = np.zeros((self.n, self.n))
        M[self.M_rows, self.M_cols] = values
        return M

    def dense_A(self, values: np.ndarray) -> np.ndarray:
        A = np.zeros((self.m, self.n))
        A[self.A_rows, self.A_cols] = values
        return A


@dataclass(frozen=True)
class CompiledEquations:
    """Generated functions of ``(t, q, qd, p)``; see :class:`NumericModel`.

    ``kkt_values(t, q, qd, p)`` returns ``[M values, f, A values, c]`` and
    ``velocity_values(t, q, p)`` ``[A values, b]`` (values in ``pattern`` order);
    ``backend`` is ``"c"`` or ``"numpy"`` (see :mod:`dalembert.codegen.c_backend`).
    """

    kkt_values: Callable
    velocity_values: Callable
    position_values: Callable
    energy_values: Callable
    pattern: SparsePattern
    holonomic_rows: tuple[int, ...]
    backend: str = "numpy"

    @property
    def n(self) -> int:
        return self.pattern.n

    @property
    def m(self) -> int:
        return self.pattern.m

    def kkt_blocks(self, t: float, q: np.ndarray, qd: np.ndarray, p: np.ndarray):
        """Dense ``(M, f, A, c)``."""
        Mv, f, Av, c = self.split_kkt(self.kkt_values(t, q, qd, p))
        return self.pattern.dense_M(Mv), f, self.pattern.dense_A(Av), c

    def split_kkt(self, values: np.ndarray) -> tuple[np.ndarray, ...]:
        """``[M values, f, A values, c]`` cut into its four parts (views)."""
        k1 = len(self.pattern.M_rows)
        k2 = k1 + self.n
        k3 = k2 + len(self.pattern.A_rows)
        return values[:k1], values[k1:k2], values[k2:k3], values[k3:]

    def velocity_constraint(self, t: float, q: np.ndarray, p: np.ndarray):
        """Dense ``(A, b)``."""
        k = len(self.pattern.A_rows)
        values = self.velocity_values(t, q, p)
        return self.pattern.dense_A(values[:k]), values[k:]

    def bind(self, p: np.ndarray) -> NumericModel:
        return NumericModel(self, np.asarray(p, dtype=float))


@dataclass(frozen=True)
class NumericModel:
    """The compiled equations with numeric parameter values.

    - ``kkt_blocks(t, q, qd) -> (M, f, A, c)`` (dense arrays)
    - ``kkt_sparse(t, q, qd) -> (M values, f, A values, c)`` in ``pattern`` order
    - ``velocity_constraint(t, q) -> (A, b)`` with ``A qd + b = 0`` (dense ``A``)
    - ``velocity_sparse(t, q) -> (A values, b)``
    - ``position_constraint(t, q) -> psi`` (holonomic rows only)
    - ``energies(t, q, qd) -> [T, V, h]`` with ``h = qd . dL/dqd - L`` (Jacobi)
    """

    compiled: CompiledEquations
    p: np.ndarray

    @property
    def n(self) -> int:
        return self.compiled.n

    @property
    def m(self) -> int:
        return self.compiled.m

    @property
    def pattern(self) -> SparsePattern:
        return self.compiled.pattern

    @property
    def holonomic_rows(self) -> tuple[int, ...]:
        return self.compiled.holonomic_rows

    def kkt_blocks(self, t: float, q: np.ndarray, qd: np.ndarray):
        return self.compiled.kkt_blocks(t, q, qd, self.p)

    def kkt_sparse(self, t: float, q: np.ndarray, qd: np.ndarray):
        return self.compiled.split_kkt(self.compiled.kkt_values(t, q, qd, self.p))

    def velocity_constraint(self, t: float, q: np.ndarray):
        return self.compiled.velocity_constraint(t, q, self.p)

    def velocity_sparse(self, t: float, q: np.ndarray):
        k = len(self.pattern.A_rows)
        values = self.compiled.velocity_values(t, q, self.p)
        return values[:k], values[k:]

    def position_constraint(self, t: float, q: np.ndarray) -> np.ndarray:
        return self.compiled.position_values(t, q, self.p)

    def energies(self, t: float, q: np.ndarray, qd: np.ndarray) -> np.ndarray:
        return self.compiled.energy_values(t, q, qd, self.p)


def compile_equations(eqs: Equations, backend: str | None = None) -> CompiledEquations:
    """Generate the numeric functions of ``eqs`` (C when a compiler exists, else NumPy).

    ``backend`` (``"c"`` or ``"numpy"``) overrides :func:`~.c_backend.backend`.
    """
    model = eqs.model
    coords = model.coords
    time = [("t", [t]), ("q", coords.q)]
    state = [*time, ("qd", coords.qd), ("p", model.parameters)]
    static = [*time, ("p", model.parameters)]
    cons = model.constraints
    M_entries, A_entries = nonzero_entries(eqs.M), nonzero_entries(eqs.A)
    pattern = SparsePattern(coords.n, cons.m, *_indices(M_entries), *_indices(A_entries))
    M_vals, A_vals = list(M_entries.values()), list(A_entries.values())
    specs = [
        ("kkt_values", state, [*M_vals, *eqs.f, *A_vals, *eqs.c]),
        ("velocity_values", static, [*A_vals, *eqs.b]),
        ("position_values", static, list(cons.psi)),
        ("energy_values", state, list(_energy_vector(eqs))),
    ]
    use = c_backend.backend() if backend is None else backend
    functions = c_backend.build_flat_functions(specs, use=use)
    used = "c" if hasattr(functions[0], "library") else "numpy"
    kkt, velocity, position, energy = functions
    return CompiledEquations(kkt, velocity, position, energy, pattern, cons.holonomic_rows,
                             used)


def _indices(entries: dict) -> tuple[np.ndarray, np.ndarray]:
    ij = np.array(list(entries), dtype=np.intp).reshape(-1, 2)
    return ij[:, 0].copy(), ij[:, 1].copy()


def _energy_vector(eqs: Equations) -> sp.Matrix:
    """``[T, V, h]``; ``T`` and ``V`` are NaN when only a Lagrangian was given."""
    model = eqs.model
    L = model.lagrangian
    qd = model.coords.qd
    jacobi = sp.Add(*(qd[k] * p for k, p in gradient(L, qd).items())) - L
    T = model.kinetic if model.kinetic is not None else sp.nan
    V = model.potential if model.potential is not None else sp.nan
    return sp.Matrix([T, V, jacobi])
