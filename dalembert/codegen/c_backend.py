"""Compile flat vectors of SymPy expressions to C, load them with ctypes, cache on disk.

Why C (measured on the standard chain workload, ``multibody.chain(n, 1, 1, 0.05)``,
on the shared 2-core development machine; ``bench/eval_cost.py`` and
``bench/results/eval_cost.json`` have the full table). One evaluation of the KKT
blocks ``(M, f, A, c)`` from Python, best of several batches:

=====  =================  ==========================
n      NumPy + cse (old)  C + cse (``-O0``, ctypes)
=====  =================  ==========================
4      100-170 us         15 us
16     360-950 us         27 us
64     (not run)          31 us
=====  =================  ==========================

The NumPy code is interpreted Python: one bytecode dispatch and one boxed float
per common subexpression, whatever the arithmetic, so it grows with the system.
The same cse compiled runs at machine speed: the raw C call for ``n = 16`` takes
9 us at ``-O0`` and 5.6 us at ``-O1``, both small next to the ~10 us of the
ctypes call and the rest of an evaluation. The compiler time decides: for
``n = 16`` (3800 lines, one function per output) gcc takes 1.0 s at ``-O0``,
7.2 s at ``-O1`` and 10.4 s at ``-O2`` (register allocation over one long
straight-line function), so ``-O0`` it is. Numba was not adopted: it is not
installed here, is a heavy dependency, and would compile the same straight-line
function through LLVM's optimizer, with the same compile-time problem as ``-O1``
and no gain at run time over C.

Multibody models take another route (:mod:`dalembert.codegen.assembly`): one short
kernel per kind of body or joint, looped over its instances by a generated
driver (:func:`scatter_library`). There the code is small whatever the size of
the mechanism, so it is optimized: for the 256-link chain ``-O2`` made the cold
build 0.2-0.4 s longer than ``-O0`` (1.2 vs 1.0 s spherical, 2.2 vs 1.75 s
revolute) and one evaluation of the KKT blocks 2.4-2.8x faster (39 vs 111 us,
58 vs 141 us). ``-O1`` evaluates as fast as ``-O2`` (3.8 us planar and 5.2-5.8 us
spherical at ``n = 16``, 15 us planar at 256, from Python) and builds 15-20%
sooner (planar ``n = 16`` cold 0.18 against 0.22 s, spherical 0.57-0.63 against
0.70-0.72 s), so ``-O1`` it is.

The library is cached under :func:`~dalembert.codegen.cache.cache_dir`
(``$DALEMBERT_CACHE_DIR``, else ``$XDG_CACHE_HOME/dalembert`` or
``~/.cache/dalembert``) by a hash of the symbolic input, so on a cache hit neither
``cse``, printing nor the compiler run again; :mod:`dalembert.codegen.cache` keeps
it private and checks each library before it is loaded. Without a C compiler
(``$CC``, ``cc``, ``gcc``, ``clang``), or when ``$DALEMBERT_BACKEND=numpy``,
:func:`build_flat_functions` falls back to the NumPy printer with the same
interface; when that is not the user's choice, a
:class:`~dalembert.errors.NativeUnavailableWarning` says why (once per reason).
"""

from __future__ import annotations

import ctypes
import hashlib
import os
import shutil
import subprocess
import warnings
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from functools import partial
from pathlib import Path
from typing import Any

import numpy as np
import sympy as sp
from sympy.printing.c import C99CodePrinter

from ..errors import CompileError, NativeUnavailableWarning
from . import cache
from .cache import cache_dir as cache_dir  # where libraries are kept (re-exported)
from .numpy_printer import generate_function

Arguments = Sequence[tuple[str, Sequence[sp.Symbol]]]
#: One flat function: (name, arguments, expressions) -> ``name(*arrays) -> 1-D array``.
FlatSpec = tuple[str, Arguments, Sequence[sp.Expr]]

#: Bumped whenever the generated C changes, so that stale cached libraries are not used
#: (4: every library ends with the cache's probe function and has a digest record;
#: 5: a small power printed as a parenthesized product, right after "/" too;
#: 6: part kernels gather their parameters as they gather their coordinates;
#: 7: Piecewise and Heaviside as conditional expressions).
GENERATOR_VERSION = "7"
CFLAGS = ("-O0", "-fPIC", "-shared", "-fno-math-errno")
#: Kernels of one part (a body, a joint) are short, so optimizing them costs little;
#: their gathers and scatters have fixed counts, which unrolling turns into straight code.
PART_CFLAGS = ("-O1", "-funroll-loops", *CFLAGS[1:])
#: Hand-written loops (the simulation runtime): compiled once, so fully optimized. Their
#: loops run over blocks of 1 to 4 and bands a few rows wide: unrolling them and the part
#: kernels made one evaluation 3-13% faster, vectorizing (-O3) 30% slower (bench/README.md).
SOURCE_CFLAGS = ("-O2", "-funroll-loops", *CFLAGS[1:])
BACKENDS = ("auto", "c", "numpy")


def find_compiler() -> str | None:
    """The C compiler to use (``$CC`` first), or ``None`` when there is none.

    >>> find_compiler() is None or isinstance(find_compiler(), str)
    True
    """
    for name in (os.environ.get("CC"), "cc", "gcc", "clang"):
        if name and shutil.which(name):
            return shutil.which(name)
    return None


def backend() -> str:
    """``"c"`` or ``"numpy"``: ``$DALEMBERT_BACKEND`` (``auto`` = C when a compiler exists).

    >>> backend() in ("c", "numpy")
    True
    """
    choice = os.environ.get("DALEMBERT_BACKEND", "auto").lower()
    if choice not in BACKENDS:
        raise ValueError(f"DALEMBERT_BACKEND must be one of {BACKENDS}, not {choice!r}")
    if choice == "numpy":
        return "numpy"
    if find_compiler() is None:
        warn_unavailable(MODEL_CODE, "no C compiler found (looked for $CC, cc, gcc, clang); "
                         "install one, or set DALEMBERT_BACKEND=numpy to choose NumPy")
        return "numpy"
    return "c"


#: What :func:`warn_unavailable` names, and what runs instead.
MODEL_CODE = ("the model's C code", "using NumPy instead (slower)")
RUNTIME = ("the C simulation loop", "the Python loop runs instead (slower)")
_WARNED: set[tuple[str, str]] = set()


def warn_unavailable(route: tuple[str, str], reason: object) -> None:
    """Say (a :class:`~dalembert.errors.NativeUnavailableWarning`, once per process and
    reason) that a C route is unavailable and a slower one is taken.

    Parameters
    ----------
    route
        :data:`MODEL_CODE` or :data:`RUNTIME`.
    reason
        Why (an exception or a text).

    Examples
    --------
    >>> import warnings
    >>> with warnings.catch_warnings(record=True) as caught:
    ...     warnings.simplefilter("always")
    ...     for _ in range(2):
    ...         warn_unavailable(RUNTIME, "an example reason")
    >>> [str(w.message) for w in caught]  # doctest: +NORMALIZE_WHITESPACE
    ['the C simulation loop is unavailable, the Python loop runs instead (slower):
      an example reason']
    """
    what, instead = route
    key = (what, str(reason))
    if key not in _WARNED:
        warnings.warn(f"{what} is unavailable, {instead}: {reason}", NativeUnavailableWarning,
                      stacklevel=3)
        _WARNED.add(key)  # after warning: a filter turning it into an error raises each time


def build_flat_functions(specs: Sequence[FlatSpec], *, use: str | None = None) -> list[Callable]:
    """One callable per spec, ``fn(*arrays) -> 1-D array`` of the expressions' values.

    Each argument is an array (or a scalar) unpacked into its symbols, in order. With
    the C backend all functions share one shared library (one compiler run).

    >>> x, k = sp.symbols("x k")
    >>> (fn,) = build_flat_functions([("spring", [("q", [x]), ("p", [k])], [-k * x, x**2])])
    >>> fn(np.array([0.5]), np.array([2.0]))
    array([-1.  ,  0.25])
    """
    use = backend() if use is None else use
    if use == "c":
        try:
            return _c_functions(specs)
        except CompileError as exc:
            warn_unavailable(MODEL_CODE, exc)
    return [_numpy_function(*spec) for spec in specs]


def _numpy_function(name: str, arguments: Arguments, exprs: Sequence[sp.Expr]) -> Callable:
    if not exprs:
        return _empty
    fn = generate_function(name, arguments, [("v", sp.Matrix(list(exprs)))])

    def flat(*arrays):
        return fn(*arrays)[0]

    flat.__source__ = fn.__source__  # type: ignore[attr-defined]  # the generated code
    return flat


def _empty(*arrays) -> np.ndarray:
    return np.zeros(0)


def _c_functions(specs: Sequence[FlatSpec]) -> list[Callable]:
    lib = _library(specs, "flat", lambda: [_c_source(*s) for s in specs], CFLAGS)
    return [_bind(lib, name, arguments, len(exprs)) for name, arguments, exprs in specs]


def scatter_library(kinds: Sequence[tuple[str, Sequence[FlatSpec]]],
                    gathered: Sequence[Sequence[str]]) -> ctypes.CDLL:
    """Compile (or load from the cache) one driver per kind that sums many kernels.

    Each spec describes one part of a model in its local variables. For kind
    ``name`` the library exports ::

        void name(const int64_t *K, const int64_t *const *index, const int64_t *const *target,
                  const double *arg1, ..., double *out)

    which, for each spec ``g`` and each of its ``K[g]`` instances ``k``, reads the
    ``gathered`` arguments at the global positions ``index[g][k, :]``, evaluates
    the spec's expressions and adds value ``e`` into ``out[target[g][k, e]]``
    (``out`` is not cleared). ``gathered`` lists groups of argument names: the
    groups take consecutive columns of an index row, in order, and the arguments of
    one group share theirs (``[("q", "qd"), ("p",)]``: a row holds the positions of
    the part's coordinates, which index both ``q`` and ``qd``, then those of its
    parameters). The other arguments are passed through whole. Each spec's kernel is a
    static function under the spec's name (names must differ from each other and
    from the kinds). Raises :class:`CompileError` when C is unavailable.
    """
    groups = tuple(tuple(group) for group in gathered)
    every = [s for _, specs in kinds for s in specs]
    variant = ("scatter:" + "|".join(",".join(g) for g in groups) + ":"
               + ",".join(k for k, _ in kinds))
    return _library(every, variant, lambda: [
        _scatter_source(kind, specs, groups) for kind, specs in kinds], PART_CFLAGS)


def source_library(source: str, flags: Sequence[str] = SOURCE_CFLAGS) -> ctypes.CDLL:
    """Compile hand-written C ``source`` (or load it from the cache, keyed by its text).

    Raises :class:`CompileError` when C is unavailable.
    """
    compiler = _compiler()
    return _load(_source_key(source, compiler, flags), lambda: source, compiler, flags)


def _source_key(source: str, compiler: str, flags: Sequence[str]) -> str:
    parts = [GENERATOR_VERSION, compiler, *flags, source]
    return hashlib.sha256("\0".join(parts).encode()).hexdigest()[:32]


def _library(specs: Sequence[FlatSpec], variant: str, sources: Callable,
             flags: Sequence[str]) -> ctypes.CDLL:
    compiler = _compiler()
    key = _cache_key(specs, compiler, variant + " ".join(flags))
    return _load(key, lambda: "\n".join(["#include <math.h>", "#include <stdint.h>", *sources()]),
                 compiler, flags)


def _compiler() -> str:
    compiler = find_compiler()
    if compiler is None:
        raise CompileError("no C compiler found")
    return compiler


def _load(key: str, source: Callable[[], str], compiler: str,
          flags: Sequence[str]) -> ctypes.CDLL:
    return cache.load_library(key, partial(_compile, source, compiler, flags))


def _cache_key(specs: Sequence[FlatSpec], compiler: str, variant: str) -> str:
    """Hash of everything the library depends on: expressions, argument order, flags."""
    h = hashlib.sha256()
    for part in (GENERATOR_VERSION, sp.__version__, compiler, variant):
        h.update(part.encode() + b"\0")
    memo: dict[sp.Basic, bytes] = {}
    for name, arguments, exprs in specs:
        h.update(name.encode() + b"\0")
        for arg, symbols in arguments:
            h.update(f"{arg}:{','.join(map(sp.srepr, symbols))}\0".encode())
        for e in exprs:
            h.update(_digest(sp.sympify(e), memo) + b"\0")
    return h.hexdigest()[:32]


def _digest(expr: sp.Basic, memo: dict[sp.Basic, bytes]) -> bytes:
    """A hash of ``expr``'s tree (as ``srepr`` spells it), each shared node hashed once.

    ``srepr`` of every expression re-prints the subexpressions they share (a
    joint's rotation entries appear in all its rows): 0.2 s of a 16-link chain's build.
    """
    done = memo.get(expr)
    if done is None:
        if expr.args:
            text = type(expr).__name__ + "(" + ",".join(
                _digest(a, memo).hex() for a in expr.args) + ")"
        else:
            text = sp.srepr(expr)
        done = memo[expr] = hashlib.sha256(text.encode()).digest()
    return done


class _Printer(C99CodePrinter):
    """Prints each argument symbol as ``arg[i]`` and each temporary under its name."""

    def __init__(self, names: dict[sp.Symbol, str]) -> None:
        super().__init__({"strict": True})
        self._names = names

    def _print_Symbol(self, expr: sp.Symbol) -> str:
        name = self._names.get(expr)
        if name is None:
            raise CompileError(f"symbol {expr} is not an argument")
        return name

    _print_Dummy = _print_Symbol

    def _print_Pow(self, expr: sp.Pow) -> str:
        # Small integer powers as products: exact, and faster than pow(). The product is
        # parenthesized whole: SymPy prints a denominator's power after "/" as an atom
        # (x/l**3 as "x/" + this), and x/(l)*(l)*(l) would be x*l.
        if expr.exp.is_Integer and 2 <= int(expr.exp) <= 4:
            base = self.parenthesize(expr.base, 100)
            return "(" + "*".join([f"({base})"] * int(expr.exp)) + ")"
        return super()._print_Pow(expr)

    # Switching functions (saturation, dead zones, Coulomb-like laws) as conditional
    # expressions, so that such models stay in C.
    def _print_Piecewise(self, expr: sp.Piecewise) -> str:
        """Nested ``cond ? value : rest``; NaN where no condition holds (as SymPy)."""
        code = "NAN"
        for value, condition in reversed(expr.args):
            if condition == sp.true:
                code = self._print(value)
            else:
                code = f"(({self._print(condition)}) ? ({self._print(value)}) : ({code}))"
        return code

    def _print_Heaviside(self, expr: sp.Heaviside) -> str:
        x = self._print(expr.args[0])
        at_zero = expr.args[1] if len(expr.args) > 1 else sp.S.Half
        return f"(({x}) > 0 ? 1.0 : (({x}) < 0 ? 0.0 : ({self._print(at_zero)})))"

    def _print_DiracDelta(self, expr: sp.Expr) -> str:
        # The derivative of a step (of Heaviside, sign, Abs, Min, Max): zero wherever it
        # is defined, which is every state but a set of measure zero.
        return "0.0"


def _c_source(name: str, arguments: Arguments, exprs: Sequence[sp.Expr]) -> str:
    params = ", ".join([*(f"const double *{arg}" for arg, _ in arguments), "double *out"])
    return "\n".join([f"void {name}({params}) {{", *_c_body(arguments, exprs), "}"])


def _c_body(arguments: Arguments, exprs: Sequence[sp.Expr]) -> list[str]:
    """Statements setting ``out[i]`` from the arguments, common subexpressions first."""
    names = {s: f"{arg}[{i}]" for arg, symbols in arguments for i, s in enumerate(symbols)}
    temporaries = (sp.Dummy(f"w{k}") for k in range(10**9))
    replacements, reduced = sp.cse(list(exprs), symbols=temporaries)
    printer = _Printer(names)
    lines = []
    for k, (tmp, expr) in enumerate(replacements):
        code = _print(printer, expr)
        names[tmp] = f"w{k}"
        lines.append(f"  const double w{k} = {code};")
    lines += [f"  out[{i}] = {_print(printer, e)};" for i, e in enumerate(reduced)]
    return lines


def _scatter_source(kind: str, specs: Sequence[FlatSpec],
                    gathered: tuple[tuple[str, ...], ...]) -> str:
    """The kernels of one kind (gather, evaluate, add) and their driver ``kind``."""
    kernels, calls = [], []
    for g, (name, arguments, exprs) in enumerate(specs):
        if not exprs:
            continue
        kernels.append(_scatter_kernel(name, arguments, exprs, gathered))
        passed = ", ".join(arg for arg, _ in arguments)
        calls.append(f"  {name}(K[{g}], index[{g}], target[{g}], {passed}, out);")
    arguments = specs[0][1]
    params = ", ".join(["const int64_t *K", "const int64_t *const *index",
                        "const int64_t *const *target",
                        *(f"const double *{arg}" for arg, _ in arguments), "double *out"])
    return "\n".join([*kernels, f"void {kind}({params}) {{", *calls, "}"])


def _scatter_kernel(name: str, arguments: Arguments, exprs: Sequence[sp.Expr],
                    gathered: tuple[tuple[str, ...], ...]) -> str:
    sizes = dict(arguments)
    offset: dict[str, int] = {}  # the first column of each gathered argument
    width = 0
    for group in gathered:
        present = [arg for arg in group if arg in sizes]
        for arg in present:
            offset[arg] = width
        width += max((len(sizes[arg]) for arg in present), default=0)
    size = len(exprs)
    params = ", ".join(["int64_t K", "const int64_t *index", "const int64_t *target",
                        *(f"const double *{arg}_all" if arg in offset
                          else f"const double *{arg}" for arg, _ in arguments),
                        "double *out_all"])
    lines = [f"static void {name}({params}) {{", "  for (int64_t k = 0; k < K; ++k) {",
             f"    const int64_t *at = index + k * {width};",
             f"    double out[{size}];"]
    for arg, symbols in arguments:
        if arg in offset and symbols:
            lines += [f"    double {arg}[{len(symbols)}];",
                      f"    for (int i = 0; i < {len(symbols)}; ++i) "
                      f"{arg}[i] = {arg}_all[at[{offset[arg]} + i]];"]
    lines += ["  " + line for line in _c_body(arguments, exprs)]
    lines += [f"    const int64_t *to = target + k * {size};",
              f"    for (int e = 0; e < {size}; ++e) out_all[to[e]] += out[e];", "  }", "}"]
    return "\n".join(lines)


def _print(printer: _Printer, expr: sp.Expr) -> str:
    try:
        code = printer.doprint(expr)
    except CompileError:
        raise
    except Exception as exc:  # sympy raises several types for what C cannot express
        raise CompileError(f"no C translation of {expr}: {exc}") from exc
    if "\n" in code:  # a multi-line construct (e.g. Piecewise without a default)
        raise CompileError(f"no single-expression C translation of {expr}")
    return code


def _compile(source: Callable[[], str], compiler: str, flags: Sequence[str],
             folder: Path) -> None:
    """Compile ``source()`` into ``folder`` as the cache expects (its probe appended)."""
    src = folder / cache.SOURCE
    src.write_text(source() + cache.PROBE_SOURCE)
    try:
        run = subprocess.run([compiler, *flags, str(src), "-o", str(folder / cache.LIBRARY),
                              "-lm"], capture_output=True, text=True)
    except OSError as exc:  # not the cache's fault: the compiler cannot be run
        raise CompileError(f"cannot run the C compiler {compiler}: {exc}") from exc
    if run.returncode != 0:
        raise CompileError(f"{compiler} failed: {run.stderr.strip()[:500]}")


def _bind(lib: ctypes.CDLL, name: str, arguments: Arguments, size: int) -> Callable:
    cfun = getattr(lib, name)
    cfun.restype = None
    cfun.argtypes = [ctypes.c_void_p] * (len(arguments) + 1)
    if not size:
        def call(*arrays):
            return np.zeros(0)
    else:
        def call(*arrays):
            args = [np.ascontiguousarray(a, dtype=float).reshape(-1) for a in arrays]
            out = np.empty(size)
            cfun(*(a.ctypes.data for a in args), out.ctypes.data)
            return out

    # Generated functions carry their library (kept loaded as long as the function
    # lives) and, for C loops (:mod:`dalembert.solvers.native`), their address.
    call.library = lib  # type: ignore[attr-defined]
    call.native = NativeHandle(function_address(cfun), 0, 0, 0, size)  # type: ignore[attr-defined]
    return call


def function_address(cfun: Any) -> int:
    """The address of a C function loaded with ctypes."""
    address = ctypes.cast(cfun, ctypes.c_void_p).value
    if address is None:
        raise CompileError("a generated C function has no address")
    return address


@dataclass(frozen=True)
class NativeHandle:
    """A generated function as C code calls it: a flat ``fn(t, q, [qd,] p, out)`` (the
    tables are 0) or a scatter driver ``fn(K, index, target, t, q, [qd,] p, out)``
    that adds into ``out``; ``size`` outputs. A driver's ``targets`` (per group, the
    place in ``out`` of each output) let a caller make one that writes elsewhere."""

    address: int
    K: int
    index: int
    target: int
    size: int
    targets: tuple[np.ndarray, ...] = field(default=(), compare=False, repr=False)
