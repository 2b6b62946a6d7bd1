"""The :class:`~dalembert.definition.Definition` of a Multibody: the System it builds holds it.

Its numeric functions come from :func:`~dalembert.multibody.parts.multibody_parts`
(each kind of body and joint derived and compiled once, evaluated for all of
them), so building it costs time in proportion to the number of different
pieces, not the size of the mechanism. The global symbolic model -- needed only
for :meth:`~dalembert.System.equations`, statics and reports -- is made on first
use and gives the same equations.
"""

from __future__ import annotations

from functools import cached_property
from typing import TYPE_CHECKING

import numpy as np
import sympy as sp

from ..codegen.assembly import compile_parts
from ..codegen.compiled import CompiledEquations
from ..equations.lagrange import Equations, derive_equations
from ..model.constraints import ClosedGaps
from ..model.model import Model, build_model
from .bodies import RigidBody
from .parts import multibody_parts

if TYPE_CHECKING:
    from .builder import Multibody
    from .contacts import Contact


class MultibodyDefinition:
    """A Multibody as a :class:`~dalembert.System` reads it: names and checks from its
    pieces, code compiled part by part.

    Parameters
    ----------
    multibody
        The mechanism (:attr:`multibody`).

    Examples
    --------
    >>> from dalembert.multibody import chain
    >>> definition = chain(3, 1.0, 1.0, 0.05).system.definition
    >>> len(definition.coordinate_names), len(definition.constraint_names)
    (21, 12)
    """

    #: ``M`` comes from the bodies' kinetic energies.
    kinetic_energy = True

    def __init__(self, multibody: Multibody) -> None:
        self.multibody = multibody
        self._model: Model | None = None
        self.coordinate_names = tuple(c.name for c in multibody.coordinates)
        self.constraint_names = tuple(
            [name for b in multibody.bodies for name in b.constraint_names]
            + [name for j in multibody.joints for name in j.constraint_names]
        )

    @property
    def name(self) -> str:
        """The Multibody's name."""
        return self.multibody.name

    @property
    def parameters(self) -> tuple[sp.Symbol, ...]:
        """The symbols the mechanism's numbers and loads are written in."""
        return self.multibody.parameters

    @property
    def inputs(self) -> tuple[sp.Symbol, ...]:
        """The mechanism's input symbols (``Multibody(inputs=...)``)."""
        return self.multibody.inputs

    @property
    def rheonomic(self) -> bool:
        """Whether a joint prescribes a motion in time (a driver)."""
        return any(getattr(j, "rheonomic", False) for j in self.multibody.joints)

    @property
    def conserves_energy(self) -> bool:
        """Whether ``T + V`` is constant along every motion (read from the pieces, no
        symbolic model built): no force, torque, actuator or input, no damping in a
        spring, no driver."""
        return self.multibody.conserves_energy

    @property
    def unilateral(self) -> tuple[Contact, ...]:
        """The Multibody's contacts (its unilateral constraints)."""
        return self.multibody.contacts

    @property
    def quaternions(self) -> np.ndarray:
        """The places of each rigid body's Euler parameters ``b0..b3``, ``(k, 4)``.

        Examples
        --------
        >>> from dalembert.multibody import Multibody, Particle, RigidBody
        >>> mb = Multibody([Particle("p", 1.0), RigidBody("box", 1.0, (1, 1, 1))])
        >>> mb.system.definition.quaternions.tolist()
        [[6, 7, 8, 9]]
        """
        place = {name: i for i, name in enumerate(self.coordinate_names)}
        blocks = [[place[c.name] for c in body.coordinates[3:]]
                  for body in self.multibody.bodies if isinstance(body, RigidBody)]
        return np.array(blocks, dtype=int).reshape(-1, 4)

    def with_gaps_closed(self, which: ClosedGaps) -> MultibodyDefinition:
        """The definition of the Multibody with the contacts ``which.closed`` as joints
        (and the sliding velocities of ``which.held`` as joints after them)."""
        return MultibodyDefinition(self.multibody.with_contacts_closed(
            which.closed, which.held, which.sliding))

    @property
    def model(self) -> Model:
        """The global symbolic model (built on first use; the numerics do not need it)."""
        if self._model is None:
            mb = self.multibody
            self._model = build_model(
                mb.coordinates, kinetic=mb.kinetic_energy(), potential=mb.potential_energy(),
                constraints=mb.constraints(), generalized_forces=mb.generalized_forces() or None,
                forces=mb.point_forces(), name=mb.name, inputs=mb.inputs,
            )
        return self._model

    def equations(self) -> Equations:
        """The symbolic equations of the global model (derived on first use)."""
        return self._equations

    @cached_property  # not pickled (an ensemble's workers derive nothing they need not)
    def _equations(self) -> Equations:
        return derive_equations(self.model)

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
        mb, name = self.multibody, self.constraint_names[i]
        owners = [*((b, b.constraint_names) for b in mb.bodies),
                  *((j, j.constraint_names) for j in mb.joints)]
        owner = next(o for o, names in owners if name in names)
        return f"constraint {name!r} ({type(owner).__name__} {owner.name!r})"

    def compile(self) -> CompiledEquations:
        """One kernel per kind of body, joint and the loads."""
        parts = multibody_parts(self.multibody)
        return compile_parts(parts, len(self.coordinate_names), len(self.constraint_names),
                             self.parameters, inputs=self.inputs)

    def check_values(self, p: np.ndarray) -> None:
        """Check the mechanism with the parameter values ``p`` (a mass must come out
        positive, an inertia valid...)."""
        if self.parameters:
            self.multibody._check_at(p)
