"""The time-stepping contact mode: Moreau-Jean steps, for many contacts.

Event-driven runs (:mod:`~dalembert.solvers.contact.driver`) are exact but pay for each
impact; a chain falling onto a table closes dozens of contacts in cascades. Moreau
and Jean's scheme steps over them at a fixed step ``h``, impacts and persistent
contact alike, with impulses over the step in place of forces:

1. the midpoint ``q_m = q + h/2 v``; there ``M``, ``f``, the rows ``A`` and the gaps;
   a rigid body's Euler parameters turn there instead, by its angular velocity
   (:mod:`~dalembert.solvers.contact.rotations`: a straight line would cost a
   spinning body ``O((h w)^2)`` of its spin each step), its rates carried along;
2. the contacts that count are the gaps closed (or touching, to rounding) at the
   midpoint, ``g(q_m) <= 0``;
3. the velocity at the step's end solves the KKT system with the bilateral rows,
   ``M v+ = M v + h f + A_b^T P_b + A_c^T P_c``, the impulses ``P_c`` on the contacts
   from the complementarity problem ``0 <= P_c  _|_  U+ + e U >= 0`` (``U`` the
   gaps' rates, Newton's law at the velocity level; ``e`` 0 for an impact slower than
   twice what the step's free motion adds to its rate, so that a body settling rests
   instead of hopping by ``g h`` for ever: :func:`_restitution`): with the Delassus matrix
   ``W = A_c K^-1 A_c^T`` (one KKT factorization, one solve per contact) it is a small
   dense LCP, solved by principal pivoting
   (:func:`~dalembert.solvers.contact.impulses.solve_lcp`);
4. ``q+ = q_m + h/2 v+`` (the quaternions turned again), then the positions
   projected onto the bilateral rows and
   the gaps that went below 0 (least change), and the velocities onto the bilateral
   rows.

It is first order: the impacts land within a step of their times and the apexes of a
bouncing ball within ``O(h)`` of the closed form (measured in the tests), against the
event-driven mode's rounding. The multipliers reported are the impulses over ``h``.

Inputs held by a digital controller (``sample_time``): the steps fall on the sample
instants (each interval between two instants, or an instant and an output time, cut
into equal steps of at most ``h``), the sample is taken at each instant from the
state there (as the event-driven mode takes it, :class:`~.driver.Hold`) and held
over the steps to the next; an output time at an instant shows the sample taken there.
Under inputs held constant over a step the step is exact for a constant force (its
position update is the trapezoid of a velocity linear in time), so a free motion
follows the zero-order hold's recurrence to rounding.
"""

from __future__ import annotations

import itertools
import math
import time
from dataclasses import dataclass
from functools import partial

import numpy as np

from ...codegen.compiled import NumericModel
from ...errors import ContactError, InputError, TimeLimitExceeded
from ...inputs import InputSignal
from ...numerics.gauss_newton import gauss_newton
from ..kkt.factorization import kkt_factorization
from ..kkt.sparse import matvec
from ..outputs import output_arrays
from ..projection import project_velocities
from ..running.integrate import IntegrationResult
from ..running.watchdog import GRACE, Watchdog, watching, where_stopped
from .driver import ContactHistory, Hold, ImpactRecord, Switch
from .gaps import TOUCH_RTOL, Gaps
from .impulses import contact_impulses
from .rotations import Rotations

#: An impact slower than this many times the change a step's free motion makes to its
#: gap's rate is plastic in the time-stepping mode (:func:`_restitution`): the hops of a
#: body at rest are one to two such changes.
STEP_REST = 2.0
#: Rounds of the position projection after a step (each a Gauss-Newton projection on
#: the rows held so far), and Gauss-Newton iterations in each.
PROJECTION_ITERATIONS = 8


@dataclass(frozen=True)
class SteppedRun:
    """A time-stepping run: the states, the outputs, the contact history, and (inputs
    sampled) the inputs held at each point recorded."""

    result: IntegrationResult
    derived: dict[str, np.ndarray]
    history: ContactHistory
    inputs: np.ndarray | None = None


def run_time_stepping(full: NumericModel, gaps: Gaps, t_span: tuple[float, float],
                      y0: np.ndarray, h: float, t_eval: np.ndarray | None,
                      signal: InputSignal | None = None,
                      rotations: Rotations | None = None,
                      deadline: float | None = None) -> SteppedRun:
    """Run ``t_span`` with Moreau-Jean steps of ``h`` (see the module docstring).

    Parameters
    ----------
    full
        The model with every gap a row (after the bilateral ones), its own parameter
        vector (the inputs are written into it).
    gaps
        Where its gaps are and their laws.
    t_span, y0
        The span and the initial state (consistent with the bilateral rows, every gap
        at or above 0).
    h
        The step.
    t_eval
        The times to record (each a step's end: the steps between two of them are
        equal, at most ``h``); ``None``: every step.
    signal
        The inputs at each step's midpoint, or (with its ``sample_time``) sampled at
        each instant and held; or ``None``.
    rotations
        Where the coordinates are unit quaternions (turned, not moved along a line,
        by a step); ``None``: nowhere.
    deadline
        The ``time.monotonic()`` past which the run stops (the run's ``timeout``),
        status ``"timeout"``, the steps done kept: checked after each step, and a
        :class:`~dalembert.solvers.running.watchdog.Watchdog` stops a function of the
        user's (an input) that does not return. ``None``: no limit.
    """
    t0, tf = t_span
    n, m = full.n, full.m
    hold = Hold.of(signal, t_span, n)
    asked = None if t_eval is None else hold_marks(hold, t_eval)
    instants = np.zeros(0) if hold.schedule is None else hold.schedule.instants
    grid = _grid(t0, tf, h, None if asked is None and not len(instants) else
                 np.concatenate([np.zeros(0) if asked is None else asked, instants]))
    turn = Rotations.none() if rotations is None else rotations
    pattern = full.pattern
    kkt = kkt_factorization(pattern)
    bilateral = np.zeros(m, dtype=bool)
    bilateral[:gaps.first] = True
    history = ContactHistory(gaps.names, tangents=gaps.sizes)
    q, v = np.array(y0[:n], dtype=float), np.array(y0[n:], dtype=float)
    history.switches.append(Switch(t0, (), q.copy(), v.copy()))
    times, states, forces = [t0], [np.concatenate([q, v])], [np.zeros(m)]
    accelerations = [np.full(n, np.nan)]  # the mean over the step ending there
    held = [hold.sample(t0, np.concatenate([q, v]))] if hold.sampled else []
    closed_before: tuple[int, ...] = ()
    status, message = "finished", "the integration reached the end of t_span"
    stop: list[str] = []  # the status and message of a run stopped between steps

    def _steps() -> None:
        nonlocal q, v, closed_before
        P = np.zeros(m)
        for t, end in itertools.pairwise(grid):
            h = end - t
            if held:
                full.set_inputs(held[-1])
            q_next, v_next, P = _step(full, gaps, kkt, bilateral, t, q, v, h, turn,
                                      None if hold.sampled else signal, P)
            if hold.sampled:  # the sample at an instant, shown at its point; else held
                try:
                    held.append(hold.sample(end, np.concatenate([q_next, v_next]))
                                if hold.is_instant(end) else held[-1])
                except InputError as exc:  # the point is the sample's: not recorded
                    stop[:] = ["failed", f"integration stopped at t={end:.6g}: {exc}"]
                    return
            v = turn.carry(q, v, q_next)  # the velocity before, at the new positions
            q = q_next
            closed = tuple(int(i) for i in np.flatnonzero(P[gaps.rows] > 0.0))
            new = sorted(set(closed) - set(closed_before))
            # an impact: a contact closing faster than its rest speed (not one that
            # opened and closed again at rest within the cascade)
            if new and (gaps.rates(full, end, q, v)[new] < -gaps.rest_speed[new]).any():
                lost = float(full.energies(end, q, v)[0] - full.energies(end, q, v_next)[0])
                history.impacts.append(ImpactRecord(end, P[gaps.rows], lost, v, v_next,
                                                    gaps.tangential(P)))
            if closed != closed_before:
                history.switches.append(Switch(end, closed, q.copy(), v_next.copy()))
                closed_before = closed
            accelerations.append((v_next - v) / h)
            v = v_next
            times.append(end)
            states.append(np.concatenate([q, v]))
            forces.append(P / h)
            if deadline is not None and end < tf and time.monotonic() > deadline:
                stop[:] = ["timeout", f"stopped at t={end:.6g}: the run's time limit "
                           "(timeout=) passed"]
                return

    watchdog = None if deadline is None else Watchdog(deadline)
    try:
        with watching(watchdog):
            _steps()
    except TimeLimitExceeded as exc:  # an input that did not return: the steps done kept
        assert watchdog is not None
        watchdog.disarm()
        status, message = "timeout", (
            f"stopped at t={times[-1]:.6g}: the run's time limit (timeout=) passed "
            f"while a function of yours, {where_stopped(exc) or 'an input'}, had not "
            f"returned; it was stopped {GRACE:g} s later")
    except ContactError as exc:
        status, message = "failed", str(exc)
    except KeyboardInterrupt:
        status, message = "interrupted", f"interrupted by the user at t={times[-1]:.6g}"
    # a step cut short (the watchdog's exception between two of its records): the
    # points of the steps completed
    done = min(len(times), len(states), len(forces), len(accelerations))
    del times[done:], states[done:], forces[done:], accelerations[done:]
    if held:
        del held[done:]
    if stop:
        status, message = stop[0], stop[1]
    t_all, y_all = np.array(times), np.array(states)
    f_all, a_all = np.array(forces), np.array(accelerations)
    u_all = np.array(held) if hold.sampled else None
    if t_eval is not None and asked is not None:  # each a step's end (the grid's)
        kept = np.isin(t_all, asked)
        t_all, y_all, f_all, a_all = t_all[kept], y_all[kept], f_all[kept], a_all[kept]
        # the times asked for, where one was moved onto an instant within rounding
        t_all = np.asarray(t_eval, dtype=float)[np.searchsorted(asked, t_all)]
        u_all = None if u_all is None else u_all[kept]
    derived = _outputs(full, gaps, t_all, y_all, f_all, a_all)
    result = IntegrationResult(t=t_all, y=y_all, status=status, message=message,
                               stats={"n_steps": len(times) - 1,
                                      "n_impacts": len(history.impacts)})
    return SteppedRun(result, derived, history, u_all)


def hold_marks(hold: Hold, t_eval: np.ndarray) -> np.ndarray:
    """The output times, each within rounding of a sample instant moved onto it (a
    ``t_eval`` of ``0.3`` against the instant ``3 * 0.1``): a step ends there, not a
    rounding error away from it.

    Parameters
    ----------
    hold
        The sample instants (none: ``t_eval`` as it is).
    t_eval
        The output times, increasing.

    Examples
    --------
    >>> from dalembert.inputs import input_signal
    >>> signal = input_signal(lambda t, q, qd: -q[0], ["u"], 0.1, (0.0, 1.0))
    >>> hold_marks(Hold.of(signal, (0.0, 1.0), 1), np.array([0.15, 0.3])).tolist()
    [0.15, 0.30000000000000004]
    """
    t_eval = np.asarray(t_eval, dtype=float)
    if hold.schedule is None or not len(t_eval):
        return t_eval
    instants = hold.schedule.instants
    nearest = instants[np.abs(t_eval[:, None] - instants[None, :]).argmin(axis=1)]
    return np.where(np.abs(t_eval - nearest) <= hold.tolerance, nearest, t_eval)


def _step(full: NumericModel, gaps: Gaps, kkt, bilateral: np.ndarray, t: float,
          q: np.ndarray, v: np.ndarray, h: float, turn: Rotations,
          signal: InputSignal | None, previous: np.ndarray | None = None
          ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """One Moreau-Jean step: the positions and velocity after it and the impulses
    (the inputs from ``signal`` at the midpoint, if given; the friction's sweeps start
    from the impulses of the step before, ``previous``: a body resting or sliding
    steadily poses nearly the same problem at every step)."""
    n, m, pattern = full.n, full.m, full.pattern
    tm, qm = t + h / 2, turn.advance(q, v, h / 2)
    v = turn.carry(q, v, qm)  # rates tied to the midpoint's quaternions
    if signal is not None:
        full.set_inputs(signal(tm, qm, v))
    Mv, f, Av, _ = full.kkt_sparse(tm, qm, v)
    _, b = full.velocity_sparse(tm, qm)
    momentum = matvec(pattern.M_rows, pattern.M_cols, Mv, v, n) + h * f
    # a gap row with no derivative here (a disk lying flat, far from the plane) does not
    # act in the free step: it must not spoil the factorization of the others
    free_Av = np.where((pattern.A_rows >= gaps.first) & ~np.isfinite(Av), 0.0, Av)
    kkt.factor(np.concatenate([Mv, free_Av]), bilateral)
    v_free, P_b = kkt.solve(np.concatenate([momentum, -b]))
    P = np.zeros(m)
    P[bilateral] = P_b[bilateral]
    pushing = np.zeros(0, dtype=int)
    g = gaps.values(full, tm, qm)
    # closed or touching at the midpoint (a body at rest on a floor sits at rounding
    # above it: counted, else it would fall a step and be caught every other step)
    near = np.flatnonzero(g <= TOUCH_RTOL * (1.0 + np.abs(qm).max(initial=0.0)))
    if len(near):
        A = pattern.dense_A(Av)
        gaps.check_finite(A[gaps.first + near].sum(axis=1), tm)
        found = contact_impulses(gaps, kkt, A, b, near, v, v_free,
                                 _restitution(gaps, A, b, near, v, v_free), previous)
        v_free = v_free + found.velocity
        P[found.rows] = found.impulse
        pushing = near[found.impulse[:len(near)] > 0.0]
        P[bilateral] += found.reaction[bilateral]
    q_next = _project(full, gaps, t + h, turn.advance(qm, v_free, h / 2), pushing)
    return q_next, project_velocities(full, t + h, q_next, turn.carry(qm, v_free, q_next),
                                      rows=np.flatnonzero(bilateral)), P


def _restitution(gaps: Gaps, A: np.ndarray, b: np.ndarray, near: np.ndarray,
                 v: np.ndarray, v_free: np.ndarray) -> np.ndarray:
    """Newton's coefficient of every gap for a step: its own, but 0 for an impact of
    the gaps ``near`` slower than its rest speed or than :data:`STEP_REST` times the
    change the step's free motion makes to its rate (``A (v_free - v)``, ``g h`` for a
    ball on a floor). A body settling (a bouncing ball's accumulation) otherwise never
    rests: each step of free fall feeds it ``g h``, which ``e > 0`` returns as a hop of
    a step or two, for ever."""
    rows = gaps.first + near
    rate = A[rows] @ v + b[rows]
    change = A[rows] @ (v_free - v)
    slow = -rate < np.maximum(gaps.rest_speed[near], STEP_REST * np.abs(change))
    e = gaps.restitution.copy()
    e[near[slow]] = 0.0
    return e


def _project(full: NumericModel, gaps: Gaps, t: float, q: np.ndarray,
             pushing: np.ndarray) -> np.ndarray:
    """``q`` moved the least onto the bilateral rows, the gaps ``pushing`` this step and
    the gaps below 0 (Gauss-Newton, the initial projection's), gaps that the projection
    itself pushes below 0 joining (a rod lifting one mass out of the table lowers its
    neighbour). A contact that pushes is held at 0, not only kept above it: left free,
    the projection of the rods of a chain lying flat lifts its masses by ~1e-8, which
    then fall a step and are caught the next (a hop of ``g h``)."""
    rows = np.asarray(full.holonomic_rows, dtype=int)
    held = rows < gaps.first  # entries of psi held at 0
    held |= np.isin(rows, gaps.first + pushing)
    for _ in range(PROJECTION_ITERATIONS):
        psi = full.position_constraint(t, q)
        held |= (psi < 0.0) & (rows >= gaps.first)
        if not held.any() or np.abs(psi[held]).max() <= 1e-14 * (1.0 + np.abs(q).max()):
            return q
        entries = np.flatnonzero(held)
        try:
            q = gauss_newton(partial(_held_psi, full, t, entries),
                             partial(_held_jacobian, full, t, rows[entries]), q,
                             max_iter=PROJECTION_ITERATIONS).q
        except np.linalg.LinAlgError:  # rows not finite: named, not a raw solver failure
            held_gaps = rows[entries][rows[entries] >= gaps.first] - gaps.first
            names = ", ".join(repr(gaps.names[k]) for k in held_gaps)
            raise ContactError(
                f"the projection onto the contacts {names} failed at t={t:.6g}: a gap "
                "with no finite derivative there (a disk's rim with the disk lying flat "
                "has no lowest point); keep the contact away from such a configuration"
            ) from None
    return q


def _finite_open_rows(A: np.ndarray, gaps: Gaps, force: np.ndarray) -> np.ndarray:
    """``A`` with the rows of the gaps that carry no force and have no derivative here
    set to 0 (they add nothing to ``A^T lambda``; a NaN would)."""
    rows = gaps.rows[(force[gaps.rows] == 0.0) & ~np.isfinite(A[gaps.rows]).all(axis=1)]
    if len(rows):
        A = A.copy()
        A[rows] = 0.0
    return A


def _held_psi(full: NumericModel, t: float, entries: np.ndarray, q: np.ndarray) -> np.ndarray:
    """The entries ``entries`` of ``psi`` at ``q``."""
    return full.position_constraint(t, q)[entries]


def _held_jacobian(full: NumericModel, t: float, rows: np.ndarray,
                   q: np.ndarray) -> np.ndarray:
    """The rows ``rows`` of ``A = dpsi/dq`` at ``q``."""
    return full.velocity_constraint(t, q)[0][rows]


def _grid(t0: float, tf: float, h: float, t_eval: np.ndarray | None) -> np.ndarray:
    """The steps' ends: equal steps of at most ``h`` between the output times.

    >>> _grid(0.0, 1.0, 0.3, np.array([0.5, 1.0])).round(3).tolist()
    [0.0, 0.25, 0.5, 0.75, 1.0]
    """
    marks = np.unique(np.concatenate([[t0, tf], [] if t_eval is None else t_eval]))
    pieces = [np.linspace(a, b, max(1, math.ceil((b - a) / h - 1e-9)) + 1)[:-1]
              for a, b in itertools.pairwise(marks)]
    return np.concatenate([*pieces, [tf]])


def _outputs(full: NumericModel, gaps: Gaps, t: np.ndarray, y: np.ndarray,
             forces: np.ndarray, accelerations: np.ndarray) -> dict[str, np.ndarray]:
    """The trajectory's derived arrays: the multipliers as the step's mean forces, the
    step's mean accelerations, the bilateral rows' residuals, the energies."""
    n, m = full.n, full.m
    out = output_arrays(len(t), n, m)
    rows = list(full.holonomic_rows)
    bilateral_psi = [k for k, r in enumerate(rows) if r < gaps.first]
    for i, (ti, yi) in enumerate(zip(t, y)):
        q, qd = yi[:n], yi[n:]
        Av, b = full.velocity_sparse(ti, q)
        A = _finite_open_rows(full.pattern.dense_A(Av), gaps, forces[i])
        out["multipliers"][i] = forces[i]
        out["constraint_forces"][i] = A.T @ forces[i]
        out["qdd"][i] = accelerations[i]
        psi = full.position_constraint(ti, q)
        out["position_residual"][i] = np.abs(psi[bilateral_psi]).max(initial=0.0)
        out["velocity_residual"][i] = np.abs((A @ qd + b)[:gaps.first]).max(initial=0.0)
        out["energies"][i] = full.energies(ti, q, qd)
    out["near_singular"] = np.zeros(len(t), dtype=bool)
    return out
