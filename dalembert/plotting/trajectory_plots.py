"""PNG plots of a :class:`~dalembert.Trajectory`, drawn off-screen.

Each function takes a trajectory, writes one PNG and returns its path. Figures are
built as :class:`matplotlib.figure.Figure` objects, never through pyplot: no
screen is needed, the user's pyplot backend is left alone, and plotting in a loop
leaks nothing.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
from matplotlib.axes import Axes
from matplotlib.figure import Figure
from numpy.typing import ArrayLike, NDArray

from ..trajectory import Trajectory, name_list
from .drawers import multibody_or_none
from .groups import Groups, constraint_groups, coordinate_groups

if TYPE_CHECKING:
    from ..system import System

#: Exact zeros are drawn at this value on log axes (a residual of exactly 0.0).
LOG_FLOOR = 1e-18
#: What :func:`plot_energy_error` can show: ``T + V`` or the Jacobi integral.
ENERGY_QUANTITIES = ("energy", "jacobi")
#: Curves on one axes at most: more are drawn as small multiples, one panel per body or
#: joint (or group of names), each with at most this many curves.
PANEL_LINES = 8
#: Panels at most (the groups with the largest curves; the others are named in a note).
MAX_PANELS = 9
PANEL_COLUMNS = 3
_DPI = 110


def plot_coordinates(
    traj: Trajectory, path: str | os.PathLike, *, system: System | None = None,
    title: str | None = None,
) -> Path:
    """Every coordinate against time, one line each, the legend beside the axes.

    More than :data:`PANEL_LINES` coordinates are drawn as small multiples, one panel
    per body of a multibody ``system`` (else per group of names,
    :func:`~dalembert.plotting.groups.coordinate_groups`): the :data:`MAX_PANELS`
    bodies that move most, each with its :data:`PANEL_LINES` coordinates of largest
    range, and a note naming the others.

    Parameters
    ----------
    traj
        The simulated trajectory.
    path
        The PNG to write (parent folders are created).
    system
        Optional :class:`~dalembert.System`, for the default title and the bodies.
    title
        Figure title (default: the system's name).

    Returns
    -------
    Path
        ``path``.

    Examples
    --------
    >>> import pathlib, tempfile
    >>> from dalembert.examples import load
    >>> pendulum = load("pendulum")
    >>> system = pendulum.build()
    >>> traj = system.simulate((0, 1), **pendulum.INITIAL, t_eval=[0.0, 0.5, 1.0])
    >>> with tempfile.TemporaryDirectory() as folder:
    ...     png = plot_coordinates(traj, pathlib.Path(folder) / "q.png", system=system)
    ...     png.name, png.stat().st_size > 0
    ('q.png', True)
    """
    return _plot_grouped(
        traj.t, traj.q, traj.coordinate_names, coordinate_groups(traj.coordinate_names, system),
        path, title=_title(title, system, "coordinates"), ylabel="q",
        rank=np.ptp, ranked_by="smaller range", what="bodies" if _is_multibody(system)
        else "groups", traj=traj)


def relative_drift(values: ArrayLike) -> NDArray[np.float64]:
    """``|e(t) - e(0)| / |e(0)|`` (absolute change when ``e(0) == 0``).

    Parameters
    ----------
    values
        The quantity along the trajectory (``e(0)`` first).

    Examples
    --------
    >>> relative_drift(np.array([2.0, 2.0, 2.5]))
    array([0.  , 0.  , 0.25])
    """
    values = np.asarray(values, dtype=float)
    scale = abs(values[0]) if len(values) and values[0] != 0 else 1.0
    return np.abs(values - values[0]) / scale


def plot_energy_error(
    traj: Trajectory, path: str | os.PathLike, *, quantity: str = "energy",
    system: System | None = None, title: str | None = None,
) -> Path:
    """Relative drift of a conserved quantity against time (log scale).

    Parameters
    ----------
    traj
        The simulated trajectory.
    path
        The PNG to write.
    quantity
        ``"energy"`` for ``T + V`` or ``"jacobi"`` for the Jacobi integral
        ``qd . dL/dqd - L`` (conserved when ``T + V`` is not, e.g. with a moving
        frame built into ``L``). The caller knows which one the system conserves.
    system, title
        As in :func:`plot_coordinates`.

    Returns
    -------
    Path
        ``path``.

    Examples
    --------
    >>> import pathlib, tempfile
    >>> from dalembert.examples import load
    >>> pendulum = load("pendulum")
    >>> system = pendulum.build()
    >>> traj = system.simulate((0, 1), **pendulum.INITIAL, t_eval=[0.0, 0.5, 1.0])
    >>> with tempfile.TemporaryDirectory() as folder:
    ...     png = plot_energy_error(traj, pathlib.Path(folder) / "e.png", system=system)
    ...     png.stat().st_size > 0
    True
    """
    if quantity not in ENERGY_QUANTITIES:
        raise ValueError(f"quantity must be one of {ENERGY_QUANTITIES}, not {quantity!r}")
    values = traj.energy if quantity == "energy" else traj.jacobi_integral
    label = "T + V" if quantity == "energy" else "Jacobi integral"
    if traj.contacts is not None and traj.contacts.impacts:  # what the impacts took, added
        values = values + traj.contacts.energy_lost_by(traj.t)
        label += " + lost in impacts"
    fig, ax = _figure()
    if len(values) and np.all(np.isfinite(values)):
        ax.semilogy(traj.t, _floored(relative_drift(values)), label=label)
    else:
        _note(ax, f"{label} is not available for this model (NaN)")
    _mark_impacts(ax, traj)
    ax.set_xlabel("t")
    ax.set_ylabel(f"relative change of {label}")
    _finish(ax, _title(title, system, f"relative change of {label}"), legend=False)
    return _save(fig, path)


def plot_residuals(
    traj: Trajectory, path: str | os.PathLike, *, system: System | None = None,
    title: str | None = None,
) -> Path:
    """Largest position and velocity constraint residuals against time (log scale).

    Exact zeros are drawn at :data:`LOG_FLOOR`. With a ``system`` that has only
    Pfaffian constraints the (identically zero) position residual is left out.

    Parameters
    ----------
    traj
        The simulated trajectory.
    path
        The PNG to write (parent folders are created).
    system
        Optional :class:`~dalembert.System`, for the default title and to tell
        whether it has holonomic constraints (without it both residuals are drawn).
    title
        Figure title (default: the system's name).

    Returns
    -------
    Path
        ``path``.

    Examples
    --------
    >>> import pathlib, tempfile
    >>> from dalembert.examples import load
    >>> pendulum = load("pendulum")
    >>> system = pendulum.build()
    >>> traj = system.simulate((0, 1), **pendulum.INITIAL, t_eval=[0.0, 0.5, 1.0])
    >>> with tempfile.TemporaryDirectory() as folder:
    ...     png = plot_residuals(traj, pathlib.Path(folder) / "r.png", system=system)
    ...     png.stat().st_size > 0
    True
    """
    fig, ax = _figure()
    if traj.constraint_names:
        if _has_holonomic(system):
            ax.semilogy(traj.t, _floored(traj.position_residual), label="position |psi|")
        ax.semilogy(traj.t, _floored(traj.velocity_residual), label="velocity |A qd + b|")
    else:
        _note(ax, "no constraints")
    ax.set_xlabel("t")
    ax.set_ylabel("max constraint residual")
    _finish(ax, _title(title, system, "constraint residuals"),
            legend=bool(traj.constraint_names))
    return _save(fig, path)


def plot_multipliers(
    traj: Trajectory, path: str | os.PathLike, *, system: System | None = None,
    title: str | None = None,
) -> Path:
    """Each constraint's Lagrange multiplier against time, labelled by constraint name.

    More than :data:`PANEL_LINES` multipliers are drawn as small multiples, one panel
    per joint of a multibody ``system`` (its bodies' unit-quaternion rows in one more;
    else per group of names, :func:`~dalembert.plotting.groups.constraint_groups`):
    the :data:`MAX_PANELS` joints with the largest multipliers and a note naming the
    others.

    Parameters
    ----------
    traj
        The simulated trajectory.
    path
        The PNG to write (parent folders are created).
    system
        Optional :class:`~dalembert.System`, for the default title and the joints.
    title
        Figure title (default: the system's name).

    Returns
    -------
    Path
        ``path``.

    Examples
    --------
    >>> import pathlib, tempfile
    >>> from dalembert.examples import load
    >>> pendulum = load("pendulum")
    >>> system = pendulum.build()
    >>> traj = system.simulate((0, 1), **pendulum.INITIAL, t_eval=[0.0, 0.5, 1.0])
    >>> with tempfile.TemporaryDirectory() as folder:
    ...     png = plot_multipliers(traj, pathlib.Path(folder) / "m.png", system=system)
    ...     png.stat().st_size > 0
    True
    """
    if not traj.constraint_names:
        fig, ax = _figure()
        _note(ax, "no constraints, no multipliers")
        ax.set_xlabel("t")
        ax.set_ylabel("lambda")
        _finish(ax, _title(title, system, "Lagrange multipliers"), legend=False)
        return _save(fig, path)
    return _plot_grouped(
        traj.t, traj.multipliers, traj.constraint_names,
        constraint_groups(traj.constraint_names, system), path,
        title=_title(title, system, "Lagrange multipliers"), ylabel="lambda",
        rank=lambda v: np.abs(v).max(initial=0.0), ranked_by="smaller peak",
        what="joints" if _is_multibody(system) else "groups", label="lambda[{}]",
        traj=traj)


def plot_path(
    traj: Trajectory, path: str | os.PathLike, *, x: str = "x", y: str = "y",
    system: System | None = None, title: str | None = None,
) -> Path:
    """The path ``(x(t), y(t))`` of two coordinates, with equal axis scales.

    Parameters
    ----------
    traj, path
        As in :func:`plot_coordinates`.
    x, y
        Coordinate names (velocities such as ``"x_dot"`` work too).
    system, title
        As in :func:`plot_coordinates`.

    Returns
    -------
    Path
        ``path``.

    Examples
    --------
    >>> import pathlib, tempfile
    >>> from dalembert.examples import load
    >>> pendulum = load("pendulum")
    >>> system = pendulum.build()
    >>> traj = system.simulate((0, 1), **pendulum.INITIAL, t_eval=[0.0, 0.5, 1.0])
    >>> with tempfile.TemporaryDirectory() as folder:
    ...     png = plot_path(traj, pathlib.Path(folder) / "xy.png", x="x", y="y")
    ...     png.stat().st_size > 0
    True
    """
    xs, ys = traj[x], traj[y]
    fig, ax = _figure()
    ax.plot(xs, ys, lw=1.0)
    if len(xs):
        ax.plot(xs[:1], ys[:1], "o", label="start")
        ax.plot(xs[-1:], ys[-1:], "s", label="end")
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_xlabel(x)
    ax.set_ylabel(y)
    _finish(ax, _title(title, system, f"path {y} vs {x}"), legend=bool(len(xs)))
    return _save(fig, path)


def plot_all(
    traj: Trajectory, out_dir: str | os.PathLike, *, system: System | None = None,
    energy: str = "energy", path_xy: Sequence[str] | None = None,
) -> list[Path]:
    """The standard set of plots in ``out_dir``; returns their paths.

    Writes ``coordinates.png``, ``energy.png`` (drift of ``energy``, see
    :func:`plot_energy_error`), ``residuals.png``, ``multipliers.png`` and, when
    ``path_xy = (x, y)`` is given, ``path.png``.

    Parameters
    ----------
    traj
        The simulated trajectory.
    out_dir
        The folder to write to (created if need be).
    system
        Optional :class:`~dalembert.System`, for the titles.
    energy
        ``"energy"`` or ``"jacobi"`` (see :func:`plot_energy_error`).
    path_xy
        Two coordinate names for a path plot.

    Returns
    -------
    list of Path
        The files written.

    Examples
    --------
    >>> import pathlib, tempfile
    >>> from dalembert.examples import load
    >>> pendulum = load("pendulum")
    >>> system = pendulum.build()
    >>> traj = system.simulate((0, 1), **pendulum.INITIAL, t_eval=[0.0, 0.5, 1.0])
    >>> with tempfile.TemporaryDirectory() as folder:
    ...     [png.name for png in plot_all(traj, folder, system=system)]
    ['coordinates.png', 'energy.png', 'residuals.png', 'multipliers.png']
    """
    out = Path(out_dir)
    paths = [
        plot_coordinates(traj, out / "coordinates.png", system=system),
        plot_energy_error(traj, out / "energy.png", quantity=energy, system=system),
        plot_residuals(traj, out / "residuals.png", system=system),
        plot_multipliers(traj, out / "multipliers.png", system=system),
    ]
    if path_xy is not None:
        x, y = path_xy
        paths.append(plot_path(traj, out / "path.png", x=x, y=y, system=system))
    return paths


# -- helpers -------------------------------------------------------------------------
def _figure(size: tuple[float, float] = (7.0, 4.2)) -> tuple[Figure, Axes]:
    # constrained layout: it makes room for the legends outside the axes
    fig = Figure(figsize=size, dpi=_DPI, layout="constrained")
    return fig, fig.add_subplot()


def _legend_outside(ax: Axes, title: str | None = None) -> None:
    """The legend right of the axes, where it covers no curve."""
    ax.legend(loc="upper left", bbox_to_anchor=(1.02, 1.0), borderaxespad=0.0,
              fontsize="small", title=title, title_fontsize="small")


def _plot_grouped(t: NDArray[np.float64], values: NDArray[np.float64], names: Sequence[str],
                  groups: Groups, path: str | os.PathLike, *, title: str, ylabel: str,
                  rank: Callable[[NDArray[np.float64]], float], ranked_by: str, what: str,
                  label: str = "{}", traj: Trajectory | None = None) -> Path:
    """The columns of ``values`` against ``t``: on one axes when there are at most
    :data:`PANEL_LINES` of them, else one panel per group (the :data:`MAX_PANELS`
    groups that rank highest, each with its :data:`PANEL_LINES` highest curves, the
    others named in a note); the impacts of ``traj`` marked."""
    if len(names) <= PANEL_LINES:
        fig, ax = _figure()
        _mark_impacts(ax, traj)
        for i, name in enumerate(names):
            ax.plot(t, values[:, i], label=label.format(name))
        ax.set_xlabel("t")
        ax.set_ylabel(ylabel)
        _finish(ax, title, legend=bool(names))
        return _save(fig, path)

    def score(column: int) -> float:
        return float(np.nan_to_num(rank(values[:, column])))

    best = {g: max(score(i) for i, _ in members) for g, members in groups.items()}
    chosen = set(sorted(groups, key=lambda g: -best[g])[:MAX_PANELS])
    shown = [g for g in groups if g in chosen]
    columns = min(PANEL_COLUMNS, len(shown))
    rows = -(-len(shown) // columns)
    size = (3.9 * columns, 0.9 + 2.0 * rows) if len(shown) > 1 else (7.0, 4.2)
    fig = Figure(figsize=size, dpi=_DPI, layout="constrained")
    axes = fig.subplots(rows, columns, sharex=True, squeeze=False).ravel()
    for ax, group in zip(axes, shown):
        _mark_impacts(ax, traj)
        members = groups[group]
        kept = set(sorted(members, key=lambda m: -score(m[0]))[:PANEL_LINES])
        for i, name in members:
            if (i, name) in kept:
                ax.plot(t, values[:, i], label=name)
        ax.set_title(group, fontsize="medium")
        ax.grid(True, alpha=0.3)
        more = len(members) - len(kept)
        _legend_outside(ax, f"+{more} more ({ranked_by})" if more else None)
    for ax in axes[len(shown):]:
        ax.remove()
    hidden = [g for g in groups if g not in chosen]
    note = f"\nnot shown ({ranked_by}): {name_list(hidden, what)}" if hidden else ""
    fig.supxlabel("t" + note, fontsize="medium")
    fig.supylabel(ylabel)
    fig.suptitle(title)
    return _save(fig, path)


def _mark_impacts(ax: Axes, traj: Trajectory | None) -> None:
    """A thin vertical line at each impact of a run with unilateral constraints."""
    if traj is None or traj.contacts is None:
        return
    for k, t in enumerate(traj.contacts.impact_times):
        ax.axvline(t, color="0.6", linewidth=0.6, linestyle=":",
                   label="impacts" if k == 0 else None)


def _is_multibody(system: object) -> bool:
    return multibody_or_none(system) is not None


def _title(title: str | None, system: System | None, what: str) -> str:
    if title is not None:
        return title
    # the name, not system.model.name: a Multibody's System builds its symbolic model
    # only on request, which for a large mechanism takes long
    name = system.name if system is not None else None
    return f"{name}: {what}" if name else what


def _finish(ax: Axes, title: str, *, legend: bool) -> None:
    ax.set_title(title)
    ax.grid(True, alpha=0.3)
    if legend:
        _legend_outside(ax)


def _has_holonomic(system: System | None) -> bool:
    # from the compiled equations: a Multibody's symbolic model is not built for this
    return system is None or bool(system.compiled.holonomic_rows)


def _note(ax: Axes, text: str) -> None:
    ax.text(0.5, 0.5, text, ha="center", va="center", transform=ax.transAxes)


def _floored(values: ArrayLike) -> NDArray[np.float64]:
    # log axes cannot show 0; a residual of exactly 0.0 is drawn at the floor
    return np.maximum(np.asarray(values, dtype=float), LOG_FLOOR)


def _save(fig: Figure, path: str | os.PathLike) -> Path:
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path)
    return path
