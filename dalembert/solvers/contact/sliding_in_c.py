"""A sliding set's friction forces computed in C, segment by segment.

A segment with sliding contacts takes their friction forces as inputs of its model.
In the C loop, C computes them before each evaluation
(:mod:`~dalembert.solvers.native.friction`): the same solve as
:func:`~dalembert.solvers.contact.friction.solve_sliding`, and for contacts starting
to slide from rest the same solve of Coulomb's law at the level of accelerations as
:func:`~dalembert.solvers.contact.friction.onset_friction`, so the segment's
steps do not call Python for them. The Python side
(:class:`~dalembert.solvers.contact.friction.SlidingForces`) computes them in the
Python loop. The user's inputs stay the user's: a signal read at each state is still
called, a sample held is written once per segment.
"""

from __future__ import annotations

from collections.abc import Container, Sequence

import numpy as np

from ...codegen.compiled import NumericModel
from ...inputs import InputSignal
from ...model.constraints import ClosedGaps, friction_force_name
from ..native.friction import FrictionTable, OnsetSearch, SlidingContact
from ..running.run_data import RunData
from .friction import (
    ONSET_FREE_STEPS,
    ONSET_ITERATIONS,
    ONSET_ROUNDING,
    ONSET_SMALLEST_STEP,
    ONSET_STALLED,
    ONSET_STEP,
)
from .gaps import Gaps

#: The onset's search as :func:`~dalembert.solvers.contact.friction.onset_friction`
#: makes it.
SEARCH = OnsetSearch(ONSET_ITERATIONS, ONSET_STEP, ONSET_ROUNDING, ONSET_SMALLEST_STEP,
                     ONSET_STALLED, ONSET_FREE_STEPS)


class SlidingInC:
    """A sliding set's friction forces in C.

    Parameters
    ----------
    data
        The run data of the set's model (its C solver set per segment).
    table
        The set's sliding contacts as C computes their friction.
    names
        The inputs that are their friction forces (the model's last).
    user
        The user's inputs read at each state (``None``: none, or a sample held).
    """

    def __init__(self, data: RunData, table: FrictionTable, names: Sequence[str],
                 user: InputSignal | None) -> None:
        self.data, self.table = data, table
        zeros = self._zeros = np.zeros(table.forces)
        # the friction forces' slots written 0 by the callback; C writes them after it
        self.user = None if user is None else user.extended(
            names, lambda t, q, qd: zeros, "the sliding friction (computed in C)")

    @classmethod
    def of(cls, data: RunData, full: NumericModel, gaps: Gaps, which: ClosedGaps,
           user: InputSignal | None) -> SlidingInC | None:
        """The set's friction in C, or ``None`` where its run is not in C (the Python
        loop, a model whose functions are not C).

        Parameters
        ----------
        data
            The run data of the model of ``which``.
        full, gaps
            The model with every gap a row (its own parameter vector) and its gaps.
        which
            The closed set, with sliding contacts.
        user
            The user's inputs read at each state, or ``None``.
        """
        native = data.native
        functions = full.compiled.functions
        if native is None or functions["velocity"].native is None \
                or functions["kkt"].native is None:
            return None
        assert gaps.friction is not None  # (sliding contacts have coefficients)
        contacts = [SlidingContact(
            normal=gaps.first + which.closed.index(k), mu=float(gaps.friction[k]),
            tangents=tuple(int(r) for r in gaps.tangents[k]),
            inputs=tuple(friction_force_name(gaps.names[k], j)
                         for j in range(len(gaps.tangents[k]))))
            for k in which.sliding]
        names = [name for c in contacts for name in c.inputs]
        return cls(data, FrictionTable(contacts, full, native, SEARCH), names, user)

    def start_segment(self, directions: dict[int, np.ndarray], sliding: tuple[int, ...],
                      onset: Container[int], held: np.ndarray | None) -> None:
        """Set the run's C solver for a segment.

        Parameters
        ----------
        directions
            Each sliding contact's direction at the segment's start.
        sliding
            The set's sliding contacts, in order.
        onset
            The contacts starting to slide from rest in this segment.
        held
            The user's inputs held in this segment (a sampled signal), or ``None``.
        """
        native = self.data.native
        assert native is not None
        self.table.start_segment([directions[k] for k in sliding], [k in onset for k in sliding])
        native.set_inputs(self.user)
        if held is not None:
            self.data.hold_inputs(np.concatenate([held, self._zeros]))
        native.set_friction(self.table)

    def forces(self, t: np.ndarray, y: np.ndarray) -> np.ndarray:
        """The friction forces at the current segment's states ``y`` (one row per time
        of ``t``) as C computes them.

        Parameters
        ----------
        t, y
            Times and states ``[q, qd]`` of the current segment.
        """
        native = self.data.native
        assert native is not None
        return native.inputs(t, y)[:, -self.table.forces:]
