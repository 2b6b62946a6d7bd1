"""``System``: the one object a user builds, derives and simulates.

It ties the layers together (model -> equations -> generated code -> solver ->
trajectory) and caches each stage, so the equations are derived and the numeric
code generated once per System however often it is simulated.
"""

from __future__ import annotations

import warnings
from collections.abc import Callable, Mapping, Sequence
from functools import cached_property

import numpy as np

from .codegen import compiled as codegen
from .codegen.compiled import CompiledEquations, NumericModel
from .equations.lagrange import Equations, derive_equations
from .errors import InitialConditionsAdjusted, IntegrationWarning, RedundantConstraintsWarning
from .model.forces import PointForce
from .model.model import Model, build_model
from .model.parameters import parameter_values, resolve_parameters
from .model.values import coordinate_values
from .solvers.engine import choose_engine
from .solvers.initialization import InitializationReport, consistent_state
from .solvers.integrate import IntegrationResult, integrate
from .solvers.kkt import REDUNDANT_MODES
from .solvers.native.library import prepare_runtime
from .solvers.step_control import check_step_control
from .statics import Equilibrium, Linearization
from .statics import equilibrium as _equilibrium
from .statics import linearize as _linearize
from .trajectory import Trajectory

STABILIZATIONS = ("projection", "baumgarte", None)


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
    redundant_constraints
        Dependent (redundant) constraints, detected at the initial state:
        ``"minimum-norm"`` (default) proceeds with a
        :class:`~dalembert.solvers.kkt.RedundantConstraintsWarning` naming them; the
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

    def __init__(
        self,
        coordinates: object,
        *,
        kinetic: object = None,
        potential: object = None,
        lagrangian: object = None,
        constraints: object = (),
        generalized_forces: Mapping[object, object] | Sequence[object] | None = None,
        forces: Sequence[PointForce] = (),
        parameters: Mapping[object, object] | None = None,
        velocities: Sequence[object] | None = None,
        name: str = "system",
        redundant_constraints: str = "minimum-norm",
    ) -> None:
        self.redundant_constraints = _check_redundant(redundant_constraints)
        self.model: Model = build_model(
            coordinates, kinetic=kinetic, potential=potential, lagrangian=lagrangian,
            constraints=constraints, generalized_forces=generalized_forces, forces=forces,
            velocities=velocities, name=name,
        )
        self.parameter_values = parameter_values(self.model.parameters, parameters)

    # -- description -----------------------------------------------------------------
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
    def parameters(self) -> tuple:
        """The model's parameter symbols (sorted by name)."""
        return self.model.parameters

    @property
    def degrees_of_freedom(self) -> int:
        """Coordinates minus constraint rows.

        With dependent (redundant) constraints this undercounts; the true number,
        ``n - rank(A)`` at a state, is ``consistent_initial_state(q0).degrees_of_freedom``.
        """
        return len(self.coordinate_names) - len(self.constraint_names)

    def describe_constraint(self, i: int) -> str:
        """Constraint ``i`` for a message: its name, kind and equation."""
        return self.model.constraints.describe(i)

    def __repr__(self) -> str:
        return (f"System({self.name!r}, coordinates={list(self.coordinate_names)}, "
                f"constraints={list(self.constraint_names)})")

    # -- equations and code ----------------------------------------------------------
    def equations(self) -> Equations:
        """The symbolic constrained equations ``M qdd = f + A^T lambda``, ``A qdd = c``."""
        return self._equations

    @cached_property
    def _equations(self) -> Equations:
        return derive_equations(self.model)

    @cached_property
    def compiled(self) -> CompiledEquations:
        """Generated numeric functions (made on first use, then reused)."""
        prepare_runtime()  # the C loop compiles beside the derivation
        return self._compile()

    def _compile(self) -> CompiledEquations:
        # Looked up on the module so that tests (and profilers) can wrap it.
        return codegen.compile_equations(self._equations)

    def numeric(self, parameters: Mapping[object, object] | None = None) -> NumericModel:
        """The compiled equations bound to parameter values."""
        p = resolve_parameters(self.parameters, self.parameter_values, parameters)
        return self.compiled.bind(p)

    # -- simulation ------------------------------------------------------------------
    def consistent_initial_state(
        self,
        q0: object,
        qd0: object = None,
        *,
        t0: float = 0.0,
        fixed: Sequence[object] | None = None,
        parameters: Mapping[object, object] | None = None,
        redundant_constraints: str | None = None,
    ) -> InitializationReport:
        """Project ``(q0, qd0)`` onto the constraints (least change); ``fixed`` stay put.

        The report also gives the true degrees of freedom ``n - rank(A)`` there
        (``report.degrees_of_freedom``) and the dependent constraints
        (``report.dependent_constraints``).
        """
        names = self.coordinate_names
        q = coordinate_values(q0, names, "q0")
        qd = coordinate_values(qd0, names, "qd0")
        labels = _LazyLabels(self.describe_constraint, len(self.constraint_names))
        mode = self.redundant_constraints if redundant_constraints is None \
            else _check_redundant(redundant_constraints)
        return consistent_state(self.numeric(parameters), t0, q, qd, names, labels, fixed,
                                constraint_names=self.constraint_names,
                                redundant_constraints=mode)

    def simulate(
        self,
        t_span: Sequence[float],
        q0: object,
        qd0: object = None,
        *,
        t_eval: Sequence[float] | None = None,
        method: str = "DOP853",
        rtol: float = 1e-11,
        atol: float = 1e-13,
        stabilization: str | None = "projection",
        baumgarte_gain: float = 10.0,
        parameters: Mapping[object, object] | None = None,
        fixed: Sequence[object] | None = None,
        events: Sequence[Callable] = (),
        dense_output: bool = False,
        progress: bool = False,
        redundant_constraints: str | None = None,
        native: bool | None = None,
        step_control: str = "PI",
        **options: object,
    ) -> Trajectory:
        """Integrate the constrained equations of motion over ``t_span``.

        Like :func:`scipy.integrate.solve_ivp`: ``method`` is any of its solvers
        (``"DOP853"`` default, ``"Radau"``/``"BDF"`` for stiff mechanisms), ``t_eval``
        picks output times, ``events`` are functions ``event(t, q, qd)`` with optional
        ``terminal``/``direction`` attributes, ``dense_output`` adds ``traj.sol(t)``;
        other keywords (``max_step``, ``first_step``...) go to the solver.

        Initial values are first projected onto the constraints (least change,
        ``fixed`` coordinates held; a warning reports what changed).
        ``stabilization`` is ``"projection"`` (positions and velocities projected after
        every step: no tuning, residuals at rounding level), ``"baumgarte"`` (gain
        ``baumgarte_gain``, see :mod:`dalembert.solvers.dynamics`) or ``None`` (raw
        drift). A failure or Ctrl-C returns the part computed so far with
        ``success=False`` and an :class:`~dalembert.errors.IntegrationWarning`.
        ``redundant_constraints`` overrides the System's option of that name.
        ``native`` chooses the simulation loop: ``None`` runs it in C when it applies
        (C-generated functions, independent constraints, a block-structured mass
        matrix; see :mod:`dalembert.solvers.native`), ``True`` requires that,
        ``False`` keeps it in Python. Both give the same trajectory to rounding.
        ``step_control`` is the explicit Runge-Kutta methods' step-size controller:
        ``"PI"`` (default; fewer rejected steps where stability limits the step, see
        :mod:`dalembert.solvers.step_control`) or ``"scipy"`` (``solve_ivp``'s steps).
        """
        if stabilization not in STABILIZATIONS:
            raise ValueError(
                f"stabilization must be one of {STABILIZATIONS}, not {stabilization!r}"
            )
        t_span = _check_span(t_span)
        _check_tolerances(rtol, atol)
        check_step_control(step_control)
        num = self.numeric(parameters)
        report = self.consistent_initial_state(q0, qd0, t0=t_span[0], fixed=fixed,
                                               parameters=parameters,
                                               redundant_constraints=redundant_constraints)
        if report.changed:
            warnings.warn(report.describe_changes(), InitialConditionsAdjusted, stacklevel=2)
        if report.dependent_constraints:
            warnings.warn(str(report.rank), RedundantConstraintsWarning, stacklevel=2)
        kept = report.rank.kept if report.rank is not None else None
        y0 = np.concatenate([report.q, report.qd])
        engine = choose_engine(
            num, t_span[0], y0, method, projection=stabilization == "projection",
            baumgarte=baumgarte_gain if stabilization == "baumgarte" else 0.0, kept=kept,
            native=native)
        result = integrate(
            engine.rhs, t_span, y0, method=engine.method,
            t_eval=_check_t_eval(t_eval, t_span), dense_output=dense_output,
            events=[_state_event(e, num.n) for e in events], project=engine.project,
            progress=progress, step_control=step_control, rtol=rtol, atol=atol,
            **engine.options, **options,
        )
        if not result.success:
            warnings.warn(f"{result.message}; returning the trajectory up to "
                          f"t={result.t[-1] if len(result.t) else t_span[0]:.6g}",
                          IntegrationWarning, stacklevel=2)
        return self._trajectory(result, report, engine.outputs)

    # -- rest and small oscillations -------------------------------------------------
    def equilibrium(self, guess: object, **options: object) -> Equilibrium:
        """Static equilibrium near ``guess``: ``f(q, 0, t) + A^T lambda = 0``, ``psi(q) = 0``.

        Returns the configuration, the multipliers, the reactions at rest
        ``A^T lambda`` and the stability; see :func:`dalembert.statics.equilibrium`.
        """
        return _equilibrium(self, guess, **options)

    def linearize(self, q_eq: object, **options: object) -> Linearization:
        """Small oscillations about an equilibrium, on the constraint manifold.

        Natural frequencies, mode shapes in the original coordinates and a
        state-space form; see :func:`dalembert.statics.linearize`.
        """
        return _linearize(self, q_eq, **options)

    def _trajectory(
        self, result: IntegrationResult, report: InitializationReport, outputs: Callable,
    ) -> Trajectory:
        n = len(self.coordinate_names)
        derived = outputs(result.t, result.y)
        energies = derived.pop("energies")
        return Trajectory(
            t=result.t, q=result.y[:, :n], qd=result.y[:, n:], **derived,
            kinetic_energy=energies[:, 0], potential_energy=energies[:, 1],
            jacobi_integral=energies[:, 2], coordinate_names=self.coordinate_names,
            constraint_names=self.constraint_names, status=result.status,
            message=result.message, stats=result.stats, initialization=str(report),
            t_events=result.t_events, y_events=result.y_events, sol=result.sol,
        )


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


def _check_redundant(mode: str) -> str:
    if mode not in REDUNDANT_MODES:
        raise ValueError(f"redundant_constraints must be one of {REDUNDANT_MODES}, not {mode!r}")
    return mode


def _check_span(t_span: Sequence[float]) -> tuple[float, float]:
    try:
        t0, tf = (float(v) for v in t_span)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"t_span must be two numbers (t0, tf), got {t_span!r}") from exc
    if not (np.isfinite(t0) and np.isfinite(tf)) or t0 == tf:
        raise ValueError(f"t_span must be two different finite times, got {t_span!r}")
    return t0, tf


def _check_tolerances(rtol: float, atol: float) -> None:
    if not (np.all(np.asarray(rtol) > 0) and np.all(np.asarray(atol) > 0)):
        raise ValueError(f"rtol and atol must be positive, got rtol={rtol}, atol={atol}")


def _check_t_eval(t_eval: Sequence[float] | None, t_span: tuple[float, float]):
    if t_eval is None:
        return None
    t_eval = np.asarray(t_eval, dtype=float)
    lo, hi = min(t_span), max(t_span)
    if t_eval.ndim != 1 or np.any((t_eval < lo) | (t_eval > hi)):
        raise ValueError("t_eval must be a 1-D array of times inside t_span")
    d = np.diff(t_eval) * np.sign(t_span[1] - t_span[0])
    if np.any(d <= 0):
        raise ValueError("t_eval must be strictly ordered in the direction of integration")
    return t_eval


def _state_event(event: Callable, n: int) -> Callable:
    """Adapt ``event(t, q, qd)`` to SciPy's ``event(t, y)``, keeping its attributes."""

    def wrapped(t: float, y: np.ndarray) -> float:
        return event(t, y[:n], y[n:])

    wrapped.terminal = getattr(event, "terminal", False)
    wrapped.direction = getattr(event, "direction", 0)
    return wrapped
