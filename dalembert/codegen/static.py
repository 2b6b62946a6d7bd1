"""Generated functions for statics, beside the functions of the equations of motion.

One function ``values(t, q, p)`` returns the nonzero entries of the derivatives
statics needs (:mod:`dalembert.equations.static`): ``[stiffness, curvature,
damping, rest]``, each in the order of a :class:`StaticPattern` fixed at generation.
It is generated like the others -- C when a compiler exists, cached on disk, and
part by part for a mechanism (:func:`~.assembly.compile_static_parts`) -- but only
when statics first asks for it, since dynamics never needs it.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import sympy as sp

from ..equations.lagrange import Equations
from ..equations.static import static_entries
from ..model.coordinates import t
from . import c_backend

Index = np.ndarray


@dataclass(frozen=True, eq=False)
class StaticPattern:
    """Where each value of the static function belongs (``intp`` index arrays).

    ``stiffness`` and ``damping`` are ``(rows, cols)`` of ``n x n`` matrices,
    ``curvature`` is ``(k, j, i)`` of ``d A_kj / d q_i`` and ``rest`` is ``(k, j)`` of
    ``d b_k / d q_j``; ``rest_rows`` are the Pfaffian rows with ``b`` not identically
    zero. The values come in this order: stiffness, curvature, damping, rest.
    """

    n: int
    m: int
    stiffness: tuple[Index, Index]
    curvature: tuple[Index, Index, Index]
    damping: tuple[Index, Index]
    rest: tuple[Index, Index]
    rest_rows: tuple[int, ...]

    def split(self, values: np.ndarray) -> tuple[np.ndarray, ...]:
        """``values`` cut into its four parts (views)."""
        ends = np.cumsum([len(self.stiffness[0]), len(self.curvature[0]),
                          len(self.damping[0]), len(self.rest[0])])
        return tuple(np.split(values, ends[:-1]))


@dataclass(frozen=True)
class StaticFunctions:
    """The static function of a model and the pattern of its values."""

    values: Callable[[float, np.ndarray, np.ndarray], np.ndarray]
    pattern: StaticPattern

    def evaluate(self, time: float, q: np.ndarray, p: np.ndarray) -> StaticValues:
        """The derivatives at ``(time, q)`` with parameter values ``p``."""
        return StaticValues(self.pattern, *self.pattern.split(self.values(time, q, p)))


@dataclass(frozen=True)
class StaticValues:
    """The derivatives at one ``(t, q)``, as dense matrices on request."""

    pattern: StaticPattern
    stiffness_values: np.ndarray
    curvature_values: np.ndarray
    damping_values: np.ndarray
    rest_values: np.ndarray

    def balance_jacobian(self, lam: np.ndarray) -> np.ndarray:
        """``d (f(q, 0, t) + A^T lambda) / dq``, dense ``n x n``."""
        n, (rows, cols), (k, j, i) = self.pattern.n, self.pattern.stiffness, \
            self.pattern.curvature
        flat = np.zeros(n * n)
        flat += np.bincount(rows * n + cols, weights=self.stiffness_values, minlength=n * n)
        flat += np.bincount(j * n + i, weights=np.asarray(lam)[k] * self.curvature_values,
                            minlength=n * n)
        return flat.reshape(n, n)

    def damping(self) -> np.ndarray:
        """``-d f / d qd`` at ``qd = 0``, dense ``n x n``."""
        rows, cols = self.pattern.damping
        C = np.zeros((self.pattern.n, self.pattern.n))
        np.add.at(C, (rows, cols), self.damping_values)
        return C

    def rest_jacobian(self) -> np.ndarray:
        """``d b / d q`` (the rows in ``rest_rows``; the others zero), dense ``m x n``."""
        rows, cols = self.pattern.rest
        J = np.zeros((self.pattern.m, self.pattern.n))
        np.add.at(J, (rows, cols), self.rest_values)
        return J


def compile_static(eqs: Equations, use: str) -> StaticFunctions:
    """The static function of ``eqs`` (the global route).

    Parameters
    ----------
    eqs
        The model's equations of motion.
    use
        ``"c"`` or ``"numpy"`` (C falls back to NumPy with a warning, as for the
        equations of motion).

    Examples
    --------
    >>> from dalembert.examples import cartesian_pendulum
    >>> fn = compile_static(cartesian_pendulum.build().equations(), "numpy")
    >>> lam = np.array([-4.905])  # -m g / (2 l) at the bottom; p = (g, l, m)
    >>> fn.evaluate(0.0, np.array([0.0, -1.0]), np.array([9.81, 1.0, 1.0])).balance_jacobian(lam)
    array([[-9.81,  0.  ],
           [ 0.  , -9.81]])
    """
    model = eqs.model
    entries = static_entries(eqs)
    groups = (entries.stiffness, entries.curvature, entries.damping, entries.rest)
    exprs: list[sp.Expr] = [e for group in groups for e in group.values()]
    arguments = [("t", [t]), ("q", model.coords.q), ("p", [*model.parameters, *model.inputs])]
    (values,) = c_backend.build_flat_functions([("static_values", arguments, exprs)], use=use)
    pattern = StaticPattern(
        model.coords.n, model.constraints.m, _index(entries.stiffness, 2),
        _index(entries.curvature, 3), _index(entries.damping, 2), _index(entries.rest, 2),
        entries.rest_rows)
    return StaticFunctions(values, pattern)


def _index(entries: dict, width: int) -> tuple:
    keys = np.array(list(entries), dtype=np.intp).reshape(-1, width)
    return tuple(keys[:, w].copy() for w in range(width))
