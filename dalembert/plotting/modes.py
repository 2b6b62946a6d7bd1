"""PNG drawings of a mechanism at rest and of its small-oscillation mode shapes.

A mechanism is drawn by a ``draw(system, q)`` function (see
:mod:`dalembert.examples`) returning polylines, each a ``(k, 2)`` array of ``x, y``
points (rods, links); ``(k, 3)`` polylines (the 3D multibody examples) are drawn
projected on a coordinate plane, ``"xz"`` by default (``z`` up). As in
:mod:`dalembert.plotting.trajectory_plots`, figures are
:class:`matplotlib.figure.Figure` objects, never pyplot.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any, Literal

import numpy as np
from matplotlib.axes import Axes
from matplotlib.figure import Figure
from numpy.typing import ArrayLike, NDArray

from ..errors import InitialConditionError
from .trajectory_plots import _legend_outside, _save

if TYPE_CHECKING:
    from ..statics import Equilibrium, Linearization
    from ..system import System

#: ``draw(system, q) -> list of (k, 2) arrays`` (or ``(k, 3)``), ``q`` in coordinate order.
DrawFunction = Callable[["System", NDArray[np.float64]], Sequence[ArrayLike]]
#: A coordinate plane a 3D drawing is projected on.
Plane = Literal["xy", "xz", "yz"]
#: Coordinate planes a 3D drawing can be projected on.
PLANES: dict[Plane, tuple[int, int]] = {"xy": (0, 1), "xz": (0, 2), "yz": (1, 2)}
#: Default largest coordinate displacement of a drawn mode, relative to the drawing's size.
MODE_FRACTION = 0.1
_HALVINGS = 8
_DPI = 110


def plot_mechanism(
    draw: DrawFunction, system: System, q: ArrayLike,
    path: str | os.PathLike, *, title: str | None = None, plane: Plane = "xz",
) -> Path:
    """Draw the mechanism at the configuration ``q`` (equal axis scales).

    Parameters
    ----------
    draw
        ``draw(system, q)`` returning polylines, each a ``(k, 2)`` array of points.
    system
        The :class:`~dalembert.System` (passed on to ``draw``; its name titles the plot).
    q
        Configuration, an array in the system's coordinate order (e.g. ``Equilibrium.q``).
    path
        The PNG to write (parent folders are created).
    title
        Figure title (default: the system's name).
    plane
        ``"xy"``, ``"xz"`` or ``"yz"``: where 3D polylines are projected.

    Returns
    -------
    Path
        ``path``.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> from dalembert.examples import cartesian_pendulum as ex
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     png = plot_mechanism(ex.draw, ex.build(), [0.0, -1.0], pathlib.Path(tmp) / "m.png")
    ...     png.stat().st_size > 0
    True
    """
    fig, ax = _figure()
    _draw_lines(ax, _polylines(draw, system, q, plane), color="C0", lw=2.0,
                label="configuration")
    _finish(ax, title if title is not None else _name(system, "mechanism"),
            _labels(draw, system, q, plane))
    return _save(fig, path)


def plot_mode_shapes(
    draw: DrawFunction, system: System, linearization: Linearization, equilibrium: Equilibrium,
    path: str | os.PathLike, *, mode: int = 0, amplitude: float | None = None,
    title: str | None = None, plane: Plane = "xz",
) -> Path:
    """Draw one mode: the mechanism at equilibrium and displaced by +- the mode shape.

    The displaced configurations ``q* +- amplitude * v / max|v|`` (``v`` the mode
    shape in the original coordinates) are projected back onto the constraints
    with ``system.consistent_initial_state`` (least change), so rods keep their
    length; an ``amplitude`` too large to project raises ``ValueError``.

    Parameters
    ----------
    draw, system
        As in :func:`plot_mechanism`.
    linearization
        :class:`~dalembert.statics.Linearization` about ``equilibrium``.
    equilibrium
        The :class:`~dalembert.statics.Equilibrium` (its ``q`` is drawn).
    path
        The PNG to write.
    mode
        Index of the mode, 0 for the lowest frequency (``Linearization.mode(k)``).
    amplitude
        Largest coordinate displacement before projection, in the coordinates'
        units (default: :data:`MODE_FRACTION` of the drawing's size, halved until
        the displaced configurations can be projected onto the constraints).
    title
        Figure title (default: the system's name, the mode and its frequency).
    plane
        As in :func:`plot_mechanism`.

    Returns
    -------
    Path
        ``path``.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> from dalembert.examples import cartesian_pendulum as ex
    >>> system = ex.build()
    >>> eq = system.equilibrium(ex.EQUILIBRIUM_GUESS)
    >>> lin = system.linearize(eq)
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     png = plot_mode_shapes(ex.draw, system, lin, eq, pathlib.Path(tmp) / "mode.png")
    ...     png.stat().st_size > 0
    True
    """
    shapes = np.real(np.asarray(linearization.mode_shapes))
    count = shapes.shape[1] if shapes.ndim == 2 else 0
    if count == 0:
        raise ValueError("the linearization has no modes (no degree of freedom is free)")
    if not 0 <= mode < count:
        raise ValueError(f"mode must be between 0 and {count - 1} (the linearization has "
                         f"{count} modes), not {mode}")
    q_eq = np.asarray(equilibrium.q, dtype=float)
    at_rest = _polylines(draw, system, q_eq, plane)
    v = shapes[:, mode] / np.abs(shapes[:, mode]).max()
    if amplitude is None:
        displaced = _reachable(system, equilibrium, q_eq, v, MODE_FRACTION * _size(at_rest),
                               _HALVINGS)
    else:
        displaced = _reachable(system, equilibrium, q_eq, v, float(amplitude), 1)
    fig, ax = _figure()
    for q, sign, style in zip(displaced, "+-", ("-", "--")):
        _draw_lines(ax, _polylines(draw, system, q, plane), color="C1", lw=1.5, ls=style,
                    label=f"{sign} mode {mode + 1}")
    _draw_lines(ax, at_rest, color="C0", lw=2.0, label="equilibrium")
    _finish(ax, title if title is not None else _mode_title(system, linearization, mode),
            _labels(draw, system, q_eq, plane))
    return _save(fig, path)


# -- helpers -------------------------------------------------------------------------
def _polylines(draw: DrawFunction, system: System, q: ArrayLike,
               plane: Plane) -> list[NDArray[np.float64]]:
    if plane not in PLANES:
        raise ValueError(f"plane must be one of {', '.join(PLANES)}, not {plane!r}")
    lines = [np.asarray(line, dtype=float) for line in draw(system, np.asarray(q, dtype=float))]
    for i, line in enumerate(lines):
        if line.ndim != 2 or line.shape[1] not in (2, 3) or len(line) < 1:
            raise ValueError(f"draw() returned polyline {i} with shape {line.shape}; each "
                             "polyline must be a (k, 2) array of x, y points (or (k, 3))")
    return [line[:, list(PLANES[plane])] if line.shape[1] == 3 else line for line in lines]


def _labels(draw: DrawFunction, system: System, q: ArrayLike, plane: Plane) -> str:
    """Axis names: ``x, y`` for a planar drawing, the plane's for a projected 3D one."""
    three_d = any(np.shape(line)[-1] == 3 for line in draw(system, np.asarray(q, dtype=float)))
    return plane if three_d else "xy"


def _on_constraints(system: System, equilibrium: Equilibrium,
                    q: NDArray[np.float64]) -> NDArray[np.float64]:
    """The least change of ``q`` that satisfies the constraints (same parameters and
    fixed coordinates as the equilibrium)."""
    # copied by items: a dict[str, float] is no Mapping[Any, object] to a type checker
    # (a mapping's key type is invariant)
    parameters: Mapping[Any, object] = dict(equilibrium.parameter_values.items())
    report = system.consistent_initial_state(q, parameters=parameters or None,
                                             fixed=equilibrium.fixed or None)
    return np.asarray(report.q, dtype=float)


def _reachable(system: System, equilibrium: Equilibrium, q_eq: NDArray[np.float64],
               v: NDArray[np.float64], amplitude: float,
               attempts: int) -> list[NDArray[np.float64]]:
    """``q* +- amplitude v`` on the constraints, halving ``amplitude`` until both project
    (an inextensible chain cannot follow a large linear displacement)."""
    for _ in range(attempts):
        try:
            return [_on_constraints(system, equilibrium, q_eq + sign * amplitude * v)
                    for sign in (1.0, -1.0)]
        except InitialConditionError as exc:
            error, amplitude = exc, amplitude / 2
    raise ValueError(
        f"the mode displaced by amplitude {2 * amplitude:g} cannot be projected back onto the "
        f"constraints ({error}); pass a smaller amplitude"
    ) from error


def _size(lines: list[NDArray[np.float64]]) -> float:
    points = np.vstack(lines)
    size = float(np.ptp(points, axis=0).max())
    return size if size > 0 else 1.0


def _mode_title(system: System, linearization: Linearization, mode: int) -> str:
    w = complex(np.asarray(linearization.natural_frequencies)[mode])
    if abs(w.imag) <= 1e-12 * abs(w.real):
        what = f"mode {mode + 1}: {w.real / (2 * np.pi):.4g} Hz ({w.real:.4g} rad/s)"
    else:
        what = f"mode {mode + 1}: unstable, growth rate {abs(w.imag):.4g} 1/s"
    return _name(system, what)


def _name(system: System, what: str) -> str:
    # the name, not system.model.name (a large Multibody's model takes long to build)
    return f"{system.name}: {what}" if system.name else what


def _draw_lines(ax: Axes, lines: list[NDArray[np.float64]], *, label: str,
                **style: Any) -> None:
    for i, line in enumerate(lines):
        ax.plot(line[:, 0], line[:, 1], marker="o", ms=3, label=label if i == 0 else None,
                **style)


def _figure() -> tuple[Figure, Axes]:
    # constrained layout: room for the legend beside the axes
    fig = Figure(figsize=(7.0, 5.0), dpi=_DPI, layout="constrained")
    return fig, fig.add_subplot()


def _finish(ax: Axes, title: str, labels: str) -> None:
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_xlabel(labels[0])
    ax.set_ylabel(labels[1])
    ax.set_title(title, fontsize="medium")
    ax.grid(True, alpha=0.3)
    _legend_outside(ax)
