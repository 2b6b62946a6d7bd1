"""Integration like :func:`scipy.integrate.solve_ivp`, through a simulation loop.

:func:`integrate` takes ``solve_ivp``'s arguments (``t_span``, ``t_eval``,
``dense_output``, ``events``, a solver class and its options) plus a projector,
and runs one of the loops of :mod:`~dalembert.solvers.running.loop` under a progress bar
and Ctrl-C: a failure or an interruption ends the run but keeps every step
computed so far (the start alone if it comes before the first step: the solver's
start evaluates the model). It checks nothing: its arguments come from
:func:`dalembert.options.simulation_options` through the simulation plan.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence

import numpy as np
from scipy.integrate import OdeSolver, Radau

from ...errors import DalembertError, InputError, TimeLimitExceeded
from ..singular.careful import CarefulSteps
from ..singular.watch import Runaway, Singularity
from ..steppers.scipy_ivp import CONTROLLED, ControlledSteps
from .loop import IntegrationResult, Projector, PythonLoop, SimulationLoop, StretchLoop
from .nonfinite import Diagnosis
from .switching import StiffSwitch
from .watchdog import GRACE, Watchdog, watching, where_stopped

__all__ = ["IntegrationResult", "finite_difference_jacobian", "integrate", "progress_bar"]


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
    diagnose: Diagnosis | None = None,
    singular: Singularity | None = None,
    careful: CarefulSteps | None = None,
    runaway: Runaway | None = None,
    deadline: float | None = None,
    watchdog: Watchdog | None = None,
    switch: StiffSwitch | None = None,
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
        native solver with its native projection, no dense output, and no events but
        screened ones (:mod:`~dalembert.solvers.native.screens`).
    diagnose
        ``diagnose(t, y)``: what is not finite at a state, for the message of a run
        that meets a NaN or an infinity (:mod:`~dalembert.solvers.running.nonfinite`).
    singular
        ``singular(t, y)``: the singular configuration at a state, or ``""``; steps
        that collapse there end the run (:mod:`~dalembert.solvers.singular.watch`).
    careful
        The careful steps near a singular configuration
        (:mod:`~dalembert.solvers.singular.careful`):
        with ``stretches``, how to take them the Python way.
    runaway
        ``runaway(t, y)``: what in the model grew most since the start, or ``""``;
        steps that keep shrinking toward a time the run would take hours to reach
        end it naming that (:meth:`~dalembert.solvers.singular.watch.StepCollapse.runaway`).
    deadline
        A ``time.monotonic()`` past which the run stops, status ``"timeout"``,
        keeping what it computed; checked after each unit of the loop's work (a
        step, or a stretch of C steps of a fraction of a second), or ``None``.
    watchdog
        The run's :class:`~.watchdog.Watchdog` (its deadline's), armed while the loop
        runs: a function of the user's that never returns is stopped by it, the run
        ending as at the deadline; or ``None``.
    switch
        ``method="auto"``'s switching between the explicit solver (``method``) and an
        implicit one (:mod:`~.switching`), or ``None``.
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
    y0 = np.asarray(y0, dtype=float)
    jac = solver_options.get("jac", solver_options.get("linearize"))
    jac_before = getattr(jac, "evaluations", 0)  # fun's calls in a Jacobian, in nfev too
    times = None
    loop: SimulationLoop | None = None
    bar = None
    # A NaN or an overflow ends the run with a message naming it (loop.py), so NumPy's
    # warnings about them (from the model's code, from SciPy's norms) would only repeat it
    with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
        try:
            with watching(watchdog):
                times = None if t_eval is None else np.asarray(t_eval, dtype=float)
                # SciPy's solvers evaluate fun (and pick the first step) when made: the
                # model may fail right there, and a Ctrl-C may land there too
                solver = method(fun, t0, y0, tf, **solver_options)
                if stretches and project is not None:
                    loop = StretchLoop(solver, times, project, diagnose, singular, careful,
                                       runaway, switch, events)
                else:
                    loop = PythonLoop(solver, times, events, project, dense_output,
                                      diagnose, singular, careful, runaway, switch)
                bar = progress_bar(t0, tf) if progress else None
                while loop.status is None:
                    loop.advance()
                    if bar is not None:
                        bar.update(abs(loop.t_reached - bar.n_t))
                        bar.n_t = loop.t_reached
                    if deadline is not None and loop.status is None and \
                            time.monotonic() > deadline:
                        loop.stop("timeout", f"stopped at t={loop.t_reached:.6g}: the "
                                  "run's time limit (timeout=) passed")
        except KeyboardInterrupt:
            if loop is None:
                return _not_started(t0, y0, times, "interrupted", "interrupted by the user "
                                    f"at t={t0:.6g}, before the first step")
            loop.interrupt()
        except TimeLimitExceeded as exc:  # the watchdog: a function that did not return
            assert watchdog is not None
            watchdog.disarm()  # (raised again only after GRACE: this comes first)
            if loop is None:
                return _not_started(t0, y0, times, "timeout",
                                    _stopped(t0, where_stopped(exc)))
            loop.interrupt()  # back to the last complete unit of work
            if loop.status == "interrupted":  # (not a run that had ended before)
                loop.status = "timeout"
                loop.message = _stopped(loop.t_reached, where_stopped(exc))
        except DalembertError as exc:
            if loop is not None:  # the loops stop on their own errors: this is not one
                raise
            # the inputs' own error says what failed; else what is not finite at the start
            cause = "" if isinstance(exc, InputError) or diagnose is None else \
                diagnose(t0, y0)
            result = _not_started(t0, y0, times, "failed",
                                  f"integration stopped at t={t0:.6g}: {cause or exc}")
            result.error = exc
            return result
        finally:
            if bar is not None:
                bar.close()
    result = loop.result(_method_name(method) if switch is None else "auto")
    if "nfev" in result.stats:
        result.stats["nfev"] += getattr(jac, "evaluations", 0) - jac_before
    return result


def _stopped(t: float, where: str) -> str:
    """The message of a run the watchdog stopped at ``t`` in the function ``where``."""
    inside = f"while a function of yours, {where}, had not returned" if where else \
        "within a step"
    return (f"stopped at t={t:.6g}: the run's time limit (timeout=) passed {inside}; it "
            f"was stopped {GRACE:g} s later")


def _not_started(t0: float, y0: np.ndarray, t_eval: np.ndarray | None, status: str,
                 message: str) -> IntegrationResult:
    """The result of a run that ended before its first step: the start, if it is an
    output time (as the loops record it)."""
    start = t_eval is None or bool(np.any(t_eval == t0))
    return IntegrationResult(t=np.array([t0] if start else []),
                             y=y0[None, :] if start else np.empty((0, y0.size)),
                             status=status, message=message, stats={"n_steps": 0})


def _method_name(cls: type[OdeSolver]) -> str:
    """SciPy's name for its solvers' controlled, native and linearized versions."""
    if issubclass(cls, ControlledSteps):
        return next(c.__name__ for c in cls.__mro__ if c in CONTROLLED)
    return "Radau" if issubclass(cls, Radau) else cls.__name__


def finite_difference_jacobian(fun: Callable) -> Callable:
    """Forward-difference Jacobian with a fixed relative step, for Radau and BDF.

    SciPy's own ``num_jac`` grows its step by 10x at every call for a column that
    does not change ``fun`` (a position entering only through a linear constraint).
    After ~300 Jacobians the step overflows, and BDF then crawls with tiny steps.
    Its ``evaluations`` attribute counts the calls of ``fun`` it made (``integrate``
    adds them to ``nfev``: SciPy counts only its own).

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
    >>> jac.evaluations
    3
    """

    def jac(t: float, y: np.ndarray) -> np.ndarray:
        jac.evaluations += 1 + y.size  # type: ignore[attr-defined]
        f0 = np.asarray(fun(t, y), dtype=float)
        J = np.empty((f0.size, y.size))
        for j in range(y.size):
            h = np.sqrt(np.finfo(float).eps) * max(1.0, abs(y[j]))
            shifted = y.copy()
            shifted[j] += h
            J[:, j] = (np.asarray(fun(t, shifted), dtype=float) - f0) / (shifted[j] - y[j])
        return J

    jac.evaluations = 0  # type: ignore[attr-defined]
    return jac


def progress_bar(t0: float, tf: float):
    """A progress bar over ``[t0, tf]`` (tqdm's), advanced by ``bar.update(dt)``."""
    from tqdm.auto import tqdm

    bar = tqdm(total=abs(tf - t0), unit="s", desc="simulating", bar_format=(
        "{desc}: {percentage:3.0f}%|{bar}| t={n:.3g}/{total:.3g} [{elapsed}<{remaining}]"))
    bar.n_t = t0
    return bar
