"""What the multibody functions take and give, named once.

SymPy has no type information, so a SymPy value is ``Any`` to a type checker;
these aliases say what is meant all the same.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from typing import TYPE_CHECKING, Literal, Protocol, TypeAlias, TypeVar

import numpy as np
import sympy as sp
from numpy.typing import NDArray

if TYPE_CHECKING:
    from .bodies import Body

#: Numbers computed here: poses, velocities and forces along a trajectory.
FloatArray: TypeAlias = NDArray[np.float64]
#: Numbers as users give them: a sequence or an array (a configuration ``q``...).
Numbers: TypeAlias = Sequence[float] | NDArray[np.floating]
#: A point, an axis or a direction: 3 numbers (2 in the plane of a planar body).
Vector: TypeAlias = Numbers
#: An orientation: a rotation matrix, Euler parameters, or a planar body's angle.
Orientation: TypeAlias = float | Sequence[float] | Sequence[Sequence[float]] | NDArray[np.floating]
#: 3 components that may be SymPy expressions (a load that depends on time or state).
ExprVector: TypeAlias = Sequence[float | sp.Expr] | sp.MatrixBase | NDArray[np.floating]
#: The components a vector is given in: the world frame or the body's own.
Frame = Literal["world", "body"]

_V_co = TypeVar("_V_co", covariant=True)


class ByBody(Protocol[_V_co]):
    """Values by body: a mapping from a body or its name to a value.

    Any ``dict`` keyed by bodies or by names fits (``Mapping`` would not: its key
    type must match exactly, so a ``dict[str, ...]`` would not pass for a mapping
    keyed by ``Body | str``).
    """

    def items(self) -> Iterable[tuple[Body | str, _V_co]]: ...
