"""The example gallery: each module builds a real constrained system.

Every example module defines ``TITLE`` (one line), ``build(**parameters) -> System``,
``INITIAL`` (keyword arguments ``q0``/``qd0`` for ``simulate``), ``T_END`` (default
simulated time) and ``checks(system, traj) -> dict[str, float]``: measured errors
against an independent closed form or conservation law, used by the demo and
the CLI summary. The tests validate each example separately.

Optional attributes, used by ``dalembert equilibrium`` and ``dalembert modes``:

- ``EQUILIBRIUM_GUESS``: a dict by coordinate name, the starting point of
  ``System.equilibrium`` (it need not satisfy the constraints: it is projected
  onto them first). Examples without it have no statics commands.
- ``draw(system, q) -> list of numpy arrays``: the mechanism at the
  configuration ``q`` (an array in coordinate order) as polylines, each a
  ``(k, 2)`` array of ``x, y`` points in the plane of the drawing (rods, links,
  pivots included); 3D mechanisms return ``(k, 3)`` arrays, projected on a
  coordinate plane when drawn. Used by :mod:`dalembert.plotting.modes` and
  ``dalembert equilibrium`` / ``dalembert modes`` (which skip the PNGs without it).
"""

from __future__ import annotations

import importlib
from types import ModuleType

#: name -> module (in dalembert.examples), in gallery order.
EXAMPLES: dict[str, str] = {
    "pendulum": "cartesian_pendulum",
    "double-pendulum": "double_pendulum",
    "spherical-pendulum": "spherical_pendulum",
    "hoop": "bead_on_hoop",
    "dumbbell": "dumbbell",
    "knife-edge": "knife_edge",
    "rolling-disk": "rolling_disk",
    "whirled-string": "whirled_string",
    "tumbling-body": "tumbling_body",
    "heavy-top": "heavy_top",
    "coin": "coin",
    "spherical-chain": "spherical_chain",
    "hanging-chain": "hanging_chain",
    "four-bar": "four_bar",
    "slider-crank": "slider_crank",
    "closed-chain": "closed_chain",
}


def load(name: str) -> ModuleType:
    """The example module called ``name`` (see :data:`EXAMPLES`)."""
    if name not in EXAMPLES:
        raise KeyError(f"unknown example {name!r}; the examples are {', '.join(EXAMPLES)}")
    return importlib.import_module(f"{__name__}.{EXAMPLES[name]}")
