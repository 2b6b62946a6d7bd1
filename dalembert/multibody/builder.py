"""``Multibody``: bodies + joints + loads -> a :class:`dalembert.System`.

The system is in redundant (absolute) coordinates: every particle carries its
position and every rigid body its full pose (7 coordinates), so the kinetic
energy is block-diagonal and each joint's equations involve only its two bodies.
"""

from __future__ import annotations

import copy
from collections.abc import Iterable, Mapping, Sequence
from functools import cached_property
from typing import TYPE_CHECKING, Any, Literal, TypeVar

import numpy as np
import sympy as sp

from ..codegen.numpy_printer import expression_values
from ..errors import ConstraintError, InitialConditionError, ModelError
from ..model.constraints import Holonomic, Pfaffian, friction_inputs
from ..model.coordinates import t
from ..model.forces import PointForce
from ..model.parameters import resolve_parameters
from ..model.values import CoordinateValues
from ..system import System
from ..trajectory import Trajectory
from .bodies import Body, Ground, MovingBody, PlanarBody, RigidBody, check_bodies, check_inertias
from .contacts import Contact, SlidingFriction
from .diagnostics import check_initial_joint_points, check_joint_points, check_mobility
from .drawing import stick_figure
from .drivers import Actuator, Driver, JointSpring
from .initial_state import bodies_state
from .joints import Joint, Revolute, Spherical
from .loads import Force, SpringDamper, Torque
from .parametric import (
    Scalar,
    array,
    evaluated_expressions,
    is_symbolic,
    parametric_expressions,
    parametric_symbols,
    scalar,
    with_numbers,
)
from .parts import gravity_potential
from .system import MultibodyDefinition
from .types import ByBody, FloatArray, Frame, Numbers, Orientation, Vector

if TYPE_CHECKING:
    from .importing.model import ImportedModel

_V = TypeVar("_V")


#: How many recently bound sets of values a mechanism keeps, with what they gave.
BOUND_KEPT = 4


class Multibody:
    """A multibody system in redundant coordinates.

    Parameters
    ----------
    bodies
        The moving bodies (:class:`Particle`, :class:`RigidBody`, :class:`PlanarBody`).
        ``Ground`` is implicit; any ``Ground`` instance may appear in joints and springs.
    joints
        :mod:`dalembert.multibody.joints` objects between listed bodies or ground.
    gravity
        Uniform field (world components), as the potential ``-sum m g . x``.
    forces, torques, springs
        :class:`Force`, :class:`Torque`, :class:`SpringDamper` loads.
    joint_springs
        :class:`~dalembert.multibody.drivers.JointSpring` loads: springs and dampers
        on revolute angles and prismatic travels (drivers, which prescribe those, are
        joints: :class:`~dalembert.multibody.drivers.Driver`).
    actuators
        :class:`~dalembert.multibody.drivers.Actuator` loads: a torque about a
        revolute joint's axis, a force along a prismatic joint's.
    inputs
        Input symbols (``sympy.Symbol``) that forces, torques and actuators may hold;
        their values come with ``simulate(inputs=...)`` (see :mod:`dalembert.inputs`).
    contacts
        :mod:`dalembert.multibody.contacts` between listed bodies or ground (a sphere on
        a floor, two spheres, a disk's rim, a joint's stop; with Coulomb friction in
        the time-stepping mode): unilateral constraints, closed and opened by the run
        (:mod:`dalembert.solvers.contact`).
    name
        The system's name (in titles and messages).
    parameters
        Default values of the parameter symbols the mechanism's numbers are written
        in (a mass ``m``, a length ``l``, gravity ``g``: see
        :mod:`dalembert.multibody.parametric`), by symbol or name;
        ``simulate(parameters=...)`` changes them without generating any code.

    Examples
    --------
    A particle on a massless rod hung from the origin (a spherical pendulum):

    >>> from dalembert.multibody import Distance, Ground, Multibody, Particle
    >>> bob = Particle("bob", 1.0)
    >>> mb = Multibody([bob], [Distance("rod", Ground(), bob, length=1.0)])
    >>> mb.system.degrees_of_freedom
    2
    """

    def __init__(
        self,
        bodies: Sequence[MovingBody],
        joints: Sequence[Joint] = (),
        gravity: Vector = (0.0, 0.0, -9.81),
        forces: Sequence[Force] = (),
        torques: Sequence[Torque] = (),
        springs: Sequence[SpringDamper] = (),
        name: str = "multibody",
        parameters: Mapping[Any, object] | None = None,
        joint_springs: Sequence[JointSpring] = (),
        actuators: Sequence[Actuator] = (),
        inputs: Sequence[sp.Symbol] = (),
        contacts: Sequence[Contact] = (),
    ) -> None:
        self.bodies = _pieces(bodies, "bodies", "Particle, RigidBody or PlanarBody objects")
        self.joints = _pieces(joints, "joints", "Joint objects")
        self.forces = tuple(forces)
        self.torques = tuple(torques)
        self.springs = tuple(springs)
        self.joint_springs = tuple(joint_springs)
        self.actuators = tuple(actuators)
        self.inputs = tuple(inputs)
        self.contacts = _pieces(contacts, "contacts", "Contact objects "
                                "(dalembert.multibody.plane_contact, sphere_contact)")
        #: A closed set's sliding contacts' friction (:meth:`with_contacts_closed`).
        self.sliding_friction: tuple[SlidingFriction, ...] = ()
        self.name = name
        self.gravity = array(gravity, (3,), "gravity (world components)")
        self.defaults = dict(parameters or {})
        #: The last values bound and the mechanisms they gave, most recent last (binding
        #: checks every piece; a run binds the defaults for its initial state and its
        #: own values for the simulation, so one slot would be refilled every run)
        self._bound: dict[tuple[float, ...], Multibody] = {}
        self._check()

    PARAMETRIC = ("gravity",)
    #: What :func:`~dalembert.multibody.from_mjcf` or ``from_urdf`` read (shapes to draw,
    #: MuJoCo's bodies and model), for an imported mechanism; ``None`` otherwise.
    imported: ImportedModel | None = None

    # -- parameters ------------------------------------------------------------------
    def _with_defaults(self) -> Multibody | None:
        """The mechanism bound to its default values, or ``None`` if some are missing."""
        if not self.parameters:
            return self
        if any(s not in self.defaults and s.name not in self.defaults
               for s in self.parameters):
            return None
        return self.bound()

    @cached_property
    def parameters(self) -> tuple[sp.Symbol, ...]:
        """The parameter symbols of the mechanism's numbers and loads, sorted by name."""
        found = parametric_symbols(self)
        for piece in (*self.bodies, *self.springs, *self.forces, *self.joint_springs):
            found |= parametric_symbols(piece)
        for joint in self.joints:
            found |= joint.parameter_symbols()
        found |= {c.restitution for c in self.contacts if isinstance(c.restitution, sp.Symbol)}
        loads = [*(c for f in self.forces for c in f.force),
                 *(c for tq in self.torques for c in tq.torque),
                 *(a.value for a in self.actuators)]
        for expr in loads:
            found |= {s for s in sp.sympify(expr).free_symbols
                      if isinstance(s, sp.Symbol) and s != t}
        return tuple(sorted(found - set(self.inputs), key=lambda s: s.name))

    @cached_property
    def _parametric_expressions(self) -> tuple[sp.Expr, ...]:
        """Every expression of every piece in the parameters, once (pieces share some)."""
        return parametric_expressions(
            [self, *self.bodies, *self.joints, *self.joint_springs, *self.springs,
             *self.forces, *self.torques], self.parameters)

    def bound(self, *values: Mapping[Any, object] | None) -> Multibody:
        """The mechanism with its parameters replaced by numbers (each piece checked
        as if it had been given them: a positive mass, a valid inertia...).

        Parameters
        ----------
        values
            Parameter values by symbol or name, over :attr:`defaults` (later ones
            overriding earlier ones).

        Raises
        ------
        ModelError
            A value makes a piece invalid (naming it), or a parameter has no value.

        Examples
        --------
        >>> from dalembert.multibody import Particle
        >>> m = sp.Symbol("m")
        >>> mb = Multibody([Particle("p", 2 * m)], parameters={m: 1.5})
        >>> mb.bound().bodies[0].mass, mb.bound({"m": 4}).bodies[0].mass
        (3.0, 8.0)
        """
        if not self.parameters:
            resolve_parameters((), {}, *values)  # a name it does not have is said, not dropped
            return self
        return self._bound_at(resolve_parameters(self.parameters, self.defaults, *values))

    def _check_at(self, p: Sequence[float] | np.ndarray) -> None:
        """Check the mechanism at the parameter values ``p`` (resolved already: a System's
        parameter vector) as :meth:`bound` does, raising its error. Where only rigid
        bodies' masses and inertias depend on the parameters (the usual case), these are
        computed in one call and checked together, without binding every piece; a value
        at fault, or parameters in other pieces, go through :meth:`bound`'s checks."""
        checked = self._body_values
        if checked is None:
            self._bound_at(p)
            return
        names, exprs = checked
        values = expression_values(self.parameters, exprs, np.asarray(p, dtype=float))
        k = len(names)
        if (values[:k] > 0).all():
            try:
                check_inertias(values[k:].reshape(k, 3, 3), names)
                return
            except ModelError:
                pass
        self._bound_at(p)  # a value at fault: its error names the first piece, in order

    @cached_property
    def _body_values(self) -> tuple[list[str], tuple[sp.Expr, ...]] | None:
        """The rigid bodies whose mass or inertia depends on the parameters (by name) and
        these values as one list (the masses, then each inertia's nine entries); ``None``
        when a piece of another kind depends on them (its own checks then run)."""
        def parametric(piece: object) -> bool:
            return any(is_symbolic(getattr(piece, name))
                       for name in getattr(piece, "PARAMETRIC", ()))

        moving = [b for b in self.bodies if parametric(b)]
        bodies = [b for b in moving if isinstance(b, RigidBody)
                  and type(b).check_values is RigidBody.check_values]
        others = [x for x in (*self.joints, *self.joint_springs, *self.springs,
                              *self.forces, *self.torques) if parametric(x)]
        if others or len(bodies) < len(moving):
            return None
        masses = [sp.sympify(b.mass) for b in bodies]
        inertias = [sp.sympify(v) for b in bodies
                    for v in np.asarray(b.inertia, dtype=object).ravel()]
        return [b.name for b in bodies], tuple(masses + inertias)

    def _bound_at(self, p: Sequence[float] | np.ndarray) -> Multibody:
        """:meth:`bound` to ``p``, one value per parameter in their order (resolved
        already: a System's parameter vector)."""
        key = tuple(float(v) for v in p)
        # The cache is shared by an ensemble's threads: each step is one dict call (atomic
        # under the GIL), so a race loses an entry at worst, never raises.
        found = self._bound.pop(key, None)
        if found is not None:  # values bound lately: checked already
            self._bound[key] = found  # now the most recent
            return found
        numbers = dict(zip(self.parameters, key))
        # every expression of every piece evaluated at once (pieces share some)
        memo = evaluated_expressions(self._parametric_expressions, numbers)
        bound = copy.copy(self)
        bound.gravity = with_numbers(self, numbers, memo).gravity
        mapped = {id(b): with_numbers(b, numbers, memo, check=False) for b in self.bodies}
        check_bodies([mapped[id(b)] for b in self.bodies if mapped[id(b)] is not b])
        bound.bodies = tuple(mapped[id(b)] for b in self.bodies)

        def rebody(piece: _Piece) -> _Piece:
            out = with_numbers(piece, numbers, memo)
            swaps = {a: mapped[id(b)] for a in ("body", "body_a", "body_b")
                     if (b := getattr(piece, a, None)) is not None and id(b) in mapped
                     and mapped[id(b)] is not b}
            if swaps:
                out = copy.copy(out) if out is piece else out
                for attribute, body in swaps.items():
                    setattr(out, attribute, body)
            return out

        bound.joints = tuple(rebody(j) for j in self.joints)
        joints = {id(j): b for j, b in zip(self.joints, bound.joints)}
        bound.joint_springs = tuple(
            _with_joint(with_numbers(s, numbers, memo), joints.get(id(s.joint), s.joint))
            for s in self.joint_springs)
        bound.actuators = tuple(_with_joint(a, joints.get(id(a.joint), a.joint))
                                for a in self.actuators)
        bound.springs = tuple(rebody(s) for s in self.springs)
        bound.forces = tuple(rebody(f) for f in self.forces)
        bound.torques = tuple(rebody(tq) for tq in self.torques)
        bound.__dict__.pop("parameters", None)
        bound.__dict__.pop("_parametric_expressions", None)
        bound.__dict__.pop("_body_values", None)
        bound.__dict__.pop("system", None)
        bound.__dict__.pop("_bodies_by_name", None)
        bound._bound = {}
        self._bound[key] = bound
        if len(self._bound) > BOUND_KEPT:
            self._bound = dict(list(self._bound.items())[-BOUND_KEPT:])
        return bound

    # -- validation ------------------------------------------------------------------
    def _check(self) -> None:
        if not self.bodies:
            raise ModelError("a Multibody needs at least one moving body")
        names = set()
        for body in self.bodies:
            if not isinstance(body, MovingBody):
                raise ModelError("bodies must be Particle, RigidBody or PlanarBody objects, "
                                 f"got {body!r}")
            if body.name in names:
                raise ModelError(f"two bodies are named {body.name!r}; names must be distinct")
            names.add(body.name)
        for j in self.joints:
            if not isinstance(j, Joint):
                raise ModelError(f"joints must be Joint objects, got {j!r}")
        joint_names = [j.name for j in self.joints]
        for j in self.joints:
            if joint_names.count(j.name) > 1:
                raise ModelError(f"two joints are named {j.name!r}; names must be distinct")
            self._check_members(j.bodies, f"joint {j.name!r}")
        for s in self.springs:
            self._check_members(s.bodies, f"spring {s.name!r}")
        for d in self.joints:
            if isinstance(d, Driver) and not any(d.driven is j for j in self.joints):
                raise ModelError(
                    f"driver {d.name!r} drives joint {d.driven.name!r}, which is not in this "
                    f"system's joints ({', '.join(joint_names)}): a driver prescribes the "
                    "joint's angle or travel only; add the joint to the joints list too")
        for c in self.contacts:
            if not isinstance(c, Contact):
                raise ModelError(f"contacts must be Contact objects (plane_contact, "
                                 f"sphere_contact), got {c!r}")
            if c.name in joint_names or [d.name for d in self.contacts].count(c.name) > 1:
                raise ModelError(f"two joints or contacts are named {c.name!r}; names must "
                                 "be distinct")
            self._check_members(c.bodies, f"contact {c.name!r}")
        coordinate_loads: list[JointSpring | Actuator] = [*self.joint_springs, *self.actuators]
        for js in coordinate_loads:
            if not any(js.joint is j for j in self.joints):
                raise ModelError(f"{type(js).__name__} {js.name!r} acts on joint "
                                 f"{js.joint.name!r}, which is not in this system's joints")
        loads: tuple[Force | Torque, ...] = (*self.forces, *self.torques)
        for load in loads:
            self._check_members((load.body,), load.name)
        for j in self.joints:
            check_joint_points(j)
        self._check_plane()

    def _check_plane(self) -> None:
        """Planar bodies move in the x-y plane: gravity along z would be silently lost."""
        planar = [b.name for b in self.bodies if isinstance(b, PlanarBody)]
        if planar and not (isinstance(self.gravity[2], float) and self.gravity[2] == 0):
            raise ModelError(
                f"gravity {tuple(self.gravity.tolist())} has a z component, but the planar "
                f"bodies {', '.join(planar)} move in the x-y plane, where it does no work; "
                "give gravity in the plane, e.g. gravity=(0, -9.81, 0)")

    def _check_members(self, bodies: Sequence[Body], what: str) -> None:
        for body in bodies:
            if isinstance(body, Ground):
                continue
            if not any(body is b for b in self.bodies):
                raise ModelError(
                    f"{what} acts on body {body.name!r}, which is not in this system's bodies "
                    f"({', '.join(b.name for b in self.bodies)})"
                )

    # -- the System ------------------------------------------------------------------
    @property
    def conserves_energy(self) -> bool:
        """Whether ``T + V`` stays constant along every motion: no force, torque,
        actuator or input, no damping in a spring or a joint spring (a damping given as
        a parameter counts as damping), no driver; gravity, springs and workless joints
        (rolling among them) conserve it.

        Examples
        --------
        >>> chain(2, 1.0, 1.0, 0.1).conserves_energy
        True
        """
        if self.forces or self.torques or self.actuators or self.inputs:
            return False
        dampers = [*(s.damping for s in self.springs), *(s.damping for s in self.joint_springs)]
        if any(not (isinstance(c, float) and c == 0.0) for c in dampers):
            return False
        return not any(getattr(j, "rheonomic", False) for j in self.joints)

    @property
    def coordinates(self) -> list[sp.Function]:
        """Every body's coordinates, in the order of ``bodies``."""
        return [c for b in self.bodies for c in b.coordinates]

    def constraints(self) -> list[Holonomic | Pfaffian]:
        """The bodies' constraints (unit quaternions), then the joints'."""
        body_rows: list[Holonomic | Pfaffian] = [c for b in self.bodies for c in b.constraints()]
        return body_rows + [c for j in self.joints for c in j.constraints()]

    def kinetic_energy(self) -> sp.Expr:
        """``T``: the sum of the bodies' kinetic energies."""
        return sp.Add(*(b.kinetic_energy() for b in self.bodies))

    def potential_energy(self) -> sp.Expr:
        """``V``: gravity ``-sum m g . x`` and the springs' ``1/2 k (L - L0)^2``."""
        V = sp.Add(*(gravity_potential(b, self.gravity) for b in self.bodies))
        V += sp.Add(*(s.potential() for s in self.springs))
        return V + sp.Add(*(s.potential() for s in self.joint_springs))

    def generalized_forces(self) -> dict[object, sp.Expr]:
        """Generalized forces of the torques, by coordinate."""
        Q: dict[object, sp.Expr] = {}
        loads = [load.generalized_forces() for load in self.torques]
        loads += [spring.generalized_forces() for spring in self.joint_springs]
        loads += [actuator.generalized_forces() for actuator in self.actuators]
        loads += [friction.generalized_forces() for friction in self.sliding_friction]
        for forces in loads:
            for coord, value in forces.items():
                Q[coord] = Q.get(coord, sp.S.Zero) + value
        return Q

    def point_forces(self) -> list[PointForce]:
        """The forces and the spring dampers as :class:`~dalembert.PointForce` objects."""
        pfs = [f.point_force() for f in self.forces]
        return pfs + [pf for s in self.springs for pf in s.point_forces()]

    @cached_property
    def system(self) -> System:
        """The :class:`dalembert.System` (built once; :func:`multibody_of` finds ``self``).

        Its numeric code is assembled from one kernel per kind of body and joint
        (:mod:`dalembert.multibody.parts`); its symbolic equations are made on request.
        """
        return System.from_definition(MultibodyDefinition(self), parameters=self.defaults)

    def with_contacts_closed(self, closed: tuple[int, ...], held: tuple[int, ...] = (),
                             sliding: tuple[int, ...] = ()) -> Multibody:
        """This mechanism with the contacts ``closed`` (indices) as joints after its own,
        and no contact left apart: the mechanism while they hold.

        Parameters
        ----------
        closed
            Indices into :attr:`contacts`.
        held
            Closed contacts whose sliding velocities (those with friction) are joints
            of Pfaffian rows after them (:class:`~.contacts.Sliding`): a rough or
            sticking contact's, or the rows the time-stepping mode reads for
            friction, never enforced there.
        sliding
            Closed contacts sliding: their friction forces are loads
            (:class:`~.contacts.SlidingFriction`) whose values are inputs after the
            mechanism's own (:func:`~dalembert.model.constraints.friction_inputs`).

        Examples
        --------
        >>> from dalembert.multibody import Ground, Particle, plane_contact
        >>> ball = Particle("ball", 1.0)
        >>> mb = Multibody([ball], contacts=[plane_contact("floor", Ground(), ball)])
        >>> [j.name for j in mb.with_contacts_closed((0,)).joints]
        ['floor']
        """
        closed_mb = copy.copy(self)
        closed_mb.__dict__ = {k: v for k, v in self.__dict__.items()
                              if not isinstance(getattr(type(self), k, None), cached_property)}
        rows = [s for k in held for s in (self.contacts[k].sliding,) if s is not None]
        closed_mb.joints = (*self.joints, *(self.contacts[k].joint for k in closed),
                            *rows)
        closed_mb.sliding_friction = tuple(
            SlidingFriction(self.contacts[k], friction_inputs(self.contacts, [k]))
            for k in sliding)
        closed_mb.inputs = (*self.inputs, *(f for friction in closed_mb.sliding_friction
                                            for f in friction.forces))
        closed_mb.contacts = ()
        closed_mb._bound = {}
        return closed_mb

    def body(self, name: str) -> MovingBody:
        """The body called ``name``.

        Parameters
        ----------
        name
            A body's name; a ``KeyError`` lists the names there are.

        Examples
        --------
        >>> chain(2, 1.0, 1.0, 0.1).body("link2")
        RigidBody('link2')
        """
        found = self._bodies_by_name.get(name)
        if found is None:
            raise KeyError(f"no body {name!r}; the bodies are "
                           f"{', '.join(b.name for b in self.bodies)}")
        return found

    @cached_property
    def _bodies_by_name(self) -> dict[str, MovingBody]:
        """The bodies by name (an initial state names each one: no search per name)."""
        return {b.name: b for b in self.bodies}

    def joint(self, name: str) -> Joint:
        """The joint called ``name``.

        Parameters
        ----------
        name
            A joint's name; a ``KeyError`` lists the names there are.

        Examples
        --------
        >>> chain(2, 1.0, 1.0, 0.1).joint("joint1")
        Spherical('joint1', 'ground', 'link1')
        """
        for j in self.joints:
            if j.name == name:
                return j
        raise KeyError(f"no joint {name!r}; the joints are "
                       f"{', '.join(j.name for j in self.joints) or 'none'}")

    def _resolve(self, key: Body | str) -> Body:
        if isinstance(key, Body):
            if self._bodies_by_name.get(key.name) is not key:
                self._check_members((key,), "initial state")  # the ground, or raises
            return key
        return self.body(str(key))

    def _by_name(self, values: ByBody[_V] | None, what: str) -> dict[str, _V]:
        """``values`` (the argument ``what``) keyed by body name (a body not in this
        system raises)."""
        if values is not None and not isinstance(values, Mapping):
            raise InitialConditionError(
                f"{what} must be a dict {{body or body name: value}}, got {values!r:.80}")
        return {self._resolve(key).name: value for key, value in (values or {}).items()}

    # -- initial state ---------------------------------------------------------------
    def initial_state(
        self,
        positions: ByBody[Vector] | None = None,
        orientations: ByBody[Orientation] | None = None,
        velocities: ByBody[Vector] | None = None,
        angular_velocities: ByBody[Vector | float] | None = None,
        angular_velocity_frame: Frame = "world",
    ) -> tuple[dict[str, float], dict[str, float]]:
        """``(q0, qd0)`` dicts by coordinate name for :meth:`dalembert.System.simulate`.

        Each argument maps bodies (or body names) to values; unlisted bodies start
        at the origin, unrotated, at rest (see :mod:`~dalembert.multibody.initial_state`).

        Parameters
        ----------
        positions, velocities
            The mass center's position and velocity (world); a planar body also
            takes 2 numbers.
        orientations
            Rotation matrices (body -> world) or Euler parameters (a non-unit
            quaternion is normalized with an
            :class:`~dalembert.InitialConditionsAdjusted` warning); a planar body's
            angle about ``z``.
        angular_velocities
            In world or body components (``angular_velocity_frame``); a planar
            body's ``w_z``.
        angular_velocity_frame
            ``"world"`` (default) or ``"body"``.

        Returns
        -------
        tuple of dict
            ``q0`` and ``qd0``; a rigid body's Euler parameter rates are
            ``bdot = 1/2 E(b)^T w_body``.

        Examples
        --------
        A body turning about ``z`` at 2 rad/s: ``bdot_3 = 1/2 w_z`` at ``b = (1, 0, 0, 0)``:

        >>> mb = Multibody([RigidBody("box", 1.0, (1, 1, 1))])
        >>> q0, qd0 = mb.initial_state(positions={"box": (0, 0, 1)},
        ...                            angular_velocities={"box": (0, 0, 2.0)})
        >>> q0["box_z"], q0["box_b0"], qd0["box_b3"]
        (1.0, 1.0, 1.0)
        """
        if angular_velocity_frame not in ("world", "body"):
            raise ValueError("angular_velocity_frame must be 'world' or 'body'")
        q, qd = bodies_state(self.bodies, angular_velocity_frame,
                             self._by_name(positions, "positions"),
                             self._by_name(orientations, "orientations"),
                             self._by_name(velocities, "velocities"),
                             self._by_name(angular_velocities, "angular_velocities"))
        # the joints' points as numbers: the mechanism's own where no joint depends on
        # the parameters, else bound to their defaults (without values, no check)
        numbers = self if self._body_values is not None else self._with_defaults()
        if numbers is not None:
            check_initial_joint_points(numbers, q)
        names = self.system.coordinate_names
        return dict(zip(names, q.tolist())), dict(zip(names, qd.tolist()))

    # -- outputs (see dalembert.multibody.outputs) -----------------------------------
    def simulate(self, t_span: Sequence[float], q0: CoordinateValues,
                 qd0: CoordinateValues | None = None, **kwargs: Any) -> Trajectory:
        """``self.system.simulate(...)``, with errors about immobility naming the joints.

        Joints that leave no degree of freedom at the initial state raise a
        :class:`~dalembert.ConstraintError` listing every joint, its rows and those
        rows that depend on the others (see :func:`check_mobility`).

        Parameters
        ----------
        t_span, q0, qd0
            As in :meth:`dalembert.System.simulate` (``q0``, ``qd0`` e.g. from
            :meth:`initial_state`).
        kwargs
            :meth:`dalembert.System.simulate`'s keywords.

        Examples
        --------
        A particle thrown sideways falls on a parabola:

        >>> from dalembert.multibody import Particle
        >>> mb = Multibody([Particle("p", 1.0)], gravity=(0.0, 0.0, -10.0))
        >>> traj = mb.simulate((0.0, 1.0), *mb.initial_state(velocities={"p": (2, 0, 0)}),
        ...                    t_eval=[1.0])
        >>> [round(float(traj[name][0]), 9) for name in ("p_x", "p_z")]
        [2.0, -5.0]
        """
        try:
            return self.system.simulate(t_span, q0, qd0, **kwargs)
        except (ConstraintError, InitialConditionError) as exc:
            self._explain_immobility(q0, t_span, kwargs.get("parameters"), exc)
            raise

    def stick_figure(self, q: Numbers, *, body_axes: bool | None = None) -> list[FloatArray]:
        """Polylines ``(k, 3)`` drawing the system at ``q`` (see
        :func:`dalembert.multibody.drawing.stick_figure`, which has an example); used by
        :func:`dalembert.plotting.animate`.

        Parameters
        ----------
        q
            The configuration, in the order of ``self.system.coordinate_names``.
        body_axes
            Draw each rigid body's axes (three lines through its mass center), none,
            or (``None``) those of the bodies that no joint or spring holds.

        Examples
        --------
        A link hanging from the origin: the ground's joint point, the line from its
        center to its joint point and its center; with its axes instead of the center:

        >>> mb = chain(1, 1.0, 1.0, 0.1)
        >>> q0, _ = mb.initial_state(positions={"link1": (0, 0, -0.5)})
        >>> q = [q0[n] for n in mb.system.coordinate_names]
        >>> [len(line) for line in mb.stick_figure(q)]
        [1, 2, 1]
        >>> [len(line) for line in mb.stick_figure(q, body_axes=True)]
        [1, 2, 2, 2, 2]
        """
        return stick_figure(self._with_defaults() or self.bound(), np.asarray(q, dtype=float),
                            body_axes=body_axes)

    def _explain_immobility(self, q0: CoordinateValues, t_span: Sequence[float],
                            parameters: Mapping[Any, object] | None,
                            exc: Exception) -> None:
        """Raise the joint-naming error if the failure was a mechanism without freedom."""
        try:
            t0 = float(t_span[0])
            check_mobility(self, q0, t0, parameters, cause=exc)
        except ConstraintError:
            raise
        except Exception:  # the original error is the better report then
            return

    def __repr__(self) -> str:
        return (f"Multibody({self.name!r}, bodies={[b.name for b in self.bodies]}, "
                f"joints={[j.name for j in self.joints]})")


def multibody_of(system: System) -> Multibody:
    """The :class:`Multibody` whose ``.system`` is ``system``.

    Parameters
    ----------
    system
        A System from :attr:`Multibody.system` (any other raises
        :class:`~dalembert.ModelError`).

    Examples
    --------
    >>> from dalembert.multibody import chain
    >>> mb = chain(1, 1.0, 1.0, 0.1)
    >>> multibody_of(mb.system) is mb
    True
    """
    mb = getattr(getattr(system, "definition", None), "multibody", None)
    if not isinstance(mb, Multibody):
        raise ModelError(f"{system!r} was not built by a dalembert.multibody.Multibody")
    return mb


_Piece = TypeVar("_Piece")
_Load = TypeVar("_Load", JointSpring, Actuator)


def _with_joint(spring: _Load, joint: Joint) -> _Load:
    """``spring`` (or an actuator) acting on ``joint`` (a bound copy of its own)."""
    if spring.joint is joint:
        return spring
    out = copy.copy(spring)
    out.joint = joint
    return out


def _pieces(values: object, what: str, kind: str) -> tuple:
    """``values`` as a tuple; a ``ModelError`` if it is not a sequence (``None``, a
    string: its letters would be taken for bodies)."""
    if isinstance(values, (str, bytes)) or not isinstance(values, Iterable):
        raise ModelError(f"{what} must be a sequence of {kind}, got {values!r:.80}")
    return tuple(values)


def chain(
    n: int,
    length: Scalar,
    mass: Scalar,
    radius: Scalar,
    joint: Literal["spherical", "revolute"] = "spherical",
    gravity: Vector | None = None,
    planar: bool = False,
) -> Multibody:
    """An ``n``-link chain of uniform cylinders hung from the origin.

    Link ``k`` (bodies ``link1..linkn``, top first) has its axis along its body
    ``z``, joint points ``(0, 0, +-length/2)`` and, hanging straight down, its
    center at ``(0, 0, -(k - 1/2) length)``. Joints ``joint1`` (ground to
    ``link1``) ... ``jointn`` are spherical or revolute about the body ``y`` axes.
    Gravity defaults to ``(0, 0, -9.81)``.

    ``planar=True`` (revolute joints only) makes the links :class:`PlanarBody`
    objects in the ``x-y`` plane instead (3 coordinates each, pins of 2 rows): the
    link axis is its body ``y``, the joint points ``(0, +-length/2, 0)``, link
    ``k`` hangs at ``(0, -(k - 1/2) length)`` and gravity defaults to
    ``(0, -9.81, 0)``.

    Parameters
    ----------
    n
        The number of links.
    length, mass, radius
        Each link's length, mass and radius (a solid cylinder's inertia): numbers, or
        expressions of parameter symbols (then give their values with
        ``Multibody.defaults`` or ``simulate(parameters=...)``).
    joint
        ``"spherical"`` or ``"revolute"``.
    gravity
        The field, world components (default: see above).
    planar
        Planar links (revolute joints only).

    Examples
    --------
    >>> chain(2, 1.0, 1.0, 0.05, joint="revolute").system.degrees_of_freedom
    2
    >>> len(chain(2, 1.0, 1.0, 0.05, joint="revolute", planar=True).system.coordinate_names)
    6
    """
    if int(n) != n or n < 1:
        raise ModelError(f"a chain needs a positive whole number of links, got {n!r}")
    if joint not in ("spherical", "revolute"):
        raise ModelError(f"joint must be 'spherical' or 'revolute', got {joint!r}")
    if planar and joint != "revolute":
        raise ModelError("a planar chain has revolute joints; use joint='revolute'")
    length, mass, radius = (scalar(v, f"the chain's {what}") for v, what in
                            ((length, "length"), (mass, "mass"), (radius, "radius")))
    for value, what in ((length, "length"), (radius, "radius")):
        if isinstance(value, float) and not value > 0:
            raise ModelError(f"the chain's {what} must be positive, got {value}")
    transverse = mass * (3 * radius**2 + length**2) / 12
    links: list[MovingBody]
    if planar:
        links = [PlanarBody(f"link{k + 1}", mass, transverse) for k in range(int(n))]
        axis, down, hinge = 1, (0.0, -9.81, 0.0), (0, 0, 1)
    else:
        inertia = (transverse, transverse, mass * radius**2 / 2)
        links = [RigidBody(f"link{k + 1}", mass, inertia) for k in range(int(n))]
        axis, down, hinge = 2, (0.0, 0.0, -9.81), (0, 1, 0)
    top, bottom = np.zeros(3, dtype=object), np.zeros(3, dtype=object)
    top[axis], bottom[axis] = length / 2, -length / 2
    joints: list[Joint] = []
    parents: list[Body] = [Ground(), *links[:-1]]
    for k, (parent, child) in enumerate(zip(parents, links)):
        pa = (0, 0, 0) if k == 0 else bottom
        if joint == "spherical":
            joints.append(Spherical(f"joint{k + 1}", parent, child, pa, top))
        else:
            joints.append(Revolute(f"joint{k + 1}", parent, child, pa, top, axis_a=hinge))
    kind = "planar revolute" if planar else joint
    return Multibody(links, joints, gravity=down if gravity is None else gravity,
                     name=f"{n}-link {kind} chain")


def ring(
    n: int,
    length: Scalar,
    mass: Scalar,
    radius: Scalar,
    joint: Literal["revolute", "spherical"] = "revolute",
    gravity: Vector = (0.0, 0.0, -9.81),
) -> Multibody:
    """A closed ring of ``n`` equal rods (uniform cylinders), hung from one vertex.

    A regular polygon in the ``x-z`` plane: rod ``k`` (``rod1..rodn``) joins vertex
    ``k-1`` to vertex ``k``, the joint ``pivot`` holds vertex 0 to the origin and
    ``hinge1 .. hingen`` join consecutive rods, the last closing the loop. With
    ``joint="revolute"`` (axes along ``y``) the planar loop is closed with 3D hinges,
    so three of its rows are combinations of the others: a classic mechanism with
    dependent constraints (``n - 3`` degrees of freedom for the planar loop on its
    pivot, counted from the rank); with ``"spherical"`` the rows are independent.
    :func:`ring_state` places it.

    Parameters
    ----------
    n
        The number of rods (at least 4).
    length, mass, radius
        Each rod's length, mass and radius (numbers or parameter expressions).
    joint
        ``"revolute"`` or ``"spherical"``.
    gravity
        The field (world components).

    Examples
    --------
    >>> import warnings
    >>> mb = ring(6, 0.5, 1.0, 0.02)
    >>> with warnings.catch_warnings():
    ...     warnings.simplefilter("ignore")  # the dependent rows are reported
    ...     report = mb.system.consistent_initial_state(*ring_state(mb, 6, 0.5))
    >>> report.degrees_of_freedom, len(report.dependent_constraints)
    (4, 3)
    """
    if int(n) != n or n < 4:
        raise ModelError(f"a ring needs a whole number of rods, at least 4, got {n!r}")
    if joint not in ("spherical", "revolute"):
        raise ModelError(f"joint must be 'spherical' or 'revolute', got {joint!r}")
    transverse = mass * (3 * radius**2 + length**2) / 12
    rods = [RigidBody(f"rod{k + 1}", mass, (transverse, transverse, mass * radius**2 / 2))
            for k in range(int(n))]
    top = np.array([0, 0, 1], dtype=object) * (length / 2)
    bottom = -top

    def hinge(name: str, a: Body, b: Body, point_a: Any, point_b: Any) -> Joint:
        if joint == "revolute":
            return Revolute(name, a, b, point_a, point_b, axis_a=(0, 1, 0))
        return Spherical(name, a, b, point_a, point_b)

    joints = [hinge("pivot", Ground(), rods[0], (0, 0, 0), top)]
    joints += [hinge(f"hinge{k + 1}", rods[k], rods[(k + 1) % int(n)], bottom, top)
               for k in range(int(n))]
    return Multibody(rods, joints, gravity=gravity, name=f"{n}-rod {joint} ring")


def ring_state(mb: Multibody, n: int, length: float, tilt: float = 0.6,
               turn: float = 1.0) -> tuple[dict[str, float], dict[str, float]]:
    """``(q0, qd0)`` of a :func:`ring`: regular, tilted by ``tilt`` about the pivot's
    ``y`` axis and turning rigidly about it at ``turn`` rad/s (consistent: a rigid
    rotation about the hinge axis through the pivot keeps every joint together).

    Parameters
    ----------
    mb
        The ring.
    n, length
        Its number of rods and their length (numbers).
    tilt, turn
        The angle (rad) and the rate (rad/s) about ``y`` through the pivot.

    Examples
    --------
    >>> q0, qd0 = ring_state(ring(4, 1.0, 1.0, 0.05), 4, 1.0, tilt=0.0, turn=0.0)
    >>> round(q0["rod3_z"], 12)  # a square on its corner: -1.5 L / (2 sin(pi/4))
    -1.06066017178
    """
    phi = np.arange(n + 1) * 2 * np.pi / n  # the vertices, the pivot first
    vertex = length / (2 * np.sin(np.pi / n)) * np.column_stack(
        [np.sin(phi), np.zeros(n + 1), np.cos(phi) - 1.0])

    def about_y(angle: float) -> FloatArray:
        c, s = np.cos(angle), np.sin(angle)
        return np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])

    omega = np.array([0.0, turn, 0.0])
    positions, orientations, velocities = {}, {}, {}
    for k in range(n):
        axis = vertex[k] - vertex[k + 1]  # body z, from the lower joint to the upper
        center = about_y(tilt) @ (vertex[k] + vertex[k + 1]) / 2
        positions[f"rod{k + 1}"] = center
        orientations[f"rod{k + 1}"] = about_y(tilt + np.arctan2(axis[0], axis[2]))
        velocities[f"rod{k + 1}"] = np.cross(omega, center)
    return mb.initial_state(positions=positions, orientations=orientations,
                            velocities=velocities,
                            angular_velocities=dict.fromkeys(positions, omega))
