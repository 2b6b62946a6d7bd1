"""The example gallery: each module builds a real constrained system.

Every example module defines ``TITLE`` (one line), ``build(**parameters) -> System``,
``INITIAL`` (keyword arguments of ``simulate``: ``q0``/``qd0``, and ``inputs`` for a
controlled example), ``T_END`` (default
simulated time) and ``checks(system, traj) -> dict[str, float]``: measured errors
against an independent closed form or conservation law, used by the demo and
the CLI summary. The tests validate each example separately.

Optional attributes, used by ``dalembert equilibrium`` and ``dalembert modes``:

- ``EQUILIBRIUM_GUESS``: a dict by coordinate name, the starting point of
  ``System.equilibrium`` (it need not satisfy the constraints: it is projected
  onto them first). Examples without it have no statics commands.
- ``plots(system, traj, out) -> list of paths``: plots of the example's own (a
  motor's torque, a parameter study), written into the folder ``out`` by
  ``dalembert run`` beside the standard ones.
- ``draw(system, q) -> list of numpy arrays``: the mechanism at the
  configuration ``q`` (an array in coordinate order) as polylines, each a
  ``(k, 2)`` array of ``x, y`` points in the plane of the drawing (rods, links,
  pivots included); 3D mechanisms return ``(k, 3)`` arrays, projected on a
  coordinate plane when drawn. Used by :mod:`dalembert.plotting.modes` and
  ``dalembert equilibrium`` / ``dalembert modes`` (which skip the PNGs without it).
"""

from __future__ import annotations

import importlib
import importlib.util
import os
from pathlib import Path
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
    "crank-press": "crank_press",
    "spacecraft": "spacecraft",
    "cart-pole": "cart_pole",
    "chain-frequencies": "chain_frequencies",
    "closed-chain": "closed_chain",
    "n-four-bar": "n_four_bar",
    "imported-linkage": "imported_linkage",
    "bouncing-ball": "bouncing_ball",
    "slack-string": "slack_string",
    "newtons-cradle": "newtons_cradle",
    "falling-chain": "falling_chain",
    "rolling-sphere": "rolling_sphere",
    "flyball-governor": "flyball_governor",
}


#: What every example module defines (a user's file given by path too).
REQUIRED = ("TITLE", "build", "INITIAL", "T_END", "checks")


def is_path(name: str) -> bool:
    """Whether ``name`` names a Python file rather than a gallery example.

    Parameters
    ----------
    name
        A gallery name (see :data:`EXAMPLES`) or a path.

    Examples
    --------
    >>> is_path("four-bar"), is_path("models/my_crane.py")
    (False, True)
    """
    return name.endswith(".py") or os.sep in name or "/" in name


def load(name: str) -> ModuleType:
    """The example module called ``name`` (see :data:`EXAMPLES`), or the user's Python
    file at the path ``name`` (see :func:`load_file`).

    Parameters
    ----------
    name
        A gallery name or a path; an unknown name raises ``KeyError`` listing the
        gallery.

    Examples
    --------
    >>> example = load("pendulum")
    >>> example.TITLE
    'Pendulum in Cartesian x, y with the rod x^2 + y^2 = l^2'
    >>> sorted(example.INITIAL)
    ['q0', 'qd0']
    """
    if is_path(name):
        return load_file(name)
    if name not in EXAMPLES:
        raise KeyError(f"unknown example {name!r}; the examples are {', '.join(EXAMPLES)}")
    return importlib.import_module(f"{__name__}.{EXAMPLES[name]}")


def load_file(path: str | os.PathLike) -> ModuleType:
    """A user's model file that defines what a gallery example does (:data:`REQUIRED`).

    Parameters
    ----------
    path
        A Python file defining ``TITLE``, ``build``, ``INITIAL``, ``T_END`` and
        ``checks`` (and optionally ``EQUILIBRIUM_GUESS`` and ``draw``).

    Raises
    ------
    FileNotFoundError
        No such file.
    AttributeError
        The file lacks some of :data:`REQUIRED` (all missing ones are named).

    Examples
    --------
    >>> import inspect, tempfile
    >>> source = inspect.getsource(load("pendulum")).replace("from ..", "from dalembert.")
    >>> with tempfile.TemporaryDirectory() as folder:
    ...     mine = Path(folder) / "my_pendulum.py"
    ...     _ = mine.write_text(source)
    ...     load_file(mine).TITLE == load("pendulum").TITLE
    True
    """
    file = Path(path)
    if not file.is_file():
        raise FileNotFoundError(f"no model file {str(file)!r}")
    spec = importlib.util.spec_from_file_location(f"dalembert_user_model_{file.stem}", file)
    if spec is None or spec.loader is None:
        raise ImportError(f"{str(file)!r} cannot be loaded as a Python module")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    missing = [name for name in REQUIRED if not hasattr(module, name)]
    if missing:
        raise AttributeError(
            f"{str(file)!r} does not define {', '.join(missing)}; a model file defines "
            "TITLE (one line), build(**parameters) -> System, INITIAL (q0/qd0 for "
            "simulate), T_END (simulated time) and checks(system, traj) -> dict, like "
            "the gallery's examples (dalembert/examples)")
    return module
