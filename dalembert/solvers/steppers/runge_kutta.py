"""Explicit Runge-Kutta steps on the stepper contract (see :mod:`.`).

A method is a :class:`Tableau` (SciPy's coefficients for RK23, RK45 and DOP853, read
through :func:`dalembert.solvers.steppers.scipy_ivp.tableau_of`); :class:`ExplicitRungeKutta`
takes one attempt and gives an accepted step's interpolant, and
:func:`controlled_step` joins it to a :class:`~.controller.PIController`. The
formulas and the order of the floating-point operations are SciPy's, so the steps
under ``step_control="scipy"`` are SciPy's own, bit for bit (tested).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from .controller import ControllerState, PIController

Rhs = Callable[[float, np.ndarray], np.ndarray]


@dataclass(frozen=True, eq=False)
class Tableau:
    """An explicit Runge-Kutta method with an embedded error estimate and an interpolant.

    Attributes
    ----------
    order, error_estimator_order
        The orders of the step and of its error estimate.
    A, B, C
        The Butcher tableau (``A``: ``s x s``, strictly lower).
    E
        Weights of the error estimate over the ``s + 1`` stages (the last: ``f`` at the
        new point); DOP853's fifth-order one.
    E3
        DOP853's third-order estimate, combined with ``E`` as Hairer's code does; or
        ``None``.
    P
        The interpolant's coefficients (``(s + 1) x k``: ``y(t + x h) = y + h K^T P
        [x, x^2, ...]``), or ``None`` for DOP853's form.
    A_extra, C_extra, D
        DOP853's interpolant: its extra stages and the coefficients of its polynomial.
    """

    order: int
    error_estimator_order: int
    A: np.ndarray
    B: np.ndarray
    C: np.ndarray
    E: np.ndarray
    E3: np.ndarray | None = None
    P: np.ndarray | None = None
    A_extra: np.ndarray | None = None
    C_extra: np.ndarray | None = None
    D: np.ndarray | None = None

    @property
    def n_stages(self) -> int:
        return len(self.B)


@dataclass(frozen=True, eq=False)
class Attempt:
    """One attempted step from ``t`` to ``t + h``.

    Attributes
    ----------
    t, h, t_new
        Its start, signed size and end (``t_new``: the end time asked for, which
        ``t + h`` gives to rounding).
    y, y_new, f_new
        The state at ``t``, and the state and derivative at ``t + h``.
    K
        The stages (``s + 1`` rows, the last ``f_new``; DOP853: room for the
        interpolant's extra stages after them).
    error
        The error norm against the scale ``atol + rtol max(|y|, |y_new|)``: accepted
        below 1.
    """

    t: float
    h: float
    t_new: float
    y: np.ndarray
    y_new: np.ndarray
    f_new: np.ndarray
    K: np.ndarray
    error: float


class ExplicitRungeKutta:
    """The stepper of one explicit Runge-Kutta method.

    Parameters
    ----------
    tableau
        The method.

    Examples
    --------
    One step of DOP853 on ``y' = -y``:

    >>> from scipy.integrate import DOP853
    >>> from dalembert.solvers.steppers.scipy_ivp import tableau_of
    >>> rk = ExplicitRungeKutta(tableau_of(DOP853))
    >>> y0 = np.array([1.0])
    >>> step = rk.attempt(lambda t, y: -y, 0.0, y0, -y0, 0.1, rtol=1e-8, atol=1e-10)
    >>> bool(abs(step.y_new[0] - np.exp(-0.1)) < 1e-12), step.error < 1
    (True, True)
    """

    def __init__(self, tableau: Tableau) -> None:
        self.tableau = tableau
        s = tableau.n_stages
        extra = 0 if tableau.C_extra is None else len(tableau.C_extra)
        self._rows = s + 1 + extra

    def attempt(self, fun: Rhs, t: float, y: np.ndarray, f: np.ndarray, h: float, *,
                rtol: float | np.ndarray, atol: float | np.ndarray,
                K: np.ndarray | None = None, t_new: float | None = None) -> Attempt:
        """Attempt the step of signed size ``h`` from ``(t, y)``, ``f = fun(t, y)``.

        Parameters
        ----------
        fun
            The right-hand side ``fun(t, y)``.
        t, y, f
            Where the step starts and the derivative there.
        h
            The signed step.
        rtol, atol
            The tolerances of the error's scale.
        K
            Storage for the stages (reused between attempts), or ``None``.
        t_new
            The end time the step was made for (default ``t + h``).
        """
        tb = self.tableau
        if K is None:
            K = np.empty((self._rows, y.size))
        s = tb.n_stages
        K[0] = f
        for i, (a, c) in enumerate(zip(tb.A[1:], tb.C[1:]), start=1):
            dy = np.dot(K[:i].T, a[:i]) * h
            K[i] = fun(t + c * h, y + dy)
        y_new = y + h * np.dot(K[:s].T, tb.B)
        f_new = fun(t + h, y_new)
        K[s] = f_new
        scale = atol + np.maximum(np.abs(y), np.abs(y_new)) * rtol
        return Attempt(t, h, t + h if t_new is None else t_new, y, y_new, f_new, K,
                       self._error_norm(K[:s + 1], h, scale))

    def _error_norm(self, K: np.ndarray, h: float, scale: np.ndarray) -> float:
        tb = self.tableau
        if tb.E3 is None:
            err = np.dot(K.T, tb.E) * h / scale
            return float(np.linalg.norm(err) / err.size ** 0.5)
        err5 = np.dot(K.T, tb.E) / scale  # DOP853: Hairer's combined estimate
        err3 = np.dot(K.T, tb.E3) / scale
        err5_norm_2 = np.linalg.norm(err5) ** 2
        err3_norm_2 = np.linalg.norm(err3) ** 2
        if err5_norm_2 == 0 and err3_norm_2 == 0:
            return 0.0
        denom = err5_norm_2 + 0.01 * err3_norm_2
        return float(np.abs(h) * err5_norm_2 / np.sqrt(denom * len(scale)))

    def interpolant(self, fun: Rhs, step: Attempt) -> Callable[[float], np.ndarray]:
        """``y(t)`` on an accepted step ``[step.t, step.t + step.h]`` (DOP853's
        evaluates its three extra stages first).

        Parameters
        ----------
        fun
            The right-hand side the step was taken with.
        step
            The accepted attempt.
        """
        tb, K, h, y_old = self.tableau, step.K, step.h, step.y
        if tb.P is not None:
            Q = K[:tb.n_stages + 1].T.dot(tb.P)

            def power(t: float) -> np.ndarray:
                x = (t - step.t) / h
                p = np.cumprod(np.full(Q.shape[1], x))
                return y_old + h * np.dot(Q, p)

            return power
        assert tb.A_extra is not None and tb.C_extra is not None and tb.D is not None
        start = tb.n_stages + 1
        for i, (a, c) in enumerate(zip(tb.A_extra, tb.C_extra), start=start):
            dy = np.dot(K[:i].T, a[:i]) * h
            K[i] = fun(step.t + c * h, y_old + dy)
        F = np.empty((tb.D.shape[0] + 3, y_old.size))
        f_old, delta_y = K[0], step.y_new - y_old
        F[0] = delta_y
        F[1] = h * f_old - delta_y
        F[2] = 2 * delta_y - h * (step.f_new + f_old)
        F[3:] = h * np.dot(tb.D, K)

        def dop853(t: float) -> np.ndarray:
            x = (t - step.t) / h
            y = np.zeros_like(y_old)
            for i, f in enumerate(reversed(F)):
                y += f
                y *= x if i % 2 == 0 else 1 - x
            return y + y_old

        return dop853


@dataclass(frozen=True, eq=False)
class ControlledStep:
    """What :func:`controlled_step` returns: the accepted attempt (``None`` if the step
    became too small), the next step size and the controller's new state."""

    step: Attempt | None
    h_abs: float
    state: ControllerState


def controlled_step(stepper: ExplicitRungeKutta, controller: PIController,
                    state: ControllerState, fun: Rhs, t: float, y: np.ndarray,
                    f: np.ndarray, h_abs: float, *, direction: float, t_bound: float,
                    rtol: float | np.ndarray, atol: float | np.ndarray,
                    max_step: float = np.inf, K: np.ndarray | None = None) -> ControlledStep:
    """Attempt steps from ``(t, y)`` until one is accepted, as SciPy's solvers do:
    the step starts at ``h_abs`` (within ``max_step`` and SciPy's smallest step), ends
    at ``t_bound`` at the latest, and shrinks after each rejection.

    Parameters
    ----------
    stepper, controller, state
        The method, the controller and its state before this step.
    fun, t, y, f
        The right-hand side, where the step starts and the derivative there.
    h_abs
        The step size to try first.
    direction, t_bound
        The direction of integration (+1 or -1) and where it ends.
    rtol, atol, max_step
        Tolerances and the largest step.
    K
        Storage for the stages, or ``None``.

    Examples
    --------
    >>> from scipy.integrate import RK45
    >>> from dalembert.solvers.steppers.scipy_ivp import tableau_of
    >>> pi = PIController.for_method("PI", 4)
    >>> out = controlled_step(ExplicitRungeKutta(tableau_of(RK45)), pi, pi.initial_state(),
    ...                       lambda t, y: -y, 0.0, np.ones(1), -np.ones(1), 0.5,
    ...                       direction=1.0, t_bound=1.0, rtol=1e-6, atol=1e-9)
    >>> out.step is not None and bool(out.step.h < 0.5), bool(out.h_abs < 0.5)
    (True, True)
    """
    min_step = 10 * np.abs(np.nextafter(t, direction * np.inf) - t)
    h_abs = max_step if h_abs > max_step else max(h_abs, min_step)
    rejected = False
    while True:
        if h_abs < min_step:
            return ControlledStep(None, h_abs, state)
        t_new = t + h_abs * direction
        if direction * (t_new - t_bound) > 0:
            t_new = t_bound
        h = t_new - t
        h_abs = np.abs(h)
        step = stepper.attempt(fun, t, y, f, h, rtol=rtol, atol=atol, K=K, t_new=t_new)
        if step.error < 1:
            factor, state = controller.accepted(state, step.error, rejected)
            return ControlledStep(step, h_abs * factor, state)
        h_abs *= controller.rejected(step.error)
        rejected = True
