"""``System``: the one object a user builds, derives and simulates.

It ties the layers together (model -> equations -> generated code -> solver ->
trajectory) and caches each stage, so the equations are derived and the numeric
code generated once per System however often it is simulated.
"""

from __future__ import annotations

import math
import time
import warnings
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import replace
from functools import cached_property
from typing import TYPE_CHECKING, Any, Literal

import numpy as np
import sympy as sp

from .codegen.compiled import CompiledEquations, NumericModel
from .definition import Definition, SymbolicDefinition, UnilateralLaw
from .equations.lagrange import Equations
from .errors import (
    ConstraintError,
    InitialConditionsAdjusted,
    InputError,
    IntegrationWarning,
    ModelError,
    ParameterError,
    RedundantConstraintsWarning,
    SingularConfigurationWarning,
    user_stacklevel,
)
from .inputs import InputSignal
from .model.constraints import ClosedGaps
from .model.forces import PointForce
from .model.model import Model, build_model
from .model.parameters import parameter_values, resolve_parameters
from .model.sympy_mechanics import from_lagranges_method, is_sympy_method
from .model.values import CoordinateValues, coordinate_values
from .numerics.state_layout import StateLayout
from .options import (
    FIXED,
    INPUT_VALUES,
    PARAMETER_VALUES,
    REDUNDANT_CONSTRAINTS,
    SIMULATE_PARAMETERS,
    Backend,
    ContactMode,
    ImpactLaw,
    RedundantConstraints,
    SimulationOptions,
    StepController,
    VelocityProjection,
    run_options,
    simulation_options,
)
from .rules import (
    NONE,
    CheckedWhereUsed,
    FiniteNumber,
    Rule,
    before_running,
    check_parameters,
    checked_keywords,
    unchecked,
)
from .solvers.initialization import InitializationReport, consistent_state
from .solvers.state import InverseDynamics, accelerations_at, inverse_dynamics_at
from .trajectory import Trajectory

if TYPE_CHECKING:  # imported on first use: statics pulls in scipy.optimize, the running
    # layer scipy.integrate (large imports, not made by ``import dalembert``)
    from scipy.integrate import OdeSolver

    from .solvers.running.integrate import IntegrationResult
    from .solvers.running.plan import SimulationPlan
    from .solvers.running.run_data import RunData
    from .statics import Equilibrium, Linearization

#: A piece of the model (energies, constraints, forces...): build_model checks each.
MODEL_PART: list[Rule] = [CheckedWhereUsed("a piece of the model (see dalembert.System)")]
#: The keywords of :meth:`System.simulate`: the run options, the inputs (checked against
#: the model's), and what belongs to one run (parameters, fixed coordinates).
SIMULATE: dict[str, list[Rule]] = {
    **SIMULATE_PARAMETERS,
    "redundant_constraints": [*REDUNDANT_CONSTRAINTS, NONE],  # None: the System's own
    "inputs": INPUT_VALUES,
    "parameters": PARAMETER_VALUES,
    "fixed": FIXED,
}


#: What runs :meth:`System.simulate_many`: :func:`dalembert.ensemble.simulate_many`, a
#: later layer, which the System does not import (docs/design.md): the package's root
#: installs it (:func:`install_ensemble`), as it imports both.
_ENSEMBLE: Callable[..., Any] | None = None


def install_ensemble(runner: Callable[..., Any]) -> None:
    """Make ``runner(system, t_span, cases, **options)`` what
    :meth:`System.simulate_many` calls.

    Parameters
    ----------
    runner
        The ensemble's entry point, :func:`dalembert.ensemble.simulate_many`.

    Examples
    --------
    >>> import dalembert.ensemble
    >>> install_ensemble(dalembert.ensemble.simulate_many)  # as dalembert does
    """
    global _ENSEMBLE
    _ENSEMBLE = runner


class System:
    """A mechanical system in (possibly redundant) coordinates with constraints.

    Sign convention, used everywhere: ``M qdd = f + A^T lambda`` with the
    constraints ``A qd + b = 0``; ``A^T lambda`` is the generalized constraint force.

    Parameters
    ----------
    coordinates
        SymPy ``dynamicsymbols`` (or names / plain symbols, see ``velocities``).
    kinetic, potential
        Kinetic energy ``T(q, qd, t)`` and potential energy ``V(q, t)``.
    lagrangian
        ``L(q, qd, t)`` instead of ``T`` and ``V``.
    constraints
        :class:`~dalembert.Holonomic` and :class:`~dalembert.Pfaffian` constraints.
    generalized_forces
        Non-conservative generalized forces: a dict by coordinate or a sequence.
    forces
        :class:`~dalembert.PointForce` objects (forces applied at points).
    parameters
        Numeric values of the model's other symbols (can be overridden in
        :meth:`simulate`).
    velocities
        With plain-symbol coordinates, the velocity symbols (default ``<name>_dot``).
    inputs
        Input symbols (SymPy ``Symbol``): values given during a simulation, by
        ``simulate(inputs=...)`` (a number, a function of the state, a table, a
        sampled controller). They may appear in the applied forces only.
    redundant_constraints
        Dependent (redundant) constraints, detected at the initial state:
        ``"minimum-norm"`` (default) proceeds with a
        :class:`~dalembert.errors.RedundantConstraintsWarning` naming them; the
        motion is unique, the multipliers are the minimum-norm ones (not unique).
        ``"error"`` raises a :class:`~dalembert.ConstraintError` naming them.
        :meth:`simulate` accepts the same keyword to override it.

    Examples
    --------
    The Cartesian pendulum, ``x^2 + y^2 = l^2``:

    >>> import sympy as sp
    >>> from dalembert import System, Holonomic, coordinates
    >>> x, y = coordinates("x y")
    >>> m, g, l = sp.symbols("m g l", positive=True)
    >>> pendulum = System(
    ...     [x, y],
    ...     kinetic=m / 2 * (x.diff() ** 2 + y.diff() ** 2),
    ...     potential=m * g * y,
    ...     constraints=[Holonomic(x**2 + y**2 - l**2, name="rod")],
    ...     parameters={m: 1.0, g: 9.81, l: 1.0},
    ... )
    >>> traj = pendulum.simulate((0, 1), q0={x: 1.0, y: 0.0})
    >>> bool(traj.position_residual.max() < 1e-12)
    True
    """

    @checked_keywords({
        "kinetic": MODEL_PART, "potential": MODEL_PART, "lagrangian": MODEL_PART,
        "constraints": MODEL_PART, "generalized_forces": MODEL_PART, "forces": MODEL_PART,
        "parameters": PARAMETER_VALUES, "velocities": MODEL_PART, "name": MODEL_PART,
        "redundant_constraints": REDUNDANT_CONSTRAINTS, "inputs": MODEL_PART,
    }, caller="System")
    def __init__(
        self,
        coordinates: Iterable[object],
        *,
        kinetic: object = None,
        potential: object = None,
        lagrangian: object = None,
        constraints: object = (),
        generalized_forces: Mapping[Any, object] | Sequence[object] | None = None,
        forces: Sequence[PointForce] = (),
        parameters: Mapping[Any, object] | None = None,
        velocities: Sequence[object] | None = None,
        name: str = "system",
        redundant_constraints: RedundantConstraints = "minimum-norm",
        inputs: Sequence[object] = (),
    ) -> None:
        if is_sympy_method(coordinates):
            raise ModelError(
                f"System takes coordinates, not a {type(coordinates).__name__}: use "
                "System.from_lagranges_method(method, parameters=...) for a LagrangesMethod")
        model = build_model(
            coordinates, kinetic=kinetic, potential=potential, lagrangian=lagrangian,
            constraints=constraints, generalized_forces=generalized_forces, forces=forces,
            velocities=velocities, name=name, inputs=inputs,
        )
        self._hold(SymbolicDefinition(model, kinetic_energy=lagrangian is None), parameters,
                   redundant_constraints)

    @classmethod
    @checked_keywords({"parameters": PARAMETER_VALUES,
                       "redundant_constraints": REDUNDANT_CONSTRAINTS}, caller="System")
    def from_definition(
        cls,
        definition: Definition,
        *,
        parameters: Mapping[Any, object] | None = None,
        redundant_constraints: RedundantConstraints = "minimum-norm",
    ) -> System:
        """The System of a :class:`~dalembert.definition.Definition` other than a symbolic
        model's (a Multibody's, whose code is compiled part by part).

        Parameters
        ----------
        definition
            The names, parameters and code of the model.
        parameters
            Numeric values of its parameters.
        redundant_constraints
            As for :class:`System`.

        Examples
        --------
        >>> from dalembert.multibody import chain
        >>> mb = chain(2, 1.0, 1.0, 0.05)
        >>> same = System.from_definition(mb.system.definition)
        >>> same.coordinate_names == mb.system.coordinate_names
        True
        """
        system = cls.__new__(cls)
        system._hold(definition, parameters, redundant_constraints)
        return system

    def _hold(self, definition: Definition, parameters: Mapping[Any, object] | None,
              redundant_constraints: RedundantConstraints) -> None:
        self._definition = definition
        self.redundant_constraints = redundant_constraints
        #: Made by :meth:`with_gaps_closed`: contacts may hold it still (no freedom left).
        self._closed_contacts = False
        self.parameter_values = parameter_values(
            definition.parameters, parameters, coordinates=definition.coordinate_names,
            inputs=[u.name for u in definition.inputs])

    @classmethod
    def from_lagranges_method(
        cls,
        method: Any,
        *,
        parameters: Mapping[Any, object] | None = None,
        name: str = "system",
        redundant_constraints: RedundantConstraints = "minimum-norm",
    ) -> System:
        """The System of a ``sympy.physics.mechanics.LagrangesMethod``.

        Its Lagrangian, coordinates, holonomic constraints (kept at position level),
        nonholonomic constraints and loads (turned into generalized forces through
        their partial velocities). The multipliers are those SymPy's
        ``mass_matrix_full`` / ``forcing_full`` give; its symbolic ``eom`` holds with
        their opposites (see :mod:`dalembert.model.sympy_mechanics`). The
        constraints are named ``holonomic_1, ...`` and ``nonholonomic_1, ...``.

        Parameters
        ----------
        method
            The ``LagrangesMethod`` (``form_lagranges_equations`` need not have been
            called). A ``KanesMethod`` is refused with a message.
        parameters
            Numeric values of the model's other symbols.
        name, redundant_constraints
            As for :class:`System`.

        Examples
        --------
        A pendulum in Cartesian coordinates with its rod as a holonomic constraint:

        >>> import sympy as sp
        >>> from sympy.physics.mechanics import LagrangesMethod, dynamicsymbols
        >>> x, y = dynamicsymbols("x y")
        >>> m, g, l = sp.symbols("m g l")
        >>> L = m / 2 * (x.diff()**2 + y.diff()**2) - m * g * y
        >>> lm = LagrangesMethod(L, [x, y], hol_coneqs=[x**2 + y**2 - l**2])
        >>> pendulum = System.from_lagranges_method(lm, parameters={m: 1, g: 9.81, l: 1})
        >>> pendulum.constraint_names
        ('holonomic_1',)
        """
        inputs = from_lagranges_method(method)
        return cls(inputs.coordinates, lagrangian=inputs.lagrangian,
                   constraints=inputs.constraints,
                   generalized_forces=inputs.generalized_forces, parameters=parameters,
                   name=name, redundant_constraints=redundant_constraints)

    # -- description ----------------------------------------------------------------
    @property
    def definition(self) -> Definition:
        """What this System is made from: names, parameters, code
        (:class:`~dalembert.definition.Definition`)."""
        return self._definition

    @property
    def model(self) -> Model:
        """The global symbolic model."""
        return self._definition.model

    @property
    def name(self) -> str:
        return self._definition.name

    @property
    def coordinate_names(self) -> tuple[str, ...]:
        return self._definition.coordinate_names

    @property
    def constraint_names(self) -> tuple[str, ...]:
        return self._definition.constraint_names

    @property
    def parameters(self) -> tuple:
        """The model's parameter symbols (sorted by name)."""
        return self._definition.parameters

    @property
    def inputs(self) -> tuple[sp.Symbol, ...]:
        """The model's input symbols, in the order they were declared."""
        return self._definition.inputs

    @property
    def degrees_of_freedom(self) -> int:
        """Coordinates minus constraint rows.

        With dependent (redundant) constraints this undercounts; the true number,
        ``n - rank(A)`` at a state, is ``consistent_initial_state(q0).degrees_of_freedom``.
        """
        return len(self.coordinate_names) - len(self.constraint_names)

    @property
    def rheonomic(self) -> bool:
        """Whether a constraint depends on time explicitly (a driven, prescribed motion:
        it may leave no degree of freedom)."""
        return self._definition.rheonomic

    @property
    def conserves_energy(self) -> bool:
        """Whether ``T + V`` is constant along every motion (no applied force, input or
        moving constraint: see :attr:`dalembert.model.model.Model.conserves_energy`); a
        trajectory's summary calls a change of it an error only then."""
        return self._definition.conserves_energy

    def describe_constraint(self, i: int) -> str:
        """Constraint ``i`` for a message: its name, kind and equation."""
        return self._definition.describe_constraint(i)

    @property
    def unilateral_names(self) -> tuple[str, ...]:
        """The unilateral constraints' names (:class:`~dalembert.Unilateral`), apart
        from :attr:`constraint_names` (the rows that always hold)."""
        return tuple(u.name for u in self._unilateral)

    @property
    def _unilateral(self) -> tuple[UnilateralLaw, ...]:
        return self._definition.unilateral

    def with_gaps_closed(self, closed: Sequence[str] | None = None) -> System:
        """This System with unilateral constraints closed: each a holonomic row after
        the others (the equations while those contacts hold).

        Parameters
        ----------
        closed
            The names of the unilateral constraints to close (default: all).

        Examples
        --------
        >>> from dalembert import System, Unilateral, coordinates
        >>> x, y = coordinates("x y")
        >>> ball = System([x, y], kinetic=(x.diff()**2 + y.diff()**2) / 2, potential=9.81 * y,
        ...               constraints=[Unilateral(y, name="floor", restitution=0.5)])
        >>> ball.constraint_names, ball.unilateral_names, ball.with_gaps_closed().constraint_names
        ((), ('floor',), ('floor',))
        """
        names = self.unilateral_names
        wanted = names if closed is None else tuple(closed)
        unknown = [c for c in wanted if c not in names]
        if unknown:
            raise ConstraintError(f"{unknown[0]!r} is not a unilateral constraint of "
                                  f"{self.name!r}; they are {', '.join(names) or 'none'}")
        return self._closed(ClosedGaps(tuple(k for k, name in enumerate(names)
                                             if name in wanted)))

    def _closed(self, which: ClosedGaps) -> System:
        """:meth:`with_gaps_closed` by indices, with the sliding velocities of
        ``which.held`` as rows after the gaps and the friction forces of
        ``which.sliding`` as inputs (:class:`~dalembert.model.constraints.ClosedGaps`),
        made once."""
        made = self.__dict__.setdefault("_closed_systems", {})
        if which not in made:
            system = System.from_definition(
                self._definition.with_gaps_closed(which),
                parameters=self.parameter_values,
                redundant_constraints=self.redundant_constraints)
            system._closed_contacts = bool(which.closed)
            made[which] = system
        return made[which]

    def __repr__(self) -> str:
        return (f"System({self.name!r}, coordinates={list(self.coordinate_names)}, "
                f"constraints={list(self.constraint_names)})")

    # -- equations and code ----------------------------------------------------------
    def equations(self) -> Equations:
        """The symbolic constrained equations ``M qdd = f + A^T lambda``, ``A qdd = c``."""
        return self._definition.equations()

    @cached_property
    def compiled(self) -> CompiledEquations:
        """Generated numeric functions (made on first use, then reused)."""
        from .solvers.native.library import prepare_runtime

        prepare_runtime()  # the C loop compiles beside the derivation
        return self._definition.compile()

    def numeric(self, parameters: Mapping[Any, object] | None = None) -> NumericModel:
        """The compiled equations bound to parameter values."""
        p = resolve_parameters(self.parameters, self.parameter_values, parameters,
                               coordinates=self.coordinate_names,
                               inputs=[u.name for u in self.inputs])
        self._definition.check_values(p)
        return self.compiled.bind(p)

    # -- the dynamics at one state ---------------------------------------------------
    def accelerations(
        self, t: float, q: CoordinateValues, qd: CoordinateValues | None = None, *,
        parameters: Mapping[Any, object] | None = None,
    ) -> tuple[np.ndarray, np.ndarray]:
        """``qdd`` and the multipliers ``lambda`` at one state, from the KKT system.

        Parameters
        ----------
        t
            The time.
        q, qd
            Positions and velocities (dict by coordinate or sequence; left out: 0).
            They are used as given, not projected onto the constraints.
        parameters
            Parameter values overriding the System's.

        Returns
        -------
        tuple of numpy.ndarray
            ``qdd`` (coordinate order) and ``lambda`` (constraint order; the
            minimum-norm ones where the constraints are dependent there).

        Examples
        --------
        The pendulum released horizontally falls freely at first, its rod slack:

        >>> from dalembert.examples import load
        >>> qdd, lam = load("pendulum").build().accelerations(0.0, {"x": 1.0, "y": 0.0})
        >>> [round(float(v), 12) + 0.0 for v in (*qdd, *lam)]
        [0.0, -9.81, 0.0]
        """
        num = self.numeric(parameters)
        q_, qd_ = self._state(q, qd)
        return accelerations_at(num, float(t), q_, qd_)

    def inverse_dynamics(
        self, t: float, q: CoordinateValues, qd: CoordinateValues | None,
        qdd: CoordinateValues, *, parameters: Mapping[Any, object] | None = None,
    ) -> InverseDynamics:
        """The generalized forces a given motion needs at one instant.

        ``M qdd - f`` is split into what the constraints supply, ``A^T lambda``, and
        ``applied``, orthogonal to the rows of ``A``: what applied forces (actuators)
        must add along the directions the constraints leave free. A motion fully
        prescribed by rheonomic constraints needs none, and its multipliers are the
        driving forces.

        Parameters
        ----------
        t
            The time.
        q, qd, qdd
            The motion (dict by coordinate or sequence; left out: 0). ``qdd`` must
            satisfy the constraints differentiated twice.
        parameters
            Parameter values overriding the System's.

        Returns
        -------
        InverseDynamics
            ``multipliers``, ``constraint_forces``, ``applied`` and ``required``.

        Raises
        ------
        ValueError
            ``qdd`` violates a constraint (named).

        Examples
        --------
        To hold the pendulum's bob still at 90 degrees takes ``m g`` upwards, all of it
        applied (a horizontal rod cannot carry it):

        >>> from dalembert.examples import load
        >>> pendulum = load("pendulum").build()
        >>> need = pendulum.inverse_dynamics(0.0, {"x": 1.0, "y": 0.0}, None, {})
        >>> [round(float(v), 12) + 0.0 for v in need.applied]
        [0.0, 9.81]
        """
        check_parameters({"t": t}, {"t": [FiniteNumber()]}, "inverse_dynamics")
        num = self.numeric(parameters)
        q_, qd_ = self._state(q, qd)
        qdd_ = coordinate_values(qdd, self.coordinate_names, "qdd")
        names = tuple(self.describe_constraint(i) for i in range(num.m))
        return inverse_dynamics_at(num, float(t), q_, qd_, qdd_, names)

    def _state(self, q: CoordinateValues,
               qd: CoordinateValues | None) -> tuple[np.ndarray, np.ndarray]:
        names = self.coordinate_names
        q_ = coordinate_values(q, names, "q")
        qd_ = np.zeros(len(names)) if qd is None else coordinate_values(qd, names, "qd")
        return q_, qd_

    # -- simulation ------------------------------------------------------------------
    @checked_keywords({
        "t0": [FiniteNumber()], "fixed": FIXED, "parameters": PARAMETER_VALUES,
        "redundant_constraints": [*REDUNDANT_CONSTRAINTS, NONE],
        "velocity_projection": SIMULATE_PARAMETERS["velocity_projection"],
    })
    def consistent_initial_state(
        self,
        q0: CoordinateValues,
        qd0: CoordinateValues | None = None,
        *,
        t0: float = 0.0,
        fixed: Sequence[object] | None = None,
        parameters: Mapping[Any, object] | None = None,
        redundant_constraints: RedundantConstraints | None = None,
        velocity_projection: VelocityProjection = "kinetic-energy",
    ) -> InitializationReport:
        """Project ``(q0, qd0)`` onto the constraints; ``fixed`` coordinates stay put.

        Positions change the least (Gauss-Newton). Velocities become, by default,
        those after a perfectly plastic impact onto the constraints (the projection
        in the kinetic-energy metric, which does not depend on units; the report's
        ``impulse`` is the generalized impulse it implies).

        Parameters
        ----------
        q0, qd0
            Positions and velocities: a dict by coordinate (symbol or name; a
            coordinate left out is 0) or a sequence in coordinate order.
        t0
            The initial time (for rheonomic constraints).
        fixed
            Coordinates whose given position and velocity must not change.
        parameters
            Parameter values overriding the System's.
        redundant_constraints
            ``"minimum-norm"`` or ``"error"``; default the System's option.
        velocity_projection
            ``"kinetic-energy"`` (default) or ``"least-change"`` (the Euclidean
            nearest velocities).

        Returns
        -------
        InitializationReport
            ``q``, ``qd``, what changed, the impulse, the true degrees of freedom
            ``n - rank(A)`` there (``degrees_of_freedom``) and the dependent
            constraints (``dependent_constraints``).

        Examples
        --------
        >>> from dalembert.examples import load
        >>> pendulum = load("pendulum").build()
        >>> report = pendulum.consistent_initial_state({"x": 2.0, "y": 0.0}, {"y": -1.0})
        >>> [round(float(v), 12) for v in (*report.q, *report.qd)]
        [1.0, 0.0, 0.0, -1.0]
        """
        return self._initial_state(self.numeric(parameters), q0, qd0, float(t0), fixed,
                                   redundant_constraints or self.redundant_constraints,
                                   velocity_projection)

    def _initial_state(
        self, num: NumericModel, q0: CoordinateValues, qd0: CoordinateValues | None,
        t0: float, fixed: Sequence[object] | None,
        redundant_constraints: RedundantConstraints, velocity_projection: VelocityProjection,
    ) -> InitializationReport:
        names = self.coordinate_names
        q = coordinate_values(q0, names, "q0")
        qd = coordinate_values(qd0, names, "qd0")
        labels = _LazyLabels(self.describe_constraint, len(self.constraint_names))
        return consistent_state(num, t0, q, qd, names, labels, fixed,
                                constraint_names=self.constraint_names,
                                redundant_constraints=redundant_constraints,
                                velocity_projection=velocity_projection,
                                driven=self.rheonomic or self._closed_contacts,
                                kinetic_energy=self._definition.kinetic_energy)

    @checked_keywords(SIMULATE)
    def simulate(
        self,
        t_span: Sequence[float],
        q0: CoordinateValues,
        qd0: CoordinateValues | None = None,
        *,
        t_eval: Sequence[float] | np.ndarray | None = None,
        method: str | type[OdeSolver] = "auto",
        rtol: float | Sequence[float] | None = None,
        atol: float | Sequence[float] | None = None,
        first_step: float | None = None,
        max_step: float = np.inf,
        step_control: StepController = "PI",
        stabilization: Literal["projection", "baumgarte"] | None = "projection",
        baumgarte_gain: float | None = None,
        parameters: Mapping[Any, object] | None = None,
        fixed: Sequence[object] | None = None,
        events: Sequence[Callable] = (),
        dense_output: bool = False,
        progress: bool = False,
        redundant_constraints: RedundantConstraints | None = None,
        velocity_projection: VelocityProjection = "kinetic-energy",
        backend: Backend = "auto",
        native: bool | None = None,
        inputs: object = None,
        sample_time: float | None = None,
        timeout: float | None = None,
        impact_law: ImpactLaw = "sequential",
        contact_mode: ContactMode = "event-driven",
        contact_step: float | None = None,
    ) -> Trajectory:
        """Integrate the constrained equations of motion over ``t_span``.

        The keywords follow :func:`scipy.integrate.solve_ivp`. They are checked
        once (:func:`dalembert.options.simulation_options`), the initial state is
        made consistent, and :meth:`plan` decides how the run goes (which loop,
        which solver); ``simulate`` is ``run(plan(...))``.

        Parameters
        ----------
        t_span
            ``(t0, tf)``; ``tf < t0`` integrates backwards.
        q0, qd0
            Initial positions and velocities: a dict by coordinate (a coordinate
            left out is 0) or a sequence in coordinate order. They are projected onto
            the constraints first (see :meth:`consistent_initial_state`; a warning
            reports what changed).
        t_eval
            Output times (default: every step).
        method
            ``"auto"`` (default: DOP853, switching to Radau where the problem turns
            out stiff, :mod:`dalembert.solvers.running.switching`), a ``solve_ivp``
            method name (``"DOP853"``; ``"Radau"``/``"BDF"`` for stiff mechanisms), an
            ``OdeSolver`` subclass, or ``"IDA"`` (SUNDIALS IDA on the stabilized
            index-2 form, through scikit-sundae: :mod:`dalembert.solvers.ida`; no
            events, dense output or inputs yet).
        rtol, atol
            Tolerances: finite positive numbers (or arrays, one per state entry).
            Default (``None``): the method's (:data:`dalembert.options.DEFAULT_TOLERANCES`),
            ``rtol=1e-11, atol=1e-13`` for the explicit methods, ``1e-8, 1e-10`` for
            the implicit ones (Radau, BDF, LSODA, IDA); ``"auto"`` runs DOP853 and
            Radau each at its own.
        first_step, max_step
            Step limits, as in ``solve_ivp``.
        step_control
            The explicit Runge-Kutta methods' step-size controller: ``"PI"``
            (default; fewer rejected steps where stability limits the step, see
            :mod:`dalembert.solvers.steppers.scipy_ivp`) or ``"scipy"`` (``solve_ivp``'s,
            with an explicit ``method`` named: ``"auto"`` watches the PI controller's
            steps).
        stabilization
            ``"projection"`` (positions and velocities projected after every step:
            no tuning, residuals at rounding level), ``"baumgarte"`` (see
            :mod:`dalembert.solvers.dynamics`) or ``None`` (raw drift).
        baumgarte_gain
            The Baumgarte gain, a finite positive number (default 10); only with
            ``stabilization="baumgarte"``.
        parameters
            Parameter values overriding the System's (no code is regenerated).
        fixed
            Coordinates the initial projection must not change.
        events
            Functions ``event(t, q, qd)`` with optional ``terminal``/``direction``
            attributes, as in ``solve_ivp``; a function of four positional parameters,
            ``event(t, q, qd, lam)``, also receives the multipliers at the state (a
            string going slack: ``lam[0]`` crossing zero).
        dense_output
            Add ``traj.sol(t)``.
        progress
            Show a progress bar.
        redundant_constraints
            Overrides the System's option of that name.
        velocity_projection
            ``"kinetic-energy"`` (default: the velocities after a plastic impact
            onto the constraints) or ``"least-change"``.
        backend
            ``"auto"`` (default): the loop runs in C where it applies (C-generated
            functions, a block-structured mass matrix; see
            :mod:`dalembert.solvers.native`), else in Python; ``"c"`` requires C
            (a ``ValueError`` says why it does not apply); ``"python"``. Both give
            the same trajectory to rounding.
        native
            Deprecated alias of ``backend`` (``True``: ``"c"``, ``False``:
            ``"python"``).
        inputs
            The values of the model's inputs (``System(inputs=...)``): a number, a
            function ``u(t, q, qd)`` or ``u(t)``, a table ``(times, values)``
            (interpolated linearly), or a dict by input of these (see
            :mod:`dalembert.inputs`). The trajectory records them (``traj.inputs``).
        sample_time
            Hold the inputs between samples taken every ``sample_time`` (a digital
            controller's zero-order hold); the integration restarts at each sample
            (in the time-stepping contact mode the steps fall on the samples).
        timeout
            Seconds on the wall clock the integration may take (default: no limit),
            checked between steps (between the C loop's stretches of steps, a
            fraction of a second each): a run past it stops with status
            ``"timeout"`` and an :class:`~dalembert.errors.IntegrationWarning`,
            returning what it computed. A function of yours (an input, an event)
            that itself never returns is stopped half a second after the limit, the
            run ending the same way (unless the function is blocked in a C call such
            as ``time.sleep``: then when that call returns).
        impact_law
            With unilateral constraints (:class:`~dalembert.Unilateral`), how an impact
            on several touching ones is resolved: ``"sequential"`` (default: the
            approaching contacts first, then those the impulse makes approach, as a
            wave; Newton's cradle gives its physical outcome) or ``"simultaneous"``
            (one complementarity problem over all of them); see
            :mod:`dalembert.solvers.contact.laws`.
        contact_mode, contact_step
            With unilateral constraints: ``"event-driven"`` (default: each impact
            located to rounding and resolved exactly) or ``"time-stepping"``
            (Moreau-Jean steps of ``contact_step``, default 1e-3, first order: for many
            contacts, a chain falling on a table; see
            :mod:`dalembert.solvers.contact.time_stepping`).

        Returns
        -------
        Trajectory
            With unilateral constraints, ``traj.contacts`` holds the impacts and the
            closed contacts over time. A failure or Ctrl-C returns the part computed so far with
            ``success=False`` and an :class:`~dalembert.errors.IntegrationWarning`.

        Examples
        --------
        >>> from dalembert.examples import load
        >>> pendulum = load("pendulum").build()
        >>> traj = pendulum.simulate((0, 1), {"x": 1.0, "y": 0.0}, t_eval=[0.5, 1.0])
        >>> traj.t.tolist(), bool(traj.position_residual.max() < 1e-12)
        ([0.5, 1.0], True)
        """
        # The run options are this call's parameters named in the table (every one of
        # them, checked at import): passed on as they are, checked already at the door.
        try:  # a Ctrl-C here (a t_eval of 1e7 times being checked) has lost nothing
            options = self._options(t_span, run_options(locals()),
                                    unchecked(simulation_options))
            plan = self._plan(options, q0, qd0, parameters, fixed)
        except KeyboardInterrupt:
            raise KeyboardInterrupt(before_running(
                "simulate", "its arguments were checked and its initial state made "
                "consistent")) from None
        return self._run(plan)

    def simulate_many(self, t_span: Sequence[float], cases: Any, **options: Any) -> Any:
        """Simulate this System once per case (an ensemble): serially, on threads or on
        Dask, the results labelled (see :func:`dalembert.ensemble.simulate_many`).

        Parameters
        ----------
        t_span
            ``(t0, tf)``, shared by every case.
        cases
            A DataFrame or list of dicts whose columns name parameters, coordinates
            (``x``), velocities (``x_dot``) and inputs (held at the case's value);
            :func:`dalembert.ensemble.grid` and
            :func:`dalembert.ensemble.sample` make them.
        options
            :func:`dalembert.ensemble.simulate_many`'s keywords and ``simulate``'s.

        Returns
        -------
        dalembert.ensemble.EnsembleResult
            ``.dataset`` (xarray), ``.summary`` (pandas), ``.retry()``...

        Examples
        --------
        >>> from dalembert.examples import load
        >>> pendulum = load("pendulum").build()
        >>> result = pendulum.simulate_many((0, 1), [{"x": 0.6, "y": -0.8}, {"x": 1.0, "y": 0}],
        ...                                 scheduler="serial", progress=False)
        >>> result.summary["status"].tolist()
        ['finished', 'finished']
        """
        if _ENSEMBLE is None:
            raise RuntimeError("no ensemble runner is installed (dalembert/__init__.py "
                               "installs dalembert.ensemble.simulate_many)")
        return _ENSEMBLE(self, t_span, cases, **options)

    @checked_keywords({"parameters": PARAMETER_VALUES, "fixed": FIXED})
    def plan(
        self,
        t_span: Sequence[float],
        q0: CoordinateValues,
        qd0: CoordinateValues | None = None,
        *,
        parameters: Mapping[Any, object] | None = None,
        fixed: Sequence[object] | None = None,
        **options: Any,
    ) -> SimulationPlan:
        """How :meth:`simulate` would run, without running it.

        Parameters
        ----------
        t_span, q0, qd0, parameters, fixed
            As in :meth:`simulate`.
        options
            :meth:`simulate`'s other keywords.

        Returns
        -------
        SimulationPlan
            The decisions (``plan.loop``, ``plan.why_python``, ``plan.solver``,
            ``plan.stretches``...); :meth:`run` executes it.

        Examples
        --------
        >>> from dalembert.examples import load
        >>> pendulum = load("pendulum").build()
        >>> plan = pendulum.plan((0, 1), {"x": 1.0, "y": 0.0}, backend="python")
        >>> plan.loop
        'python'
        >>> traj = pendulum.run(plan)
        >>> traj.status
        'finished'
        """
        return self._plan(self.check_options(t_span, **options), q0, qd0, parameters, fixed)

    def check_options(self, t_span: Sequence[float], **options: Any) -> SimulationOptions:
        """:meth:`simulate`'s keywords checked as :meth:`simulate` checks them, once for
        many runs (an ensemble's): :meth:`plan_checked` makes a run's plan from them.

        Parameters
        ----------
        t_span
            ``(t0, tf)``.
        options
            :meth:`simulate`'s other keywords, but ``q0``, ``qd0``, ``parameters`` and
            ``fixed`` (they belong to each run).

        Returns
        -------
        SimulationOptions
            The checked options (:func:`dalembert.options.simulation_options`).

        Raises
        ------
        ValueError
            A keyword's value is not allowed (the message names it).

        Examples
        --------
        >>> from dalembert.examples import load
        >>> pendulum = load("pendulum").build()
        >>> options = pendulum.check_options((0, 1), t_eval=[0.5, 1.0], backend="python")
        >>> options.t_span, options.output.t_eval.tolist()
        ((0.0, 1.0), [0.5, 1.0])
        """
        return self._options(t_span, options, simulation_options)

    def _options(self, t_span: Sequence[float], options: Mapping[str, Any],
                 make: Callable[..., SimulationOptions]) -> SimulationOptions:
        """The options of a run of this System made by ``make`` (:func:`simulation_options`,
        or its unchecked body for keywords checked at :meth:`simulate`'s door)."""
        if options.get("redundant_constraints") is None:  # None: the System's option
            options = {**options, "redundant_constraints": self.redundant_constraints}
        return make(t_span, state_size=2 * len(self.coordinate_names),
                    input_names=[u.name for u in self.inputs], **options)

    def plan_checked(
        self,
        options: SimulationOptions,
        q0: CoordinateValues,
        qd0: CoordinateValues | None = None,
        *,
        parameters: Mapping[Any, object] | None = None,
        fixed: Sequence[object] | None = None,
    ) -> SimulationPlan:
        """:meth:`plan` with options already checked by :meth:`check_options` (or
        ``dataclasses.replace`` of them): what an ensemble does for each of its runs.

        Parameters
        ----------
        options
            From :meth:`check_options` of this System.
        q0, qd0, parameters, fixed
            As in :meth:`simulate`.

        Returns
        -------
        SimulationPlan
            As :meth:`plan` returns it; :meth:`run` executes it.

        Examples
        --------
        >>> from dalembert.examples import load
        >>> pendulum = load("pendulum").build()
        >>> options = pendulum.check_options((0, 1), t_eval=[1.0])
        >>> left, right = (pendulum.run(pendulum.plan_checked(options, {"x": x, "y": -0.8}))
        ...                for x in (0.6, -0.6))
        >>> bool(abs(left.q[-1, 0] + right.q[-1, 0]) < 1e-12)  # mirror images
        True
        """
        return self._plan(options, q0, qd0, parameters, fixed)

    def _plan(self, options: SimulationOptions, q0: CoordinateValues,
              qd0: CoordinateValues | None, parameters: Mapping[Any, object] | None,
              fixed: Sequence[object] | None) -> SimulationPlan:
        num = self.numeric(parameters)
        report = self._initial_state(num, q0, qd0, options.t_span[0], fixed,
                                     options.redundant_constraints,
                                     options.velocity_projection)
        # user_stacklevel: the user's line (a call of simulate, plan, plan_checked,
        # Multibody.simulate...)
        if report.changed:
            warnings.warn(report.describe_changes(), InitialConditionsAdjusted,
                          stacklevel=user_stacklevel())
        if report.dependent_constraints or (report.rank is not None and report.rank.near):
            warnings.warn(str(report.rank), RedundantConstraintsWarning,
                          stacklevel=user_stacklevel())
        from .solvers.running.plan import plan_simulation

        return plan_simulation(num, report, options)

    def run(self, plan: SimulationPlan, *, dynamics: bool = True) -> Trajectory:
        """Execute a plan made by :meth:`plan` (see there for an example).

        Parameters
        ----------
        plan
            From :meth:`plan` of this System (or ``dataclasses.replace`` of one).
        dynamics
            ``False``: the trajectory's ``qdd``, multipliers and constraint forces may
            be left uncomputed (NaN), for a caller that keeps none of them (an
            ensemble keeping positions only saves the KKT solves at its output times).

        Returns
        -------
        Trajectory
            As :meth:`simulate` returns it.
        """
        return self._run(plan, dynamics)

    def _run(self, plan: SimulationPlan, dynamics: bool = True) -> Trajectory:
        """:meth:`run`; without ``dynamics`` the trajectory's ``qdd``, multipliers and
        constraint forces may be left uncomputed (NaN), for a caller that keeps none of
        them."""
        if self._unilateral:
            return self._run_contacts(plan, dynamics)
        from .solvers.running.execute import execute

        done = execute(plan, dynamics)
        result = done.run.result
        if done.passages:
            warnings.warn(done.passages, SingularConfigurationWarning,
                          stacklevel=user_stacklevel())
        if not result.success:
            reached = result.t[-1] if len(result.t) else plan.options.t_span[0]
            warning = IntegrationWarning(f"{result.message}; returning the trajectory up to "
                                         f"t={reached:.6g}")
            warning.__cause__ = result.error  # an event function's exception, chained
            warnings.warn(warning, stacklevel=user_stacklevel())  # the user's call
        return self._trajectory(result, plan, done.run.derived, done.run.inputs)

    def _run_contacts(self, plan: SimulationPlan, dynamics: bool = True) -> Trajectory:
        """:meth:`_run` with unilateral constraints: the event-driven contact mode
        (:mod:`dalembert.solvers.contact.driver`), each set of closed gaps run as the
        System with those gaps closed."""
        from .solvers.contact.driver import run_contacts
        from .solvers.contact.gaps import Gaps

        options = plan.options
        t0, tf = options.t_span
        if tf < t0:
            raise ValueError("a System with unilateral constraints runs forward in time "
                             f"only (impacts lose energy): got t_span ({t0}, {tf})")
        rows = self._unilateral
        stepping = options.contact_mode == "time-stepping"
        rough = [u.name for u in rows if u.friction == math.inf]
        if rough and stepping:
            raise ValueError(f"the unilateral constraint {rough[0]!r} is rough "
                             "(friction=math.inf), which runs in the event-driven contact "
                             "mode: give a finite friction coefficient for time-stepping")
        parameters = {s.name: float(v) for s, v in zip(self.parameters, plan.parameters)}
        # every gap a row, and the sliding velocities of those with friction after them
        every = self._closed(ClosedGaps(tuple(range(len(rows))),
                                        tuple(k for k, u in enumerate(rows) if u.friction > 0)))
        full = every.numeric(parameters).for_run()  # the run's inputs are written in it
        gaps = Gaps.of(rows, len(self.constraint_names),
                       [_restitution(u, parameters) for u in rows])
        user = options.output.events
        # one time limit for the run: each set of closed gaps' data gets what is left
        deadline = None if options.timeout is None else time.monotonic() + options.timeout

        def start(which: ClosedGaps, t: float, y: np.ndarray, events: tuple[Callable, ...],
                  inputs: InputSignal | None) -> RunData:
            system = self._closed(which)
            output = replace(options.output, events=user + events)
            left = None if deadline is None else max(deadline - time.monotonic(), 1e-9)
            segment = replace(options, t_span=(t, tf), output=output, timeout=left,
                              inputs=options.inputs if inputs is None else inputs)
            layout = StateLayout(len(self.coordinate_names))
            # a switch's state, ours, not the user's: held sliding velocities may be
            # dependent, and gaps closing within the touching tolerance are projected
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", RedundantConstraintsWarning)
                warnings.simplefilter("ignore", InitialConditionsAdjusted)
                return system._plan(segment, *layout.split(y), parameters, None).start()

        if stepping:
            from .solvers.contact.rotations import Rotations
            from .solvers.contact.time_stepping import run_time_stepping

            stepped = run_time_stepping(full, gaps, (t0, tf), plan.y0, options.contact_step,
                                        options.output.t_eval, options.inputs,
                                        Rotations(self.definition.quaternions), deadline)
            result, derived, history = stepped.result, stepped.derived, stepped.history
            applied = stepped.inputs  # the samples held (None: the inputs at each point)
        else:
            done = run_contacts(full, gaps, start, (t0, tf), plan.y0, options.output.t_eval,
                                options.impact_law, len(user), options.inputs, dynamics)
            result, derived, history = done.run.result, done.run.derived, done.history
            applied = done.run.inputs
        if not result.success:
            reached = result.t[-1] if len(result.t) else t0
            warnings.warn(IntegrationWarning(f"{result.message}; returning the trajectory "
                                             f"up to t={reached:.6g}"),
                          stacklevel=user_stacklevel())
        traj = every._trajectory(result, plan, derived, applied)
        return replace(traj, contacts=history,
                       energy_conserved=traj.energy_conserved
                       and not any(i.energy_lost for i in history.impacts))

    # -- rest and small oscillations -------------------------------------------------
    def equilibrium(self, guess: Any, **options: Any) -> Equilibrium:
        """Static equilibrium near ``guess``: ``f(q, 0, t) + A^T lambda = 0``, ``psi(q) = 0``.

        Parameters
        ----------
        guess
            A starting configuration: a dict by coordinate or a sequence (it need
            not satisfy the constraints).
        options
            See :func:`dalembert.statics.equilibrium` (``parameters``, ``t``,
            ``fixed``, tolerances...).

        Returns
        -------
        Equilibrium
            The configuration, the multipliers, the reactions at rest
            ``A^T lambda`` and the stability.

        Examples
        --------
        The Cartesian pendulum hangs straight down, its rod pulling ``m g`` upwards:

        >>> from dalembert.examples import load
        >>> pendulum = load("pendulum").build()
        >>> rest = pendulum.equilibrium({"x": 0.1, "y": -1.0})
        >>> round(abs(rest["x"]), 12), round(rest["y"], 12), rest.stability
        (0.0, -1.0, 'stable')
        """
        from .statics import equilibrium

        return equilibrium(self, guess, **options)

    def linearize(self, q_eq: Any, **options: Any) -> Linearization:
        """Small oscillations about an equilibrium, on the constraint manifold.

        Parameters
        ----------
        q_eq
            The equilibrium: an :class:`~dalembert.statics.Equilibrium` or a
            configuration (dict by coordinate or sequence).
        options
            See :func:`dalembert.statics.linearize`.

        Returns
        -------
        Linearization
            Natural frequencies, mode shapes in the original coordinates and a
            state-space form.

        Examples
        --------
        The pendulum's small oscillations have ``omega = sqrt(g / l)``:

        >>> from dalembert.examples import load
        >>> pendulum = load("pendulum").build()
        >>> modes = pendulum.linearize(pendulum.equilibrium({"x": 0.1, "y": -1.0}))
        >>> bool(abs(modes.natural_frequencies[0] - 9.81**0.5) < 1e-10)
        True
        """
        from .statics import linearize

        return linearize(self, q_eq, **options)

    def _trajectory(self, result: IntegrationResult, plan: SimulationPlan,
                    derived: dict[str, np.ndarray],
                    applied: np.ndarray | None = None) -> Trajectory:
        layout = StateLayout(len(self.coordinate_names))
        signal = plan.options.inputs
        arrays: dict[str, Any] = dict(derived)  # by Trajectory field
        energies = arrays.pop("energies")
        if applied is None and signal is not None:  # the inputs at the points recorded
            applied = np.array([_or_nan(signal, t, *layout.split(y), len(signal.names))
                                for t, y in zip(result.t, result.y)])
            applied = applied.reshape(len(result.t), len(signal.names))
        return Trajectory(
            t=result.t, q=layout.rows_q(result.y), qd=layout.rows_qd(result.y), **arrays,
            kinetic_energy=energies[:, 0], potential_energy=energies[:, 1],
            jacobi_integral=energies[:, 2], coordinate_names=self.coordinate_names,
            constraint_names=self.constraint_names, status=result.status,
            message=result.message, stats=result.stats, initialization=str(plan.initial),
            parameters={s.name: float(v) for s, v in zip(self.parameters, plan.parameters)},
            inputs=np.zeros((len(result.t), 0)) if applied is None else applied,
            input_names=tuple(u.name for u in self.inputs),
            t_events=result.t_events, y_events=result.y_events, sol=result.sol,
            energy_conserved=self.conserves_energy,
        )


def _restitution(row: UnilateralLaw, parameters: Mapping[str, float]) -> float:
    """A unilateral constraint's restitution: its number, or its parameter's value
    (checked here, where the values are known)."""
    if not isinstance(row.restitution, sp.Symbol):
        return row.restitution
    value = parameters[row.restitution.name]
    if not 0.0 <= value <= 1.0:
        raise ParameterError(f"the restitution of unilateral constraint {row.name!r}, the "
                             f"parameter {row.restitution.name!r}, must be in [0, 1]; got "
                             f"{value!r}")
    return value


def _or_nan(signal: InputSignal, t: float, q: np.ndarray, qd: np.ndarray,
            size: int) -> np.ndarray:
    try:
        return signal(t, q, qd)
    except InputError:
        return np.full(size, np.nan)


class _LazyLabels(Sequence):
    """``describe(i)`` for ``i < size``, each made on first access (printing is slow)."""

    def __init__(self, describe: Callable[[int], str], size: int) -> None:
        self._describe, self._size = describe, size

    def __len__(self) -> int:
        return self._size

    def __getitem__(self, i):
        if isinstance(i, slice):
            return [self[k] for k in range(*i.indices(self._size))]
        if not -self._size <= i < self._size:
            raise IndexError(i)
        return self._describe(i % self._size)
