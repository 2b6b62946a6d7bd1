"""Step-size control of the explicit Runge-Kutta methods: SciPy's, or PI control.

SciPy's :class:`~scipy.integrate.RungeKutta` solvers pick the next step from the
current error estimate alone, ``h *= 0.9 err^(-1/k)`` (``k``: the order of the
error estimator plus one). Where the step is limited by stability rather than
accuracy, as in a long pendulum chain at a loose tolerance or any mechanism with a
fast mode it does not need to resolve, that controller oscillates: a step past
the stability boundary is rejected, the next is cut, the error collapses, the step
grows past the boundary again. A third of the attempts can be wasted that way.

The PI controller (Gustafsson 1991; "PI.3.4" in Söderlind 2002; Hairer & Wanner,
*Solving ODEs II*, IV.2) also weighs the previous step's error,

    h *= 0.9 err^(-alpha) err_old^beta,   alpha = 0.7 / k,  beta = 0.4 / k,

which damps the oscillation. It is the default here (``step_control="PI"``);
``step_control="scipy"`` keeps SciPy's controller and so SciPy's steps. Both use
SciPy's safety factor and step limits, and never grow the step right after a
rejection; rejected steps shrink by ``0.9 err^(-alpha)`` (Hairer's DOPRI codes).

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

import numpy as np
from scipy.integrate import DOP853, RK23, RK45, OdeSolver

from ..options import StepController
from .scipy_ivp import MAX_FACTOR, MIN_FACTOR, SAFETY, RungeKutta, rk_step

#: PI.3.4's gains times k: alpha = 0.7 / k, beta = 0.4 / k.
PI_ALPHA, PI_BETA = 0.7, 0.4
#: The previous error is never taken below this (Hairer's DOPRI codes): a step with a
#: tiny error may not let the next one grow without bound.
ERROR_FLOOR = 1e-4


def controller_exponents(step_control: StepController,
                         error_estimator_order: int) -> tuple[float, float]:
    """``(alpha, beta)`` of the controller for a method with an error estimator of
    that order (``k`` = order + 1); SciPy's own controller is ``(1 / k, 0)``.

    >>> controller_exponents("PI", DOP853.error_estimator_order)
    (0.0875, 0.05)
    """
    k = error_estimator_order + 1
    if step_control == "scipy":
        return 1 / k, 0.0
    return PI_ALPHA / k, PI_BETA / k


class ControlledSteps(RungeKutta):
    """Mixin for a SciPy ``RungeKutta`` subclass: its steps under ``step_control``.

    The controller's state is ``err_old``, the error of the last accepted step
    (kept across restarts from a projected state: the step-size history is the
    integration's, not the state's).
    """

    def __init__(self, fun, t0, y0, t_bound, *, step_control: StepController = "PI",
                 **options) -> None:
        super().__init__(fun, t0, y0, t_bound, **options)
        self.step_control = step_control
        self.alpha, self.beta = controller_exponents(step_control, self.error_estimator_order)
        self.err_old = ERROR_FLOOR

    def _accepted_factor(self, err: float, rejected: bool) -> float:
        """The growth of the step after one accepted with error ``err``."""
        factor = MAX_FACTOR if err == 0 else min(
            MAX_FACTOR, SAFETY * err ** -self.alpha * self.err_old ** self.beta)
        self.err_old = max(err, ERROR_FLOOR)
        return min(1.0, factor) if rejected else factor

    def _step_impl(self):
        # SciPy's RungeKutta._step_impl with the controller's factors.
        t, y = self.t, self.y
        min_step = 10 * np.abs(np.nextafter(t, self.direction * np.inf) - t)
        h_abs = self.max_step if self.h_abs > self.max_step else max(self.h_abs, min_step)
        rejected = False
        while True:
            if h_abs < min_step:
                return False, self.TOO_SMALL_STEP
            t_new = t + h_abs * self.direction
            if self.direction * (t_new - self.t_bound) > 0:
                t_new = self.t_bound
            h = t_new - t
            h_abs = np.abs(h)
            y_new, f_new = rk_step(self.fun, t, y, self.f, h, self.A, self.B, self.C, self.K)
            scale = self.atol + np.maximum(np.abs(y), np.abs(y_new)) * self.rtol
            err = self._estimate_error_norm(self.K, h, scale)
            if err < 1:
                h_abs *= self._accepted_factor(err, rejected)
                break
            h_abs *= max(MIN_FACTOR, SAFETY * err ** -self.alpha)
            rejected = True
        self.h_previous, self.y_old = h, y
        self.t, self.y, self.h_abs, self.f = t_new, y_new, h_abs, f_new
        return True, None


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
