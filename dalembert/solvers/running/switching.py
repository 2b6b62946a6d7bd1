"""``method="auto"``: DOP853 until it meets stiffness, then Radau while Radau pays.

The run starts with DOP853 under Hairer's stiffness detector
(:mod:`~dalembert.solvers.steppers.stiffness`, its limit lowered: :data:`DETECTOR`).
When the detector says stiff, the loop hands the run, at the state reached, to Radau
(in C on the KKT structure where it applies), its first step the explicit one. After
``TRIAL_STEPS`` implicit steps the switch is judged: if the step Radau has grown to is
``COST_RATIO`` times the explicit step it replaced, the run stays with Radau; if it is
still growing (by ``GROWING`` over the last judgement) the trial goes on; otherwise the
implicit steps do not pay (a mildly stiff problem, where DOP853 at its stability limit
is cheaper) and the run goes back to DOP853 for good. A run switches at most twice: a
problem that turns non-stiff again later is left to Radau (the explicit method is not
tried again).

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
#: A trial that ends short of paying is extended while the implicit step still grows by
#: this factor over it (a fast transient at the switch holds Radau's first steps short).
GROWING = 1.5
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
    _judged: float = 0.0  # the implicit step at the last judgement (0: none yet)
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
            h_explicit = step_size(solver)
            self._trial, self._judged = (solver.t, n_steps, h_explicit), h_explicit
            self.switches.append((solver.t, self.implicit_name))
            return self.implicit(solver.t, solver.y, solver.t_bound, h_explicit)
        _, steps0, h_explicit = self._trial
        if n_steps - steps0 < TRIAL_STEPS:
            return None
        h_implicit = step_size(solver)  # the step Radau has grown to
        if h_implicit >= COST_RATIO * h_explicit:
            self._settled = True
            return None
        if h_implicit > GROWING * self._judged:  # still growing: another trial
            self._trial, self._judged = (solver.t, n_steps, h_explicit), h_implicit
            return None
        self._settled = True
        self.switches.append((solver.t, "DOP853"))
        return self.explicit(solver.t, solver.y, solver.t_bound, h_explicit)
