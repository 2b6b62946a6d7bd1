"""A System as statics sees it: its one numeric model, bound to parameter values.

Statics evaluates the same generated functions as dynamics (``M``, ``f``, ``A``,
``b``, ``psi``), plus the static function generated beside them on first use
(:mod:`dalembert.codegen.static`): C or NumPy, cached on disk, and part by part
for a mechanism, so the statics of a long chain never builds its global symbolic
equations.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np
from numpy.typing import NDArray

from ..codegen.compiled import NumericModel
from ..model.parameters import ParameterSet

Array = NDArray[np.float64]


class StaticsModel(Protocol):
    """What statics reads of a model: a :class:`~dalembert.System` (a multibody one
    included) is one. Statics sits below the System in the layers (docs/design.md):
    the System's ``equilibrium`` and ``linearize`` are thin aliases of its functions."""

    @property
    def coordinate_names(self) -> tuple[str, ...]: ...

    @property
    def constraint_names(self) -> tuple[str, ...]: ...

    @property
    def parameters(self) -> tuple: ...

    def describe_constraint(self, i: int) -> str: ...

    def numeric(self, parameters: Mapping[Any, object] | None = None) -> NumericModel: ...


@dataclass(frozen=True)
class StaticSystem:
    """The numeric model of a System with the names statics reports.

    - ``constraints(t, q) -> (psi, A, b, Jb)``: ``psi`` the holonomic rows, ``A`` and
      ``b`` all rows (``A qd + b = 0``), ``Jb = db/dq`` on the :attr:`rest_rows`
    - ``forces(t, q, lam) -> (f0, G)``: ``f0 = f(q, 0, t)`` and
      ``G = d(f0 + A^T lam)/dq`` (the stiffness is ``K = -G``)
    - ``inertia(t, q) -> (M, C)``: ``M`` and ``C = -df/dqd`` at ``qd = 0``
    """

    num: NumericModel
    coordinate_names: tuple[str, ...]
    constraint_names: tuple[str, ...]
    constraint_labels: tuple[str, ...]
    parameter_values: dict[str, float]

    @property
    def n(self) -> int:
        return self.num.n

    @property
    def m(self) -> int:
        return self.num.m

    @property
    def holonomic_rows(self) -> tuple[int, ...]:
        return self.num.holonomic_rows

    @property
    def pfaffian_rows(self) -> tuple[int, ...]:
        holonomic = set(self.num.holonomic_rows)
        return tuple(i for i in range(self.m) if i not in holonomic)

    @property
    def rest_rows(self) -> tuple[int, ...]:
        """Pfaffian rows whose ``b`` is not identically zero: rest needs ``b_k(q, t) = 0``."""
        if not self.pfaffian_rows:
            return ()
        return self.num.compiled.static.pattern.rest_rows

    def constraints(self, t: float, q: Array) -> tuple[Array, Array, Array, Array]:
        psi = self.num.position_constraint(t, q)
        A, b = self.num.velocity_constraint(t, q)
        Jb = (self.num.static_derivatives(t, q).rest_jacobian() if self.rest_rows
              else np.zeros((self.m, self.n)))
        return psi, A, b, Jb

    def forces(self, t: float, q: Array, lam: Array) -> tuple[Array, Array]:
        G = self.num.static_derivatives(t, q).balance_jacobian(lam)
        return self.num.forces_at_rest(t, q), G

    def inertia(self, t: float, q: Array) -> tuple[Array, Array]:
        M = self.num.kkt_blocks(t, q, np.zeros(self.n))[0]
        return M, self.num.static_derivatives(t, q).damping()


def static_system(system: StaticsModel, *parameters: Mapping[Any, object] | None) -> StaticSystem:
    """``system`` bound to its parameter values, later ``parameters`` overriding earlier.

    Parameters
    ----------
    system
        A :class:`~dalembert.System` (a multibody one included).
    parameters
        Parameter values overriding the System's, by name or symbol.

    Examples
    --------
    >>> from dalembert.examples import cartesian_pendulum
    >>> s = static_system(cartesian_pendulum.build(), {"l": 2.0})
    >>> s.parameter_values["l"], s.constraint_labels
    (2.0, ("constraint 'rod' (holonomic: -l**2 + x**2 + y**2 = 0)",))
    """
    given = [v for v in parameters if v]
    overrides = ParameterSet(strict=all(getattr(v, "strict", True) for v in given))
    for value_set in given:
        overrides.update(value_set)
    num = system.numeric(overrides)
    return StaticSystem(
        num, tuple(system.coordinate_names), tuple(system.constraint_names),
        tuple(system.describe_constraint(i) for i in range(num.m)),
        {s.name: float(v) for s, v in zip(system.parameters, num.p)})
