"""Whole stretches of a simulation in C: steps, projections, outputs and restarts.

A call also ends after a step that ends near a singular configuration (the smallest
pivot ratio of the projection's ``A A^T`` below ``SCREEN``): the caller then
measures as the Python loop does and decides (:mod:`~dalembert.solvers.singular.careful`).

:class:`StretchRunner` drives ``dl_rk_run`` for one of the native Runge-Kutta
solvers, :class:`RadauStretchRunner` ``dl_radau_run`` for ``NativeRadau``: each call
takes steps as :func:`~dalembert.solvers.running.integrate.integrate`'s
loop takes them (step, project the end, interpolate and project the output times
in the step, restart from the projected end) and returns after a fraction of a
second, so Ctrl-C and the progress bar are served between calls. A step C cannot
finish (too small, a singular system, a failed projection) is left to the caller,
which takes it the step-by-step way (the Python projector then stands in).
"""

from __future__ import annotations

import ctypes
from collections.abc import Callable, Sequence
from functools import partial

import numpy as np
from scipy.integrate import OdeSolver

from ...numerics.singular import SCREEN
from ..steppers.scipy_ivp import step_size, step_start, take_state
from ..steppers.stiffness import StiffnessState
from . import library
from .screens import Screen, ScreenTable
from .turns import outside_python

#: The budget of one call: seconds on the wall clock (it returns after the step that
#: exceeds them) and steps.
MAX_SECONDS, MAX_STEPS = 0.05, 1 << 62
#: Output rows one call may write: about this many doubles, within ``ROWS``.
BUFFER_DOUBLES, ROWS = 1 << 20, (64, 4096)


class _Stretches:
    """What the stretch runners share: the output buffers, the ``dl_run`` struct, the
    call (made by the subclass, over ``work_rows`` rows of work) and the hand-over.

    :meth:`run` calls C; :meth:`take` hands over what it did and brings the SciPy
    solver object up to date (through the adapter: its time, state, derivative, step
    sizes, ``nfev`` and ``status``). The two are separate so that what a call did
    survives a Ctrl-C that lands right after it: ``take`` can be called again until
    it returns.
    """

    def __init__(self, solver: OdeSolver, t_eval: np.ndarray | None, work_rows: int,
                 screens: ScreenTable | None) -> None:
        self.solver, native, n_state = solver, solver._native, solver.n
        rows = max(ROWS[0], min(ROWS[1], BUFFER_DOUBLES // n_state))
        if t_eval is not None:  # no more than the output times (a large buffer is mapped anew)
            rows = max(1, min(rows, len(t_eval)))
        self._y = np.empty(n_state)
        self._t_out, self._y_out = np.empty(rows), np.empty((rows, n_state))
        self._work = np.empty((2 + work_rows, n_state))  # y_new, y_end, rows
        self._t_eval = np.ascontiguousarray([] if t_eval is None else t_eval, dtype=float)
        self._ahead = None if t_eval is None else solver.direction * self._t_eval
        mask, max_newton, max_full, position_tol, accept_tol = native.projection_arguments()
        y_new, y_end, interpolant = (row.ctypes.data for row in self._work[:3])
        self._run = library.Run(
            t_eval=self._t_eval.ctypes.data, n_eval=-1 if t_eval is None else len(self._t_eval),
            holonomic=mask, max_newton=max_newton, max_full=max_full,
            position_tol=position_tol, accept_tol=accept_tol, max_steps=MAX_STEPS,
            max_seconds=MAX_SECONDS, capacity=rows, t_out=self._t_out.ctypes.data,
            y_out=self._y_out.ctypes.data, y_new=y_new, y_end=y_end,
            rows=interpolant, near2=SCREEN,
            screens=None if screens is None else screens.address)
        self._screens = screens  # kept alive while C may read it
        self._nfev = 0
        self._pending = False
        self.near_singular = False

    #: the stretch's C call over this runner's buffers (made by the subclass): its status
    _call: Callable[[], int]

    def _load(self) -> int:
        """Load the solver's state into C; the solver's ``nfev`` before the call."""
        raise NotImplementedError

    def _hand_back(self) -> int:
        """Bring the solver to the end of the last finished step; the evaluations C made."""
        raise NotImplementedError

    def run(self, max_steps: int | None = None) -> bool:
        """Steps from the solver's state until ``t_bound`` or the budget of one call
        (``max_steps``: fewer steps than the usual budget).

        ``False`` if C could not finish the next step, or a screen of the events
        flags it: the caller takes it (from the solver's state after :meth:`take`,
        which must follow, after a Ctrl-C too).
        What the inputs' function raised (an :class:`~dalembert.errors.InputError`, a
        Ctrl-C landing in it) is raised again here, :meth:`take` still to follow.
        """
        solver, run = self.solver, self._run
        self._nfev = self._load()
        if self._ahead is not None:
            run.next_eval = int(np.searchsorted(self._ahead, solver.direction * solver.t,
                                                "right"))
        run.n_steps = run.n_out = 0
        run.max_steps = MAX_STEPS if max_steps is None else min(max_steps, MAX_STEPS)
        self._pending = True
        with outside_python():  # the GIL is released: other threads run their Python
            status = self._call()
        #: whether the stretch ended after a step near a singular configuration (the
        #: caller then measures it, :mod:`~dalembert.solvers.singular.careful`)
        self.near_singular = status == library.NEAR_SINGULAR
        if status == library.INPUT:  # the inputs' function raised (or took a Ctrl-C):
            self.solver._native._check(status)  # raised here, not retried in Python
        return status in (library.OK, library.NEAR_SINGULAR, library.STIFF)

    def take(self) -> tuple[int, np.ndarray, np.ndarray] | None:
        """``(steps, t, y)`` done by the last :meth:`run`, the solver brought up to
        date; ``None`` if that was handed over already (an interrupted ``take`` may be
        repeated: it hands over nothing twice)."""
        if not self._pending:
            return None
        run = self._run
        k = run.n_out
        taken = (run.n_steps, self._t_out[:k].copy(), self._y_out[:k].copy())
        self.solver.nfev = self._nfev + self._hand_back()
        self._pending = False
        return taken


class StretchRunner(_Stretches):
    """Runs a native Runge-Kutta solver (``NativeDOP853``, ``NativeRK45``,
    ``NativeRK23``) in C by ``dl_rk_run``, with outputs at ``t_eval`` (or at every step
    end if ``None``)."""

    def __init__(self, solver: OdeSolver, t_eval: np.ndarray | None,
                 screens: ScreenTable | None = None) -> None:
        super().__init__(solver, t_eval, solver._n_rows, screens)
        native = solver._native
        self._K = solver.stage_storage()
        self._call = partial(native.lib.dl_rk_run, *native._at, *solver._fixed,
                               ctypes.addressof(self._run), self._y.ctypes.data,
                               self._K.ctypes.data, solver._stage.ctypes.data)

    def _load(self) -> int:
        solver, st = self.solver, self.solver._stepper
        start = step_start(solver)
        self._y[:] = start.y
        self._K[0] = start.f
        st.t, st.h_abs, st.err_old, st.nfev = start.t, start.h_abs, start.state.err_old, 0
        detector = solver.detector  # C runs the same test (0: off)
        st.stiff_limit = 0.0 if detector is None else detector.limit
        if detector is not None:
            st.stiff_after, st.calm_after = detector.stiff_after, detector.calm_after
            st.stiff_count, st.calm_count = solver.stiffness.stiff, solver.stiffness.calm
        return solver.nfev

    def _hand_back(self) -> int:
        solver, st, run = self.solver, self.solver._stepper, self._run
        if run.n_steps:
            take_state(solver, t=st.t, t_old=run.t_old, y=self._y.copy(), f=self._K[0].copy(),
                       h_abs=st.h_abs, h_previous=st.h_previous)
            solver.err_old = st.err_old
            if solver.detector is not None:
                solver.stiffness = StiffnessState(st.stiff_count, st.calm_count)
        return st.nfev


class RadauStretchRunner(_Stretches):
    """Runs a :class:`~.radau.NativeRadau` in C by ``dl_radau_run``, with outputs at
    ``t_eval`` (or at every step end if ``None``): the step's interpolant and the end
    projected, the restart from ``f`` at the projected end (SciPy's restart)."""

    def __init__(self, solver: OdeSolver, t_eval: np.ndarray | None,
                 screens: ScreenTable | None = None) -> None:
        # the step's f and f at the projected end
        super().__init__(solver, t_eval, 2, screens)
        native = solver._native
        self._f, self._Z = np.empty(solver.n), np.empty((3, solver.n))
        self._call = partial(native.lib.dl_radau_run, *native._at, *solver._fixed,
                               ctypes.addressof(self._run), self._y.ctypes.data,
                               self._f.ctypes.data, self._Z.ctypes.data)
        self._counts = (0, 0, 0)

    def _load(self) -> int:
        solver = self.solver
        st = solver._state
        st.t, st.h_abs = solver.t, step_size(solver)
        self._y[:] = solver.y
        self._f[:] = solver.f
        self._counts = (st.nfev, st.njev, st.nlu)
        return solver.nfev

    def _hand_back(self) -> int:
        solver, st, run = self.solver, self.solver._state, self._run
        solver.njev += st.njev - self._counts[1]
        solver.nlu += st.nlu - self._counts[2]
        if run.n_steps:
            take_state(solver, t=st.t, t_old=run.t_old, y=self._y.copy(), f=self._f.copy(),
                       h_abs=st.h_abs, h_previous=st.t - run.t_old)
        return st.nfev - self._counts[0]


def stretch_runner(solver: OdeSolver, t_eval: np.ndarray | None,
                   screens: Sequence[Screen] = ()) -> _Stretches | None:
    """The runner of ``solver``'s stretches in C (its class decides which), or ``None``
    for a solver that steps in Python (``method="auto"`` may switch to one).

    Parameters
    ----------
    solver
        A native solver: a Runge-Kutta one or :class:`~.radau.NativeRadau`.
    t_eval
        The output times (``None``: every step end).
    screens
        The screens of the run's events (:mod:`.screens`): a step whose end one flags
        is left to the caller.

    Examples
    --------
    >>> from scipy.integrate import RK45
    >>> stretch_runner(RK45(lambda t, y: -y, 0.0, np.ones(1), 1.0), None) is None
    True
    """
    from .radau import NativeRadau  # scipy.integrate: imported when a run needs it
    from .runge_kutta import NATIVE_METHODS

    if isinstance(solver, NativeRadau):
        return RadauStretchRunner(solver, t_eval, _table(solver, screens))
    if isinstance(solver, tuple(NATIVE_METHODS.values())):
        return StretchRunner(solver, t_eval, _table(solver, screens))
    return None


def _table(solver: OdeSolver, screens: Sequence[Screen]) -> ScreenTable | None:
    """The screens' table over the native solver's model, or ``None`` for none."""
    return ScreenTable(screens, solver._native) if screens else None
