"""Sliding friction in C: the friction forces of a segment's sliding contacts, computed
before each evaluation of the run's model (``friction.c``).

A sliding contact's friction ``-mu N d`` depends on its normal force ``N``, an unknown
of the same KKT system, and on its direction ``d``, its sliding velocity's; the
segment's model takes these forces as inputs. The Python side computes them by
:func:`~dalembert.solvers.contact.friction.solve_sliding` on the model with every gap
a row, which costs a Python call and several solves at every evaluation. C solves the
same equations on the run's own model: the model's generalized force is linear in the
inputs (``A_t^T F``), so the system without friction and one solve per sliding contact
with ``-mu A_t^T d`` give the normal forces by a small linear system (the low-rank
correction of ``solve_sliding``). The tangent rows and their rates come from the model
with every gap a row (the run's model lacks them), its velocity function evaluated in
C. Where the run drops rows as dependent, the multipliers are made the minimum-norm
ones first, as the Python side's are. Contacts starting to slide from rest take the
friction Coulomb's law gives at the level of accelerations (each holds, or slides along
its acceleration), found by the same semismooth Newton's method as
:func:`~dalembert.solvers.contact.friction.onset_friction` (:class:`OnsetSearch`), from
the last found in the segment's steps, else from their start directions
(docs/design.md, "Sliding friction in C").
"""

from __future__ import annotations

import ctypes
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from ...codegen.c_backend import NativeHandle
from ...codegen.compiled import NumericModel
from ...numerics.rank import RANK_RTOL
from . import library
from .screens import dependent_group, group_work_size, rate_terms, row_entries
from .solver import NativeSolver, Pinned, c_function


@dataclass(frozen=True)
class OnsetSearch:
    """How the friction of contacts starting to slide from rest is found: a semismooth
    Newton's method (as :func:`~dalembert.solvers.contact.friction.onset_friction`).

    Attributes
    ----------
    iterations
        Its most iterations.
    difference
        The difference step of its accelerations' Jacobian.
    rounding
        Its residual within this many ulps of 0 is a solution.
    smallest_step
        The shortest fraction of a step its line search tries.
    stalled
        Where nothing lowers its residual, within this of 0 it is a solution.
    free_steps
        Whole steps it takes where no fraction of one lowers its residual (per solve).
    """

    iterations: int
    difference: float
    rounding: float
    smallest_step: float
    stalled: float
    free_steps: int


@dataclass(frozen=True)
class SlidingContact:
    """One sliding contact as C computes its friction.

    Attributes
    ----------
    normal
        Its normal row in the run's model.
    mu
        Its friction coefficient.
    tangents
        Its sliding velocities' rows in the watched model (the model with every gap a
        row).
    inputs
        The run's inputs that are its friction forces, by name (one per sliding
        velocity, in the tangents' order).
    """

    normal: int
    mu: float
    tangents: tuple[int, ...]
    inputs: tuple[str, ...]


class FrictionTable:
    """The ``dl_friction`` of a run whose model takes sliding contacts' friction forces
    as inputs (kept alive while C may read it).

    Parameters
    ----------
    contacts
        The sliding contacts.
    watched
        The model with every gap a row, with its own parameter vector (C copies the
        run's inputs it shares into it).
    native
        The run's C solver.
    search
        How the friction of contacts starting to slide from rest is found.
    """

    def __init__(self, contacts: Sequence[SlidingContact], watched: NumericModel,
                 native: NativeSolver, search: OnsetSearch) -> None:
        self._pinned = pin = Pinned()
        num = native.num
        f = self.struct = library.Friction(
            n_sliding=len(contacts), dependent_rtol=RANK_RTOL, iterations=search.iterations,
            difference=search.difference, rounding=search.rounding,
            smallest_step=search.smallest_step, stalled=search.stalled,
            free_steps=search.free_steps)
        names = list(num.compiled.input_names)
        f.normal = pin.array([c.normal for c in contacts])
        f.mu = pin.array([c.mu for c in contacts], np.float64)
        f.start = pin.array(np.cumsum([0] + [len(c.tangents) for c in contacts]))
        f.slot = pin.array([num.compiled.input_offset + names.index(name)
                            for c in contacts for name in c.inputs])
        #: How many friction forces (one per sliding velocity).
        self.forces = sum(len(c.tangents) for c in contacts)
        self._start = np.zeros(self.forces)
        self._onset = np.zeros(len(contacts), dtype=np.int64)
        f.start_direction = pin.array(self._start, np.float64)
        f.onset = pin.array(self._onset)
        self._last = np.full(2 * self.forces, np.nan)
        f.last_direction = pin.array(self._last, np.float64)
        tangents = [r for c in contacts for r in c.tangents]
        self._terms(f, tangents, watched)
        f.tangent_row = pin.array(tangents)
        functions = watched.compiled.functions
        f.velocity = c_function("velocity", functions["velocity"].native)
        # the watched model's KKT values, flat [M values, f, A values, c]: its c
        pattern = watched.pattern
        f.c_at = len(pattern.M_rows) + watched.n + len(pattern.A_rows)
        kkt = functions["kkt"].native
        if not isinstance(kkt, NativeHandle) or kkt.size != f.c_at + watched.m:
            raise ValueError("the watched model's KKT function must write its flat values")
        f.kkt = c_function("kkt", kkt)
        f.kkt_values = pin.zeros(kkt.size)
        f.p = pin.array(watched.p, np.float64)
        if pin.arrays[-1] is not watched.p:  # C writes the vector the Python side reads
            raise ValueError("the watched model's parameters must be a float64 vector")
        f.vel = pin.zeros(len(watched.pattern.A_rows) + watched.m)
        shared = [name for name in watched.compiled.input_names if name in names]
        f.n_copy = len(shared)
        f.copy_from = pin.array([num.compiled.input_offset + names.index(x) for x in shared])
        f.copy_to = pin.array([watched.compiled.input_offset +
                               list(watched.compiled.input_names).index(x) for x in shared])
        group = dependent_group(native)
        if len(group):
            assert native.kept is not None
            start, entry, col = row_entries(num, group)
            f.run_velocity = c_function("velocity", num.compiled.functions["velocity"].native)
            f.run_vel = pin.zeros(len(num.pattern.A_rows) + num.m)
            f.n_group, f.n_group_kept = len(group), int(np.isin(group, native.kept).sum())
            f.group_row, f.group_start = pin.array(group), pin.array(start)
            f.group_entry, f.group_col = pin.array(entry), pin.array(col)
        ns, nt, n, m = len(contacts), self.forces, num.n, num.m
        # friction.c's search_size
        search_size = 2 * nt + nt * nt + 36 * ns + 8 * ns * ns
        f.work = pin.zeros(nt + 2 * n + nt * n + nt * ns + 3 * m + ns * ns + ns
                           + search_size + group_work_size(len(group), n))
        self.address = ctypes.addressof(f)

    def _terms(self, f: library.Friction, rows: list[int], watched: NumericModel) -> None:
        """Each tangent row's terms in the watched model's velocity values
        (:func:`~.screens.rate_terms`)."""
        value, column, at = [], [], [0]
        for these, cols in rate_terms(watched, rows):
            value += these
            column += cols
            at.append(len(value))
        f.term_start, f.term_value = self._pinned.array(at), self._pinned.array(value)
        f.term_col = self._pinned.array(column)

    def start_segment(self, directions: Sequence[np.ndarray], onset: Sequence[bool]) -> None:
        """A segment's start: the contacts' sliding directions there (each unit, one
        entry per sliding velocity), which C keeps where the sliding velocity does not
        run along its start's, and which start to slide from rest (their directions
        sought from these).

        Parameters
        ----------
        directions
            Each contact's direction.
        onset
            Whether each contact starts to slide from rest.
        """
        self._start[:] = np.concatenate(directions)
        self._onset[:] = onset
        self._last[:] = np.nan  # none found yet in this segment
