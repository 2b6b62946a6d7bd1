"""SciPy's explicit Runge-Kutta solvers with each step taken in C.

:class:`NativeDOP853` (and ``NativeRK45``, ``NativeRK23``) are the controlled solvers
of :mod:`~dalembert.solvers.steppers.scipy_ivp` whose step (``take_step``, the stepper
contract) runs in ``runge_kutta.c``: the stages, the error estimate and the step-size
control with the same tableau, formulas and constants, so the steps taken are those of
``ControlledDOP853`` (SciPy's own under ``step_control="scipy"``) up to rounding
(tested). DOP853's interpolant has its extra stages evaluated in C too. Start-up (the
initial step), dense output and everything else stay SciPy's, behind the adapter:
nothing here reads or writes SciPy's solver attributes.

Beyond single steps, a :class:`~.run.StretchRunner` runs whole stretches of the
simulation loop in C for them (the projection after each step, the outputs at
``t_eval``, the restart); the simulation plan (:mod:`dalembert.solvers.running.plan`)
decides when.
"""

from __future__ import annotations

import ctypes
from typing import ClassVar

import numpy as np
from scipy.integrate import DOP853, RK23, RK45, OdeSolver

from ..steppers.controller import ControllerState
from ..steppers.runge_kutta import Tableau
from ..steppers.scipy_ivp import (
    INTERPOLATOR_POWER,
    ControlledDOP853,
    ControlledRK23,
    ControlledRK45,
    ControlledSteps,
    StepEnd,
    StepStart,
    tableau_of,
)
from . import library
from .solver import NativeSolver


class _NativeSteps(ControlledSteps):
    """Mixin for a controlled solver class; ``native`` is a :class:`NativeSolver`."""

    _TABLEAU: ClassVar[tuple[library.Tableau, int, int, list]]  # per class, made on first use

    def __init__(self, fun, t0, y0, t_bound, *, native: NativeSolver, **options) -> None:
        super().__init__(fun, t0, y0, t_bound, **options)
        self._native = native
        # the class keeps the arrays the tableau points to alive
        self._tableau, self._n_rows, self._n_stages, _ = self._made_tableau()
        tolerances = self.tolerances
        self._atol = tolerances.atol
        pi = self.controller  # the one controller: C reads its values
        self._stepper = library.Stepper(t_bound=t_bound, direction=self.direction,
                                        rtol=tolerances.rtol, max_step=tolerances.max_step,
                                        atol=self._atol.ctypes.data, alpha=pi.alpha,
                                        beta=pi.beta, safety=pi.safety,
                                        min_factor=pi.min_factor, max_factor=pi.max_factor,
                                        error_floor=pi.error_floor)
        self._stage = np.empty(self.n)
        self._fixed = (ctypes.addressof(self._tableau), ctypes.addressof(self._stepper))

    @classmethod
    def _made_tableau(cls) -> tuple[library.Tableau, int, int, list]:
        """The method's tableau for C, the rows of its interpolant, its number of stages
        and the arrays the tableau points to, made once per class (C only reads them)."""
        made = cls.__dict__.get("_TABLEAU")
        if made is None:
            tb = tableau_of(cls)
            keep = [None if a is None else np.ascontiguousarray(a, dtype=np.float64)
                    for a in (tb.A, tb.B, tb.C, tb.E, tb.E3)]
            A, B, C, E, E3 = (a.ctypes.data if a is not None else None for a in keep)
            tableau = library.Tableau(tb.n_stages, A, B, C, E, E3)
            made = (tableau, cls._interpolant(tb, tableau, keep), tb.n_stages, keep)
            cls._TABLEAU = made
        return made

    @classmethod
    def _interpolant(cls, tb: Tableau, tableau: library.Tableau, keep: list) -> int:
        """The dense output's coefficients into ``tableau`` (their arrays into ``keep``);
        the rows of its interpolant."""
        P = np.ascontiguousarray(tb.P, dtype=np.float64)
        keep.append(P)
        tableau.n_P, tableau.P = P.shape[1], P.ctypes.data
        return P.shape[1]

    def take_step(self, start: StepStart) -> StepEnd | str:
        st, K = self._stepper, self.stage_storage()  # K: rows of stages, C-contiguous
        y = np.ascontiguousarray(start.y, dtype=np.float64)
        K[0] = start.f
        y_new = np.empty(self.n)
        st.t, st.h_abs, st.err_old, st.nfev = start.t, start.h_abs, start.state.err_old, 0
        status = self._native.lib.dl_rk_step(
            *self._native._at, *self._fixed, y.ctypes.data, K.ctypes.data,
            y_new.ctypes.data, self._stage.ctypes.data)
        self.nfev += st.nfev
        if status == library.STEP_TOO_SMALL:
            return self.TOO_SMALL_STEP
        if status == library.NOT_FINITE:  # the loop checks first; said here for other callers
            return "the step would start from values that are not finite"
        self._native._check(status)
        return StepEnd(y, st.h_previous, st.t, y_new, K[self._n_stages].copy(), st.h_abs,
                       ControllerState(st.err_old), st.h_lambda)


class NativeDOP853(_NativeSteps, ControlledDOP853):
    """:class:`scipy.integrate.DOP853` stepping in C (its interpolant's extra stages too)."""

    @classmethod
    def _interpolant(cls, tb: Tableau, tableau: library.Tableau, keep: list) -> int:
        A, C, D = (np.ascontiguousarray(a, dtype=np.float64) for a in (tb.A_extra, tb.C_extra,
                                                                   tb.D))
        keep.extend([A, C, D])
        tableau.n_extra, tableau.A_extra, tableau.C_extra = len(C), A.ctypes.data, C.ctypes.data
        tableau.n_D, tableau.D = len(D), D.ctypes.data
        return INTERPOLATOR_POWER

    def fill_extra_stages(self, t_old: float, h: float, y_old: np.ndarray,
                          K: np.ndarray) -> None:
        s = self._n_stages + 1
        A, C = self._tableau.A_extra, self._tableau.C_extra  # addresses
        width = len(K)
        y_old = np.ascontiguousarray(y_old, dtype=np.float64)
        nfev = ctypes.c_int64(0)
        status = self._native.lib.dl_stages(
            *self._native._at, A, width, C, s, s, width, t_old, h, y_old.ctypes.data,
            K.ctypes.data, self._stage.ctypes.data, ctypes.addressof(nfev))
        self.nfev += nfev.value
        self._native._check(status)


class NativeRK45(_NativeSteps, ControlledRK45):
    """:class:`scipy.integrate.RK45` stepping in C."""


class NativeRK23(_NativeSteps, ControlledRK23):
    """:class:`scipy.integrate.RK23` stepping in C."""


NATIVE_METHODS: dict[type[OdeSolver], type[OdeSolver]] = {
    DOP853: NativeDOP853, RK45: NativeRK45, RK23: NativeRK23,
}
