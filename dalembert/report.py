"""Simulate gallery examples, write their plots and a Markdown summary of measured errors.

This is what ``dalembert run`` and ``dalembert demo`` do, as plain functions:
:func:`run_example` simulates one example from :mod:`dalembert.examples` with its
``INITIAL`` state and writes ``trajectory.npz`` and the PNGs of
:func:`dalembert.plotting.plot_all`; :func:`demo` does this for
:data:`DEMO_EXAMPLES` and writes ``summary.md``.

An example module may set ``PATH = ("x", "y")`` to name the coordinates of its
path plot; otherwise a path plot is drawn when it has coordinates ``x`` and ``y``.
"""

from __future__ import annotations

import os
import time
from dataclasses import dataclass, field
from pathlib import Path
from types import ModuleType

import numpy as np
import sympy as sp

from . import examples
from .model.coordinates import t as time_symbol
from .system import System
from .trajectory import Trajectory

#: The demo's examples: a holonomic and a nonholonomic one.
DEMO_EXAMPLES = ("pendulum", "knife-edge")
DEFAULT_POINTS = 1001
ENERGY_CHOICES = ("auto", "energy", "jacobi")


@dataclass
class ExampleRun:
    """One simulated example: its system, trajectory, measured errors and files.

    ``setup_seconds`` is the time to derive the equations and generate code,
    ``seconds`` the time of ``simulate`` itself.
    """

    name: str
    title: str
    system: System
    trajectory: Trajectory
    checks: dict[str, float]
    seconds: float
    setup_seconds: float
    energy: str
    files: list[Path] = field(default_factory=list)


def energy_quantity(system: System) -> str:
    """The quantity of the energy plot: ``"energy"`` (T + V) or ``"jacobi"``.

    The Jacobi integral ``h = qd . dL/dqd - L`` equals ``T + V`` when ``T`` is
    homogeneous quadratic in the velocities; it differs (and is the conserved one)
    when ``L`` has moving-frame terms linear in the velocities, or when only a
    Lagrangian was given. So: ``"energy"`` unless ``T`` is not homogeneous
    quadratic or missing.
    """
    model = system.model
    if not model.has_energy:
        return "jacobi"
    qd = model.coords.qd
    euler = sum(v * sp.diff(model.kinetic, v) for v in qd) - 2 * model.kinetic
    return "energy" if sp.simplify(sp.expand(euler)) == 0 else "jacobi"


def conserved(system: System) -> bool:
    """False when the model does work on itself: explicit time, moving constraints
    (``b != 0`` in ``A qd + b = 0``) or non-conservative forces; then neither
    ``T + V`` nor the Jacobi integral need be constant."""
    model = system.model
    cons = model.constraints
    explicit_time = any(
        expr.has(time_symbol) for expr in (model.lagrangian, model.Q, cons.A, cons.b)
    )
    return not (explicit_time or any(v != 0 for v in cons.b) or any(v != 0 for v in model.Q))


def path_coordinates(module: ModuleType, system: System) -> tuple[str, str] | None:
    """The ``(x, y)`` coordinates of an example's path plot, or ``None``."""
    chosen = getattr(module, "PATH", None)
    if chosen is not None:
        return tuple(chosen)
    names = system.coordinate_names
    return ("x", "y") if "x" in names and "y" in names else None


def run_example(
    name: str,
    out_dir: str | os.PathLike | None = None,
    *,
    t_end: float | None = None,
    points: int = DEFAULT_POINTS,
    energy: str = "auto",
) -> ExampleRun:
    """Simulate the example ``name`` from ``INITIAL`` over ``[0, t_end]``.

    Parameters
    ----------
    name
        A key of :data:`dalembert.examples.EXAMPLES` (``KeyError`` otherwise).
    out_dir
        Where to write ``trajectory.npz`` and the plots; nothing is written if ``None``.
    t_end
        Simulated time (default: the example's ``T_END``).
    points
        Number of equally spaced output times.
    energy
        ``"energy"``, ``"jacobi"`` or ``"auto"`` (see :func:`energy_quantity`).

    Returns
    -------
    ExampleRun
    """
    if energy not in ENERGY_CHOICES:
        raise ValueError(f"energy must be one of {ENERGY_CHOICES}, not {energy!r}")
    module = examples.load(name)
    system = module.build()
    t_end = float(module.T_END if t_end is None else t_end)
    start = time.perf_counter()
    _ = system.compiled  # derive the equations and generate code now, to time them apart
    setup = time.perf_counter() - start
    start = time.perf_counter()
    traj = system.simulate((0.0, t_end), **module.INITIAL,
                           t_eval=np.linspace(0.0, t_end, points))
    seconds = time.perf_counter() - start
    quantity = energy_quantity(system) if energy == "auto" else energy
    run = ExampleRun(name=name, title=module.TITLE, system=system, trajectory=traj,
                     checks=module.checks(system, traj), seconds=seconds,
                     setup_seconds=setup, energy=quantity)
    if out_dir is not None:
        from .plotting import plot_all  # matplotlib is imported only when plotting

        out = Path(out_dir)
        out.mkdir(parents=True, exist_ok=True)
        run.files.append(traj.save(out / "trajectory.npz"))
        run.files += plot_all(traj, out, system=system, energy=quantity,
                              path_xy=path_coordinates(module, system))
    return run


def format_checks(checks: dict[str, float]) -> str:
    """The measured errors as a Markdown table.

    >>> print(format_checks({"tension relative error": 1.5e-15}))
    | check | value |
    |---|---|
    | tension relative error | 1.50e-15 |
    """
    rows = ["| check | value |", "|---|---|"]
    rows += [f"| {key} | {value:.2e} |" for key, value in checks.items()]
    return "\n".join(rows)


def format_run(run: ExampleRun, base: Path | None = None) -> str:
    """A Markdown section for one example: errors, trajectory summary and files."""
    traj = run.trajectory
    files = ", ".join(f"`{_relative(p, base)}`" for p in run.files) or "none"
    return "\n".join([
        f"## {run.name}: {run.title}",
        "",
        f"Simulated t = {traj.t[0]:.4g}..{traj.t[-1]:.4g} ({len(traj)} output points) "
        f"in {run.seconds:.2f} s after {run.setup_seconds:.2f} s of derivation and code "
        "generation (DOP853, rtol=1e-11, projection stabilization); "
        f"energy plot: {_energy_label(run)}.",
        "",
        "Measured errors (`checks()`, against closed forms and conservation laws):",
        "",
        format_checks(run.checks),
        "",
        "```",
        traj.summary(),
        "```",
        "",
        f"Files: {files}",
        "",
    ])


def demo(
    out_dir: str | os.PathLike, *, t_end: float | None = None, points: int = DEFAULT_POINTS
) -> str:
    """Run :data:`DEMO_EXAMPLES` into ``out_dir/<name>/``, write ``summary.md``, return it.

    An example whose module does not import (yet) is skipped with a note.
    """
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    sections, skipped = [], []
    for name in DEMO_EXAMPLES:
        try:
            examples.load(name)
        except ImportError as exc:
            skipped.append(f"- `{name}` skipped: its module does not import ({exc}).")
            continue
        run = run_example(name, out / name, t_end=t_end, points=points)
        sections.append(format_run(run, base=out))
    text = "\n".join([
        "# dalembert demo",
        "",
        "Each example is simulated in redundant coordinates with Lagrange multipliers; "
        "the tables give the errors measured against independent answers.",
        "",
        *sections,
        *skipped,
    ]).rstrip() + "\n"
    (out / "summary.md").write_text(text, encoding="utf-8")
    return text


def _energy_label(run: ExampleRun) -> str:
    label = "T + V" if run.energy == "energy" else "Jacobi integral"
    if not conserved(run.system):
        label += " (not conserved here: the model is driven or has non-conservative forces)"
    return label


def _relative(path: Path, base: Path | None) -> str:
    if base is None:
        return str(path)
    try:
        return str(path.relative_to(base))
    except ValueError:
        return str(path)
