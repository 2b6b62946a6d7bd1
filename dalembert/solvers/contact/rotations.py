"""The time-stepping mode's position update, for unit quaternions too.

A Moreau-Jean step moves the positions along straight lines, ``q + s v``. For a
rigid body's Euler parameters ``b`` that line leaves the unit sphere; the projection
then normalises ``b`` and, seen from the body, the turn was ``cos``-shortened: a
spinning body lost ``O((h w)^2)`` of its spin each step (a ball rolling at 10 rad/s
with ``h = 1e-3``: 1 % in a second). Here each unit quaternion follows the rotation
instead, the exact flow of a constant body angular velocity ``w = 2 E(b) bdot``
over the step (scalar first, the convention of :mod:`dalembert.multibody.rotations`):

    b(s) = cos(s |w| / 2) b + sin(s |w| / 2) E(b)^T w / |w|

which keeps ``|b| = 1`` and turns by ``s |w|`` about ``w``. The rates ``bdot`` of a
state are tied to its own ``b`` (``bdot = E(b)^T w / 2``, ``b . bdot = 0``), so a
velocity used at other positions is carried there with the same body angular
velocity (:meth:`Rotations.carry`): for a turn about ``w`` itself the world angular
velocity is the same too, and the kinetic energy ``w . I w / 2`` is kept. The other
coordinates move along straight lines and keep their rates, so a model without
quaternions steps as before.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


def _E(b: np.ndarray) -> np.ndarray:
    """``E(b)`` of each row of ``b`` ``(k, 4)``: ``(k, 3, 4)`` (``w_body = 2 E bdot``)."""
    b0, b1, b2, b3 = b.T
    return np.stack([np.stack([-b1, b0, b3, -b2], axis=-1),
                     np.stack([-b2, -b3, b0, b1], axis=-1),
                     np.stack([-b3, b2, -b1, b0], axis=-1)], axis=1)


@dataclass(frozen=True)
class Rotations:
    """Where the unit quaternions are among the coordinates, and how they move.

    Parameters
    ----------
    blocks
        ``(k, 4)`` places of each quaternion's ``b0..b3`` (none: ``(0, 4)``).

    Examples
    --------
    A body turning at 2 rad/s about its ``z`` axis, stepped by a quarter turn: the
    quaternion stays a unit one, and the rates are those of the same spin there:

    >>> turn = Rotations(np.array([[0, 1, 2, 3]]))
    >>> q, v = np.array([1.0, 0.0, 0.0, 0.0]), np.array([0.0, 0.0, 0.0, 1.0])
    >>> q1 = turn.advance(q, v, np.pi / 4)
    >>> q1.round(12).tolist(), float(np.linalg.norm(q1))
    ([0.707106781187, 0.0, 0.0, 0.707106781187], 1.0)
    >>> (2 * _E(q1[None])[0] @ turn.carry(q, v, q1)).round(12).tolist()
    [0.0, 0.0, 2.0]
    >>> Rotations.none().advance(q, v, 0.5).tolist()  # no quaternion: a straight line
    [1.0, 0.0, 0.0, 0.5]
    """

    blocks: np.ndarray

    @classmethod
    def none(cls) -> Rotations:
        """No quaternion among the coordinates."""
        return cls(np.zeros((0, 4), dtype=int))

    def advance(self, q: np.ndarray, v: np.ndarray, s: float) -> np.ndarray:
        """The positions ``s`` later at the rates ``v`` (tied to ``q``): straight
        lines, each quaternion turned by its body angular velocity held over ``s``."""
        out = q + s * v
        if len(self.blocks):
            b, bd = q[self.blocks], v[self.blocks]
            E = _E(b)
            w = 2 * np.einsum("kij,kj->ki", E, bd)
            half = s / 2 * np.linalg.norm(w, axis=1)  # half the angle turned
            # sin(half) / |w| = s/2 sinc(half), finite at w = 0
            along = np.einsum("kji,kj->ki", E, w) * (s / 2 * np.sinc(half / np.pi))[:, None]
            out[self.blocks] = np.cos(half)[:, None] * b + along
        return out

    def carry(self, q: np.ndarray, v: np.ndarray, to: np.ndarray) -> np.ndarray:
        """The rates ``v`` (tied to ``q``) as rates at ``to``: each quaternion's with
        the same body angular velocity, the others unchanged."""
        if not len(self.blocks):
            return v
        out = np.array(v, dtype=float)
        w = 2 * np.einsum("kij,kj->ki", _E(q[self.blocks]), v[self.blocks])
        out[self.blocks] = np.einsum("kji,kj->ki", _E(to[self.blocks]), w) / 2
        return out
