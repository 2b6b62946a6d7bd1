"""Integration like :func:`scipy.integrate.solve_ivp`, through a simulation loop.

:func:`integrate` takes ``solve_ivp``'s arguments (``t_span``, ``t_eval``,
``dense_output``, ``events``, a solver class and its options) plus a projector,
and runs one of the loops of :mod:`~dalembert.solvers.loop` under a progress bar
and Ctrl-C: a failure or an interruption ends the run but keeps every step
computed so far. It checks nothing: its arguments come from
:func:`dalembert.options.simulation_options` through the simulation plan.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np
from scipy.integrate import OdeSolver

from .loop import IntegrationResult, Projector, PythonLoop, SimulationLoop, StretchLoop
from .step_control import CONTROLLED, ControlledSteps

__all__ = ["IntegrationResult", "finite_difference_jacobian", "integrate"]


def integrate(
    fun: Callable[[float, np.ndarray], np.ndarray],
    t_span: tuple[float, float],
    y0: np.ndarray,
    *,
    method: type[OdeSolver],
    t_eval: np.ndarray | None = None,
    dense_output: bool = False,
    events: Sequence[Callable] = (),
    project: Projector | None = None,
    progress: bool = False,
    stretches: bool = False,
    **solver_options: object,
) -> IntegrationResult:
    """Integrate ``y' = fun(t, y)`` like ``solve_ivp``, projecting after each step.

    Parameters
    ----------
    fun, t_span, y0, t_eval, dense_output, events
        As in :func:`scipy.integrate.solve_ivp` (``events`` take ``(t, y)``).
    method
        The solver class (SciPy's, or one of dalembert's controlled or native ones).
    project
        ``project(t, y)``, the state projected onto the constraints, or ``None``.
    progress
        Show a progress bar.
    stretches
        Run whole stretches of steps in C (:class:`~.loop.StretchLoop`): only for a
        native solver with its native projection, no events, no dense output.
    solver_options
        Passed to ``method``.

    Examples
    --------
    >>> from scipy.integrate import RK45
    >>> result = integrate(lambda t, y: -y, (0.0, 1.0), np.ones(1), method=RK45,
    ...                    t_eval=[1.0], rtol=1e-10, atol=1e-12)
    >>> bool(abs(result.y[-1, 0] - np.exp(-1.0)) < 1e-9)
    True
    """
    t0, tf = t_span
    solver = method(fun, t0, np.asarray(y0, dtype=float), tf, **solver_options)
    times = None if t_eval is None else np.asarray(t_eval, dtype=float)
    loop: SimulationLoop
    if stretches and project is not None:
        loop = StretchLoop(solver, times, project)
    else:
        loop = PythonLoop(solver, times, events, project, dense_output)
    bar = _progress_bar(t0, tf) if progress else None
    try:
        while loop.status is None:
            loop.advance()
            if bar is not None:
                bar.update(abs(loop.t_reached - bar.n_t))
                bar.n_t = loop.t_reached
    except KeyboardInterrupt:
        loop.interrupt()
    finally:
        if bar is not None:
            bar.close()
    return loop.result(_method_name(method))


def _method_name(cls: type[OdeSolver]) -> str:
    """SciPy's name for its solvers' controlled and native versions."""
    if issubclass(cls, ControlledSteps):
        return next(c.__name__ for c in cls.__mro__ if c in CONTROLLED)
    return cls.__name__


def finite_difference_jacobian(fun: Callable) -> Callable:
    """Forward-difference Jacobian with a fixed relative step, for Radau and BDF.

    SciPy's own ``num_jac`` grows its step by 10x at every call for a column that
    does not change ``fun`` (a position entering only through a linear constraint).
    After ~300 Jacobians the step overflows, and BDF then crawls with tiny steps.

    Parameters
    ----------
    fun
        The right-hand side ``fun(t, y)``.

    Examples
    --------
    >>> jac = finite_difference_jacobian(lambda t, y: np.array([y[1], -4.0 * y[0]]))
    >>> np.round(jac(0.0, np.array([1.0, 0.0])), 6)
    array([[ 0.,  1.],
           [-4.,  0.]])
    """

    def jac(t: float, y: np.ndarray) -> np.ndarray:
        f0 = np.asarray(fun(t, y), dtype=float)
        J = np.empty((f0.size, y.size))
        for j in range(y.size):
            h = np.sqrt(np.finfo(float).eps) * max(1.0, abs(y[j]))
            shifted = y.copy()
            shifted[j] += h
            J[:, j] = (np.asarray(fun(t, shifted), dtype=float) - f0) / (shifted[j] - y[j])
        return J

    return jac


def _progress_bar(t0: float, tf: float):
    from tqdm.auto import tqdm

    bar = tqdm(total=abs(tf - t0), unit="s", desc="simulating", bar_format=(
        "{desc}: {percentage:3.0f}%|{bar}| t={n:.3g}/{total:.3g} [{elapsed}<{remaining}]"))
    bar.n_t = t0
    return bar
