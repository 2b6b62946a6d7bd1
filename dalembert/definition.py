"""What a :class:`~dalembert.System` is made from: its names, its parameters, its code.

A System derives nothing itself: it holds a :class:`Definition` and runs what that
gives. :class:`SymbolicDefinition` is one made from a symbolic model (``System(...)``:
the equations derived, then compiled, as a whole); a Multibody gives another
(:class:`dalembert.multibody.system.MultibodyDefinition`: code compiled part by part,
the symbolic model made only when asked for). Everything a run, the statics or a
message needs of a model comes through these few members.
"""

from __future__ import annotations

from dataclasses import replace
from functools import cached_property
from typing import Protocol

import numpy as np
import sympy as sp

from .codegen import compiled as codegen
from .codegen.compiled import CompiledEquations
from .equations.lagrange import Equations, derive_equations
from .model.constraints import ClosedGaps, UnilateralRow, friction_inputs, with_gaps
from .model.coordinates import t as time_symbol
from .model.model import Model


class Definition(Protocol):
    """A System's model as its runs read it."""

    @property
    def name(self) -> str: ...

    @property
    def coordinate_names(self) -> tuple[str, ...]: ...

    @property
    def constraint_names(self) -> tuple[str, ...]: ...

    @property
    def parameters(self) -> tuple[sp.Symbol, ...]:
        """The parameter symbols, in the order of the generated code's array."""

    @property
    def inputs(self) -> tuple[sp.Symbol, ...]: ...

    @property
    def rheonomic(self) -> bool:
        """Whether a constraint depends on time explicitly (a driven motion)."""

    @property
    def conserves_energy(self) -> bool:
        """Whether ``T + V`` is constant along every motion."""

    @property
    def kinetic_energy(self) -> bool:
        """Whether ``M`` comes from a kinetic energy, which must not be negative (a
        Lagrangian's quadratic part may be indefinite)."""

    @property
    def model(self) -> Model:
        """The global symbolic model (made on first use where the code does not need it)."""

    def equations(self) -> Equations:
        """The symbolic constrained equations (derived once)."""

    def describe_constraint(self, i: int) -> str:
        """Constraint ``i`` for a message: its name and where it comes from."""

    def compile(self) -> CompiledEquations:
        """The generated numeric functions (called once per System)."""

    def check_values(self, p: np.ndarray) -> None:
        """Raise if the model cannot be simulated at the parameter values ``p`` (the
        array of :attr:`parameters`): a mass that comes out negative..."""

    @property
    def unilateral(self) -> tuple[UnilateralLaw, ...]:
        """The unilateral constraints (contacts), apart from the rows."""

    @property
    def quaternions(self) -> np.ndarray:
        """The places ``(k, 4)`` of the coordinates that are a unit quaternion's Euler
        parameters ``b0..b3`` (a rigid body's), which a time step turns rather than
        moves along a line; ``(0, 4)`` for none."""

    def with_gaps_closed(self, which: ClosedGaps) -> Definition:
        """The definition with the unilateral constraints ``which.closed`` as rows after
        the others, the sliding velocities of ``which.held`` as rows after them, the
        friction forces of ``which.sliding`` as inputs after the others, and no
        unilateral constraint left apart (:class:`~dalembert.model.constraints.ClosedGaps`)."""


class UnilateralLaw(Protocol):
    """What a run reads of a unilateral constraint: its name and its impact law."""

    @property
    def name(self) -> str: ...

    @property
    def restitution(self) -> float | sp.Symbol: ...

    @property
    def rest_speed(self) -> float: ...

    @property
    def friction(self) -> float: ...


class SymbolicDefinition:
    """The definition of a System given by its energies, forces and constraints.

    Parameters
    ----------
    model
        The validated symbolic model.
    kinetic_energy
        Whether ``M`` comes from a kinetic energy (``False`` for a Lagrangian).

    Examples
    --------
    >>> from dalembert.model.coordinates import coordinates
    >>> from dalembert.model.model import build_model
    >>> (x,) = coordinates("x")
    >>> spring = SymbolicDefinition(build_model([x], kinetic=x.diff()**2 / 2,
    ...                                         potential=x**2 / 2, name="spring"))
    >>> spring.coordinate_names, spring.conserves_energy, spring.rheonomic
    (('x',), True, False)
    """

    def __init__(self, model: Model, kinetic_energy: bool = True) -> None:
        self.model = model
        self.kinetic_energy = kinetic_energy

    @property
    def name(self) -> str:
        return self.model.name

    @property
    def coordinate_names(self) -> tuple[str, ...]:
        return self.model.coords.names

    @property
    def constraint_names(self) -> tuple[str, ...]:
        return self.model.constraints.names

    @property
    def parameters(self) -> tuple[sp.Symbol, ...]:
        return self.model.parameters

    @property
    def inputs(self) -> tuple[sp.Symbol, ...]:
        return self.model.inputs

    @property
    def rheonomic(self) -> bool:
        return any(time_symbol in sp.sympify(e).free_symbols
                   for e in self.model.constraints.exprs)

    @property
    def conserves_energy(self) -> bool:
        return self.model.conserves_energy

    def equations(self) -> Equations:
        return self._equations

    @cached_property  # not pickled (an ensemble's workers derive nothing they need not)
    def _equations(self) -> Equations:
        return derive_equations(self.model)

    def describe_constraint(self, i: int) -> str:
        return self.model.constraints.describe(i)

    def compile(self) -> CompiledEquations:
        # Looked up on the module so that tests (and profilers) can wrap it.
        return codegen.compile_equations(self._equations)

    def check_values(self, p: np.ndarray) -> None:
        """Nothing to check: any finite values make a model (a singular one is found by
        the run, where it shows)."""

    @property
    def unilateral(self) -> tuple[UnilateralRow, ...]:
        return self.model.constraints.unilateral

    @property
    def quaternions(self) -> np.ndarray:
        """None known: a model written by hand has no coordinates marked as Euler
        parameters, and each moves along a line in a time step."""
        return np.zeros((0, 4), dtype=int)

    def with_gaps_closed(self, which: ClosedGaps) -> SymbolicDefinition:
        model = self.model
        rows = model.constraints.unilateral
        forces = friction_inputs(rows, which.sliding)
        # each sliding velocity's friction force does work along it: Q += A_k^T F_k
        directions = [A_row for i in which.sliding for _, A_row, _ in rows[i].tangents]
        Q = model.Q
        for force, A_row in zip(forces, directions):
            Q = Q + force * sp.Matrix(A_row)
        return SymbolicDefinition(replace(
            model, constraints=with_gaps(model.constraints, which), Q=Q,
            inputs=model.inputs + forces), self.kinetic_energy)
