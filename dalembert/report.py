"""Simulate gallery examples, write their plots and a Markdown summary of measured errors.

This is what ``dalembert run``, ``dalembert demo`` and ``dalembert gallery`` do, as
plain functions: :func:`run_example` simulates one example from
:mod:`dalembert.examples` with its ``INITIAL`` state and writes ``trajectory.npz``,
the PNGs of :func:`dalembert.plotting.plot_all` and ``animation.gif`` (and
``animation.html``); :func:`demo` does this for :data:`DEMO_EXAMPLES` and writes
``summary.md``; :func:`gallery` does it for every example over a short span and
writes ``index.md`` and ``index.html``.

An example module may set ``PATH = ("x", "y")`` to name the coordinates of its
path plot; otherwise a path plot is drawn when it has coordinates ``x`` and ``y``.
The animation draws the mechanism with :func:`mechanism_drawer`: the example's
``draw(system, q)``, else the stick figure of a multibody system, else one point
per particle found in the coordinate names (``x, y[, z]`` with a common suffix).
"""

from __future__ import annotations

import html
import os
import time
import warnings
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from types import ModuleType

import numpy as np
import sympy as sp

from . import examples
from .model.coordinates import t as time_symbol
from .system import System
from .trajectory import Trajectory

#: The demo's examples: a holonomic, a nonholonomic and a multibody one (the whole demo,
#: animations included, takes ~18 s on 2 cores).
DEMO_EXAMPLES = ("pendulum", "knife-edge", "heavy-top")
DEFAULT_POINTS = 1001
ENERGY_CHOICES = ("auto", "energy", "jacobi")
#: Frames of an animation: enough to follow the motion, few enough to write in seconds.
ANIMATION_FRAMES = 60
#: The gallery's default span (each example's ``T_END`` if shorter) and output points.
GALLERY_T_END = 3.0
GALLERY_POINTS = 301


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
    notes: list[str] = field(default_factory=list)


def energy_quantity(system: System) -> str:
    """The quantity of the energy plot: ``"energy"`` (T + V) or ``"jacobi"``.

    The Jacobi integral ``h = qd . dL/dqd - L`` equals ``T + V`` when ``T`` is
    homogeneous quadratic in the velocities; it differs (and is the conserved one)
    when ``L`` has moving-frame terms linear in the velocities, or when only a
    Lagrangian was given. So: ``"energy"`` unless ``T`` is not homogeneous
    quadratic or missing.
    """
    model = system.model
    kinetic = model.kinetic
    if not model.has_energy or kinetic is None:
        return "jacobi"
    qd = model.coords.qd
    euler = sum(v * sp.diff(kinetic, v) for v in qd) - 2 * kinetic
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


def mechanism_drawer(module: ModuleType, system: System) -> tuple[Callable | None, str]:
    """``(draw, how)``: what the animation draws, or ``(None, why not)``.

    The example's ``draw(system, q)``, else what :func:`dalembert.plotting.animate`
    draws of the system (:func:`~dalembert.plotting.drawers.default_drawer`: the
    multibody stick figure, or one point per particle named by the coordinates).

    >>> from types import SimpleNamespace
    >>> draw, how = mechanism_drawer(SimpleNamespace(),
    ...                              SimpleNamespace(coordinate_names=("x", "y", "phi")))
    >>> how, [p.tolist() for p in draw(None, np.array([1.0, 2.0, 3.0]))]
    ('the particles as points', [[[1.0, 2.0]]])
    """
    from .plotting.drawers import default_drawer

    draw = getattr(module, "draw", None)
    if draw is not None:
        return draw, "the example's draw(system, q)"
    draw, how = default_drawer(system)
    return draw, how if draw is not None else f"no animation: {how}"


def write_animation(run: ExampleRun, module: ModuleType, out: Path, *, html: bool = False,
                    frames: int = ANIMATION_FRAMES) -> list[Path]:
    """Write ``animation.gif`` (and ``animation.html``) of ``run`` into ``out``.

    Returns the files written; when there is nothing to draw, none, and a note in
    ``run.notes`` says why.
    """
    from .plotting import animate

    draw, how = mechanism_drawer(module, run.system)
    if draw is None:
        run.notes.append(how)
        return []
    run.notes.append(f"animation: {how}, {frames} frames at most")
    names = ["animation.gif", "animation.html"] if html else ["animation.gif"]
    return [animate(run.trajectory, out / n, system=run.system, draw=draw, frames=frames,
                    title=run.name) for n in names]


def run_example(
    name: str,
    out_dir: str | os.PathLike | None = None,
    *,
    t_end: float | None = None,
    points: int = DEFAULT_POINTS,
    energy: str = "auto",
    animation: bool = True,
    html: bool = False,
    frames: int = ANIMATION_FRAMES,
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
    animation, html, frames
        Write ``animation.gif`` (and ``animation.html`` if ``html``) of at most
        ``frames`` frames when ``out_dir`` is given (see :func:`write_animation`).

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
        own_plots = getattr(module, "plots", None)
        if own_plots is not None:
            run.files += own_plots(system, traj, out)
        if animation:
            run.files += write_animation(run, module, out, html=html, frames=frames)
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
        f"generation ({_method_used(traj)}, projection stabilization); "
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
        *[f"\n{note}" for note in run.notes],
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


def gallery(
    out_dir: str | os.PathLike,
    names: list[str] | tuple[str, ...] | None = None,
    *,
    t_end: float | None = None,
    points: int = GALLERY_POINTS,
    frames: int = ANIMATION_FRAMES,
) -> tuple[str, list[str]]:
    """Run every example (or ``names``) into ``out_dir/<name>/``; write the indexes.

    Each example runs over ``t_end`` (default: its ``T_END``, at most
    :data:`GALLERY_T_END`) with plots and ``animation.gif``. ``index.md`` holds
    each example's measured checks and files, ``index.html`` the same with the
    PNGs and GIFs shown. Warnings (dependent constraints, adjusted initial values)
    become notes of the example. An example that fails is listed with its error,
    and the others still run.

    Returns
    -------
    tuple
        The text of ``index.md`` and the names of the examples that failed.
    """
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    names = list(examples.EXAMPLES if names is None else names)
    runs, failed = [], {}
    for name in names:
        try:
            module = examples.load(name)
            span = min(float(module.T_END), GALLERY_T_END) if t_end is None else t_end
            with warnings.catch_warnings(record=True) as caught:
                warnings.simplefilter("always")
                run = run_example(name, out / name, t_end=span, points=points, frames=frames)
            run.notes += [f"{w.category.__name__}: {w.message}" for w in caught]
            runs.append(run)
        except Exception as exc:  # one broken example must not hide the others
            failed[name] = f"{type(exc).__name__}: {' '.join(str(exc).split())}"
    text = "\n".join([
        "# dalembert gallery",
        "",
        "Every example simulated in redundant coordinates with Lagrange multipliers; the "
        "tables give the errors measured against independent answers (closed forms, "
        "minimal-coordinate models, conservation laws). Pictures: `index.html`.",
        "",
        *[format_run(run, base=out) for run in runs],
        *[f"## {name}: failed\n\n`{error}`\n" for name, error in failed.items()],
    ]).rstrip() + "\n"
    (out / "index.md").write_text(text, encoding="utf-8")
    (out / "index.html").write_text(gallery_html(runs, failed, out), encoding="utf-8")
    return text, list(failed)


_HTML_HEAD = """<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8"><title>dalembert gallery</title>
<style>body{font-family:sans-serif;max-width:1100px;margin:auto}
img{max-width:360px;margin:4px;border:1px solid #ddd}
table{border-collapse:collapse}td,th{border:1px solid #ccc;padding:2px 8px}
pre{background:#f6f6f6;padding:6px}</style></head><body>
<h1>dalembert gallery</h1>
<p>Every example simulated in redundant coordinates with Lagrange multipliers, with the
errors measured against independent answers.</p>
"""


def gallery_html(runs: list[ExampleRun], failed: dict[str, str], base: Path) -> str:
    """The gallery page: per example its checks, summary, animation and plots.

    >>> print(gallery_html([], {"x": "Error: <no>"}, Path(".")).splitlines()[-2])
    <h2>x: failed</h2><p><code>Error: &lt;no&gt;</code></p>
    """
    parts = [_HTML_HEAD, "<ul>"]
    parts += [f'<li><a href="#{run.name}">{run.name}</a>: {html.escape(run.title)}</li>'
              for run in runs]
    parts.append("</ul>")
    for run in runs:
        rows = "".join(f"<tr><td>{html.escape(k)}</td><td>{v:.2e}</td></tr>"
                       for k, v in run.checks.items())
        images = "".join(
            f'<img src="{html.escape(_relative(p, base))}" alt="{p.stem}">'
            for p in sorted(run.files, key=lambda p: p.suffix != ".gif")
            if p.suffix in (".png", ".gif"))
        notes = "".join(f"<p>{html.escape(n)}</p>" for n in run.notes)
        parts.append(
            f'<h2 id="{run.name}">{run.name}: {html.escape(run.title)}</h2>'
            f"<table><tr><th>check</th><th>value</th></tr>{rows}</table>"
            f"<pre>{html.escape(run.trajectory.summary())}</pre>{notes}<div>{images}</div>")
    parts += [f"<h2>{html.escape(name)}: failed</h2><p><code>{html.escape(err)}</code></p>"
              for name, err in failed.items()]
    parts.append("</body></html>\n")
    return "\n".join(parts)


def _method_used(traj: Trajectory) -> str:
    """The methods of a run at the default ``method="auto"`` and tolerances."""
    from .options import DEFAULT_TOLERANCES

    explicit, implicit = DEFAULT_TOLERANCES["explicit"], DEFAULT_TOLERANCES["implicit"]
    switches = int(traj.stats.get("n_switches", 0))
    if not switches:
        return f"DOP853, rtol={explicit.rtol:g}"
    return (f"DOP853 at rtol={explicit.rtol:g} and Radau at rtol={implicit.rtol:g}, "
            f"{switches} switch{'es' if switches > 1 else ''} between them")


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
