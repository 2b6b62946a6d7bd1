"""``method="auto"``: DOP853 under Hairer's stiffness detector, switching to Radau.

References: the elastic pendulum of ``test_elastic_pendulum.py`` (checked there against
its polar-coordinate model at k = 1e3 and 1e6) at k = 1e8, integrated by DOP853 at rtol
1e-12 (the polar model's own reference takes minutes at this stiffness), for runs that
switch; DOP853's own run for one that does not; the detector's estimate against
``h |lambda|`` of a linear problem; the switch back, forced, against the same reference;
a stiff spring chain whose first trial fails against DOP853 at rtol 1e-10 (its steps
held at the stability limit, so the tight tolerance costs no more steps); the waits of
the policy against the rule the module states; a probe that falls short against
DOP853's own run; the way back to DOP853, on the pendulum whose spring softens from
stiff to soft, against DOP853 at rtol 1e-12.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest
from scipy.integrate import DOP853

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from test_elastic_pendulum import T_END, TH0, build, cartesian, r0, softening

from dalembert.examples import cartesian_pendulum, hanging_chain
from dalembert.multibody import JointSpring, Multibody, chain
from dalembert.solvers.running import switching
from dalembert.solvers.steppers.scipy_ivp import ControlledDOP853
from dalembert.solvers.steppers.stiffness import StiffnessDetector, StiffnessState

K = 1e8


@pytest.fixture(scope="module")
def elastic():
    system = build(K)
    q0 = dict(zip(("x", "y", "z"), cartesian(r0(K), TH0)))
    reference = system.simulate((0.0, T_END), q0, method="DOP853", rtol=1e-12, atol=1e-14,
                                t_eval=[T_END])
    return system, q0, end_of(reference)


def end_of(traj) -> np.ndarray:
    return np.array([traj[c][-1] for c in ("x", "y", "z")])


@pytest.mark.parametrize("backend", ["c", "python"])
def test_a_stiff_run_switches_to_radau_and_meets_the_reference(elastic, backend):
    """The spring's radial mode (1e4 rad/s, undamped) holds DOP853's steps at ``h |lambda|``
    about 1.4: the detector says stiff, Radau takes over (once), and the end meets the
    reference; far fewer steps than DOP853's."""
    system, q0, expected = elastic
    options = dict(rtol=1e-8, atol=1e-10, t_eval=[T_END], backend=backend)
    auto = system.simulate((0.0, T_END), q0, method="auto", **options)
    assert auto.success and auto.stats["n_switches"] == 1
    assert auto.stats["njev"] > 0  # Radau's Jacobians
    assert np.abs(end_of(auto) - expected).max() < 1e-8
    explicit = system.simulate((0.0, T_END), q0, method="DOP853", **{**options,
                                                                    "backend": "c"})
    assert auto.stats["n_steps"] < explicit.stats["n_steps"] / 3


@pytest.mark.parametrize("backend", ["c", "python"])
def test_at_the_default_tolerances_a_probe_finds_radau_paying(elastic, backend):
    """At the defaults DOP853 (rtol 1e-11) resolves the spring's radial mode for
    accuracy, far inside its stability limit, so neither test of stiffness fires. A probe
    finds Radau at its own default (1e-8) stepping more than ``PROBE_RATIO`` times longer
    and the run switches there: the end meets the reference to Radau's accuracy, in a
    twentieth of DOP853's steps."""
    system, q0, expected = elastic
    auto = system.simulate((0.0, T_END), q0, t_eval=[T_END], backend=backend)  # defaults
    assert auto.success and auto.stats["n_probes"] == 1 and auto.stats["n_switches"] == 1
    assert np.abs(end_of(auto) - expected).max() < 1e-9
    explicit = system.simulate((0.0, T_END), q0, method="DOP853", t_eval=[T_END])
    assert auto.stats["n_steps"] < explicit.stats["n_steps"] / 20


def test_a_probe_that_falls_short_leaves_the_run_dop853s():
    """The slider-crank over 100 s is long enough, and its fastest mode fast enough, for
    a probe at the defaults, but it is not stiff: Radau's step falls short, the probe's
    steps are discarded and the run is DOP853's, step for step (the probe's evaluations
    counted beside them)."""
    from dalembert.examples import slider_crank

    system = slider_crank.build()
    span = (0.0, 10 * slider_crank.T_END)
    auto = system.simulate(span, **slider_crank.INITIAL)
    explicit = system.simulate(span, **slider_crank.INITIAL, method="DOP853")
    assert auto.stats["n_probes"] >= 1 and auto.stats["n_switches"] == 0
    assert np.array_equal(auto.t, explicit.t) and np.array_equal(auto.q, explicit.q)
    assert auto.stats["nfev"] > explicit.stats["nfev"]


def test_dense_output_runs_across_a_switch(elastic):
    """``sol(t)`` covers DOP853's steps and Radau's after the switch (their interpolants
    differ in form) and meets the reference between the steps."""
    system, q0, _ = elastic
    t = np.linspace(0.0, T_END, 41)
    auto = system.simulate((0.0, T_END), q0, method="auto", rtol=1e-8, atol=1e-10,
                           dense_output=True, backend="python")
    assert auto.success and auto.stats["n_switches"] >= 1
    reference = system.simulate((0.0, T_END), q0, method="DOP853", rtol=1e-12, atol=1e-14,
                                t_eval=t)
    assert np.abs(auto.sol(t)[:3].T - reference.q).max() < 1e-7


def test_a_switch_that_cannot_be_made_leaves_the_run_with_dop853():
    """Where the implicit method cannot be made (its Jacobian has no code: a ``sign`` of
    a rate in a force), a stiff problem stays with DOP853 with a warning saying so, and
    no trial is tried again."""
    from dalembert.errors import IntegrationWarning, ModelError

    def cannot(*args):
        raise ModelError("Derivative(sign(x_dot), x_dot) has no code")

    switch = switching.StiffSwitch(cannot, lambda *a: None)
    solver = ControlledDOP853(lambda t, y: -1e4 * y, 0.0, np.ones(1), 10.0, rtol=1e-6,
                              atol=1e-9, detector=switching.DETECTOR)
    n = 0
    while not solver.stiff:
        solver.step()
        n += 1
    with pytest.warns(IntegrationWarning, match="cannot switch to Radau.*stays with DOP853"):
        assert switch.after(solver, n) is None
    assert solver.detector is None and switch.steps_to_judgement(n) is None
    assert switch.switches == []


@pytest.fixture(scope="module")
def barely_excited():
    """The elastic pendulum at k = 1e7, the end of its polar-coordinate model
    integrated by SciPy's DOP853 at rtol 1e-11, and DOP853's steps (in C) at rtol 1e-8."""
    from test_elastic_pendulum import polar

    k = 1e7
    system = build(k)
    q0 = dict(zip(("x", "y", "z"), cartesian(r0(k), TH0)))
    explicit = system.simulate((0.0, T_END), q0, method="DOP853", rtol=1e-8, atol=1e-10,
                               t_eval=[T_END])
    return system, q0, cartesian(*polar(k)), explicit.stats["n_steps"]


@pytest.mark.parametrize("backend", ["c", "python"])
def test_a_barely_excited_stiff_spring_is_found_by_its_spectral_radius(barely_excited,
                                                                         backend):
    """At k = 1e7 the spring is loaded slowly by the swing: Hairer's test reads
    ``h |lambda|`` about 0.1 (the stages' difference is the slow motion's) while
    DOP853's steps sit at 0.9-1.4 times its stability limit. The spectral estimate
    (power iteration on the Jacobian's square: ``sqrt(k)`` here) finds it, and Radau
    takes over; the end against the polar-coordinate model."""
    system, q0, expected, explicit_steps = barely_excited
    auto = system.simulate((0.0, T_END), q0, method="auto", rtol=1e-8, atol=1e-10,
                           t_eval=[T_END], backend=backend)
    assert auto.success and auto.stats["n_switches"] == 1
    assert np.abs(end_of(auto) - expected).max() < 1e-8
    assert auto.stats["n_steps"] < explicit_steps / 2


def test_the_spectral_radius_of_a_spring_is_its_frequency():
    """Power iteration on the square of a linear problem's matrix: ``w`` for an
    undamped spring in balanced coordinates, within the coordinates' scale mismatch
    (``sqrt(w)`` at most) in raw ones, and 0 for a problem without dynamics."""
    from dalembert.solvers.steppers.stiffness import spectral_radius

    w = 3e3
    balanced = np.array([[0.0, w], [-w, 0.0]])
    rho, _ = spectral_radius(lambda t, y: balanced @ y, 0.0, np.ones(2), np.array([1.0, 0.3]))
    assert abs(rho - w) < 1e-6 * w
    raw = np.array([[0.0, 1.0], [-w**2, -0.1]])
    rho, _ = spectral_radius(lambda t, y: raw @ y, 0.0, np.ones(2), np.array([1.0, 0.3]))
    assert w / np.sqrt(w) <= rho <= w * np.sqrt(w)
    rho, _ = spectral_radius(lambda t, y: np.zeros(2), 0.0, np.ones(2), np.ones(2))
    assert rho == 0.0


def test_a_non_stiff_run_is_dop853s():
    """Without stiffness the run is DOP853's, step for step (the detector only watches)."""
    system = cartesian_pendulum.build()
    q0 = {"x": 0.6, "y": -0.8}
    auto = system.simulate((0, 2), q0, t_eval=[2.0])  # the default method
    explicit = system.simulate((0, 2), q0, method="DOP853", t_eval=[2.0])
    assert auto.stats["n_switches"] == 0
    assert auto.stats["n_steps"] == explicit.stats["n_steps"]
    assert np.array_equal(auto.q, explicit.q)


def test_going_back_when_radau_does_not_pay(elastic, monkeypatch):
    """Where Radau's steps are not ``COST_RATIO`` times DOP853's the run goes back to
    DOP853 after the trial steps (forced here by an unreachable ratio: its shortfall
    puts the next trial beyond the run) and still meets the reference."""
    system, q0, expected = elastic
    monkeypatch.setattr(switching, "COST_RATIO", 1e9)
    traj = system.simulate((0.0, T_END), q0, method="auto", rtol=1e-8, atol=1e-10,
                           t_eval=[T_END])
    assert traj.success and traj.stats["n_switches"] == 2
    assert np.abs(end_of(traj) - expected).max() < 1e-8


@pytest.mark.parametrize("backend", ["c", "python"])
def test_radau_hands_the_run_back_where_the_problem_turns_non_stiff(backend):
    """The spring let go: ``auto`` switches to Radau in the stiff phase and, looking back
    once the fastest mode has slowed (Radau's ``h |lambda|`` below the limit, then a
    probe of DOP853 stepping longer), hands the run back to DOP853: two switches, the end
    against DOP853 at rtol 1e-12, in fewer steps than either method alone."""
    system = softening(K)
    q0 = dict(zip(("x", "y", "z"), cartesian(r0(K), TH0)))
    span, options = (0.0, 4.0), dict(rtol=1e-8, atol=1e-10, t_eval=[4.0])
    auto = system.simulate(span, q0, method="auto", backend=backend, **options)
    reference = system.simulate(span, q0, method="DOP853", rtol=1e-12, atol=1e-14,
                                t_eval=[4.0])
    alone = [system.simulate(span, q0, method=m, **options).stats["n_steps"]
             for m in ("Radau", "DOP853")]
    assert auto.success and auto.stats["n_switches"] == 2
    assert np.abs(end_of(auto) - end_of(reference)).max() < 1e-8
    assert auto.stats["n_steps"] < 0.8 * min(alone)


class _Implicit:
    """A stand-in for the implicit solver of a trial: only its state and step are read."""

    def __init__(self, t: float, h_abs: float) -> None:
        self.t, self.y, self.t_bound, self.h_abs = t, np.zeros(1), 10.0, h_abs


def test_the_wait_grows_with_failed_trials_and_their_shortfall():
    """After a failed trial the detector is off for ``RETRY_WAIT x 2^(n-1) x shortfall``
    explicit steps (the module's rule), then armed with a fresh memory; a trial whose
    implicit step reaches ``COST_RATIO`` times the explicit one keeps the implicit method,
    which looks back at the explicit one ``SPECTRAL_FIRST`` steps later."""
    detector = StiffnessDetector(limit=1.0)
    made: list[str] = []

    def explicit(t, y, t_bound, h):
        made.append("explicit")
        solver = ControlledDOP853(lambda t, y: -y, t, np.ones(1), t_bound, first_step=h)
        return solver

    def implicit(t, y, t_bound, h):
        made.append("implicit")
        return _Implicit(t, h)

    switch = switching.StiffSwitch(implicit, explicit)
    first = ControlledDOP853(lambda t, y: -y, 0.0, np.ones(1), 10.0, first_step=0.01,
                             detector=detector)
    first.stiffness = StiffnessState(detector.stiff_after, 0)  # the detector fires
    h_explicit = switching.step_size(first)
    trial = switch.after(first, 30)
    assert made == ["implicit"] and switch.steps_to_judgement(30) == switching.TRIAL_STEPS
    trial.h_abs = h_explicit / 2  # shrunk below the explicit step, and not growing
    back = switch.after(trial, 30 + switching.TRIAL_STEPS)
    assert made[-1] == "explicit" and back.detector is None
    shortfall = switching.COST_RATIO * 2  # COST_RATIO h_explicit / (h_explicit / 2)
    rearm = 30 + switching.TRIAL_STEPS + switching.RETRY_WAIT * shortfall
    assert switch.steps_to_judgement(rearm - 1) == 1
    assert switch.after(back, int(rearm) - 1) is None and back.detector is None
    assert switch.after(back, int(rearm)) is None
    assert back.detector is detector and back.stiffness == StiffnessState()
    # the second trial falls short by COST_RATIO only: the wait doubled, times that
    back.stiffness = StiffnessState(detector.stiff_after, 0)
    h2 = switching.step_size(back)
    trial = switch.after(back, int(rearm) + 5)
    trial.h_abs = h2
    again = switch.after(trial, int(rearm) + 5 + switching.TRIAL_STEPS)
    assert made[-1] == "explicit"
    at = int(rearm) + 5 + switching.TRIAL_STEPS
    assert switch.steps_to_judgement(at) == 2 * switching.RETRY_WAIT * switching.COST_RATIO
    # the third pays and keeps the run: its first look back is due SPECTRAL_FIRST steps on
    switch.after(again, at + 2 * switching.RETRY_WAIT * int(switching.COST_RATIO))
    again.stiffness = StiffnessState(detector.stiff_after, 0)
    trial = switch.after(again, at + 1000)
    trial.h_abs = switching.COST_RATIO * switching.step_size(again)
    kept = at + 1000 + switching.TRIAL_STEPS
    assert switch.after(trial, kept) is None
    assert switch.steps_to_judgement(kept) == switching.SPECTRAL_FIRST
    assert [m for _, m in switch.switches] == ["Radau", "DOP853"] * 2 + ["Radau"]


def spring_chain(links: int = 4, k: float = 1e6, c: float = 17.5) -> Multibody:
    """A planar chain hung from a pin with a torsional spring and damper on every joint
    but the pin (``c``: the fastest mode's damping ratio about 0.05 at k = 1e6)."""
    base = chain(links, 1.0, 1.0, 0.05, joint="revolute", planar=True)
    springs = [JointSpring(f"spring{i + 1}", base.joints[i], k, c)
               for i in range(1, links)]
    return Multibody(base.bodies, base.joints, gravity=(0.0, -9.81, 0.0),
                     joint_springs=springs, name="spring chain")


def test_a_stiff_start_with_a_transient_is_tried_again():
    """Released 30 degrees from hanging, the stiff chain's first Radau steps resolve a
    fast transient and stay below DOP853's stable step: the first trial fails; the
    detector, armed again, switches once more and Radau then pays and keeps the run
    (DOP853 to the first trial, Radau, DOP853, Radau: three switches), which meets DOP853
    at a tight tolerance with far fewer steps."""
    mb = spring_chain()
    names = [b.name for b in mb.bodies]
    down = np.array([-np.sin(np.radians(30.0)), -np.cos(np.radians(30.0))])
    q0, qd0 = mb.initial_state(positions={n: (j + 0.5) * down for j, n in enumerate(names)},
                               orientations=dict.fromkeys(names, -np.radians(30.0)))

    def angles(traj):
        return np.array([traj[f"{n}_theta"][-1] for n in names])

    auto = mb.simulate((0.0, 10.0), q0, qd0, method="auto", rtol=1e-6, atol=1e-8,
                       t_eval=[10.0])
    reference = mb.simulate((0.0, 10.0), q0, qd0, rtol=1e-10, atol=1e-12, t_eval=[10.0])
    assert auto.success and auto.stats["n_switches"] == 3
    assert np.abs(angles(auto) - angles(reference)).max() < 1e-4
    assert auto.stats["n_steps"] < reference.stats["n_steps"] / 5


def test_a_false_alarm_goes_back_with_bounded_extra_work():
    """The hanging chain is not stiff, but at rtol 1e-8 the detector fires: the trial
    fails far short and the run goes back to DOP853 for the rest of 20 s (the shortfall
    sets the next alarm beyond it), its evaluations within 5 % of DOP853's and its end
    as accurate (against DOP853 at rtol 1e-12)."""
    system = hanging_chain.build()
    span = (0.0, 10 * hanging_chain.T_END)
    options = dict(rtol=1e-8, atol=1e-10, t_eval=[span[1]])
    auto = system.simulate(span, **hanging_chain.INITIAL, method="auto", **options)
    explicit = system.simulate(span, **hanging_chain.INITIAL, **options)
    reference = system.simulate(span, **hanging_chain.INITIAL, rtol=1e-12, atol=1e-14,
                                t_eval=[span[1]])
    assert auto.success and auto.stats["n_switches"] in (0, 2)  # ends with DOP853
    assert auto.stats["nfev"] < 1.05 * explicit.stats["nfev"]
    error = np.abs(auto.q[-1] - reference.q[-1]).max()
    assert error < 3 * max(np.abs(explicit.q[-1] - reference.q[-1]).max(), 1e-10)


@pytest.mark.parametrize("rtol", [1e-3, 1e-6])
def test_a_false_alarm_with_few_steps_left_starts_no_trial(rtol):
    """The hanging chain over its gallery span: the detector fires (it made one trial
    at each of these tolerances before), but DOP853 has fewer steps left than a trial
    could repay (``TRIAL_LEFT``): the run is DOP853's, step for step."""
    system = hanging_chain.build()
    span = (0.0, hanging_chain.T_END)
    options = dict(rtol=rtol, atol=rtol * 1e-2, t_eval=[span[1]])
    auto = system.simulate(span, **hanging_chain.INITIAL, method="auto", **options)
    explicit = system.simulate(span, **hanging_chain.INITIAL, **options)
    assert auto.stats["n_switches"] == 0
    assert auto.stats["n_steps"] == explicit.stats["n_steps"]
    assert np.array_equal(auto.q, explicit.q)


def test_the_detector_measures_h_lambda():
    """On ``y' = -lambda y`` the estimate is ``h lambda``; a long run at DOP853's
    stability limit is called stiff, a smooth one is not."""
    lam = 1e4
    solver = ControlledDOP853(lambda t, y: -lam * y + np.cos(t), 0.0, np.array([0.0]), 1.0,
                              rtol=1e-6, atol=1e-9, detector=StiffnessDetector())
    for _ in range(60):
        solver.step()
    assert solver.stiff
    assert 6.1 < lam * solver.h_previous < 6.6  # at the edge of the stability region
    smooth = ControlledDOP853(lambda t, y: np.cos(t), 0.0, np.array([0.0]), 10.0,
                              rtol=1e-6, atol=1e-9, detector=StiffnessDetector())
    while smooth.status == "running":
        smooth.step()
    assert not smooth.stiff
    assert issubclass(ControlledDOP853, DOP853)


def test_auto_needs_the_pi_controller(elastic):
    """SciPy's controller gives one explicit method's steps: named with it, it runs; with
    the default method ("auto") the error says to name it."""
    system, q0, _ = elastic
    for method in ({"method": "auto"}, {}):
        with pytest.raises(ValueError, match=r"give it with that method.*step_control='PI'"):
            system.simulate((0.0, 0.1), q0, step_control="scipy", **method)
    assert system.simulate((0.0, 1e-3), q0, method="DOP853", step_control="scipy").success
