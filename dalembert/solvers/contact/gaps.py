"""The unilateral rows of a model with every gap closed, and their values at a state.

The contact layer works on the model whose constraint rows are the bilateral ones
followed by every gap (``System`` builds it): :class:`Gaps` says where the gaps are
and what their laws are; the functions here read their values, rates and
accelerations from that model's generated functions.
"""

from __future__ import annotations

from collections.abc import Collection, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from ...codegen.compiled import NumericModel
from ...errors import ContactError
from ...model.constraints import ClosedGaps
from ..kkt.sparse import matvec

if TYPE_CHECKING:
    from ...definition import UnilateralLaw

#: A gap (or rate) within this much of 0, relative to ``1 + max |q|`` (to the rates'
#: scale), touches (has stopped): rounding, not a motion.
TOUCH_RTOL = 1e-9
#: A contact force within this much of 0, relative to ``1 +`` the largest multiplier
#: (or force) at the state, is 0: a contact that pushes with no force (balls at rest
#: touching) neither pulls nor opens (a fresh KKT solve has rounding errors far below).
FORCE_RTOL = 1e-12
#: The sliding speed, relative to ``1 + max |qd|``, below which a contact starting to
#: slide from rest with two sliding velocities (or three of rank 2) takes the friction
#: Coulomb's law gives at the level of accelerations
#: (:func:`~dalembert.solvers.contact.friction.onset_friction`: it holds, or slides
#: along its acceleration), not its velocity's direction. The motion differs from that
#: friction by ``O(|v|)``, so the error it leaves falls as the square of this speed, and
#: the steps it takes to follow ``v / |v|`` after it grow as its inverse square root
#: (measured on a cylinder pushed by a growing force: positions of 4.6 within 1.6e-8,
#: 1.6e-10 and 1.5e-12 at 1e-4, 1e-5 and 1e-6, in 264, 385 and 579 steps;
#: docs/design.md).
ONSET_RTOL = 1e-6


def row_rates(full: NumericModel, t: float, q: np.ndarray, qd: np.ndarray) -> np.ndarray:
    """``A qd + b`` of every row of ``full`` (NaN where a row has no derivative).

    Examples
    --------
    >>> from dalembert import System, Unilateral, coordinates
    >>> (y,) = coordinates("y")
    >>> ball = System([y], kinetic=y.diff()**2 / 2, constraints=[Unilateral(y, "floor")])
    >>> row_rates(ball.with_gaps_closed().numeric(), 0.0, np.ones(1), np.array([-2.0]))
    array([-2.])
    """
    pattern = full.pattern
    Av, b = full.velocity_sparse(t, q)
    with np.errstate(invalid="ignore"):
        return matvec(pattern.A_rows, pattern.A_cols, Av, qd, full.m) + b


@dataclass(frozen=True)
class Gaps:
    """The gaps of a model whose last rows are every unilateral constraint.

    Attributes
    ----------
    names
        The unilateral constraints' names.
    first
        The row of the first gap (the number of bilateral rows).
    restitution, rest_speed
        Newton's coefficient and the rest speed of each gap
        (:class:`~dalembert.Unilateral`).
    friction
        Coulomb's coefficient of each gap (0: none).
    tangents
        Each gap's sliding velocities' rows in the model (none without friction, or in
        a model without them: the event-driven mode's).

    Examples
    --------
    >>> gaps = Gaps(("floor",), 0, np.array([0.8]), np.array([1e-6]))
    >>> gaps.count, gaps.rows.tolist()
    (1, [0])
    """

    names: tuple[str, ...]
    first: int
    restitution: np.ndarray
    rest_speed: np.ndarray
    friction: np.ndarray | None = None
    tangents: tuple[np.ndarray, ...] = ()

    @classmethod
    def of(cls, laws: Sequence[UnilateralLaw], first: int,
           restitution: Sequence[float]) -> Gaps:
        """The gaps of unilateral constraints whose rows start at ``first``, their
        restitution's values given (a parameter's, resolved), each frictional one's
        sliding velocities' rows after every gap, in order.

        Examples
        --------
        >>> from dalembert.model.constraints import UnilateralRow
        >>> floor = UnilateralRow("floor", 0, (), 0, 0.5, 1e-6, 0.3, ((0, (1,), 0),))
        >>> wall = UnilateralRow("wall", 0, (), 0, 0.0, 1e-6)
        >>> gaps = Gaps.of([floor, wall], 1, [0.5, 0.0])
        >>> gaps.rows.tolist(), [t.tolist() for t in gaps.tangents]
        ([1, 2], [[3], []])
        """
        sizes = [len(getattr(u, "tangents", ())) if u.friction > 0 else 0 for u in laws]
        starts = first + len(laws) + np.concatenate([[0], np.cumsum(sizes)[:-1]]) \
            if laws else np.zeros(0, dtype=int)
        return cls(tuple(u.name for u in laws), first,
                   np.asarray(restitution, dtype=float),
                   np.array([u.rest_speed for u in laws], dtype=float),
                   np.array([u.friction for u in laws], dtype=float),
                   tuple(np.arange(s, s + k) for s, k in zip(starts, sizes)))

    @property
    def count(self) -> int:
        return len(self.names)

    @property
    def rows(self) -> np.ndarray:
        """The gaps' rows in the model."""
        return np.arange(self.first, self.first + self.count)

    def acting(self, m: int, chosen: np.ndarray, held: Collection[int] = ()) -> np.ndarray:
        """The rows of the model that act with the gaps ``chosen`` closed (a boolean
        mask over its ``m`` rows): the bilateral ones, the chosen gaps and the sliding
        velocities' rows of the rough ones among them (``friction=math.inf``: held
        at 0 while closed) and of those in ``held`` (sticking).

        Examples
        --------
        >>> gaps = Gaps(("a", "b"), 1, np.zeros(2), np.ones(2), np.array([np.inf, 0.3]),
        ...             (np.array([3]), np.array([4])))
        >>> gaps.acting(5, np.array([0, 1])).tolist()
        [True, True, True, True, False]
        >>> gaps.acting(5, np.array([0, 1]), held=(1,)).tolist()
        [True, True, True, True, True]
        """
        mask = np.zeros(m, dtype=bool)
        mask[:self.first] = True
        mask[self.first + chosen] = True
        for k in chosen:
            if self.friction is not None and (self.friction[k] == np.inf or k in held):
                mask[self.tangents[k]] = True
        return mask

    @property
    def rough(self) -> tuple[int, ...]:
        """The rough gaps (``friction=math.inf``: they never slide)."""
        if self.friction is None:
            return ()
        return tuple(int(k) for k in np.flatnonzero(self.friction == np.inf))

    def held_rows(self, closed: ClosedGaps) -> np.ndarray:
        """The sliding velocities' rows of the gaps ``closed.held``, in the order the
        model of that closed set has them (after the gaps).

        Examples
        --------
        >>> gaps = Gaps(("a", "b"), 1, np.zeros(2), np.ones(2), np.array([np.inf, 0.0]),
        ...             (np.array([3]), np.array([], dtype=int)))
        >>> gaps.held_rows(ClosedGaps((0, 1), held=(0,))).tolist()
        [3]
        """
        found = [self.tangents[k] for k in closed.held]
        return np.concatenate(found).astype(int) if found else np.zeros(0, dtype=int)

    @property
    def sizes(self) -> tuple[int, ...]:
        """How many sliding velocities each gap has (0 without friction)."""
        return tuple(len(t) for t in self.tangents) if self.tangents else (0,) * self.count

    def tangential(self, values: np.ndarray) -> tuple[np.ndarray, ...]:
        """Each gap's entries of ``values`` (one per row of the model) in its sliding
        velocities' rows (an empty array where it has none): its friction impulse or
        force.

        Examples
        --------
        >>> gaps = Gaps(("a", "b"), 0, np.zeros(2), np.ones(2), np.array([0.3, 0.0]),
        ...             (np.array([2, 3]), np.array([], dtype=int)))
        >>> [v.tolist() for v in gaps.tangential(np.array([5.0, 6.0, 0.5, -0.5]))]
        [[0.5, -0.5], []]
        """
        if not self.tangents:
            return tuple(np.zeros(0) for _ in range(self.count))
        return tuple(np.array(values[rows], dtype=float) for rows in self.tangents)

    def values(self, full: NumericModel, t: float, q: np.ndarray) -> np.ndarray:
        """``g(q, t)``, one per gap (the last entries of the model's ``psi``)."""
        return full.position_constraint(t, q)[-self.count:]

    def rates(self, full: NumericModel, t: float, q: np.ndarray,
              qd: np.ndarray) -> np.ndarray:
        """``g' = A qd + b``, one per gap (NaN where a gap has no derivative: see
        :meth:`check_finite`)."""
        return row_rates(full, t, q, qd)[self.rows]

    def check_finite(self, rate: np.ndarray, t: float) -> None:
        """Raise a ``ContactError`` naming the first gap whose ``rate`` (or row) is not
        finite.

        Examples
        --------
        >>> Gaps(("rim",), 0, np.zeros(1), np.ones(1)).check_finite(np.array([np.nan]), 0.5)
        Traceback (most recent call last):
        ...
        dalembert.errors.ContactError: the contact 'rim' has no finite rate at t=0.5: ...
        """
        bad = np.flatnonzero(~np.isfinite(rate))
        if len(bad):
            raise ContactError(
                f"the contact {self.names[int(bad[0])]!r} has no finite rate at t={t:.6g}: "
                "its gap is not differentiable there (a disk's rim with the disk lying flat "
                "has no lowest point); keep the contact away from such a configuration")

    def touching(self, full: NumericModel, t: float, q: np.ndarray) -> np.ndarray:
        """Which gaps are 0 to rounding (a boolean mask)."""
        g = self.values(full, t, q)
        return np.abs(g) <= TOUCH_RTOL * (1.0 + np.abs(q).max(initial=0.0))
