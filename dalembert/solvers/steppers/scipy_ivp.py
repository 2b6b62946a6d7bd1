"""The one door to SciPy's private solver internals (``scipy.integrate._ivp``).

Constrained dynamics restarts a solver from a projected state after every step,
steps SciPy's Runge-Kutta tableaus under its own step-size controller and in C,
and hands a solver back the state a stretch of steps run in C reached. All of
that reads or writes attributes SciPy does not document (``h_abs``, ``f``, ``K``,
``D``...) or imports names from its private modules. They are gathered here, so
that a SciPy release that renames one breaks one module, and
``tests/solvers/steppers/test_scipy_ivp.py`` says which name moved. ``pyproject.toml``
bounds SciPy to the releases tested against these names.

>>> from scipy.integrate import DOP853
>>> import numpy as np
>>> solver = DOP853(lambda t, y: -y, 0.0, np.ones(2), 1.0)
>>> restart(solver, np.array([0.5, 0.5]))
>>> solver.f
array([-0.5, -0.5])
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
import scipy.sparse
from scipy.integrate import BDF, DOP853, RK23, RK45, OdeSolver, Radau
from scipy.integrate._ivp import dop853_coefficients
from scipy.integrate._ivp.rk import (
    MAX_FACTOR,
    MIN_FACTOR,
    SAFETY,
    Dop853DenseOutput,
    RkDenseOutput,
    RungeKutta,
)

from ...numerics.state_layout import StateLayout
from ...options import StepController
from .controller import ControllerState, PIController
from .runge_kutta import ExplicitRungeKutta, Tableau, controlled_step
from .stiffness import StiffnessDetector, StiffnessState, h_lambda

if TYPE_CHECKING:
    from ..newton import Linearization

__all__ = [
    "CONTROLLED",
    "INTERPOLATOR_POWER",
    "MAX_FACTOR",
    "MIN_FACTOR",
    "SAFETY",
    "ControlledSteps",
    "LinearizedRadau",
    "RadauEnd",
    "StepEnd",
    "StepStart",
    "StepTolerances",
    "SteppedRadau",
    "controlled_class",
    "hand_over",
    "interpolant_form",
    "last_stages",
    "last_step_size",
    "restart",
    "restart_second_order",
    "roll_back",
    "snapshot",
    "step_inputs",
    "step_size",
    "step_start",
    "tableau_of",
    "take_state",
]

#: The number of rows of DOP853's dense-output polynomial.
INTERPOLATOR_POWER: int = dop853_coefficients.INTERPOLATOR_POWER


def tableau_of(cls: type[RungeKutta]) -> Tableau:
    """The coefficients of one of SciPy's explicit Runge-Kutta methods (class
    attributes SciPy does not document).

    Parameters
    ----------
    cls
        ``RK23``, ``RK45`` or ``DOP853`` (or a subclass).

    Examples
    --------
    >>> tb = tableau_of(DOP853)
    >>> tb.order, tb.n_stages, tb.D.shape[0] + 3 == INTERPOLATOR_POWER
    (8, 12, True)
    """
    s = cls.n_stages
    A = np.zeros((s, s))  # RK45 leaves out the last (zero) column
    A[:, :cls.A.shape[1]] = cls.A[:s, :s]
    if issubclass(cls, DOP853):
        return Tableau(cls.order, cls.error_estimator_order, A, cls.B, cls.C, cls.E5,
                       E3=cls.E3, A_extra=cls.A_EXTRA, C_extra=cls.C_EXTRA, D=cls.D)
    return Tableau(cls.order, cls.error_estimator_order, A, cls.B, cls.C, cls.E, P=cls.P)


def restart(solver: OdeSolver, y: np.ndarray) -> None:
    """Continue ``solver`` from ``y`` at its current time (a projected state).

    Parameters
    ----------
    solver
        A SciPy solver after an accepted step.
    y
        The state to continue from.
    """
    solver.y = y.copy()
    if isinstance(solver, BDF):
        solver.D[0] = y  # BDF's history: the newest entry is the state
    elif hasattr(solver, "f"):
        solver.f = solver.fun(solver.t, solver.y)


def restart_second_order(solver: OdeSolver, y: np.ndarray) -> None:
    """Continue ``solver`` from ``y = [q, qd]`` without evaluating ``f`` again, where
    that is safe (SciPy's explicit Runge-Kutta solvers); otherwise as :func:`restart`.

    The explicit Runge-Kutta solvers keep ``f = [qd, qdd]`` for their next step's
    first stage: ``qd`` is the state's, and ``qdd`` its last stage's, at the end
    before the projection. That ``qdd`` differs from the one at the projected state
    by about the projection's change ``d``, the size of the step's local error, and
    enters the next step multiplied by ``h``: a local error ``O(h d)``, an order
    above the step's own. One evaluation per step saved.

    Parameters
    ----------
    solver
        A SciPy solver after an accepted step.
    y
        The projected state ``[q, qd]``.
    """
    if isinstance(solver, RungeKutta):
        layout = StateLayout.of(y)
        solver.y = y.copy()
        solver.f = layout.join(layout.qd(y), layout.qd(solver.f))
    else:
        restart(solver, y)


#: What an explicit Runge-Kutta solver's next step depends on (the controller's
#: ``err_old`` too, where it keeps one).
_STEP_STATE = ("t", "t_old", "y", "f", "h_abs", "h_previous", "status", "err_old")


def snapshot(solver: OdeSolver) -> dict[str, object] | None:
    """What :func:`roll_back` needs to take ``solver``'s next step again, or ``None`` for
    a solver whose history cannot be restored (the implicit and multistep ones).

    >>> from scipy.integrate import RK45
    >>> solver = RK45(lambda t, y: -y, 0.0, np.ones(1), 1.0)
    >>> saved = snapshot(solver)
    >>> _ = solver.step()
    >>> roll_back(solver, saved, 0.01)
    >>> solver.t, solver.h_abs
    (0.0, 0.01)
    """
    if not isinstance(solver, RungeKutta):
        return None
    return {name: getattr(solver, name) for name in _STEP_STATE if hasattr(solver, name)}


def roll_back(solver: OdeSolver, saved: dict[str, object], h_abs: float) -> None:
    """Bring ``solver`` back to where :func:`snapshot` saw it, its next step ``h_abs``.

    Parameters
    ----------
    solver
        The explicit Runge-Kutta solver.
    saved
        Its :func:`snapshot` before the step taken back.
    h_abs
        The size of the step to try instead.
    """
    for name, value in saved.items():
        setattr(solver, name, value)
    solver.h_abs = h_abs


def take_state(solver: OdeSolver, *, t: float, t_old: float, y: np.ndarray, f: np.ndarray,
               h_abs: float, h_previous: float) -> None:
    """Bring an explicit Runge-Kutta ``solver`` to the end of steps taken elsewhere (in C).

    Parameters
    ----------
    solver
        The SciPy Runge-Kutta solver the steps were taken for.
    t, t_old
        The time reached and the start of the last step.
    y, f
        The state there and the right-hand side its next step starts from.
    h_abs, h_previous
        The next step size and the last one taken.
    """
    solver.t, solver.t_old, solver.h_previous = t, t_old, h_previous
    solver.y, solver.f, solver.h_abs = y, f, h_abs
    if solver.direction * (solver.t - solver.t_bound) >= 0:
        solver.status = "finished"


def step_inputs(solver: OdeSolver) -> dict[str, np.ndarray]:
    """What the solver's next step starts from, by name: the state, and where the
    solver keeps them, the derivative there (``f``) and the step size (``h_abs``).

    Parameters
    ----------
    solver
        A SciPy solver.
    """
    inputs = {"state": np.asarray(solver.y)}
    f = getattr(solver, "f", None)  # the explicit Runge-Kutta solvers and Radau
    if f is not None:
        inputs["derivative"] = np.asarray(f)
    h_abs = getattr(solver, "h_abs", None)  # all but LSODA
    if h_abs is not None:
        inputs["step size"] = np.asarray(h_abs)
    return inputs


def last_stages(solver: OdeSolver) -> np.ndarray | None:
    """The stage derivatives of an explicit Runge-Kutta solver's last attempted step
    (``K``), or ``None`` for other solvers.

    Parameters
    ----------
    solver
        A SciPy solver.
    """
    return np.asarray(solver.K) if isinstance(solver, RungeKutta) else None


def interpolant_form(dense: object) -> tuple[str, np.ndarray, np.ndarray] | None:
    """The numbers of an explicit Runge-Kutta step's interpolant, or ``None`` for
    another solver's.

    ``("power", y_old, R)``: ``y(x) = y_old + h sum_j R[j] x^(j + 1)`` (SciPy's
    ``RkDenseOutput``, ``R = Q^T``); ``("dop853", y_old, F)``: DOP853's, evaluated from
    the last row of ``F`` to the first, alternately times ``x`` and ``1 - x``
    (``Dop853DenseOutput``). ``x = (t - t_old) / h`` in both.

    Parameters
    ----------
    dense
        What the solver's ``dense_output()`` returned.
    """
    if isinstance(dense, RkDenseOutput):
        return "power", dense.y_old, dense.Q.T
    if isinstance(dense, Dop853DenseOutput):
        return "dop853", dense.y_old, dense.F
    return None


def step_size(solver: OdeSolver) -> float:
    """The size of the next step ``solver`` will try (0 for a solver without one).

    Parameters
    ----------
    solver
        A SciPy solver.
    """
    return float(getattr(solver, "h_abs", 0.0) or 0.0)


def last_step_size(solver: OdeSolver) -> float | None:
    """The size of the last step ``solver`` took, ``None`` before its first.

    Parameters
    ----------
    solver
        A SciPy solver.
    """
    return getattr(solver, "h_previous", None)


def hand_over(source: OdeSolver, target: OdeSolver, f: np.ndarray) -> None:
    """Bring the explicit Runge-Kutta ``target`` to where ``source`` stands (the careful
    steps handing a run back to the solver that steps in C), its next step as
    ``source``'s.

    Parameters
    ----------
    source, target
        SciPy Runge-Kutta solvers of the same problem.
    f
        The right-hand side at ``source``'s state, as ``target`` evaluates it.
    """
    take_state(target, t=source.t, t_old=source.t_old, y=source.y, f=f,
               h_abs=step_size(source), h_previous=last_step_size(source) or 0.0)


# SciPy's explicit Runge-Kutta classes stepping on our stepper contract: start-up,
# dense output and restarts stay SciPy's; each step is taken by
# :func:`~.runge_kutta.controlled_step` with the method's
# :class:`~.runge_kutta.ExplicitRungeKutta` and a :class:`~.controller.PIController`,
# PI control by default (``step_control="PI"``), SciPy's own under
# ``step_control="scipy"`` (:mod:`.controller` says why PI).


@dataclass(frozen=True, eq=False)
class StepStart:
    """Where a controlled solver's next step starts.

    Attributes
    ----------
    t, y, f
        The time, the state and the derivative there (the first stage).
    h_abs
        The step size to try first.
    state
        The controller's memory.
    """

    t: float
    y: np.ndarray
    f: np.ndarray
    h_abs: float
    state: ControllerState


@dataclass(frozen=True, eq=False)
class StepEnd:
    """An accepted step, as the solver continues from it.

    Attributes
    ----------
    y_old, h
        The state the step started from and its signed size.
    t, y, f
        Its end: the time, the state and the derivative there.
    h_abs
        The next step's size.
    state
        The controller's memory after it.
    h_lambda
        The step's stiffness estimate (:mod:`.stiffness`; NaN: not measured).
    """

    y_old: np.ndarray
    h: float
    t: float
    y: np.ndarray
    f: np.ndarray
    h_abs: float
    state: ControllerState
    h_lambda: float = float("nan")


@dataclass(frozen=True, eq=False)
class StepTolerances:
    """A solver's tolerances and largest step, as SciPy checked them (``atol`` one
    value per component)."""

    rtol: float
    atol: np.ndarray
    max_step: float


def _tolerances(solver: OdeSolver) -> StepTolerances:
    """A SciPy solver's tolerances and largest step, as it checked them (``atol`` one
    value per component)."""
    atol = np.ascontiguousarray(np.broadcast_to(solver.atol, (solver.n,)), dtype=np.float64)
    return StepTolerances(float(solver.rtol), atol, float(solver.max_step))


class ControlledSteps(RungeKutta):
    """Mixin for a SciPy ``RungeKutta`` subclass: its steps taken by our stepper under
    ``step_control``.

    ``controller`` is the controller's value (``step_control``'s unless one is given)
    and ``controller_state`` its memory (the
    error of the last accepted step), kept across restarts from a projected state: the
    step-size history is the integration's, not the state's.

    Each step is :meth:`take_step`, from a :class:`StepStart` to a :class:`StepEnd`
    (or the message saying why no step could be taken); a subclass taking its steps elsewhere (in
    C, :mod:`dalembert.solvers.native.runge_kutta`) overrides it alone, and reads what
    it needs through :attr:`tolerances` and :meth:`stage_storage`: this class alone
    reads and writes SciPy's solver attributes.
    """

    def __init__(self, fun, t0, y0, t_bound, *, step_control: StepController = "PI",
                 controller: PIController | None = None,
                 detector: StiffnessDetector | None = None, **options) -> None:
        super().__init__(fun, t0, y0, t_bound, **options)
        self.step_control = step_control
        self.controller = controller if controller is not None else \
            PIController.for_method(step_control, self.error_estimator_order)
        self.controller_state: ControllerState = self.controller.initial_state()
        self.stepper = ExplicitRungeKutta(tableau_of(type(self)))
        #: the stiffness detector (``None``: none) and its memory, kept across restarts
        self.detector = detector
        self.stiffness = StiffnessState()

    @property
    def stiff(self) -> bool:
        """Whether the stiffness detector (if any) says the problem is stiff."""
        return self.detector is not None and self.detector.stiff(self.stiffness)

    @property
    def err_old(self) -> float:
        """The controller's memory: the error of the last accepted step."""
        return self.controller_state.err_old

    @err_old.setter
    def err_old(self, value: float) -> None:
        self.controller_state = ControllerState(value)

    @property
    def tolerances(self) -> StepTolerances:
        """The tolerances and the largest step, as SciPy checked them."""
        return _tolerances(self)

    def stage_storage(self) -> np.ndarray:
        """SciPy's own stage array, one row per stage and the last step's end
        derivative after them (DOP853: room for its interpolant's extra stages); its
        dense output reads the stages from it."""
        return np.asarray(getattr(self, "K_extended", self.K))  # the array itself

    def take_step(self, start: StepStart) -> StepEnd | str:
        """One accepted step from ``start`` (attempts repeated, shorter, until one is
        accepted), or the message saying why none could be taken (the step became too
        small).

        Parameters
        ----------
        start
            Where the step starts (:func:`step_start`).
        """
        out = controlled_step(self.stepper, self.controller, start.state, self.fun,
                              start.t, start.y, start.f, start.h_abs,
                              direction=self.direction, t_bound=self.t_bound,
                              rtol=self.rtol, atol=self.atol, max_step=self.max_step,
                              K=self.stage_storage())
        step = out.step
        if step is None:
            return self.TOO_SMALL_STEP
        stiffness = h_lambda(self.stepper.tableau, step) if self.detector is not None \
            else float("nan")
        return StepEnd(step.y, step.h, step.t_new, step.y_new, step.f_new, out.h_abs,
                       out.state, stiffness)

    def _step_impl(self):
        end = self.take_step(step_start(self))
        if isinstance(end, str):
            return False, end
        self.h_previous, self.y_old = end.h, end.y_old
        self.t, self.y, self.h_abs, self.f = end.t, end.y, end.h_abs, end.f
        self.controller_state = end.state
        if self.detector is not None:
            self.stiffness = self.detector.note(self.stiffness, end.h_lambda)
        return True, None


def step_start(solver: ControlledSteps) -> StepStart:
    """Where ``solver``'s next step starts.

    Parameters
    ----------
    solver
        A controlled explicit Runge-Kutta solver.

    Examples
    --------
    >>> solver = ControlledRK45(lambda t, y: -y, 0.0, np.ones(1), 1.0)
    >>> start = step_start(solver)
    >>> start.t, start.f
    (0.0, array([-1.]))
    """
    return StepStart(solver.t, solver.y, solver.f, solver.h_abs, solver.controller_state)


class ControlledDOP853(ControlledSteps, DOP853):
    """:class:`scipy.integrate.DOP853` under ``step_control`` (PI by default).

    Its dense output is SciPy's, the three extra stages of the interpolant evaluated by
    :meth:`fill_extra_stages` (in C where the steps are).

    >>> sol = ControlledDOP853(lambda t, y: -y, 0.0, np.array([1.0]), 1.0, rtol=1e-8,
    ...                        atol=1e-10)
    >>> while sol.status == "running":
    ...     _ = sol.step()
    >>> bool(abs(sol.y[0] - np.exp(-1.0)) < 1e-8)
    True
    """

    def fill_extra_stages(self, t_old: float, h: float, y_old: np.ndarray,
                          K: np.ndarray) -> None:
        """Evaluate the interpolant's extra stages of the step from ``(t_old, y_old)`` of
        size ``h`` into the rows of ``K`` after the step's own (SciPy's evaluation).

        Parameters
        ----------
        t_old, h, y_old
            The step's start, signed size and initial state.
        K
            The stage rows (:meth:`stage_storage`).
        """
        for s, (a, c) in enumerate(zip(self.A_EXTRA, self.C_EXTRA), start=self.n_stages + 1):
            dy = np.dot(K[:s].T, a[:s]) * h
            K[s] = self.fun(t_old + c * h, y_old + dy)

    def _dense_output_impl(self):
        # SciPy's DOP853._dense_output_impl, its extra stages by fill_extra_stages
        K, h = self.K_extended, self.h_previous
        self.fill_extra_stages(self.t_old, h, self.y_old, K)
        F = np.empty((INTERPOLATOR_POWER, self.n), dtype=self.y_old.dtype)
        f_old, delta_y = K[0], self.y - self.y_old
        F[0] = delta_y
        F[1] = h * f_old - delta_y
        F[2] = 2 * delta_y - h * (self.f + f_old)
        F[3:] = h * np.dot(self.D, K)
        return Dop853DenseOutput(self.t_old, self.t, self.y_old, F)


class ControlledRK45(ControlledSteps, RK45):
    """:class:`scipy.integrate.RK45` under ``step_control`` (PI by default)."""


class ControlledRK23(ControlledSteps, RK23):
    """:class:`scipy.integrate.RK23` under ``step_control`` (PI by default)."""


CONTROLLED: dict[type[OdeSolver], type[OdeSolver]] = {
    DOP853: ControlledDOP853, RK45: ControlledRK45, RK23: ControlledRK23,
}


def controlled_class(cls: type[OdeSolver], step_control: StepController) -> type[OdeSolver]:
    """The class that integrates ``cls``'s method under ``step_control``: SciPy's
    explicit Runge-Kutta classes become their controlled versions under PI; other
    solvers (the implicit ones, controlled ones already, a user's) stay as they are."""
    if step_control == "PI" and cls in CONTROLLED:
        return CONTROLLED[cls]
    return cls


# SciPy's Radau with the linear algebra given. Its step builds the Newton matrices as
# ``MU / h * self.I - J`` and factors them with ``self.lu``, solving with
# ``self.solve_lu``, and gets ``J`` from ``self.jac(t, y, f)``: four attributes SciPy
# does not document. Here ``J`` is a linearization (``factor(c)`` solves
# ``(I - c J) x = b``, :mod:`dalembert.solvers.newton`), ``self.I`` turns
# ``MU / h * I - J`` into the pair ``(MU / h, J)``, and ``self.lu`` factors it as
# ``I - (h / MU) J``: ``(MU/h I - J) x = b`` is ``(I - (h/MU) J) x = (h/MU) b``. The
# Newton iteration, error estimate, step control and dense output stay SciPy's.


class _ShiftedIdentity:
    """``a * I - J`` as the pair ``(a, J)`` (see above)."""

    def __init__(self, a: complex = 1.0) -> None:
        self.a = a

    def __rmul__(self, a: complex) -> _ShiftedIdentity:
        return _ShiftedIdentity(a * self.a)

    def __sub__(self, lin: Linearization) -> tuple[complex, Linearization]:
        return self.a, lin


class LinearizedRadau(Radau):
    """SciPy's Radau IIA (order 5) solving its Newton systems with a given
    linearization (see the comment above) instead of a Jacobian matrix.

    Parameters
    ----------
    fun, t0, y0, t_bound
        As SciPy's solvers take them.
    linearize
        ``linearize(t, y, f)``: an object whose ``factor(c)`` returns a solve of
        ``(I - c J) x = b`` for real and complex ``c`` (:mod:`dalembert.solvers.newton`).
    options
        Radau's other keywords (``rtol``, ``atol``, ``max_step``, ``first_step``).

    Examples
    --------
    The same steps as SciPy's Radau given the Jacobian as a function:

    >>> from dalembert.solvers.newton import dense_linearization
    >>> J = np.array([[0.0, 1.0], [-1e4, -10.0]])
    >>> solvers = [LinearizedRadau(lambda t, y: J @ y, 0.0, np.array([1.0, 0.0]), 1.0,
    ...                            linearize=dense_linearization(lambda t, y: J)),
    ...            Radau(lambda t, y: J @ y, 0.0, np.array([1.0, 0.0]), 1.0,
    ...                  jac=lambda t, y: J)]
    >>> for solver in solvers:
    ...     while solver.status == "running":
    ...         _ = solver.step()
    >>> bool(np.allclose(solvers[0].y, solvers[1].y, rtol=0, atol=1e-12))
    True
    >>> solvers[0].nlu == solvers[1].nlu, solvers[0].njev == solvers[1].njev
    (True, True)
    """

    def __init__(self, fun, t0, y0, t_bound, *, linearize, **options) -> None:
        n = len(y0)
        # a zero sparse Jacobian: SciPy's set-up then takes its sparse branch, which
        # allocates no dense identity; everything it set up for it is replaced below
        super().__init__(fun, t0, y0, t_bound, jac=scipy.sparse.csc_matrix((n, n)),
                         **options)

        def jac(t: float, y: np.ndarray, f: np.ndarray) -> Linearization:
            self.njev += 1
            return linearize(t, y, f)

        def lu(shifted: tuple[complex, Linearization]):
            a, lin = shifted
            self.nlu += 1
            solve = lin.factor(1.0 / a)
            return lambda b: solve(b / a)

        self.jac, self.lu, self.I = jac, lu, _ShiftedIdentity()
        self.solve_lu = lambda LU, b: LU(b)
        self.njev = 0
        self.J = self.jac(self.t, self.y, self.f)


# SciPy's Radau with each step taken elsewhere (in C: native/radau.py). Its start-up
# (the first derivative and step size), dense output (``RadauDenseOutput`` from the
# step's stages ``Z``) and restarts stay SciPy's; a step writes back the attributes
# SciPy's own ``_step_impl`` leaves (``h_abs_old`` and ``error_norm_old`` for the
# step-size predictor, ``Z`` and ``sol`` for the dense output and the next step's
# Newton guess).


@dataclass(frozen=True, eq=False)
class RadauEnd:
    """An accepted Radau step, as SciPy's Radau continues from it.

    Attributes
    ----------
    t_old, y_old
        Its start.
    t, y, f
        Its end: the time, the state and the derivative there.
    Z
        The stage increments (``3 x n``): the collocation polynomial.
    h_abs
        The next step's size.
    h_abs_old, error_norm_old
        The step-size predictor's memory (``None``: none).
    """

    t_old: float
    y_old: np.ndarray
    t: float
    y: np.ndarray
    f: np.ndarray
    Z: np.ndarray
    h_abs: float
    h_abs_old: float | None
    error_norm_old: float | None


class SteppedRadau(Radau):
    """SciPy's Radau IIA whose steps :meth:`take_step` takes (see the comment above).

    Parameters
    ----------
    fun, t0, y0, t_bound
        As SciPy's solvers take them.
    options
        Radau's other keywords (``rtol``, ``atol``, ``max_step``, ``first_step``).
    """

    def __init__(self, fun, t0, y0, t_bound, **options) -> None:
        n = len(y0)
        # a zero sparse Jacobian: SciPy's set-up then makes no dense matrix and evaluates
        # no Jacobian; the steps' linear algebra is take_step's
        super().__init__(fun, t0, y0, t_bound, jac=scipy.sparse.csc_matrix((n, n)),
                         **options)

    @property
    def newton_tolerance(self) -> float:
        """SciPy's tolerance of the Newton iteration (from ``rtol``)."""
        return float(self.newton_tol)

    @property
    def tolerances(self) -> StepTolerances:
        """The tolerances and the largest step, as SciPy checked them."""
        return _tolerances(self)

    def take_step(self, t: float, y: np.ndarray, f: np.ndarray, h_abs: float
                  ) -> RadauEnd | str:
        """One accepted step from ``(t, y)`` (``f`` the derivative there, ``h_abs`` the
        size to try first), or the message saying why none could be taken.

        Parameters
        ----------
        t, y, f
            Where the step starts.
        h_abs
            The step size to try first.
        """
        raise NotImplementedError

    def _step_impl(self):
        end = self.take_step(self.t, self.y, self.f, self.h_abs)
        if isinstance(end, str):
            return False, end
        self.t_old, self.y_old = end.t_old, end.y_old
        self.t, self.y, self.f, self.Z = end.t, end.y, end.f, end.Z
        self.h_abs, self.h_abs_old, self.error_norm_old = end.h_abs, end.h_abs_old, \
            end.error_norm_old
        self.sol = self._compute_dense_output()
        return True, None
