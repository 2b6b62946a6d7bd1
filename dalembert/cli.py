"""The ``dalembert`` command: list, run and print the gallery examples, and the demo.

    dalembert list
    dalembert run EXAMPLE|PATH.py [--t-end T] [--out DIR] [--points N] [--energy auto|energy|jacobi]
                  [--no-animation] [--html [PAGE.html]]
    dalembert equations EXAMPLE [--latex]
    dalembert equilibrium EXAMPLE [--out DIR]
    dalembert modes EXAMPLE [--out DIR] [--count K]
    dalembert demo [--out DIR] [--t-end T] [--points N]
    dalembert gallery [EXAMPLE ...] [--out DIR] [--t-end T] [--points N]

Errors raised by dalembert (:class:`~dalembert.errors.DalembertError`), unknown
example names and an output folder that cannot be written print one line on stderr
and exit with status 2; ``gallery`` exits with status 1 when an example failed (its
error is in ``index.md``, the others are written). Ctrl-C exits with status 130
(a simulation it stops still writes the part computed so far).
"""

from __future__ import annotations

import argparse
import math
import signal
import sys
import tempfile
from collections.abc import Sequence
from pathlib import Path
from types import ModuleType
from typing import TYPE_CHECKING

from . import examples
from .errors import DalembertError
from .report import DEFAULT_POINTS, GALLERY_POINTS, GALLERY_T_END

if TYPE_CHECKING:
    from .report import ExampleRun
    from .statics import Equilibrium, Linearization
    from .system import System

EXIT_ERROR = 2
EXIT_IMPORT = 1
#: After Ctrl-C, as a shell reports a process ended by SIGINT (128 + 2).
EXIT_INTERRUPTED = 130
#: Output times at most: the plots cannot show more, and each point holds the whole
#: state with its multipliers (a 1e8-point request ran out of memory).
MAX_POINTS = 100_000
#: ``dalembert gallery`` when some example failed (the others are written).
EXIT_GALLERY_FAILED = 1
#: Modes printed and drawn by ``dalembert modes`` unless ``--count`` says otherwise.
DEFAULT_MODES = 3


class _CommandError(Exception):
    """A user-facing failure: printed as one line, exit status attached.

    Internal control flow of the command line: :func:`main` catches it and prints
    its message; it never escapes as a traceback."""

    def __init__(self, message: str, status: int = EXIT_ERROR) -> None:
        super().__init__(message)
        self.status = status


def main(argv: Sequence[str] | None = None) -> int:
    """Run the command line ``argv`` (default ``sys.argv[1:]``); return the exit status."""
    parser = build_parser()
    try:
        args = parser.parse_args(argv)
    except SystemExit as exc:  # --help or a usage error: keep main() returning an int
        return exc.code if isinstance(exc.code, int) else 0
    interrupts = _InterruptFlag()
    try:
        with interrupts:
            if args.handler in (cmd_run, cmd_demo, cmd_gallery):  # they always write
                _check_output_folder(args.out)
            status = args.handler(args)
    except KeyboardInterrupt:
        return _fail("interrupted", EXIT_INTERRUPTED)
    except DalembertError as exc:
        return _fail(f"{type(exc).__name__}: {exc}", EXIT_ERROR)
    except _CommandError as exc:
        return _fail(str(exc), exc.status)
    except OSError as exc:  # an output file that cannot be written (disk full, no access)
        return _fail(_os_error(exc), EXIT_ERROR)
    if interrupts.seen:  # the simulation caught Ctrl-C and returned what it had
        return _fail("interrupted; the files hold the part computed before Ctrl-C",
                     EXIT_INTERRUPTED)
    return status


class _InterruptFlag:
    """Records Ctrl-C while still raising ``KeyboardInterrupt``: a simulation catches it
    and returns the part computed so far, and the command must then not exit 0."""

    def __init__(self) -> None:
        self.seen = False
        self._previous: object = None

    def _handler(self, signum: int, frame: object) -> None:
        self.seen = True
        raise KeyboardInterrupt

    def __enter__(self) -> _InterruptFlag:
        try:
            self._previous = signal.signal(signal.SIGINT, self._handler)
        except ValueError:  # not the main thread: Ctrl-C cannot reach this one anyway
            self._previous = None
        return self

    def __exit__(self, *exc: object) -> None:
        if self._previous is not None:
            signal.signal(signal.SIGINT, self._previous)  # type: ignore[arg-type]


def _check_output_folder(out: str | None) -> None:
    """Fail before simulating, not after, when ``out`` cannot be written."""
    if out is None:
        return
    folder = Path(out)
    try:
        folder.mkdir(parents=True, exist_ok=True)
        with tempfile.TemporaryFile(dir=folder):
            pass
    except OSError as exc:
        raise _CommandError(f"cannot write to the output folder {out!r}: "
                            f"{exc.strerror or exc}") from exc


def _os_error(exc: OSError) -> str:
    where = f" {exc.filename!r}" if exc.filename else ""
    return f"could not write{where}: {exc.strerror or exc}"


def build_parser() -> argparse.ArgumentParser:
    """The argument parser with its seven sub-commands."""
    parser = argparse.ArgumentParser(
        prog="dalembert",
        description="Constrained dynamics in redundant coordinates: the example gallery.",
    )
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")

    p = sub.add_parser("list", help="list the gallery examples")
    p.set_defaults(handler=cmd_list)

    p = sub.add_parser("run", help="simulate one example, write plots and trajectory.npz")
    p.add_argument("example", help="example name (see `dalembert list`), or the path of a "
                   "Python file defining TITLE, build, INITIAL, T_END and checks")
    p.add_argument("--t-end", type=_positive_float, default=None,
                   help="simulated time (default: the example's T_END)")
    p.add_argument("--out", default=None, help="output folder (default: out/EXAMPLE)")
    _add_points(p)
    p.add_argument("--energy", choices=("auto", "energy", "jacobi"), default="auto",
                   help="quantity of the energy plot: T + V or the Jacobi integral (default: "
                        "auto, the Jacobi integral when T has terms linear in the velocities)")
    p.add_argument("--no-animation", dest="animation", action="store_false",
                   help="do not write animation.gif")
    p.add_argument("--html", nargs="?", const="", default=None, metavar="PAGE.html",
                   help="also write the 3D viewer: one page to open in a browser "
                        "(default: OUT/viewer.html)")
    p.set_defaults(handler=cmd_run)

    p = sub.add_parser("equations", help="print an example's equations of motion")
    p.add_argument("example", help="example name (see `dalembert list`)")
    p.add_argument("--latex", action="store_true", help="print LaTeX instead of text")
    p.set_defaults(handler=cmd_equations)

    p = sub.add_parser("equilibrium", help="static equilibrium of an example, drawn as a PNG")
    p.add_argument("example", help="example name (one with EQUILIBRIUM_GUESS)")
    p.add_argument("--out", default=None, help="output folder (default: out/EXAMPLE)")
    p.set_defaults(handler=cmd_equilibrium)

    p = sub.add_parser("modes", help="natural frequencies and mode shapes about the equilibrium")
    p.add_argument("example", help="example name (one with EQUILIBRIUM_GUESS)")
    p.add_argument("--out", default=None, help="output folder (default: out/EXAMPLE)")
    p.add_argument("--count", type=_count, default=DEFAULT_MODES,
                   help=f"number of modes, lowest first (default: {DEFAULT_MODES})")
    p.set_defaults(handler=cmd_modes)

    p = sub.add_parser("demo", help="simulate the demo examples, write plots and summary.md")
    p.add_argument("--out", default="out/demo", help="output folder (default: out/demo)")
    p.add_argument("--t-end", type=_positive_float, default=None,
                   help="simulated time of every example (default: each example's T_END)")
    _add_points(p)
    p.set_defaults(handler=cmd_demo)

    p = sub.add_parser("gallery", help="run every example briefly; write plots, animations, "
                                       "index.md and index.html")
    p.add_argument("examples", nargs="*", metavar="EXAMPLE",
                   help="examples to run (default: all, see `dalembert list`)")
    p.add_argument("--out", default="out/gallery", help="output folder (default: out/gallery)")
    p.add_argument("--t-end", type=_positive_float, default=None,
                   help=f"simulated time of every example (default: each example's T_END, "
                        f"at most {GALLERY_T_END:g})")
    p.add_argument("--points", type=_points, default=GALLERY_POINTS,
                   help=f"number of output times (default: {GALLERY_POINTS})")
    p.set_defaults(handler=cmd_gallery)
    return parser


# -- commands ------------------------------------------------------------------------
def cmd_list(args: argparse.Namespace) -> int:
    """Print ``name  TITLE`` per example; note on stderr the ones that do not import."""
    width = max(len(name) for name in examples.EXAMPLES)
    for name in examples.EXAMPLES:
        try:
            module = examples.load(name)
        except Exception as exc:  # modules in progress may fail in any way on import
            print(f"note: skipping example {name!r}: {type(exc).__name__}: {exc}",
                  file=sys.stderr)
            continue
        print(f"{name:<{width}}  {module.TITLE}")
    return 0


def cmd_run(args: argparse.Namespace) -> int:
    """Simulate, write the files, print the summary and the measured errors."""
    from .report import format_checks, run_example

    _load(args.example)
    out = args.out if args.out is not None else f"out/{Path(args.example).stem}"
    page = _viewer_page(args.html, out)
    run = run_example(args.example, out, t_end=args.t_end, points=args.points,
                      energy=args.energy, animation=args.animation)
    if page is not None:
        run.files.append(_write_view(run, page))
    print(f"{args.example}: {run.title}")
    print(run.trajectory.summary())
    print(f"equations and code in {run.setup_seconds:.2f} s, simulated in {run.seconds:.2f} s")
    print("checks (measured errors):")
    print(format_checks(run.checks))
    for note in run.notes:
        print(note)
    print("wrote " + ", ".join(str(p) for p in run.files))
    return 0


def cmd_equations(args: argparse.Namespace) -> int:
    """Print the equations of motion as text or LaTeX."""
    equations = _load(args.example).build().equations()
    print(equations.latex() if args.latex else str(equations))
    return 0


def cmd_equilibrium(args: argparse.Namespace) -> int:
    """Find the example's equilibrium, print it, draw it if the example has ``draw``."""
    from .plotting import plot_mechanism

    module, system, eq = _equilibrium(args.example)
    print(f"{args.example}: {module.TITLE}")
    print(eq)
    draw = getattr(module, "draw", None)
    if draw is not None:
        out = Path(args.out if args.out is not None else f"out/{args.example}")
        print(f"wrote {plot_mechanism(draw, system, eq.q, out / 'equilibrium.png')}")
    return 0


def cmd_modes(args: argparse.Namespace) -> int:
    """Equilibrium, then small oscillations: print frequencies and shapes, draw each mode."""
    from .plotting import plot_mode_shapes

    module, system, eq = _equilibrium(args.example)
    lin = system.linearize(eq)
    count = min(args.count, lin.degrees_of_freedom)
    print(f"{args.example}: {module.TITLE}")
    print(f"{eq.stability} equilibrium at "
          + ", ".join(f"{n} = {v:.10g}" for n, v in eq.by_name().items()))
    print(f"{lin.degrees_of_freedom} degrees of freedom; the lowest {count} modes "
          "(shapes mass-normalized, in the original coordinates):")
    for k in range(count):
        print(_mode_line(lin, k))
    draw = getattr(module, "draw", None)
    if draw is not None and count:
        out = Path(args.out if args.out is not None else f"out/{args.example}")
        files = [plot_mode_shapes(draw, system, lin, eq, out / f"mode_{k + 1}.png", mode=k)
                 for k in range(count)]
        print("wrote " + ", ".join(str(p) for p in files))
    return 0


def cmd_demo(args: argparse.Namespace) -> int:
    """Run the demo examples and print the summary that is written to summary.md."""
    from .report import demo

    print(demo(args.out, t_end=args.t_end, points=args.points), end="")
    print(f"\n(wrote {args.out}/summary.md)")
    return 0


def cmd_gallery(args: argparse.Namespace) -> int:
    """Run the examples into ``--out``; print one line each and where the index is."""
    from .report import gallery

    for name in args.examples:
        if name not in examples.EXAMPLES:
            _load(name)  # raises the unknown-example error
    text, failed = gallery(args.out, args.examples or None, t_end=args.t_end,
                           points=args.points)
    for line in text.splitlines():
        if line.startswith("## "):
            print(line[3:])
    print(f"wrote {args.out}/index.md and {args.out}/index.html")
    if failed:
        return _fail(f"{len(failed)} example(s) failed: {', '.join(failed)} "
                     f"(their errors are in {args.out}/index.md)", EXIT_GALLERY_FAILED)
    return 0


# -- helpers -------------------------------------------------------------------------
def _viewer_page(html: str | None, out: str) -> Path | None:
    """Where ``--html`` writes the 3D viewer (checked before simulating), or ``None``."""
    if html is None:
        return None
    page = Path(html) if html else Path(out) / "viewer.html"
    if page.suffix.lower() != ".html":
        raise _CommandError(f"--html {html}: the viewer writes an .html page; give a path "
                            "ending in .html, or no path for OUT/viewer.html")
    return page


def _write_view(run: ExampleRun, page: Path) -> Path:
    from .plotting import view

    try:
        return view(run.trajectory, run.system, page, title=f"{run.name}: {run.title}",
                    energy=run.energy)
    except ValueError as exc:  # nothing to draw: the other files are written
        raise _CommandError(f"no 3D view of {run.name!r}: {exc}") from exc


def _load(name: str) -> ModuleType:
    if examples.is_path(name):
        try:
            return examples.load_file(name)
        except (FileNotFoundError, AttributeError) as exc:
            raise _CommandError(str(exc)) from exc
        except Exception as exc:  # the user's file may fail in any way on import
            raise _CommandError(f"model file {name!r} does not import: "
                                f"{type(exc).__name__}: {exc}", EXIT_IMPORT) from exc
    if name not in examples.EXAMPLES:
        raise _CommandError(
            f"unknown example {name!r}; the examples are {', '.join(examples.EXAMPLES)}"
        )
    try:
        return examples.load(name)
    except ImportError as exc:
        raise _CommandError(f"example {name!r} does not import: {exc}", EXIT_IMPORT) from exc


def _equilibrium(name: str) -> tuple[ModuleType, System, Equilibrium]:
    """The example module, its System and its equilibrium from ``EQUILIBRIUM_GUESS``."""
    module = _load(name)
    guess = getattr(module, "EQUILIBRIUM_GUESS", None)
    if guess is None:
        raise _CommandError(
            f"example {name!r} has no EQUILIBRIUM_GUESS, so there is no equilibrium to start "
            f"from; the examples with one are {', '.join(_with_guess()) or 'none'}"
        )
    system = module.build()
    return module, system, system.equilibrium(guess)


def _with_guess() -> list[str]:
    names = []
    for name in examples.EXAMPLES:
        try:
            module = examples.load(name)
        except Exception:  # an example in progress must not hide the others
            continue
        if getattr(module, "EQUILIBRIUM_GUESS", None) is not None:
            names.append(name)
    return names


def _mode_line(lin: Linearization, k: int) -> str:
    """``mode k: f = ... Hz, omega = ... rad/s`` (or the growth rate) and the shape."""
    w = complex(lin.natural_frequencies[k])
    if abs(w.imag) <= 1e-12 * abs(w.real):
        what = f"f = {w.real / (2 * math.pi):.10g} Hz, omega = {w.real:.10g} rad/s"
    else:
        what = f"unstable: growth rate {abs(w.imag):.10g} 1/s"
    values = lin.mode(k)
    # entries at the rounding level of the largest one print as 0
    tiny = 1e-12 * max(abs(v) for v in values.values())
    shape = ", ".join(f"{n}: {v if abs(v) > tiny else 0.0:+.6g}" for n, v in values.items())
    return f"  mode {k + 1}: {what}\n    shape: {shape}"


def _fail(message: str, status: int) -> int:
    print("dalembert: error: " + " ".join(message.split()), file=sys.stderr)
    return status


def _add_points(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--points", type=_points, default=DEFAULT_POINTS,
                        help=f"number of output times (default: {DEFAULT_POINTS})")


def _positive_float(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None
    if not value > 0 or value == float("inf"):
        raise argparse.ArgumentTypeError(f"must be a positive finite number, not {text}")
    return value


def _count(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not an integer") from None
    if value < 1:
        raise argparse.ArgumentTypeError(f"need at least 1 mode, not {value}")
    return value


def _points(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not an integer") from None
    if value < 2:
        raise argparse.ArgumentTypeError(f"need at least 2 points, not {value}")
    if value > MAX_POINTS:
        raise argparse.ArgumentTypeError(
            f"at most {MAX_POINTS} points, not {value} (the plots show no more; for denser "
            "output use System.simulate with t_eval or dense_output=True)")
    return value
