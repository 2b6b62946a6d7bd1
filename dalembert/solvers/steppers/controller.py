"""The step-size controller: a frozen value, its memory passed in and out.

SciPy's explicit Runge-Kutta solvers pick the next step from the current error
estimate alone, ``h *= 0.9 err^(-1/k)`` (``k``: the order of the error estimator plus
one). Where the step is limited by stability rather than accuracy, as in a long
pendulum chain at a loose tolerance or any mechanism with a fast mode it does not
need to resolve, that controller oscillates: a step past the stability boundary is
rejected, the next is cut, the error collapses, the step grows past the boundary
again. A third of the attempts can be wasted that way.

The PI controller (Gustafsson 1991; "PI.3.4" in Söderlind 2002; Hairer & Wanner,
*Solving ODEs II*, IV.2) also weighs the previous step's error,

    h *= 0.9 err^(-alpha) err_old^beta,   alpha = 0.7 / k,  beta = 0.4 / k,

which damps the oscillation. It is the default (``step_control="PI"``);
``step_control="scipy"`` is SciPy's controller (``beta = 0``) and so SciPy's steps.
Both use SciPy's safety factor and step limits, and never grow the step right after
a rejection; rejected steps shrink by ``0.9 err^(-alpha)`` (Hairer's DOPRI codes).
"""

from __future__ import annotations

from dataclasses import dataclass

from ...options import StepController

#: PI.3.4's gains times k: alpha = 0.7 / k, beta = 0.4 / k.
PI_ALPHA, PI_BETA = 0.7, 0.4


@dataclass(frozen=True)
class ControllerState:
    """What the controller remembers between steps: ``err_old``, the error of the last
    accepted step (never below the controller's ``error_floor``). It belongs to the
    integration, not to the state: it is kept across restarts from a projected state."""

    err_old: float


@dataclass(frozen=True)
class PIController:
    """``h *= safety err^-alpha err_old^beta`` after an accepted step, within
    ``[min_factor, max_factor]``; ``beta = 0`` is SciPy's controller.

    Parameters
    ----------
    alpha, beta
        The exponents of the current and of the previous error.
    safety, min_factor, max_factor
        SciPy's safety factor and the bounds of one change of the step.
    error_floor
        The previous error is never taken below this (Hairer's DOPRI codes): a step
        with a tiny error may not let the next one grow without bound.

    Examples
    --------
    >>> pi = PIController.for_method("PI", 7)  # DOP853: an error estimator of order 7
    >>> pi.alpha, pi.beta
    (0.0875, 0.05)
    >>> factor, state = pi.accepted(pi.initial_state(), 1e-3, rejected=False)
    >>> round(factor, 6), state.err_old
    (1.039304, 0.001)
    """

    alpha: float
    beta: float
    safety: float = 0.9
    min_factor: float = 0.2
    max_factor: float = 10.0
    error_floor: float = 1e-4

    @classmethod
    def for_method(cls, step_control: StepController,
                   error_estimator_order: int) -> PIController:
        """The controller ``step_control`` names, for a method whose error estimator has
        that order.

        Parameters
        ----------
        step_control
            ``"PI"`` or ``"scipy"``.
        error_estimator_order
            The order of the method's error estimator (``k`` is one more).

        Examples
        --------
        >>> PIController.for_method("scipy", 4).alpha
        0.2
        """
        k = error_estimator_order + 1
        if step_control == "scipy":
            return cls(1 / k, 0.0)
        return cls(PI_ALPHA / k, PI_BETA / k)

    def initial_state(self) -> ControllerState:
        """The state before the first step (no error measured yet: the floor)."""
        return ControllerState(self.error_floor)

    def accepted(self, state: ControllerState, err: float,
                 rejected: bool) -> tuple[float, ControllerState]:
        """The factor of the next step after one accepted with error norm ``err < 1``
        (not above 1 if an attempt of this step was rejected), and the new state.

        Parameters
        ----------
        state
            The controller's state before this step.
        err
            The accepted attempt's error norm.
        rejected
            Whether an attempt of this step was rejected first.
        """
        factor = self.max_factor if err == 0 else min(
            self.max_factor, self.safety * err ** -self.alpha * state.err_old ** self.beta)
        new = ControllerState(max(err, self.error_floor))
        return (min(1.0, factor) if rejected else factor), new

    def rejected(self, err: float) -> float:
        """The factor by which a rejected attempt's step shrinks (``err >= 1``).

        Parameters
        ----------
        err
            The rejected attempt's error norm.
        """
        return max(self.min_factor, self.safety * err ** -self.alpha)
