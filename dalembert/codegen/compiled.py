"""Numeric functions of a model, generated once and bound to parameter values.

:func:`compile_equations` turns the symbolic equations into four NumPy functions
(KKT blocks, velocity-level constraint, position-level constraint, energies).
They take the parameter values as an array, so a :class:`CompiledEquations` is
generated once per System and re-bound to new values at no cost.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import sympy as sp

from ..equations.lagrange import Equations
from ..equations.sparse import gradient
from ..model.coordinates import t
from .numpy_printer import generate_function


@dataclass(frozen=True)
class CompiledEquations:
    """Generated functions of ``(t, q, qd, p)``; see :class:`NumericModel`."""

    kkt_blocks: Callable
    velocity_constraint: Callable
    position_constraint: Callable
    energies: Callable
    n: int
    m: int
    holonomic_rows: tuple[int, ...]

    def bind(self, p: np.ndarray) -> NumericModel:
        return NumericModel(self, np.asarray(p, dtype=float))


@dataclass(frozen=True)
class NumericModel:
    """The compiled equations with numeric parameter values.

    - ``kkt_blocks(t, q, qd) -> (M, f, A, c)``
    - ``velocity_constraint(t, q) -> (A, b)`` with ``A qd + b = 0``
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
    def holonomic_rows(self) -> tuple[int, ...]:
        return self.compiled.holonomic_rows

    def kkt_blocks(self, t: float, q: np.ndarray, qd: np.ndarray):
        return self.compiled.kkt_blocks(t, q, qd, self.p)

    def velocity_constraint(self, t: float, q: np.ndarray):
        return self.compiled.velocity_constraint(t, q, self.p)

    def position_constraint(self, t: float, q: np.ndarray) -> np.ndarray:
        return self.compiled.position_constraint(t, q, self.p)[0]

    def energies(self, t: float, q: np.ndarray, qd: np.ndarray) -> np.ndarray:
        return self.compiled.energies(t, q, qd, self.p)[0]


def compile_equations(eqs: Equations) -> CompiledEquations:
    """Generate the numeric functions of ``eqs`` (common subexpressions shared)."""
    model = eqs.model
    coords = model.coords
    time = [("t", [t]), ("q", coords.q)]
    state = [*time, ("qd", coords.qd), ("p", model.parameters)]
    static = [*time, ("p", model.parameters)]
    cons = model.constraints
    vectors = ("f", "c", "b", "psi", "E")
    kkt = generate_function(
        "kkt_blocks", state, [("M", eqs.M), ("f", eqs.f), ("A", eqs.A), ("c", eqs.c)],
        vectors=vectors,
    )
    velocity = generate_function(
        "velocity_constraint", static, [("A", eqs.A), ("b", eqs.b)], vectors=vectors
    )
    position = generate_function("position_constraint", static, [("psi", cons.psi)],
                                 vectors=vectors)
    energies = generate_function("energies", state, [("E", _energy_vector(eqs))],
                                 vectors=vectors)
    return CompiledEquations(
        kkt, velocity, position, energies, coords.n, cons.m, cons.holonomic_rows
    )


def _energy_vector(eqs: Equations) -> sp.Matrix:
    """``[T, V, h]``; ``T`` and ``V`` are NaN when only a Lagrangian was given."""
    model = eqs.model
    L = model.lagrangian
    qd = model.coords.qd
    jacobi = sp.Add(*(qd[k] * p for k, p in gradient(L, qd).items())) - L
    T = model.kinetic if model.kinetic is not None else sp.nan
    V = model.potential if model.potential is not None else sp.nan
    return sp.Matrix([T, V, jacobi])
