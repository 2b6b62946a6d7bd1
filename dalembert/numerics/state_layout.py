"""Where the coordinates and the velocities sit in a first-order state ``y = [q, qd]``.

The integrators see one vector ``y``; everything else sees ``q`` and ``qd``. One small
value says how the two are laid out, so no code spells ``y[:n]`` and ``y[n:]`` (or
recovers ``n`` as ``y.size // 2``). It lives here, below every layer, because the
system, the solvers and the trajectory all cut states the same way.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class StateLayout:
    """The layout ``y = [q, qd]`` of a first-order state with ``n`` coordinates.

    The cuts are views (no copy), on one state (a 1-D ``y``) or, with :meth:`rows_q`
    and :meth:`rows_qd`, on states stored as the rows of a 2-D array.

    Parameters
    ----------
    n
        The number of coordinates (as many velocities).

    Examples
    --------
    >>> layout = StateLayout(2)
    >>> y = layout.join(np.array([1.0, 2.0]), np.array([3.0, 4.0]))
    >>> y, layout.size
    (array([1., 2., 3., 4.]), 4)
    >>> layout.q(y), layout.qd(y)
    (array([1., 2.]), array([3., 4.]))
    >>> StateLayout.of(y) == layout
    True
    """

    n: int

    @classmethod
    def of(cls, y: np.ndarray) -> StateLayout:
        """The layout of a state ``y`` known only by its size (``n = y.size // 2``)."""
        return cls(y.size // 2)

    @property
    def size(self) -> int:
        """The state's size, ``2 n``."""
        return 2 * self.n

    @property
    def q_slice(self) -> slice:
        """Where ``q`` sits in ``y``."""
        return slice(0, self.n)

    @property
    def qd_slice(self) -> slice:
        """Where ``qd`` sits in ``y``."""
        return slice(self.n, 2 * self.n)

    def q(self, y: np.ndarray) -> np.ndarray:
        """The coordinates of the state ``y`` (a view)."""
        return y[:self.n]

    def qd(self, y: np.ndarray) -> np.ndarray:
        """The velocities of the state ``y`` (a view)."""
        return y[self.n:]

    def split(self, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``(q, qd)`` of the state ``y`` (views)."""
        return y[:self.n], y[self.n:]

    def rows_q(self, ys: np.ndarray) -> np.ndarray:
        """The coordinates of states stored as rows of ``ys`` (a view)."""
        return ys[:, :self.n]

    def rows_qd(self, ys: np.ndarray) -> np.ndarray:
        """The velocities of states stored as rows of ``ys`` (a view)."""
        return ys[:, self.n:]

    def join(self, q: np.ndarray, qd: np.ndarray) -> np.ndarray:
        """The state ``[q, qd]`` (a new array)."""
        return np.concatenate([q, qd])
