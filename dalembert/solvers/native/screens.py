"""Screens: the events of a run checked in C, so that they do not push it out of C.

An event is a Python function; the loop in C cannot call it at every step's end
without paying Python's price at every step. Where an event's value is something the
generated functions give (a constraint's value or rate, a multiplier, the friction
cone's margin: the contact events), it carries a *screen* saying so (its ``screen``
attribute, like SciPy's ``terminal`` and ``direction``: a function returning one of
the values below, as they stand when a stretch starts). C evaluates the screens at
each step's projected end (``screens.c``); a value below its small margin flags the
step, and the stretch ends before it (``DL_EVENT``): the caller takes that step with
the event functions and locates the events as the Python loop does. A screen is only a
filter: the events and their roots are the Python functions', so a run with screens
fires the same events as one without (tested).

Screens are for terminal events that fall through 0 and are positive at every step's
end before they fire (the contact events are so made): then "below the margin at a
step's end" catches every step in which such an event fires.

Where the run's model drops rows as dependent (a box on its four corners), its events
see the minimum-norm multipliers, and a held contact's friction is its share of the
held contacts' friction in proportion to their normal forces
(:func:`~dalembert.solvers.contact.friction.held_forces`), not the run's multipliers
(0 on the dropped rows). C computes these from the run's at each step's end (the rows
joined to the dropped ones as combinations of their kept rows, small dense solves:
:class:`ScreenTable`), so such segments run in C too; where it cannot (a dropped row
no longer follows from the kept ones, a singular Gram matrix), it flags the step.
"""

from __future__ import annotations

import ctypes
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from ...codegen.compiled import NumericModel
from ...numerics.rank import RANK_RTOL
from . import library
from .solver import NativeSolver, Pinned, c_function

#: The margin of the position and rate screens, relative to ``1 + max |q|`` and
#: ``1 + max |qd|``: their values are the event functions' own, from the same generated
#: code, up to the rounding of a sum.
MARGIN = 1e-12
#: The margin of the force and cone screens, relative to ``1 + max |lambda|``: C's
#: multipliers and the Python solve's differ by rounding times the KKT matrix's
#: condition (far below this); a step flagged in vain costs one step in Python.
FORCE_RTOL = 1e-9


@dataclass(frozen=True)
class PositionScreen:
    """``psi[at] - floor`` of the model ``watched`` (a holonomic constraint's value)."""

    watched: NumericModel
    at: int
    floor: float = 0.0


@dataclass(frozen=True)
class RateScreen:
    """``weights . (A qd + b)[rows] - floor`` of the model ``watched`` (constraint rows'
    rates)."""

    watched: NumericModel
    rows: tuple[int, ...]
    weights: tuple[float, ...]
    floor: float = 0.0


@dataclass(frozen=True)
class ForceScreen:
    """The multiplier of the run's own row ``row``."""

    row: int


@dataclass(frozen=True)
class ConeScreen:
    """``mu lambda[normal] - |lambda[tangents]|`` of the run's own rows.

    ``shared``: the held contacts (each its normal row and tangent rows) whose friction
    is shared with this one's in proportion to their normal forces where their tangent
    rows are dependent (:func:`~dalembert.solvers.contact.friction.held_forces`; empty:
    this contact alone); ``|lambda[tangents]|`` is then its share.
    """

    normal: int
    tangents: tuple[int, ...]
    mu: float
    shared: tuple[tuple[int, tuple[int, ...]], ...] = ()


@dataclass(frozen=True)
class Never:
    """An event that cannot fire in this stretch (its value a positive constant there)."""


Screen = PositionScreen | RateScreen | ForceScreen | ConeScreen | Never


def screens_of(events: Sequence[Callable]) -> list[Screen] | None:
    """The screens of ``events`` as they stand now, or ``None`` if one has none (no
    ``screen`` attribute, or one returning ``None``: not screened in this stretch,
    whose steps are then taken in Python).

    Parameters
    ----------
    events
        Event functions (a screened one has a ``screen()`` attribute).

    Examples
    --------
    >>> def wall(t, y):
    ...     return y[0]
    >>> screens_of([wall]) is None
    True
    >>> wall.screen = lambda: ForceScreen(0)
    >>> screens_of([wall])
    [ForceScreen(row=0)]
    """
    found = []
    for event in events:
        screen = getattr(event, "screen", None)
        now = None if screen is None else screen()
        if now is None:
            return None
        found.append(now)
    return found


def screenable(events: Sequence[Callable]) -> bool:
    """Whether the loop in C can screen ``events``: every one has a screen. (Where the
    run's model drops rows as dependent, the screens of multipliers read the ones the
    events see, the minimum-norm multipliers and the held friction shared by load,
    which C computes from the run's: see :class:`ScreenTable`.)

    Parameters
    ----------
    events
        The run's event functions.

    Examples
    --------
    >>> screenable([])
    True
    >>> screenable([lambda t, y: y[0]])
    False
    """
    return all(getattr(event, "screen", None) is not None for event in events)


class ScreenTable:
    """The ``dl_screens`` of a stretch runner: the screens of its events and their
    arrays (kept alive while C may read them).

    Parameters
    ----------
    screens
        The events' screens (:func:`screens_of`).
    native
        The run's C solver (its model's rows are the force and cone screens' rows).
    """

    def __init__(self, screens: Sequence[Screen], native: NativeSolver) -> None:
        self._pinned = pin = Pinned()
        s = self.struct = library.Screens(margin=MARGIN, force_rtol=FORCE_RTOL)
        watched = {id(x.watched): x.watched for x in screens
                   if isinstance(x, (PositionScreen, RateScreen))}
        if len(watched) > 1:
            raise ValueError("the screens of one run watch one model")
        positions = [x for x in screens if isinstance(x, PositionScreen)]
        rates = [x for x in screens if isinstance(x, RateScreen)]
        forces = [x for x in screens if isinstance(x, ForceScreen)]
        cones = [x for x in screens if isinstance(x, ConeScreen)]
        if watched:
            (model,) = watched.values()
            functions = model.compiled.functions
            s.p = pin.array(model.p, np.float64)
            if pin.arrays[-1] is not model.p:  # C must read the vector the run writes
                raise ValueError("the watched model's parameters must be a float64 vector")
            if positions:
                s.position = c_function("position", functions["position"].native)
                s.psi = pin.zeros(len(model.holonomic_rows))
                s.n_position = len(positions)
                s.pos_at = pin.array([x.at for x in positions])
                s.pos_floor = pin.array([x.floor for x in positions], np.float64)
            if rates:
                s.velocity = c_function("velocity", functions["velocity"].native)
                s.vel = pin.zeros(len(model.pattern.A_rows) + model.m)
                self._rates(s, rates, model)
        s.n_force = len(forces)
        s.force_row = pin.array([x.row for x in forces])
        s.n_cone = len(cones)
        s.cone_normal = pin.array([x.normal for x in cones])
        s.cone_start = pin.array(np.cumsum([0] + [len(x.tangents) for x in cones]))
        s.cone_tangent = pin.array([j for x in cones for j in x.tangents])
        s.cone_mu = pin.array([x.mu for x in cones], np.float64)
        setattr(s, "lambda", pin.zeros(native.m))  # (a keyword in Python)
        s.ydot = pin.zeros(2 * native.n)
        if native.kept is not None and (forces or cones):
            self._dependent(s, cones, native)
        self.address = ctypes.addressof(s)

    def _dependent(self, s: library.Screens, cones: Sequence[ConeScreen],
                   native: NativeSolver) -> None:
        """Where the run's model drops rows as dependent, what C needs to give the force
        and cone screens the multipliers the events see (``screens.c``'s minimum_norm
        and held_shares): the group of rows whose minimum-norm multipliers differ from
        the run's (the dropped rows and every row joined to them through shared
        coordinates: the rows a dropped one combines are among them, and the
        projection leaves the others as they are), and the held contacts' tangent rows
        where one of them is dropped (their friction shared by load)."""
        num, pin = native.num, self._pinned
        m, n = num.m, num.n
        assert native.kept is not None
        kept = np.zeros(m, dtype=bool)
        kept[native.kept] = True
        group = dependent_group(native)
        if not len(group):
            return
        shared = {x.normal: x.tangents for x in cones}
        for x in cones:
            shared.update(dict(x.shared))
        held = np.array([r for tangents in shared.values() for r in tangents], dtype=int)
        normal = np.array([k for k, tangents in shared.items() for _ in tangents], dtype=int)
        if not len(held) or kept[held].all():
            held = normal = np.zeros(0, dtype=int)  # the run's own tangent multipliers
        s.run_velocity = c_function("velocity", num.compiled.functions["velocity"].native)
        s.run_vel = pin.zeros(len(num.pattern.A_rows) + m)
        for name, these, by in (("group", group, None), ("held", held, normal)):
            order = np.argsort(~kept[these], kind="stable")  # the kept rows first
            if by is not None:
                s.held_normal = pin.array(by[order])
            self._group(s, name, these[order], kept, native)
        size = max(len(group), len(held))
        s.work = pin.zeros(group_work_size(size, n))
        s.spread = pin.zeros(2 * m)
        s.dependent_rtol = RANK_RTOL

    def _group(self, s: library.Screens, name: str, rows: np.ndarray, kept: np.ndarray,
               native: NativeSolver) -> None:
        """A group's fields (``n_<name>``, ``<name>_row``, ...): its rows, the kept ones
        first, and their entries in the run's velocity values."""
        start, entry, col = row_entries(native.num, rows)
        pin = self._pinned
        setattr(s, f"n_{name}", len(rows))
        setattr(s, f"n_{name}_kept", int(kept[rows].sum()))
        setattr(s, f"{name}_row", pin.array(rows))
        setattr(s, f"{name}_start", pin.array(start))
        setattr(s, f"{name}_entry", pin.array(entry))
        setattr(s, f"{name}_col", pin.array(col))

    def _rates(self, s: library.Screens, rates: Sequence[RateScreen],
               model: NumericModel) -> None:
        """The rate screens' terms (:func:`rate_terms`), each weighted by its row's
        weight in the screen."""
        start, value, col, weight = [0], [], [], []
        for x in rates:
            for r, w in zip(x.rows, x.weights):
                (these, cols), = rate_terms(model, [r])
                value += these
                col += cols
                weight += [w] * len(these)
            start.append(len(value))
        s.n_rate = len(rates)
        s.rate_floor = self._pinned.array([x.floor for x in rates], np.float64)
        s.rate_start, s.rate_value = self._pinned.array(start), self._pinned.array(value)
        s.rate_col, s.rate_weight = self._pinned.array(col), self._pinned.array(weight, np.float64)


def rate_terms(model: NumericModel, rows: Sequence[int]) -> list[tuple[list[int], list[int]]]:
    """Where C reads the rates ``A qd + b`` of the constraint rows ``rows`` of ``model``
    in its velocity values ``[A values, b]``: per row, the places of its terms and their
    columns (its ``A`` values times ``qd`` there, then its ``b``, column -1).

    Examples
    --------
    >>> from dalembert.examples import load
    >>> pendulum = load("pendulum").build().numeric()
    >>> rate_terms(pendulum, [0])
    [([0, 1, 2], [0, 1, -1])]
    """
    A_rows, A_cols = np.asarray(model.pattern.A_rows), np.asarray(model.pattern.A_cols)
    out = []
    for r in rows:
        entries = np.flatnonzero(A_rows == r)
        out.append(([*entries.tolist(), len(A_rows) + int(r)], [*A_cols[entries].tolist(), -1]))
    return out


def dependent_group(native: NativeSolver) -> np.ndarray:
    """The rows whose minimum-norm multipliers differ from the run's, where its model
    drops rows as dependent (empty: none dropped), the kept ones first: the dropped rows
    and every row joined to them through shared coordinates (the rows a dropped one
    combines are among them, and the projection leaves the others as they are)."""
    if native.kept is None:
        return np.zeros(0, dtype=int)
    pattern = native.num.pattern
    kept = np.zeros(native.m, dtype=bool)
    kept[native.kept] = True
    group = _joined(np.flatnonzero(~kept), np.asarray(pattern.A_rows),
                    np.asarray(pattern.A_cols))
    return group[np.argsort(~kept[group], kind="stable")]


def row_entries(model: NumericModel, rows: np.ndarray
                ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Where C reads the constraint rows ``rows`` of ``model`` in its velocity values:
    row ``i``'s entries are ``entry[start[i]:start[i + 1]]``, at the columns ``col``
    there."""
    A_rows, A_cols = np.asarray(model.pattern.A_rows), np.asarray(model.pattern.A_cols)
    entries = [np.flatnonzero(A_rows == r) for r in rows]
    flat = np.concatenate([np.zeros(0, dtype=int), *entries])
    return np.cumsum([0] + [len(e) for e in entries]), flat, A_cols[flat]


def group_work_size(rows: int, n: int) -> int:
    """The work doubles of a group of ``rows`` rows in ``n`` coordinates (``screens.c``'s
    ``work_of``)."""
    return rows * n + 2 * rows * rows + n + 2 * rows


def _joined(start: np.ndarray, rows: np.ndarray, cols: np.ndarray) -> np.ndarray:
    """The rows joined to those of ``start`` through shared columns (the pattern's
    entries ``(rows, cols)``), sorted.

    Examples
    --------
    >>> _joined(np.array([0]), np.array([0, 1, 1, 2]), np.array([0, 0, 1, 2])).tolist()
    [0, 1]
    """
    found = set(int(r) for r in start)
    frontier = list(found)
    while frontier:
        near = np.isin(cols, cols[np.isin(rows, frontier)])
        frontier = [int(r) for r in np.unique(rows[near]) if int(r) not in found]
        found.update(frontier)
    return np.array(sorted(found), dtype=int)
