"""SciPy's explicit Runge-Kutta solvers stepping on our stepper contract.

The loops drive SciPy ``OdeSolver`` objects (start-up, dense output, the restarts of
:mod:`.scipy_ivp`); their steps are ours: :func:`~.runge_kutta.controlled_step`
with the method's :class:`~.runge_kutta.ExplicitRungeKutta` and a
:class:`~.controller.PIController`, PI control by default
(``step_control="PI"``), SciPy's own under ``step_control="scipy"`` (the
:mod:`.controller` module says why PI).

Example:

>>> import numpy as np
>>> sol = ControlledDOP853(lambda t, y: -y, 0.0, np.array([1.0]), 1.0, rtol=1e-8,
...                        atol=1e-10)
>>> while sol.status == "running":
...     _ = sol.step()
>>> bool(abs(sol.y[0] - np.exp(-1.0)) < 1e-8)
True
"""

from __future__ import annotations

from scipy.integrate import DOP853, RK23, RK45, OdeSolver

from ...options import StepController
from .controller import ControllerState, PIController
from .runge_kutta import ExplicitRungeKutta, controlled_step
from .scipy_ivp import RungeKutta, tableau_of


class ControlledSteps(RungeKutta):
    """Mixin for a SciPy ``RungeKutta`` subclass: its steps taken by our stepper under
    ``step_control``.

    ``controller`` is the controller's value (``step_control``'s unless one is given)
    and ``controller_state`` its memory (the
    error of the last accepted step), kept across restarts from a projected state: the
    step-size history is the integration's, not the state's.
    """

    def __init__(self, fun, t0, y0, t_bound, *, step_control: StepController = "PI",
                 controller: PIController | None = None, **options) -> None:
        super().__init__(fun, t0, y0, t_bound, **options)
        self.step_control = step_control
        self.controller = controller if controller is not None else \
            PIController.for_method(step_control, self.error_estimator_order)
        self.controller_state: ControllerState = self.controller.initial_state()
        self.stepper = ExplicitRungeKutta(tableau_of(type(self)))

    @property
    def err_old(self) -> float:
        """The controller's memory: the error of the last accepted step."""
        return self.controller_state.err_old

    @err_old.setter
    def err_old(self, value: float) -> None:
        self.controller_state = ControllerState(value)

    def _step_impl(self):
        out = controlled_step(self.stepper, self.controller, self.controller_state, self.fun,
                              self.t, self.y, self.f, self.h_abs, direction=self.direction,
                              t_bound=self.t_bound, rtol=self.rtol, atol=self.atol,
                              max_step=self.max_step, K=self._stage_storage())
        step = out.step
        if step is None:
            return False, self.TOO_SMALL_STEP
        self.h_previous, self.y_old = step.h, step.y
        self.t, self.y, self.h_abs, self.f = step.t_new, step.y_new, out.h_abs, step.f_new
        self.controller_state = out.state
        return True, None

    def _stage_storage(self):
        """SciPy's own stage array (its dense output reads the stages from it)."""
        return getattr(self, "K_extended", self.K)


class ControlledDOP853(ControlledSteps, DOP853):
    """:class:`scipy.integrate.DOP853` under ``step_control`` (PI by default)."""


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
