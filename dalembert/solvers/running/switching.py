"""``method="auto"``: DOP853 until it meets stiffness, then Radau while Radau pays.

The run starts with DOP853 under Hairer's stiffness detector
(:mod:`~dalembert.solvers.steppers.stiffness`, its limit lowered: :data:`DETECTOR`).
When the detector says stiff, the loop hands the run, at the state reached, to Radau
(in C on the KKT structure where it applies). After ``TRIAL_STEPS`` implicit steps the
switch is judged once: if
Radau's mean step is not ``COST_RATIO`` times the explicit step it replaced, the
implicit steps do not pay (a mildly stiff problem, where DOP853 at its stability limit
is cheaper) and the run goes back to DOP853 for good; otherwise it stays with Radau.
A run switches at most twice: a problem that turns non-stiff again later is left
to Radau (the explicit method is not tried again).

:class:`StiffSwitch` holds the policy and its memory for one run segment; the loops
(:mod:`.loop`) call :meth:`StiffSwitch.after` after each unit of work.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
from scipy.integrate import OdeSolver

from ..steppers.scipy_ivp import ControlledSteps, step_size
from ..steppers.stiffness import StiffnessDetector

#: The detector of ``method="auto"``: Hairer's test with a lower limit than DOP853's
#: 6.1 (its stability limit on the negative real axis). A stiff spring with light
#: damping puts its modes near the imaginary axis, where DOP853's steps stay at
#: ``h |lambda|`` about 1.4 (measured on the elastic pendulum at k = 1e8: DOP853 took
#: 13,889 steps at rtol 1e-8, Radau 1,301); no gallery model reaches 1 for 15 steps at
#: rtol 1e-6 or 1e-8. A false alarm costs one trial of ``TRIAL_STEPS`` Radau steps.
DETECTOR = StiffnessDetector(limit=1.0)
#: Implicit steps after a switch before it is judged.
TRIAL_STEPS = 20
#: How many times longer than the explicit step an implicit step must be to pay: a
#: Radau step in C (about 10 right-hand sides, two factorizations every few steps) costs
#: about as much as one or two of DOP853 (12 right-hand sides); measured on the 16-link
#: spring chain (bench/README.md, "method='auto'").
COST_RATIO = 2.0

#: ``make(t, y, t_bound, h_abs)``: a solver of the run's problem starting at ``(t, y)``
#: (``h_abs``: its first step, or 0 to let it choose).
SolverFactory = Callable[[float, np.ndarray, float, float], OdeSolver]


@dataclass
class StiffSwitch:
    """The switching of one run segment (see the module).

    Parameters
    ----------
    implicit, explicit
        The factories of the implicit solver and of the explicit one (going back).
    implicit_name
        The implicit method's name, for the run's record.

    Examples
    --------
    A solver without a stiffness detector never makes it switch:

    >>> from scipy.integrate import RK45
    >>> switch = StiffSwitch(lambda *a: None, lambda *a: None)
    >>> solver = RK45(lambda t, y: -y, 0.0, np.ones(1), 1.0)
    >>> switch.after(solver, 0) is None, switch.steps_to_judgement(0), switch.switches
    (True, None, [])
    """

    implicit: SolverFactory
    explicit: SolverFactory
    implicit_name: str = "Radau"
    #: ``(t, method)`` of each switch made
    switches: list[tuple[float, str]] = field(default_factory=list)
    _trial: tuple[float, int, float] | None = None  # t, steps and explicit step at the switch
    _settled: bool = False

    def steps_to_judgement(self, n_steps: int) -> int | None:
        """How many more steps before the switch is judged (``None``: none is due), so
        that a stretch of steps in C ends there.

        Parameters
        ----------
        n_steps
            The steps the run has taken.
        """
        if self._trial is None or self._settled:
            return None
        return max(1, TRIAL_STEPS - (n_steps - self._trial[1]))

    def after(self, solver: OdeSolver, n_steps: int) -> OdeSolver | None:
        """The solver to continue with after a unit of work (``None``: the same).

        Parameters
        ----------
        solver
            The run's solver after the unit of work.
        n_steps
            The steps the run has taken.
        """
        if self._settled:
            return None
        if self._trial is None:
            if not (isinstance(solver, ControlledSteps) and solver.stiff):
                return None
            self._trial = (solver.t, n_steps, step_size(solver))
            self.switches.append((solver.t, self.implicit_name))
            return self.implicit(solver.t, solver.y, solver.t_bound, 0.0)
        t0, steps0, h_explicit = self._trial
        if n_steps - steps0 < TRIAL_STEPS:
            return None
        self._settled = True
        mean_step = abs(solver.t - t0) / (n_steps - steps0)
        if mean_step >= COST_RATIO * h_explicit:
            return None
        self.switches.append((solver.t, "DOP853"))
        return self.explicit(solver.t, solver.y, solver.t_bound, h_explicit)
