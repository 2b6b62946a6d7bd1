"""The example gallery: each module builds a real constrained system.

Every example module defines ``TITLE`` (one line), ``build(**parameters) -> System``,
``INITIAL`` (keyword arguments ``q0``/``qd0`` for ``simulate``), ``T_END`` (default
simulated time) and ``checks(system, traj) -> dict[str, float]``: measured errors
against an independent closed form or conservation law, used by the demo and
the CLI summary. The tests validate each example separately.
"""

from __future__ import annotations

import importlib
from types import ModuleType

#: name -> module (in dalembert.examples), in gallery order.
EXAMPLES: dict[str, str] = {
    "pendulum": "cartesian_pendulum",
    "spherical-pendulum": "spherical_pendulum",
    "hoop": "bead_on_hoop",
    "dumbbell": "dumbbell",
    "knife-edge": "knife_edge",
    "rolling-disk": "rolling_disk",
    "whirled-string": "whirled_string",
}


def load(name: str) -> ModuleType:
    """The example module called ``name`` (see :data:`EXAMPLES`)."""
    if name not in EXAMPLES:
        raise KeyError(f"unknown example {name!r}; the examples are {', '.join(EXAMPLES)}")
    return importlib.import_module(f"{__name__}.{EXAMPLES[name]}")
