"""What an animation draws of a system that brings no ``draw(system, q)`` of its own.

One rule for :func:`dalembert.plotting.animate` and ``dalembert run`` alike:

- a system built by :class:`dalembert.multibody.Multibody` (or the ``Multibody``
  itself): its stick figure;
- any other system whose coordinates name points, ``x<s>, y<s>`` (and ``z<s>``)
  with a common suffix ``<s>`` (``x, y``; ``x1, y1, x2, y2``): one point per particle,
  in 3D if any particle has a ``z``.
"""

from __future__ import annotations

import re
from collections.abc import Callable, Sequence
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

if TYPE_CHECKING:
    from ..multibody.builder import Multibody

#: ``draw(system, q)``: the polylines of the mechanism at ``q`` (in coordinate order).
Drawer = Callable[[Any, NDArray[np.float64]], Sequence[ArrayLike]]


def particle_points(names: Sequence[str]) -> list[tuple[int, ...]]:
    """Indices ``(ix, iy)`` or ``(ix, iy, iz)`` of each particle among coordinate names.

    A particle is a set ``x<s>``, ``y<s>`` (and ``z<s>``) with a common suffix ``<s>``;
    other coordinates (angles) are ignored.

    Parameters
    ----------
    names
        Coordinate names, in coordinate order.

    Examples
    --------
    >>> particle_points(["x1", "y1", "x2", "y2", "theta"])
    [(0, 1), (2, 3)]
    >>> particle_points(["x", "y", "z", "psi"])
    [(0, 1, 2)]
    """
    groups: dict[str, dict[str, int]] = {}
    for i, name in enumerate(names):
        match = re.fullmatch(r"([xyz])(.*)", name)
        if match:
            groups.setdefault(match.group(2), {})[match.group(1)] = i
    return [tuple(g[a] for a in "xyz" if a in g)
            for g in groups.values() if "x" in g and "y" in g]


def default_drawer(system: object) -> tuple[Drawer | None, str]:
    """``(draw, how)``: how ``system`` is drawn without a ``draw`` of its own, or
    ``(None, why not)``.

    Parameters
    ----------
    system
        A :class:`~dalembert.System`, a ``Multibody``, or anything with
        ``coordinate_names``.

    Examples
    --------
    >>> from types import SimpleNamespace
    >>> draw, how = default_drawer(SimpleNamespace(coordinate_names=("x", "y", "phi")))
    >>> how, [p.tolist() for p in draw(None, np.array([1.0, 2.0, 3.0]))]
    ('the particles as points', [[[1.0, 2.0]]])
    """
    mb = multibody_or_none(system)
    if mb is not None:
        stick_figure = mb.stick_figure
        return (lambda _system, q: stick_figure(q)), "the multibody stick figure"
    particles = particle_points(list(getattr(system, "coordinate_names", ())))
    if not particles:
        return None, ("nothing to draw: no draw(system, q) was given, the system is not "
                      "built by dalembert.multibody.Multibody and no coordinates name "
                      "points (x<s>, y<s>[, z<s>] with a common suffix <s>)")
    dim = max(len(p) for p in particles)

    def draw_points(_system: object, q: NDArray[np.float64]) -> list[NDArray[np.float64]]:
        return [np.array([[*q[list(p)], *[0.0] * (dim - len(p))]]) for p in particles]

    return draw_points, "the particles as points"


def multibody_or_none(system: object) -> Multibody | None:
    """The ``Multibody`` that built ``system`` (or ``system`` itself if it is one), else
    ``None``.

    Parameters
    ----------
    system
        Anything: a System, a Multibody, ``None``.

    Examples
    --------
    >>> from dalembert.multibody import chain
    >>> mb = chain(1, 1.0, 1.0, 0.1)
    >>> multibody_or_none(mb.system) is mb, multibody_or_none(None)
    (True, None)
    """
    from ..multibody.builder import Multibody  # imported with the first multibody only

    mb = system if isinstance(system, Multibody) else \
        getattr(getattr(system, "definition", None), "multibody", None)
    return mb if isinstance(mb, Multibody) else None
