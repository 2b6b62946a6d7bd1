"""``method="auto"``: DOP853 until it meets stiffness, then Radau while Radau pays.

The run starts with DOP853 under Hairer's stiffness detector
(:mod:`~dalembert.solvers.steppers.stiffness`, its limit lowered: :data:`DETECTOR`),
with now and then an estimate of the Jacobian's largest eigenvalue beside it
(:data:`SPECTRAL_FIRST`: the test misses a stiff mode the motion barely excites).
When either says stiff, and enough explicit steps are left to repay a trial
(:data:`TRIAL_LEFT`), the loop hands the run, at the state reached, to Radau
(in C on the KKT structure where it applies), its first step the explicit one. After
``TRIAL_STEPS`` implicit steps the trial is judged on the step Radau has grown to: if it
is ``COST_RATIO`` times the explicit step it replaced, the run stays with Radau for the
rest of the segment; if it is still growing (by ``GROWING`` over the last judgement) the
trial goes on; otherwise the run goes back to DOP853.

Going back is not for good (as in LSODA, which keeps testing for a switch): the
detector is switched off and armed again, with a fresh memory, after
``RETRY_WAIT x 2^(n-1) x shortfall`` explicit steps, ``n`` the failed trials so far and
``shortfall = COST_RATIO x h_explicit / h_implicit`` how far the trial fell short.
Measured reasons:

- A stiff problem can start with a fast transient that a trial cannot outgrow: on the
  16-link spring chain at k = 1e6 (``bench/stiff.py``) at rtol 1.5e-5 Radau's steps at
  t = 0.01 were 0.66 times DOP853's stable step, twice it from about t = 0.25 on, five
  times it later. Sent back for good, the run paid DOP853's 12,000 steps (three times
  Radau's time); trying again after the wait, it switched at t = 0.27 and stayed with
  Radau (2,249 steps; Radau alone 2,204).
- A false alarm on a problem that is not stiff ends with Radau's step far below the
  explicit one (0.1-0.25 of it on the gallery's hanging chain at rtol 1e-6 and 1e-8),
  a transient that is dying out near it (0.66-1.9 on the chain): the shortfall puts
  the next alarm out of reach of the first and keeps the second close. With the wait
  doubling only, the hanging chain over 20 s had four trials instead of one (3.9-4.3 %
  more evaluations than DOP853's run, against 0.9-1.6 % with one).
- The waits double (and the shortfall of a failed trial is above 1): a problem that
  stays mildly stiff (its trials fail) has at most ``log2(N / RETRY_WAIT + 1) + 1``
  trials in ``N`` explicit steps, each about ``TRIAL_STEPS`` implicit steps, so its
  extra work is bounded and falls, relative to the run, as the run grows.

Both tests see steps held at DOP853's stability limit. Where its steps are held shorter
still, for accuracy, by a fast mode the motion excites (its default 1e-11 on a stiff
spring chain: ``h |lambda|`` 0.007), neither fires, though Radau at its own tolerance may
step many times longer. So an estimate that starts no trial may start a **probe**
instead, where the run is long (:data:`PROBE_LEFT`) and its fastest mode fast
(:data:`PROBE_SPAN`): Radau takes ``TRIAL_STEPS`` steps from the state reached, and if
its step grows to :data:`PROBE_RATIO` times DOP853's the run switches to Radau there and
keeps it (as after a trial that pays); otherwise the probe's steps are discarded (the
run stays DOP853's, step for step) and the next probe waits
``max(n, SPECTRAL_FIRST) x shortfall`` explicit steps, ``n`` the steps DOP853 has taken
since it took the run. DOP853's step is taken as the longer of its next step and its
mean since it took the run (a step held short for a moment is not the run's).

Radau, once kept, looks back as LSODA does: every ``SPECTRAL_FIRST`` implicit steps an
estimate of the Jacobian's largest ``|lambda|``; where DOP853 could take Radau's step
(the longer of its next step and its mean since the last look: a Newton failure cuts
single steps short) stably (``h |lambda|`` below ``SPECTRAL_LIMIT``: the problem has
turned non-stiff, a stiff force let go), a probe of DOP853 from the state reached, and
the run goes back to it where its step grows to ``BACK_RATIO`` times Radau's (its
detector armed again after ``RETRY_WAIT`` steps); otherwise the next look waits
``SPECTRAL_FIRST x shortfall`` steps.

A false alarm costs one trial (the detector's limit of 1 fires on some gallery models at
rtol 1e-3; lowering its 15 steps to 8 or 5 to detect sooner made more of them fire, at
rtol 1e-6 and 1e-8 too).

:class:`StiffSwitch` holds the policy and its memory for one run segment; the loops
(:mod:`.loop`) call :meth:`StiffSwitch.after` after each unit of work.
"""

from __future__ import annotations

import warnings
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
from scipy.integrate import OdeSolver

from ...errors import DalembertError, IntegrationWarning, ModelError
from ..steppers.scipy_ivp import ControlledSteps, step_size
from ..steppers.stiffness import StiffnessDetector, StiffnessState, spectral_radius

#: The detector of ``method="auto"``: Hairer's test with a lower limit than DOP853's
#: 6.1 (its stability limit on the negative real axis). A stiff spring with light
#: damping puts its modes near the imaginary axis, where DOP853's steps stay at
#: ``h |lambda|`` about 1.4 (measured on the elastic pendulum at k = 1e8: DOP853 took
#: 13,889 steps at rtol 1e-8, Radau 1,301). Of the gallery's models at rtol 1e-6 and
#: 1e-8 only the hanging chain reaches 1 for 15 steps; at rtol 1e-3 six of them do. A
#: false alarm costs a trial of ``TRIAL_STEPS`` Radau steps.
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
#: Explicit steps after the first failed trial (times its shortfall) before the detector
#: is armed again; doubled after each failed trial (see the module).
RETRY_WAIT = 100
#: Besides Hairer's test, the detector armed estimates the Jacobian's largest
#: ``|lambda|`` (:func:`~dalembert.solvers.steppers.stiffness.spectral_radius`, 13
#: evaluations) after this many explicit steps, then after as many again as the run has
#: taken (its cost falls as the run grows): Hairer's test misses a stiff spring that the
#: motion barely excites (the elastic pendulum at k = 1e7: it read ``h |lambda|``
#: about 0.1 where it was 0.94-1.35, and DOP853 took 3.5 times Radau's steps).
SPECTRAL_FIRST = 300
#: ``h |lambda|`` at or above which an estimate starts a trial of the implicit method:
#: DOP853's steps sit at 0.9-1.4 where a lightly damped stiff mode holds them (the trial
#: decides whether Radau pays: at k = 1e5 it does not, at 1e7 it does).
SPECTRAL_LIMIT = 0.8
#: A trial (either test's) starts only where the explicit steps left to the segment's
#: end, at the step reached, are at least this many: a trial costs about a Radau
#: solver's set-up and 20 implicit steps (2.5 ms on the elastic pendulum, as much as 300
#: of its DOP853 steps), which fewer steps left cannot repay. At k = 1e5 the estimate
#: fired at step 300 with 265 steps left and the trial failed; Hairer's test fires on
#: the free chains 15-22 steps into runs of 130-340 steps, and on the gallery's short
#: runs at rtol 1e-3, where every trial failed (bench/README.md).
TRIAL_LEFT = 1000
#: A probe (see the module) runs at a spectral estimate that did not start a trial, if
#: at least this many explicit steps are left at the step reached: its cost, a Radau
#: set-up and ``TRIAL_STEPS`` steps discarded, is then at most a few per cent of them.
PROBE_LEFT = 10_000
#: ... and if the time left spans at least this many time constants of the fastest mode
#: (``|lambda| (t_bound - t)``): a problem without modes that fast is not stiff, and a
#: long run of one pays no probe nor the implicit method's code generation.
PROBE_SPAN = 1e3
#: A probe pays where the implicit step grows to this many times the explicit one. At
#: the default tolerances (DOP853 1e-11, Radau 1e-8) Radau took 2.3 to 7 times
#: DOP853's steps on every gallery model that is not stiff, a thirtieth to a hundredth
#: of them on the stiff ones (bench/README.md). Twice ``COST_RATIO``: a false switch
#: would also loosen the run's accuracy to the implicit method's tolerance.
PROBE_RATIO = 4.0
#: The kept implicit method hands the run back where a probe of the explicit one, at
#: its own tolerance, steps at least this many times as long as the implicit step (a
#: DOP853 step costs less than a Radau step, half by ``COST_RATIO``: the margin keeps a
#: run from switching to and fro near the break-even).
BACK_RATIO = 1.0

#: ``make(t, y, t_bound, h_abs)``: a solver of the run's problem starting at ``(t, y)``
#: (``h_abs``: its first step, or 0 to let it choose).
SolverFactory = Callable[[float, np.ndarray, float, float], OdeSolver]


@dataclass
class StiffSwitch:
    """The switching of one run segment (see the module): a value with its memory.

    Parameters
    ----------
    implicit, explicit
        The factories of the implicit solver and of the explicit one (going back; made
        without a detector: the switch arms one when its wait is over).
    implicit_name
        The implicit method's name, for the run's record.

    Examples
    --------
    A solver without a stiffness detector never makes it switch:

    >>> from scipy.integrate import RK45
    >>> switch = StiffSwitch(lambda *a: None, lambda *a: None)
    >>> solver = RK45(lambda t, y: -y, 0.0, np.ones(1), 1.0)
    >>> switch.after(solver, 0) is None, switch.steps_to_judgement(0), switch.switches
    (True, 300, [])
    """

    implicit: SolverFactory
    explicit: SolverFactory
    implicit_name: str = "Radau"
    #: the segment's start
    t0: float = 0.0
    #: ``(t, method)`` of each switch made
    switches: list[tuple[float, str]] = field(default_factory=list)
    _trial: tuple[float, int, float] | None = None  # t, steps and explicit step at the switch
    _judged: float = 0.0  # the implicit step at the last judgement (0: none yet)
    _settled: bool = False  # DOP853 kept for the rest of the segment (no more trials)
    _kept_at: int | None = None  # the step count at which the implicit method was kept
    _back_at: int = 0  # the step count of the next look back at the explicit method
    _look: tuple[float, int] = (0.0, 0)  # t and steps at the kept method's last look back
    _detector: StiffnessDetector | None = None  # the explicit solver's, kept while it waits
    _rearm_at: int | None = None  # the step count at which the detector is armed again
    _wait: int = field(default_factory=lambda: RETRY_WAIT)  # the next failed trial's wait
    #: the probes run, and their work ``(nfev, njev, nlu)`` (discarded, not the run's)
    probes: int = 0
    probe_work: tuple[int, int, int] = (0, 0, 0)
    _estimate_at: int = SPECTRAL_FIRST  # the step count of the next spectral estimate
    _vector: np.ndarray | None = None  # the last estimate's vector
    _probe_at: int = 0  # the step count before which no probe runs
    _explicit_since: tuple[float, int] = (0.0, 0)  # t, steps: the explicit method's take-over

    def __post_init__(self) -> None:
        self._explicit_since = (self.t0, 0)

    def steps_to_judgement(self, n_steps: int) -> int | None:
        """How many more steps before the switch has something to decide (a trial to
        judge, the detector to arm again, an estimate, a look back from the implicit
        method; ``None``: nothing more), so that a stretch of steps in C ends there.

        Parameters
        ----------
        n_steps
            The steps the run has taken.
        """
        if self._settled:
            return None
        if self._kept_at is not None:
            return max(1, self._back_at - n_steps)
        if self._trial is not None:
            return max(1, TRIAL_STEPS - (n_steps - self._trial[1]))
        if self._rearm_at is not None:
            return max(1, self._rearm_at - n_steps)
        return max(1, self._estimate_at - n_steps)

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
        if self._kept_at is not None:
            return self._implicit_after(solver, n_steps)
        if self._trial is None:
            return self._explicit_after(solver, n_steps)
        _, steps0, h_explicit = self._trial
        if n_steps - steps0 < TRIAL_STEPS:
            return None
        h_implicit = step_size(solver)  # the step Radau has grown to
        if h_implicit >= COST_RATIO * h_explicit:
            self._keep(solver, n_steps)
            return None
        if h_implicit > GROWING * self._judged:  # still growing: another trial
            self._trial, self._judged = (solver.t, n_steps, h_explicit), h_implicit
            return None
        # back to the explicit method, its detector armed again after a wait that grows
        # with the failed trials and with how far the implicit step fell short
        shortfall = COST_RATIO * h_explicit / max(h_implicit, 1e-300)
        self._trial, self._explicit_since = None, (solver.t, n_steps)
        self._rearm_at = n_steps + int(min(self._wait * shortfall, 1e12))
        self._wait *= 2
        self.switches.append((solver.t, "DOP853"))
        return self.explicit(solver.t, solver.y, solver.t_bound, h_explicit)

    def _explicit_after(self, solver: OdeSolver, n_steps: int) -> OdeSolver | None:
        """The explicit method's turn: arm its detector when the wait is over, switch
        when the detector or an estimate says stiff or a probe finds the implicit
        method paying."""
        estimate = n_steps >= self._estimate_at
        if estimate:  # the next one after as many steps again (stretches in C end there)
            self._estimate_at = n_steps + max(SPECTRAL_FIRST, n_steps)
        if not isinstance(solver, ControlledSteps):
            return None
        if self._rearm_at is not None:
            if n_steps < self._rearm_at:
                return None
            solver.detector, solver.stiffness = self._detector, StiffnessState()
            self._rearm_at = None
            self._estimate_at = n_steps + SPECTRAL_FIRST
            return None
        h_explicit = step_size(solver)
        if not h_explicit > 0.0 or abs(solver.t_bound - solver.t) < TRIAL_LEFT * h_explicit:
            # too few steps left to repay a trial; a test that fired is quieted (else a
            # stretch in C would end at every step) and armed again later, as after a trial
            if solver.stiff:
                self._detector, solver.detector = solver.detector, None
                self._rearm_at = n_steps + TRIAL_LEFT
            return None
        probed = False
        if not solver.stiff:
            if not estimate or solver.detector is None:
                return None
            rho = self._spectral_radius(solver)
            if h_explicit * rho < SPECTRAL_LIMIT:
                h_ref = self._explicit_step(solver, n_steps)
                if not self._probe_due(solver, n_steps, rho, h_ref) or \
                        not self._probe_pays(solver, n_steps, h_explicit, h_ref):
                    return None
                probed = True
        try:
            implicit = self.implicit(solver.t, solver.y, solver.t_bound, h_explicit)
        except ModelError as exc:  # its Jacobian cannot be made (a sign() in a force)
            self._cannot_switch(solver, exc)
            return None
        self._detector = solver.detector
        if probed:  # the probe has shown it: no trial to judge
            self._keep(solver, n_steps)
        else:
            self._trial, self._judged = (solver.t, n_steps, h_explicit), h_explicit
        self.switches.append((solver.t, self.implicit_name))
        return implicit

    def _keep(self, solver: OdeSolver, n_steps: int) -> None:
        """Keep the implicit method (a trial or a probe has shown it paying); look back at
        the explicit one after ``SPECTRAL_FIRST`` steps."""
        self._trial, self._kept_at = None, n_steps
        self._back_at, self._look = n_steps + SPECTRAL_FIRST, (solver.t, n_steps)

    def _implicit_after(self, solver: OdeSolver, n_steps: int) -> OdeSolver | None:
        """The kept implicit method's turn: every ``SPECTRAL_FIRST`` steps an estimate of
        the Jacobian's largest ``|lambda|`` (13 evaluations: under 1 % of the steps');
        where the explicit method could take the implicit step stably, a probe of it, and
        the run goes back to it where it steps at least ``BACK_RATIO`` times as long."""
        if n_steps < self._back_at:
            return None
        # the implicit step to weigh: the longer of the next and the mean since the last
        # look (a step cut short for a moment, by a Newton failure, is not the run's)
        h_implicit = self._typical_step(solver, n_steps, self._look)
        self._back_at, self._look = n_steps + SPECTRAL_FIRST, (solver.t, n_steps)
        if not h_implicit > 0.0 or abs(solver.t_bound - solver.t) < SPECTRAL_FIRST * h_implicit:
            return None  # a probe (20 explicit steps) is repaid in fewer steps than a look's
        if h_implicit * self._spectral_radius(solver) >= SPECTRAL_LIMIT:
            return None  # stiff still: the explicit method's steps would be held shorter
        grown = self._probe(self.explicit, solver, step_size(solver))
        if grown < BACK_RATIO * h_implicit:
            shortfall = BACK_RATIO * h_implicit / max(grown, 1e-300)
            self._back_at = n_steps + int(min(SPECTRAL_FIRST * shortfall, 1e12))
            return None
        # back to the explicit method, its detector armed again after the first wait
        self._kept_at, self._wait = None, RETRY_WAIT
        self._rearm_at, self._explicit_since = n_steps + RETRY_WAIT, (solver.t, n_steps)
        self.switches.append((solver.t, "DOP853"))
        return self.explicit(solver.t, solver.y, solver.t_bound, step_size(solver))

    def _cannot_switch(self, solver: OdeSolver, exc: ModelError) -> None:
        """Leave the run with the explicit method: the implicit one cannot be made."""
        warnings.warn(f"method='auto' found the problem stiff at t={solver.t:.6g} but "
                      f"cannot switch to {self.implicit_name}: {exc}; the run stays "
                      "with DOP853", IntegrationWarning, stacklevel=2)
        solver.detector, self._settled = None, True  # DOP853's for the rest

    def _spectral_radius(self, solver: OdeSolver) -> float:
        """An estimate of the Jacobian's largest ``|lambda|`` at the state reached (see
        :data:`SPECTRAL_FIRST`), started from the last estimate's vector."""
        start = self._vector if self._vector is not None else \
            np.random.default_rng(0).standard_normal(len(solver.y))
        rho, self._vector = spectral_radius(solver.fun, solver.t, solver.y, start)
        return rho

    def _probe_due(self, solver: OdeSolver, n_steps: int, rho: float, h_ref: float) -> bool:
        """Whether a probe may run now (see :data:`PROBE_LEFT`, :data:`PROBE_SPAN`;
        ``h_ref``: :meth:`_explicit_step`)."""
        left = abs(solver.t_bound - solver.t)
        return n_steps >= self._probe_at and rho * left >= PROBE_SPAN and \
            left >= PROBE_LEFT * h_ref

    def _explicit_step(self, solver: OdeSolver, n_steps: int) -> float:
        """The explicit step to weigh the implicit one against: the longer of the next
        one and the mean since the explicit method took the run (a step held short for a
        moment is not the run's)."""
        return self._typical_step(solver, n_steps, self._explicit_since)

    @staticmethod
    def _typical_step(solver: OdeSolver, n_steps: int, since: tuple[float, int]) -> float:
        """The longer of ``solver``'s next step and its mean since ``(t, steps)``."""
        return max(step_size(solver), abs(solver.t - since[0]) / max(n_steps - since[1], 1))

    def _probe_pays(self, solver: OdeSolver, n_steps: int, h_explicit: float,
                    h_ref: float) -> bool:
        """Whether the implicit method, ``TRIAL_STEPS`` steps from the state reached,
        grows its step to ``PROBE_RATIO`` times the explicit one's (``h_ref``:
        :meth:`_explicit_step`; ``h_explicit``, the next, is the probe's first). A probe
        that falls short sets the next one's wait."""
        try:
            grown = self._probe(self.implicit, solver, h_explicit)
        except ModelError as exc:
            self._cannot_switch(solver, exc)
            return False
        if grown >= PROBE_RATIO * h_ref:
            return True
        shortfall = PROBE_RATIO * h_ref / max(grown, 1e-300)
        taken = n_steps - self._explicit_since[1]
        self._probe_at = n_steps + int(min(max(taken, SPECTRAL_FIRST) * shortfall, 1e12))
        return False

    def _probe(self, make: SolverFactory, solver: OdeSolver, h_first: float) -> float:
        """The step the other method grows to in ``TRIAL_STEPS`` steps from the state
        ``solver`` has reached (0 where it fails). Its steps are not the run's: they are
        discarded, so a run a probe leaves alone goes on step for step as without it;
        their work is counted in :attr:`probe_work`."""
        probe = make(solver.t, solver.y, solver.t_bound, h_first)
        with warnings.catch_warnings():  # a probe that fails is a probe that falls short
            warnings.simplefilter("ignore")
            try:
                for _ in range(TRIAL_STEPS):
                    if probe.status != "running" or probe.step() is not None:
                        break
            except (ArithmeticError, ValueError, DalembertError):
                probe.status = "failed"
        nfev, njev, nlu = self.probe_work
        self.probe_work = (nfev + probe.nfev, njev + (probe.njev or 0), nlu + (probe.nlu or 0))
        self.probes += 1
        return step_size(probe) if probe.status in ("running", "finished") else 0.0
