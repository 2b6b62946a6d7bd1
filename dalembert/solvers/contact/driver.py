"""The event-driven contact mode: smooth segments between switches.

A run with unilateral constraints goes segment by segment. Each segment integrates the
model with the gaps closed at its start as holonomic rows (its own plan, made once per
set of closed gaps met), and watches, as terminal events located to rounding,

- each open gap ``g(q, t)`` reaching 0 while closing;
- each closed gap's multiplier reaching 0 while falling (it would start to pull; 0
  to within :data:`~dalembert.solvers.contact.gaps.FORCE_RTOL`, so that a contact
  pushing with no force does not open at every step).

At such a switch the driver resolves the impact, if gaps close while approaching
(:func:`~dalembert.solvers.contact.laws.resolve_impact`), then finds the gaps closed
from there (:func:`~dalembert.solvers.contact.laws.closed_gaps`), and starts the next
segment from the post-switch state. The segments' points are joined as
:mod:`~dalembert.solvers.running.segments` joins a sampled run's (the state recorded at
a switch is the one after it), the multipliers by row of the model with every gap (0
where a gap is open), and the impacts and the closed gaps over time are recorded
(:class:`ContactHistory`).

Inputs held by a digital controller (``sample_time``) are sampled at their instants
(:mod:`~dalembert.solvers.running.sampled`): a segment also ends at each instant, where
the new sample is taken and the closed contacts are found again under it (a sampled
force that lifts a resting body opens its contact at that instant); an output time at
an instant shows the sample taken there.

Each gap starts a segment touching if it has just closed or opened: its event is
taken positive at the segment's start (a gap that opens at rounding level does not
fire again at once), and wherever it is exactly 0 (see :func:`_open_at_start`).

A run that cannot go on ends with status ``"failed"``, what it computed kept, and a
message naming the contacts: a switch with no solution (a
:class:`~dalembert.errors.ContactError`, chained), or a cascade of
:data:`MAX_SWITCHES_AT_ONCE` switches at one instant (contacts chattering).
"""

from __future__ import annotations

import itertools
from collections.abc import Callable, Container
from dataclasses import dataclass, field
from functools import partial
from typing import Any

import numpy as np

from ...codegen.compiled import NumericModel
from ...errors import ContactError, InputError, TimeLimitExceeded
from ...inputs import InputSignal, Source
from ...model.constraints import ClosedGaps, friction_force_name
from ...options import ImpactLaw
from ..impact import Impact, impact
from ..kkt.sparse import matvec
from ..native.screens import ConeScreen, ForceScreen, Never, PositionScreen, RateScreen, Screen
from ..running.integrate import IntegrationResult
from ..running.run_data import RunData, RunSegment
from ..running.sampled import sampled_schedule
from ..running.segments import Schedule, Segment, SegmentedRun, SegmentState, _Record
from ..running.watchdog import watching
from .friction import (
    SlidingForces,
    acting_rows,
    choose_friction,
    friction_at,
    held_forces,
    onset_holding,
    sliding_velocity,
)
from .gaps import FORCE_RTOL, ONSET_RTOL, TOUCH_RTOL, Gaps, row_rates
from .laws import closed_gaps, resolve_impact
from .sliding_in_c import SlidingInC

#: Switches within rounding of one instant before the run is called a chattering cascade.
MAX_SWITCHES_AT_ONCE = 100
#: Rounds of choosing the closed gaps and their friction in turn at a switch.
MAX_FRICTION_ROUNDS = 10
#: A value an event takes at its segment's start instead of one at or below 0 (see the
#: module docstring): positive, below any value that matters.
STARTS_OPEN = 1e-300
#: A sliding velocity along its direction within this many ulps of the velocities'
#: scale (``1 + max |qd|``) is 0: a contact that slips while the body cannot move (held
#: by other contacts still sticking) slides at 0, whose rounding must not read as a
#: stop at every step (the C loop's solves leave some, the Python loop's may not).
SPEED_ROUNDING = 16 * np.finfo(float).eps
#: An open gap within this many ulps of the positions' scale (``1 + max |q|``) of where
#: it closes, moving away or not moving (its rate within :data:`SPEED_ROUNDING`), is
#: not closing: its value's rounding, read as a fall through 0, closed a contact that
#: had just opened (slowly, or by a plastic impact that left its rate at rounding's)
#: again at once, at every switch (a box rocking on an edge after landing).
GAP_ROUNDING = 16 * np.finfo(float).eps


@dataclass(frozen=True)
class ImpactRecord:
    """One impact.

    Attributes
    ----------
    t
        Its instant.
    impulses
        The normal impulse on each gap (0 where it did not act).
    energy_lost
        ``T- - T+``.
    qd_before, qd_after
        The velocities before and after.
    friction_impulses
        Each gap's friction impulse, one entry per sliding velocity (its tangent rows,
        in the order of its ``tangents``; 0 where it did not act, empty for a gap
        without friction; empty tuple: none recorded). The generalized impulse of the
        impact is ``A_n^T impulses + sum_k A_t(k)^T friction_impulses[k]`` (and the
        bilateral rows'), ``M (qd_after - qd_before)``.

    Examples
    --------
    A ball landing on a floor that grips it (one sliding velocity):

    >>> hit = ImpactRecord(0.3, np.array([3.0]), 1.5, np.array([2.0, -2.0]),
    ...                    np.array([1.4, 1.0]), (np.array([-0.6]),))
    >>> hit.friction_impulses[0].tolist()
    [-0.6]
    """

    t: float
    impulses: np.ndarray
    energy_lost: float
    qd_before: np.ndarray
    qd_after: np.ndarray
    friction_impulses: tuple[np.ndarray, ...] = ()


@dataclass(frozen=True)
class Switch:
    """A change of the closed contacts (or the run's start).

    Attributes
    ----------
    t
        Its instant.
    closed
        The gaps closed from ``t`` on (indices in the unilateral constraints' order).
    q, qd
        The state there (after any impact).
    """

    t: float
    closed: tuple[int, ...]
    q: np.ndarray
    qd: np.ndarray


@dataclass
class ContactHistory:
    """The impacts of a run and its closed gaps over time.

    Attributes
    ----------
    names
        The unilateral constraints' names.
    impacts
        Every impact, in time order.
    switches
        The start and every switch (:class:`Switch`): the gaps closed from then on.
    tangents
        How many sliding velocities each gap has (the length of its friction
        impulses; empty: none has any; a file of an earlier version reads as none).
    """

    names: tuple[str, ...]
    impacts: list[ImpactRecord] = field(default_factory=list)
    switches: list[Switch] = field(default_factory=list)
    tangents: tuple[int, ...] = ()

    def friction_impulses(self, impact: ImpactRecord) -> tuple[np.ndarray, ...]:
        """The friction impulse of each gap at ``impact`` (zeros where it recorded
        none).

        Examples
        --------
        >>> history = ContactHistory(("floor",), tangents=(2,))
        >>> hit = ImpactRecord(0.0, np.ones(1), 0.0, np.zeros(3), np.zeros(3))
        >>> history.friction_impulses(hit)[0].tolist()
        [0.0, 0.0]
        """
        if impact.friction_impulses:
            return impact.friction_impulses
        return tuple(np.zeros(k) for k in self.tangents or (0,) * len(self.names))

    def arrays(self, n: int) -> dict[str, np.ndarray]:
        """The history as arrays (``n`` coordinates), as a trajectory file keeps it
        (:data:`~dalembert.trajectory_file.CONTACT_ARRAYS`; the friction impulses in
        ``impact_friction_impulses``, every gap's sliding velocities side by side, and
        their count per gap in ``contact_tangents``)."""
        g = len(self.names)
        closed = np.zeros((len(self.switches), g), dtype=bool)
        for k, switch in enumerate(self.switches):
            closed[k, list(switch.closed)] = True
        impacts = self.impacts
        sizes = self.tangents or (0,) * g

        def rows(values: list[np.ndarray], width: int) -> np.ndarray:
            return np.array(values, dtype=float).reshape(len(values), width)

        friction = [np.concatenate([np.zeros(0), *self.friction_impulses(i)]) for i in impacts]
        return {"impact_t": np.array([i.t for i in impacts], dtype=float),
                "impact_impulses": rows([i.impulses for i in impacts], g),
                "impact_friction_impulses": rows(friction, sum(sizes)),
                "contact_tangents": np.array(sizes, dtype=np.int64),
                "impact_energy_lost": np.array([i.energy_lost for i in impacts], dtype=float),
                "impact_qd_before": rows([i.qd_before for i in impacts], n),
                "impact_qd_after": rows([i.qd_after for i in impacts], n),
                "switch_t": np.array([s.t for s in self.switches], dtype=float),
                "switch_closed": closed,
                "switch_q": rows([s.q for s in self.switches], n),
                "switch_qd": rows([s.qd for s in self.switches], n)}

    @classmethod
    def from_arrays(cls, arrays: dict[str, Any]) -> ContactHistory:
        """The history from :meth:`arrays` (and its ``names``).

        Examples
        --------
        >>> history = ContactHistory(("floor",), [], [Switch(0.0, (0,), np.zeros(1),
        ...                                                   np.zeros(1))])
        >>> again = ContactHistory.from_arrays({"names": history.names, **history.arrays(1)})
        >>> again.switches[0].closed, again.impacts
        ((0,), [])

        The friction impulses, split by gap (arrays of an earlier version, without
        them, give zeros):

        >>> hit = ImpactRecord(0.3, np.array([3.0, 0.0]), 1.5, np.zeros(3), np.ones(3),
        ...                    (np.array([-0.6, 0.2]), np.zeros(0)))
        >>> history = ContactHistory(("floor", "wall"), [hit], [], (2, 0))
        >>> again = ContactHistory.from_arrays({"names": history.names,
        ...                                     **history.arrays(3)})
        >>> [f.tolist() for f in again.impacts[0].friction_impulses]
        [[-0.6, 0.2], []]
        """
        g = len(arrays["names"])
        sizes = tuple(int(k) for k in arrays.get("contact_tangents", np.zeros(g, dtype=int)))
        ends = np.cumsum((0, *sizes))
        friction = arrays.get("impact_friction_impulses",
                              np.zeros((len(arrays["impact_t"]), int(ends[-1]))))
        impacts = [ImpactRecord(float(t), p, float(e), b, a,
                                tuple(np.array(f[i:j]) for i, j in itertools.pairwise(ends)))
                   for t, p, e, b, a, f in zip(
                       arrays["impact_t"], arrays["impact_impulses"],
                       arrays["impact_energy_lost"], arrays["impact_qd_before"],
                       arrays["impact_qd_after"], friction)]
        switches = [Switch(float(t), tuple(int(k) for k in np.flatnonzero(c)), q, qd)
                    for t, c, q, qd in zip(arrays["switch_t"], arrays["switch_closed"],
                                           arrays["switch_q"], arrays["switch_qd"])]
        return cls(tuple(arrays["names"]), impacts, switches, sizes)

    @property
    def impact_times(self) -> np.ndarray:
        """The instants of the impacts."""
        return np.array([i.t for i in self.impacts])

    def energy_lost_by(self, t: np.ndarray) -> np.ndarray:
        """The kinetic energy the impacts took up to each time (an impact at a time
        counted: the state recorded there is the one after it): ``T + V`` plus this is
        what the run conserves when nothing else does work."""
        lost = np.cumsum([0.0] + [i.energy_lost for i in self.impacts])
        return lost[np.searchsorted(self.impact_times, np.asarray(t, dtype=float), "right")]

    def closed_at(self, t: np.ndarray) -> np.ndarray:
        """Which gaps are closed at each time (the set after a switch at its instant),
        shape ``(len(t), len(names))``."""
        starts = np.array([s.t for s in self.switches])
        where = np.searchsorted(starts, np.asarray(t, dtype=float), "right") - 1
        out = np.zeros((len(t), len(self.names)), dtype=bool)
        for i, k in enumerate(np.clip(where, 0, len(starts) - 1)):
            out[i, list(self.switches[k].closed)] = True
        return out


@dataclass(frozen=True)
class ContactRun:
    """A run with unilateral constraints: the joined segments and the contact history."""

    run: SegmentedRun
    history: ContactHistory


@dataclass
class SegmentStart:
    """The current segment's start time, its sliding contacts' directions and its open
    gaps below 0 there, which the events and the friction forces read (they are made once per set of
    closed gaps and serve every segment with that set)."""

    t: float = np.nan
    directions: dict[int, np.ndarray] = field(default_factory=dict)
    #: The open gaps below 0 at the start (within the touching tolerance), by gap.
    floors: dict[int, float] = field(default_factory=dict)
    #: The sliding gaps starting to slide from rest, by gap: the speed along their
    #: start direction where their onset ends (see :func:`_onset`).
    onset: dict[int, float] = field(default_factory=dict)


#: ``start(closed, t, y, events, inputs)``: the data of a run of the model of the closed
#: set ``closed``, from ``(t, y)``, watching ``events`` after the user's, its inputs
#: given by ``inputs`` (``None``: the run's own; with sliding contacts, the user's and
#: then the friction forces, at every evaluation).
StartSegments = Callable[[ClosedGaps, float, np.ndarray, tuple[Callable, ...],
                          InputSignal | None], RunData]


def run_contacts(full: NumericModel, gaps: Gaps, start: StartSegments,
                 t_span: tuple[float, float], y0: np.ndarray, t_eval: np.ndarray | None,
                 law: ImpactLaw, user_events: int, signal: InputSignal | None = None,
                 dynamics: bool = True) -> ContactRun:
    """Run ``t_span`` in the event-driven contact mode (see the module docstring).

    Parameters
    ----------
    full
        The model with every gap a row (after the bilateral ones), with its own
        parameter vector (the inputs are written into it at each switch).
    gaps
        Where its gaps are and their laws.
    start
        Makes the run data of the model with a set of gaps closed (once per set).
    t_span, y0, t_eval
        The run's span, its initial state (consistent with the bilateral rows) and its
        output times (``None``: every step).
    law
        The impact law.
    user_events
        How many of the events each segment watches are the user's (the gaps' follow).
    signal
        The inputs at each state, or ``None`` (which contacts stay closed depends on
        the forces).
    dynamics
        ``False``: the outputs' solves may be left out (NaN).

    Raises
    ------
    ContactError
        A gap is open below 0 at the start (penetrating).
    """
    t0, tf = t_span
    n = full.n
    t, y = float(t0), np.asarray(y0, dtype=float)
    q = y[:n]
    g = gaps.values(full, t, q)
    bad = np.flatnonzero(g < -1e-9 * (1.0 + np.abs(q).max(initial=0.0)))
    if len(bad):
        k = int(bad[0])
        raise ContactError(
            f"the unilateral constraint {gaps.names[k]!r} is violated at the start "
            f"(gap {g[k]:.6g} < 0): start with every gap >= 0")
    history = ContactHistory(gaps.names, tangents=gaps.sizes)
    segment_start = SegmentStart()
    made: dict[ClosedGaps, RunData] = {}
    watched: dict[ClosedGaps, tuple[tuple[str, int], ...]] = {}
    forces: dict[ClosedGaps, SlidingForces | None] = {}
    in_c: dict[ClosedGaps, SlidingInC | None] = {}  # the sliding friction computed in C
    record = _Record()
    hold = Hold.of(signal, t_span, n)
    held = hold.sample(t, y) if hold.sampled else None

    def inputs_at(t: float, q: np.ndarray, qd: np.ndarray) -> np.ndarray | None:
        """The inputs at a switch: the held sample, or the signal's at the state."""
        if hold.sampled:
            return held
        return None if signal is None else signal(t, q, qd)

    def held_sample(t: float, q: np.ndarray, qd: np.ndarray) -> np.ndarray:
        """The sample held now (a sampled run's inputs between its instants)."""
        assert held is not None
        return held

    y, which, directions = _switch(full, gaps, history, t, y, law, inputs_at, None, None)
    closed = which.closed
    history.switches.append(Switch(t, closed, y[:n].copy(), y[n:].copy()))
    at_once, last_switch = 0, t
    ended: set[int] = set()  # the gaps whose onset has ended since the last switch
    while True:
        segment_start.t = t
        segment_start.directions.clear()
        segment_start.directions.update(directions)
        below = gaps.values(full, t, y[:n])
        segment_start.floors = {k: float(below[k]) for k in range(gaps.count)
                                if k not in closed and below[k] < 0.0}
        segment_start.onset.clear()
        segment_start.onset.update(_onset(full, gaps, which, t, y, ended))
        data = made.get(which)
        if data is None:
            forces[which] = SlidingForces(full.for_run(), gaps, which,
                                          segment_start.directions, segment_start.onset,
                                          inputs_at) if which.sliding else None
            events, watched[which] = _contact_events(gaps, which, full, segment_start)
            inputs = _segment_inputs(gaps, which, forces[which], signal,
                                     held_sample if hold.sampled else None)
            data = made[which] = start(which, t, y, events, inputs)
            in_c[which] = None if inputs is None else SlidingInC.of(
                data, full, gaps, which, None if hold.sampled else signal)
        sliding = forces[which]
        if sliding is not None:
            sliding.restart()
        friction_in_c = in_c[which]
        if friction_in_c is not None:
            friction_in_c.start_segment(segment_start.directions, which.sliding,
                                        segment_start.onset, held)
        if held is not None and not which.sliding:  # a sliding set's inputs ask for it
            data.hold_inputs(held)
        end = hold.next_instant(t, tf)
        # an output time at an inner instant is the next segment's (after the sample)
        last = end if end == tf else end - hold.tolerance
        asked = None if t_eval is None else t_eval[(t_eval >= t) & (t_eval <= last)]
        run_at = asked if asked is None or end == tf else np.append(asked, end)
        segment = data.segment((t, end), y, run_at, False)
        result = segment.run()
        fired = _contact_fired(result, user_events)
        # the contact events differ from set to set: a joined run shows the user's
        result.t_events = result.t_events[:user_events]
        result.y_events = result.y_events[:user_events]
        keep = np.flatnonzero(result.t < fired[0]) if fired is not None else \
            np.arange(len(result.t)) if end == tf else np.flatnonzero(result.t < end)
        outputs = _outputs(full, gaps, which, dynamics, forces[which], friction_in_c)
        final_sample = fired is None and end == tf and hold.is_instant(tf) and \
            len(keep) > 0 and result.t[keep[-1]] == tf
        shown = keep[:-1] if final_sample else keep
        record.add(segment, result.t[shown], result.y[shown],
                   SegmentState(y, held, closed), outputs)
        record.segments.append(result)
        if record.interrupted:
            record.mark_stopped(result)
            break
        if fired is None and end == tf:
            if final_sample:  # the sample a controller takes at tf, shown at the last point
                y_end = result.y[keep[-1]]
                try:
                    with watching(data.watchdog):
                        held = hold.sample(tf, y_end)
                except (InputError, TimeLimitExceeded) as exc:
                    _stopped_sampling(result, tf, exc)
                    break
                if not which.sliding:
                    data.hold_inputs(held)
                record.add(segment, result.t[keep[-1:]], y_end[None, :],
                           SegmentState(y_end, held, closed), outputs)
            break
        if fired is None:  # a sample instant: new inputs, and maybe other contacts
            te, ye, opening, slipping = end, result.y[-1], None, None
        else:
            te, ye, event = fired
            kind, k = watched[which][event]
            if kind == "slid":  # the same closed set, k sliding along its velocity
                directions = _slid_directions(full, gaps, te, ye, segment_start, k)
                ended.add(k)
                t, y = te, ye
                continue
            opening = k if kind == "separating" else None
            slipping = k if kind == "slipping" else None
            at_once = at_once + 1 if te - last_switch <= 1e-12 * (1.0 + abs(te)) else 0
            if at_once > MAX_SWITCHES_AT_ONCE:
                result.status, result.message = "failed", (
                    f"the contacts switched {at_once} times at t={te:.6g} (chattering): "
                    f"last {gaps.names[k]!r}")
                break
        was = which
        try:
            with watching(data.watchdog):  # the inputs are called at a switch
                if fired is None:
                    held = hold.sample(te, ye)
                y, which, directions = _switch(full, gaps, history, te, ye, law, inputs_at,
                                               opening, slipping)
                closed = which.closed
        except ContactError as exc:
            result.status, result.message, result.error = "failed", str(exc), exc
            break
        except (InputError, TimeLimitExceeded) as exc:
            _stopped_sampling(result, te, exc, fired is None)
            break
        # a sample instant records a switch where the contacts change there (closing,
        # opening, or a stop or slip that falls on it)
        if fired is not None or which != was:
            history.switches.append(Switch(te, closed, y[:n].copy(), y[n:].copy()))
        ended.clear()
        t = te
        if fired is not None:
            last_switch = te
    joined = record.joined(len(y0), t0)
    joined.result.stats["n_impacts"] = len(history.impacts)
    return ContactRun(joined, history)


def _segment_inputs(gaps: Gaps, which: ClosedGaps, forces: SlidingForces | None,
                    signal: InputSignal | None, held_sample: Source | None
                    ) -> InputSignal | None:
    """The inputs of the segments of ``which`` at every evaluation: the user's (the
    held sample ``held_sample`` gives, if sampled), then the sliding contacts' friction
    forces; ``None`` without sliding contacts (the run's own inputs)."""
    if forces is None:
        return None
    if signal is None:
        user = InputSignal((), ())
    elif held_sample is not None:
        user = InputSignal(signal.names, ((held_sample, tuple(range(len(signal.names))),
                                           "the held sample"),))
    else:
        user = signal
    names = [friction_force_name(gaps.names[k], j) for k in which.sliding
             for j in range(len(gaps.tangents[k]))]
    return user.extended(names, forces, "the sliding friction")


def _stopped_sampling(result: IntegrationResult, t: float, exc: BaseException,
                      sampling: bool = True) -> None:
    """End the run at ``t`` because the inputs failed (``InputError``, chained) or did
    not return within the run's time limit, while sampled (or at a switch)."""
    where = "the inputs were sampled" if sampling else "the contacts switched"
    if isinstance(exc, TimeLimitExceeded):
        result.status, result.message = "timeout", (
            f"stopped at t={t:.6g}: the run's time limit (timeout=) passed while {where} "
            "there (a function of yours had not returned)")
    else:
        result.status, result.message, result.error = "failed", \
            f"integration stopped at t={t:.6g}: {exc}", exc


class Hold:
    """Inputs held between the instants a digital controller samples them
    (:mod:`~dalembert.solvers.running.sampled`), or (``schedule`` ``None``) inputs
    that are not sampled: no instant but the end. Both contact modes take their
    samples through it.

    Examples
    --------
    >>> from dalembert.inputs import input_signal
    >>> signal = input_signal(lambda t, q, qd: -q[0], ["u"], 0.5, (0.0, 1.0))
    >>> hold = Hold.of(signal, (0.0, 1.0), 1)
    >>> hold.next_instant(0.0, 1.0), hold.is_instant(0.5), hold.is_instant(0.7)
    (0.5, True, False)
    >>> hold.sample(0.5, np.array([2.0, 0.0])).tolist()
    [-2.0]
    """

    def __init__(self, schedule: Schedule | None) -> None:
        self.schedule = schedule
        self.sampled = schedule is not None
        self.tolerance = 0.0 if schedule is None else schedule.tolerance

    @classmethod
    def of(cls, signal: InputSignal | None, t_span: tuple[float, float], n: int) -> Hold:
        if signal is None or signal.sample_time is None:
            return cls(None)
        return cls(sampled_schedule(signal, t_span, n))

    def sample(self, t: float, y: np.ndarray) -> np.ndarray:
        """The inputs sampled at ``(t, y)``."""
        assert self.schedule is not None
        inputs = self.schedule.reset(t, SegmentState(y)).inputs
        assert inputs is not None  # a sample is the inputs' values
        return inputs

    def next_instant(self, t: float, tf: float) -> float:
        """The first instant after ``t`` (beyond rounding) and before ``tf``, or ``tf``."""
        if self.schedule is None:
            return tf
        later = self.schedule.instants[self.schedule.instants > t + self.tolerance]
        return float(later[0]) if len(later) and later[0] < tf - self.tolerance else tf

    def is_instant(self, t: float) -> bool:
        return self.schedule is not None and bool(
            np.any(np.abs(self.schedule.instants - t) <= self.tolerance))


def _switch(full: NumericModel, gaps: Gaps, history: ContactHistory, t: float,
            y: np.ndarray, law: ImpactLaw,
            inputs_at: Callable[[float, np.ndarray, np.ndarray], np.ndarray | None],
            opening: int | None, slipping: int | None
            ) -> tuple[np.ndarray, ClosedGaps, dict[int, np.ndarray]]:
    """The state after a switch at ``t``, the closed set from there and its sliding
    contacts' directions: the impact of the touching gaps (if any approaches), then
    the closed gaps (``opening``: the gap whose multiplier reached 0, left open) and
    which of them stick or slide (``slipping``: the gap whose sticking force reached
    the cone, made to slide), in turn until they agree, under the inputs
    ``inputs_at`` gives."""
    n = full.n
    q, qd = y[:n], y[n:]
    inputs = inputs_at(t, q, qd)
    if inputs is not None:
        full.set_inputs(inputs)
    touching = gaps.touching(full, t, q)
    gaps.check_finite(np.where(touching, gaps.rates(full, t, q, qd), 0.0), t)
    outcome = resolve_impact(full, gaps, t, q, qd, touching, law)
    if outcome.stages:
        history.impacts.append(ImpactRecord(t, outcome.impulses, outcome.energy_lost,
                                            qd.copy(), outcome.qd,
                                            outcome.friction_impulses))
        qd = outcome.qd
    settled = _settle(full, gaps, t, q, qd, touching)
    if settled is not None:
        history.impacts.append(ImpactRecord(t, settled.impulses[gaps.rows],
                                            settled.energy_lost, qd.copy(), settled.qd,
                                            gaps.tangential(settled.impulses)))
        qd = settled.qd
    exclude = () if opening is None else (opening,)
    closed = closed_gaps(full, gaps, t, q, qd, touching, exclude,
                         friction_at(full, gaps, t, q, qd), inputs_at)
    grip = _grip(full, gaps, t, q, qd, closed)
    if grip is not None:  # a rough contact closing while sliding stops sliding at once
        history.impacts.append(ImpactRecord(t, grip.impulses[gaps.rows],
                                            grip.energy_lost, qd.copy(), grip.qd,
                                            gaps.tangential(grip.impulses)))
        qd = grip.qd
    seen = friction_at(full, gaps, t, q, qd)  # the velocities stay through the rounds
    for _ in range(MAX_FRICTION_ROUNDS):
        friction = choose_friction(full, gaps, t, q, qd, closed, seen, slipping)
        again = closed_gaps(full, gaps, t, q, qd, touching, exclude, friction, inputs_at)
        if again == closed:
            which = friction.of(closed)
            held = set(which.held) | set(_held_in_onset(full, gaps, t, q, qd, which,
                                                        friction.directions))
            still = ClosedGaps(which.closed, tuple(sorted(held)))
            return np.concatenate([q, _held_still(full, gaps, t, q, qd, still)]), which, \
                {k: friction.directions[k] for k in which.sliding}
        closed = again
    raise ContactError(f"at t={t:.6g} the closed contacts and their friction (sticking "
                       f"or sliding) did not settle in {MAX_FRICTION_ROUNDS} rounds")


def _settle(full: NumericModel, gaps: Gaps, t: float, q: np.ndarray, qd: np.ndarray,
            touching: np.ndarray) -> Impact | None:
    """A plastic impact on every touching gap at once where two or more touch and each
    moves (closing or opening) slower than its rest speed, or ``None``: a body settling
    on several contacts (a block rocking down onto its base) impacts them in turn
    infinitely often in a finite time, as a bouncing ball does on one; below the rest
    speed it comes to rest on them all (its energy, within the rest speeds, recorded
    as lost)."""
    if touching.sum() < 2:
        return None
    rates = gaps.rates(full, t, q, qd)[touching]
    if np.abs(rates).max() <= TOUCH_RTOL * (1.0 + np.abs(qd).max()) or \
            np.any(np.abs(rates) >= gaps.rest_speed[touching]):
        return None
    which = ClosedGaps(tuple(int(k) for k in np.flatnonzero(touching)))
    return impact(full, t, q, qd, acting_rows(full, gaps, t, q, which))


def _grip(full: NumericModel, gaps: Gaps, t: float, q: np.ndarray, qd: np.ndarray,
          closed: tuple[int, ...]) -> Impact | None:
    """The impact of the rough gaps among ``closed`` that slide (their sliding
    velocities' rows acting, ``e = 0``), or ``None`` where none does."""
    rough = ClosedGaps(closed, tuple(k for k in closed if k in gaps.rough))
    rows = gaps.held_rows(rough)
    if not len(rows):
        return None
    rates = row_rates(full, t, q, qd)[rows]
    if np.abs(rates).max() <= TOUCH_RTOL * (1.0 + np.abs(qd).max()):
        return None
    return impact(full, t, q, qd, acting_rows(full, gaps, t, q, rough))


def _segment_rows(gaps: Gaps, which: ClosedGaps) -> np.ndarray:
    """The rows of the model with every gap that the rows of the model of ``which``
    are, in its order: the bilateral ones, the closed gaps, the held sliding
    velocities."""
    return np.concatenate([np.arange(gaps.first), gaps.first + np.array(which.closed, dtype=int),
                           gaps.held_rows(which)]).astype(int)


def _held_still(full: NumericModel, gaps: Gaps, t: float, q: np.ndarray, qd: np.ndarray,
                which: ClosedGaps) -> np.ndarray:
    """``qd`` with the sliding velocities of the gaps ``which.held`` set to 0 (by the
    plastic impact of their rows): those that start sticking (a stop is found where the
    sliding velocity along its direction is 0, which in space leaves a rounding-level
    part across it, below the speed a contact counts as at rest at,
    :data:`~dalembert.solvers.contact.gaps.TOUCH_RTOL`), and those that the onset holds
    while they still move (:func:`_held_in_onset`)."""
    rows = gaps.held_rows(which)
    if not len(rows) or not np.any(row_rates(full, t, q, qd)[rows]):
        return qd
    return impact(full, t, q, qd, acting_rows(full, gaps, t, q, which)).qd


def _held_in_onset(full: NumericModel, gaps: Gaps, t: float, q: np.ndarray,
                   qd: np.ndarray, which: ClosedGaps,
                   directions: dict[int, np.ndarray]) -> tuple[int, ...]:
    """The gaps of ``which`` that start an onset (:func:`_onset`), still move and hold
    there (Coulomb's law at the level of accelerations:
    :func:`~dalembert.solvers.contact.friction.onset_holding`): a body coming to rest
    slides ever slower, below the onset's speed, and its onset's friction, which holds
    it (no acceleration), would keep that speed for ever, so they are stopped."""
    onset = _onset(full, gaps, which, t, np.concatenate([q, qd]), ())
    moving = [k for k in onset if np.any(sliding_velocity(full, gaps, k, t, q, qd))]
    if not moving:
        return ()
    return tuple(k for k in onset_holding(full, gaps, t, q, qd, which, directions,
                                          list(onset)) if k in moving)


def _contact_events(gaps: Gaps, which: ClosedGaps, full: NumericModel,
                    start: SegmentStart
                    ) -> tuple[tuple[Callable, ...], tuple[tuple[str, int], ...]]:
    """The terminal events of a segment of the closed set ``which``, each falling
    through 0, and what each is (``(kind, gap)``):

    - per gap, an open one's value (``"closing"``), a closed one's multiplier
      (``"separating"``; its place among the rows of the model of ``which``);
    - per sticking gap, ``mu lambda_n - |lambda_t|`` (``"slipping"``: its force leaves
      the cone);
    - per sliding gap, its sliding velocity along its direction at the segment's start
      (``"sticking"``: it stops); while it starts to slide from rest with two sliding
      velocities (:func:`_onset`), the speed where its onset ends less that velocity
      (``"slid"``: it slides along its velocity from there).

    Each carries its screen (:mod:`~dalembert.solvers.native.screens`), so that the
    segments' steps run in C between switches."""
    closed = which.closed
    first = gaps.first
    rows_of = _segment_rows(gaps, which)
    place = {int(row): i for i, row in enumerate(rows_of)}  # a row's place in the segment's
    gap_at = len(full.holonomic_rows) - gaps.count  # the first gap's place in psi
    events: list[Callable] = []
    kinds: list[tuple[str, int]] = []

    def add(event: Callable, kind: str, k: int, screen: Callable[[], Screen | None]) -> None:
        event.__name__ = f"{gaps.names[k]} {kind}"
        event.terminal = True  # type: ignore[attr-defined]
        event.direction = -1  # type: ignore[attr-defined]
        event.screen = screen  # type: ignore[attr-defined]
        events.append(event)
        kinds.append((kind, k))

    for k in range(gaps.count):
        if k in closed:
            row = first + closed.index(k)

            def separating(t: float, q: np.ndarray, qd: np.ndarray, lam: np.ndarray, *,
                           row: int = row) -> float:
                # below 0 by more than rounding: a contact pushing with no force stays
                band = FORCE_RTOL * (1.0 + np.abs(lam).max())
                return _open_at_start(start, t, float(lam[row]) + band)
            add(separating, "separating", k, partial(ForceScreen, row))
        else:
            def closing(t: float, q: np.ndarray, qd: np.ndarray, *, k: int = k) -> float:
                # below where it started, if that was below 0: a gap that opens from a
                # contact held to the projection's tolerance, or left at rounding below
                # 0, must not close again in the first tiny step
                value = float(gaps.values(full, t, q)[k]) - start.floors.get(k, 0.0)
                rounding = GAP_ROUNDING * (1.0 + np.abs(q).max(initial=0.0))
                still = SPEED_ROUNDING * (1.0 + np.abs(qd).max(initial=0.0))
                if value < rounding and gaps.rates(full, t, q, qd)[k] > -still:
                    return rounding
                return _open_at_start(start, t, value)
            add(closing, "closing", k, partial(_gap_screen, full, gap_at + k, start, k))
    assert gaps.friction is not None  # made by Gaps.of
    # the held contacts whose friction held_forces shares by load: (normal, tangents)
    shared = tuple((place[first + k], tuple(place[int(r)] for r in gaps.tangents[k]))
                   for k in which.held if len(gaps.tangents[k]))
    for k in which.held:
        if gaps.friction[k] == np.inf:
            continue
        mu = float(gaps.friction[k])

        def slipping(t: float, q: np.ndarray, qd: np.ndarray, lam: np.ndarray, *, k: int = k,
                     mu: float = mu) -> float:
            every = np.zeros(full.m)
            every[rows_of] = lam
            force = held_forces(full, gaps, t, q, which, every)[k]
            return _open_at_start(start, t, mu * float(every[first + k])
                                  - float(np.linalg.norm(force)))
        # the held forces are the multipliers where the rows are independent; where
        # they are not, C shares the held friction as held_forces does
        add(slipping, "slipping", k, partial(
            ConeScreen, place[first + k], tuple(place[int(r)] for r in gaps.tangents[k]), mu,
            shared))
    for k in which.sliding:
        def sticking(t: float, q: np.ndarray, qd: np.ndarray, *, k: int = k) -> float:
            if k in start.onset:
                return 1.0  # at rest, its friction holding it or not: no stop to find
            s = sliding_velocity(full, gaps, k, t, q, qd)
            value = float(s @ start.directions[k])
            rounding = SPEED_ROUNDING * (1.0 + np.abs(qd).max(initial=0.0))
            return _open_at_start(start, t, 0.0 if abs(value) <= rounding else value)
        add(sticking, "sticking", k, partial(
            _sliding_screen, full, tuple(int(r) for r in gaps.tangents[k]), start, k))
        if len(gaps.tangents[k]) not in (2, 3):
            continue

        def slid(t: float, q: np.ndarray, qd: np.ndarray, *, k: int = k) -> float:
            speed = start.onset.get(k)
            if speed is None:
                return 1.0  # not starting from rest in this segment: never fires
            s = sliding_velocity(full, gaps, k, t, q, qd)
            return _open_at_start(start, t, speed - float(s @ start.directions[k]))
        add(slid, "slid", k, partial(_onset_screen, full, tuple(int(r) for r in gaps.tangents[k]),
                                     start, k))
    return tuple(events), tuple(kinds)


def _onset_screen(full: NumericModel, rows: tuple[int, ...], start: SegmentStart,
                  k: int) -> RateScreen | Never:
    """The screen of sliding gap ``k``'s ``"slid"`` event (its sliding velocities, the
    rows ``rows`` of ``full``) as the current segment starts: its onset speed less its
    speed along its start direction in its onset, else it cannot fire."""
    speed = start.onset.get(k)
    if speed is None:
        return Never()
    return RateScreen(full, rows, tuple(-float(w) for w in start.directions[k]), -speed)


def _onset(full: NumericModel, gaps: Gaps, which: ClosedGaps, t: float, y: np.ndarray,
           ended: Container[int]) -> dict[int, float]:
    """The sliding gaps of ``which`` with two sliding velocities (or three of rank 2)
    that start to slide from rest at ``(t, y)`` (sliding slower than
    :data:`~dalembert.solvers.contact.gaps.ONSET_RTOL` relative to ``1 + max |qd|``;
    not those in ``ended``, whose onset has ended since the last switch), with that
    speed: their friction is Coulomb's law at the level of accelerations
    (:func:`~dalembert.solvers.contact.friction.onset_friction`) until they slide that
    fast along their start direction."""
    candidates = [k for k in which.sliding
                  if len(gaps.tangents[k]) in (2, 3) and k not in ended]
    if not candidates:
        return {}
    n = full.n
    q, qd = y[:n], y[n:]
    speed = ONSET_RTOL * (1.0 + np.abs(qd).max(initial=0.0))
    rates = row_rates(full, t, q, qd)
    return {k: speed for k in candidates
            if float(np.linalg.norm(rates[gaps.tangents[k]])) < speed}


def _slid_directions(full: NumericModel, gaps: Gaps, t: float, y: np.ndarray,
                     start: SegmentStart, k: int) -> dict[int, np.ndarray]:
    """The sliding directions from ``(t, y)``, where gap ``k``'s onset has ended: its
    velocity's direction, the others' as they were."""
    n = full.n
    s = sliding_velocity(full, gaps, k, t, y[:n], y[n:])
    return {**start.directions, k: s / float(np.linalg.norm(s))}


def _gap_screen(full: NumericModel, at: int, start: SegmentStart, k: int) -> PositionScreen:
    """The screen of gap ``k``'s closing event (its value at ``at`` in ``full``'s
    ``psi``) as the current segment starts."""
    return PositionScreen(full, at, start.floors.get(k, 0.0))


def _sliding_screen(full: NumericModel, rows: tuple[int, ...], start: SegmentStart,
                    k: int) -> RateScreen | Never:
    """The screen of sliding gap ``k``'s sticking event (its sliding velocities, the
    rows ``rows`` of ``full``) as the current segment starts; in its onset it cannot
    fire."""
    if k in start.onset:
        return Never()
    return RateScreen(full, rows, tuple(float(w) for w in start.directions[k]))


def _open_at_start(start: SegmentStart, t: float, value: float) -> float:
    """An event's value, positive where it is exactly 0 (two bodies at rest touching:
    their gap stays 0 and must not close again at every step; a contact pushing with
    no force must not open at every step) and at its segment's start (it has just
    switched)."""
    return STARTS_OPEN if value == 0.0 or (t == start.t and value < 0.0) else value


def _contact_fired(result: IntegrationResult, user_events: int
                   ) -> tuple[float, np.ndarray, int] | None:
    """``(t, y, event)`` of the contact event that ended the segment (its place among
    the contact events), or ``None``."""
    if result.status != "event":
        return None
    times = [(float(te[-1]), k) for k, te in enumerate(result.t_events) if len(te)]
    t_end, k = max(times)
    if k < user_events:
        return None
    return t_end, result.y_events[k][-1], k - user_events


def _outputs(full: NumericModel, gaps: Gaps, which: ClosedGaps, dynamics: bool,
             forces: SlidingForces | None, in_c: SlidingInC | None
             ) -> Callable[[Segment, np.ndarray, np.ndarray], dict[str, np.ndarray]]:
    """The outputs of a segment, its multipliers placed by row of the model with every
    gap (0 on the open gaps; a sliding contact's friction forces, as the segment's
    evaluations had them (``in_c`` or ``forces``), in its sliding velocities' rows, and
    in the constraint forces), the same arrays for every segment."""
    m, n = full.m, full.n
    rows = _segment_rows(gaps, which)
    sliding = gaps.held_rows(ClosedGaps(which.closed, which.sliding))
    pattern = full.pattern

    def outputs(segment: Segment, t: np.ndarray, y: np.ndarray) -> dict[str, np.ndarray]:
        assert isinstance(segment, RunSegment)  # the driver makes every segment
        out = dict(segment.outputs(t, y, dynamics=dynamics))
        lam = np.zeros((len(t), m))
        lam[:, rows] = out["multipliers"]
        if which.held and dynamics:  # dependent held rows: their forces shared by load
            for i, (ti, yi) in enumerate(zip(t, y)):
                for k, force in held_forces(full, gaps, float(ti), yi[:n], which,
                                            lam[i]).items():
                    lam[i, gaps.tangents[k]] = force
        if forces is not None and dynamics:
            computed = None if in_c is None else in_c.forces(t, y)
            for i, (ti, yi) in enumerate(zip(t, y)):
                q, qd = yi[:n], yi[n:]
                lam[i, sliding] = forces(float(ti), q, qd) if computed is None else computed[i]
                Av, _ = full.velocity_sparse(float(ti), q)
                out["constraint_forces"][i] = matvec(pattern.A_cols, pattern.A_rows, Av,
                                                     lam[i], n)
        out["multipliers"] = lam
        # the mark of near-singular configurations, which a segment without rows lacks
        out.setdefault("near_singular", np.zeros(len(t), dtype=bool))
        return out

    return outputs
