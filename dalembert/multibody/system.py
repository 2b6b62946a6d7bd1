"""``MultibodySystem``: the :class:`dalembert.System` of a Multibody, built part by part.

Its numeric functions come from :func:`~dalembert.multibody.parts.multibody_parts`
(each kind of body and joint derived and compiled once, evaluated for all of
them), so building it costs time in proportion to the number of different
pieces, not the size of the mechanism. The global symbolic model -- needed only
for :meth:`equations`, statics and the printing of a constraint in an error
message -- is made on first use and gives the same equations.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import TYPE_CHECKING, Any

import sympy as sp

from ..codegen.assembly import compile_parts
from ..codegen.compiled import CompiledEquations, NumericModel
from ..model.model import Model, build_model
from ..model.parameters import parameter_values, resolve_parameters
from ..options import RedundantConstraints
from ..system import System, _check_redundant
from .parts import multibody_parts

if TYPE_CHECKING:
    from .builder import Multibody


class MultibodySystem(System):
    """A :class:`~dalembert.System` whose model and code come from a Multibody.

    >>> from dalembert.multibody import chain
    >>> system = chain(3, 1.0, 1.0, 0.05).system
    >>> len(system.coordinate_names), len(system.constraint_names)
    (21, 12)
    """

    def __init__(self, multibody: Multibody,
                 redundant_constraints: RedundantConstraints = "minimum-norm") -> None:
        self._multibody = multibody
        self._model: Model | None = None
        self.redundant_constraints = _check_redundant(redundant_constraints)
        self.parameter_values = parameter_values(multibody.parameters, multibody.defaults)
        self._names = tuple(c.name for c in multibody.coordinates)
        self._rows = tuple(
            [name for b in multibody.bodies for name in b.constraint_names]
            + [name for j in multibody.joints for name in j.constraint_names]
        )

    @property
    def name(self) -> str:
        """The Multibody's name."""
        return self._multibody.name

    @property
    def coordinate_names(self) -> tuple[str, ...]:
        return self._names

    @property
    def constraint_names(self) -> tuple[str, ...]:
        return self._rows

    @property
    def parameters(self) -> tuple[sp.Symbol, ...]:
        """The symbols the mechanism's numbers and loads are written in."""
        return self._multibody.parameters

    @property
    def inputs(self) -> tuple[sp.Symbol, ...]:
        """The mechanism's input symbols (``Multibody(inputs=...)``)."""
        return self._multibody.inputs

    def numeric(self, parameters: Mapping[Any, object] | None = None) -> NumericModel:
        """The compiled functions bound to parameter values, after the mechanism has been
        checked with them (a mass must come out positive, an inertia valid...)."""
        p = resolve_parameters(self.parameters, self.parameter_values, parameters)
        if self.parameters:
            self._multibody._check_at(p)
        return self.compiled.bind(p)

    @property
    def rheonomic(self) -> bool:
        """Whether a joint prescribes a motion in time (a driver)."""
        return any(getattr(j, "rheonomic", False) for j in self._multibody.joints)

    @property
    def conserves_energy(self) -> bool:
        """Whether ``T + V`` is constant along every motion (read from the pieces, no
        symbolic model built): no force, torque, actuator or input, no damping in a
        spring, no driver."""
        return self._multibody.conserves_energy

    def describe_constraint(self, i: int) -> str:
        """Constraint ``i`` by name and the joint or body it belongs to (no symbolic
        model is built for a message: for a large mechanism that takes long).

        Parameters
        ----------
        i
            The row, in the order of :attr:`constraint_names`.

        Examples
        --------
        >>> from dalembert.multibody import chain
        >>> chain(2, 1.0, 1.0, 0.05).system.describe_constraint(5)
        "constraint 'joint2_1' (Spherical 'joint2')"
        """
        mb, name = self._multibody, self._rows[i]
        owners = [*((b, b.constraint_names) for b in mb.bodies),
                  *((j, j.constraint_names) for j in mb.joints)]
        owner = next(o for o, names in owners if name in names)
        return f"constraint {name!r} ({type(owner).__name__} {owner.name!r})"

    @property
    def model(self) -> Model:
        """The global symbolic model (built on first use; the numerics do not need it)."""
        if self._model is None:
            mb = self._multibody
            self._model = build_model(
                mb.coordinates, kinetic=mb.kinetic_energy(), potential=mb.potential_energy(),
                constraints=mb.constraints(), generalized_forces=mb.generalized_forces() or None,
                forces=mb.point_forces(), name=mb.name, inputs=mb.inputs,
            )
        return self._model

    @model.setter
    def model(self, value: Model) -> None:
        # settable, as System.model is (and as the functools.cached_property this was)
        self._model = value

    def _compile(self) -> CompiledEquations:
        """One kernel per kind of body, joint and the loads."""
        parts = multibody_parts(self._multibody)
        return compile_parts(parts, len(self._names), len(self._rows), self.parameters,
                             inputs=self.inputs)
