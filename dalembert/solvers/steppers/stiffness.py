"""Stiffness detection for an explicit Runge-Kutta method (Hairer's, as in DOP853).

After an accepted step of size ``h``, the last stage (its argument ``y_s`` at ``t + h``
for DOP853) and the step's end ``y_new`` are two states at the same time; the ratio

    h_lambda = |h| ||f(t + h, y_new) - f(t + h, y_s)|| / ||y_new - y_s||

estimates ``h`` times the largest eigenvalue the step felt. Where the step size is
limited by stability rather than accuracy it sits at the edge of the method's
stability region (about 6.1 on DOP853's negative real axis). Hairer and Wanner's DOP853
calls the problem stiff when that happens in 15 accepted steps with no run of 6
calm ones between (Solving ODEs I, sec. II.10 and the code ``dop853.f``).

The detector is a frozen value and its memory (:class:`StiffnessState`) is passed in
and returned, as the step-size controller's is; C reads the same constants.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from .runge_kutta import Attempt, Tableau


@dataclass(frozen=True)
class StiffnessState:
    """The detector's memory: the stiff steps counted and the calm ones since."""

    stiff: int = 0
    calm: int = 0


@dataclass(frozen=True)
class StiffnessDetector:
    """Hairer's test (see the module).

    Parameters
    ----------
    limit
        ``h_lambda`` above which a step counts as stability-limited.
    stiff_after
        Stiff steps (without ``calm_after`` calm ones between) that make the problem stiff.
    calm_after
        Calm steps in a row that clear the count.

    Examples
    --------
    >>> detector = StiffnessDetector()
    >>> state = StiffnessState()
    >>> for _ in range(15):
    ...     state = detector.note(state, 6.5)
    >>> detector.stiff(state)
    True
    """

    limit: float = 6.1
    stiff_after: int = 15
    calm_after: int = 6

    def note(self, state: StiffnessState, h_lambda: float) -> StiffnessState:
        """The memory after a step whose ``h_lambda`` is given (NaN: not measured).

        Parameters
        ----------
        state
            The memory before the step.
        h_lambda
            The step's estimate (:func:`h_lambda`).
        """
        if h_lambda > self.limit:
            return StiffnessState(state.stiff + 1, 0)
        if not h_lambda <= self.limit:  # NaN: nothing learnt
            return state
        calm = state.calm + 1
        return StiffnessState(0, 0) if calm >= self.calm_after else \
            StiffnessState(state.stiff, calm)

    def stiff(self, state: StiffnessState) -> bool:
        """Whether the memory says the problem is stiff.

        Parameters
        ----------
        state
            The memory.
        """
        return state.stiff >= self.stiff_after


def h_lambda(tableau: Tableau, step: Attempt) -> float:
    """The step's estimate ``|h| ||f(y_new) - f(y_s)|| / ||y_new - y_s||`` (see the
    module), from its stages; NaN where the two states coincide.

    Parameters
    ----------
    tableau
        The method.
    step
        An accepted attempt (its stages ``K``: ``s + 1`` rows, the last ``f(y_new)``).

    Examples
    --------
    On ``y' = -100 y`` the estimate is ``100 |h|``:

    >>> from scipy.integrate import DOP853
    >>> from dalembert.solvers.steppers.runge_kutta import ExplicitRungeKutta
    >>> from dalembert.solvers.steppers.scipy_ivp import tableau_of
    >>> tb = tableau_of(DOP853)
    >>> y0 = np.array([1.0])
    >>> step = ExplicitRungeKutta(tb).attempt(lambda t, y: -100 * y, 0.0, y0, -100 * y0,
    ...                                       0.05, rtol=1e-6, atol=1e-9)
    >>> round(h_lambda(tb, step), 6)
    5.0
    """
    s, K, h = tableau.n_stages, step.K, step.h
    y_last = step.y + h * np.dot(K[:s - 1].T, tableau.A[s - 1, :s - 1])
    den = float(np.linalg.norm(step.y_new - y_last))
    if den == 0.0:
        return float("nan")
    return abs(h) * float(np.linalg.norm(K[s] - K[s - 1])) / den


def spectral_radius(fun: Callable[[float, np.ndarray], np.ndarray], t: float, y: np.ndarray,
                    start: np.ndarray, iterations: int = 6) -> tuple[float, np.ndarray]:
    """An estimate of the largest ``|lambda|`` of the Jacobian of ``fun`` at ``(t, y)``:
    power iteration on its square (a mechanism's stiff modes are conjugate pairs near
    the imaginary axis, whose squares are one real eigenvalue ``-w^2``), its products
    by forward differences (two evaluations an iteration); and the last vector, to
    start the next estimate from.

    Hairer's test sees the stiff modes in the difference of two stages; where they are
    barely excited (a stiff spring that the motion loads slowly) that difference is the
    slow motion's, and the test reads a tenth of ``h |lambda|`` while DOP853's steps are
    held at its stability limit.

    Parameters
    ----------
    fun
        The right-hand side ``f(t, y)``.
    t, y
        The point.
    start
        A start vector (the last estimate's, or random).
    iterations
        Power iterations.

    Examples
    --------
    A spring of ``w = 1000`` (in ``(w x, x')``; in ``(x, x')`` the estimate is within
    the factor the two scales' mismatch allows, 1.09 here):

    >>> J = np.array([[0.0, 1000.0], [-1000.0, 0.0]])
    >>> rho, _ = spectral_radius(lambda t, y: J @ y, 0.0, np.ones(2), np.array([1.0, 0.0]))
    >>> round(rho, 6)
    1000.0
    """
    f0 = fun(t, y)
    scale = np.sqrt(np.finfo(float).eps) * (1.0 + float(np.abs(y).max(initial=0.0)))

    def product(v: np.ndarray) -> np.ndarray:
        size = float(np.abs(v).max(initial=0.0))
        if size == 0.0:
            return v
        return (fun(t, y + (scale / size) * v) - f0) * (size / scale)

    v, squared = start / max(float(np.linalg.norm(start)), 1e-300), 0.0
    for _ in range(iterations):
        w = product(product(v))
        squared = float(np.linalg.norm(w))
        if not np.isfinite(squared) or squared == 0.0:
            return 0.0, start
        v = w / squared
    return float(np.sqrt(squared)), v
