"""Numeric functions of a model assembled from parts, each part generated once.

A mechanism's equations are sums over its parts: the Lagrangian is a sum of the
bodies' energies, each constraint belongs to one joint. A :class:`Part` is the
equations of one kind of piece (a body, a joint) in its own local coordinates,
with the places it occupies in the whole: for each of its ``K`` instances, the
global index of every local coordinate and constraint row. Identical pieces share
one part, so a chain of 1000 equal links derives and compiles one body and two
joints, not 1000 of each; the generated code loops over the instances (see
:func:`~.c_backend.build_batched_functions`).

An evaluation gathers each part's coordinates, calls its kernel once for all
instances and adds every output into its place in the global vectors with one
``bincount``: the cost is linear in the number of instances, and the result is
the same :class:`~.compiled.CompiledEquations` the global route
(:func:`~.compiled.compile_equations`) makes, so the solvers cannot tell them apart.
"""

from __future__ import annotations

import ctypes
import threading
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from functools import cached_property, partial

import numpy as np
import sympy as sp

from ..equations.lagrange import Equations
from ..equations.sparse import nonzero_entries
from ..equations.static import static_entries
from ..model.coordinates import t
from . import c_backend
from .compiled import CompiledEquations, SparsePattern, _energy_vector
from .numpy_printer import expression_values
from .static import StaticFunctions, StaticPattern


@dataclass(frozen=True)
class Part:
    """Local equations placed ``K`` times in a global model.

    ``coordinates[k, i]`` is the global index of local coordinate ``i`` in instance
    ``k``; ``rows[k, r]`` the global constraint row of local row ``r``. The kernel's
    parameters are ``parameters`` (local symbols of the part's equations) and
    ``values[k, j]`` is parameter ``j``'s value in instance ``k``: an expression of the
    model's parameters (``m``, ``2 * l``), so that pieces that differ only in their
    parameter values share one kernel. By default the part's parameters are the
    model's own, the same in every instance.
    """

    equations: Equations
    coordinates: np.ndarray
    rows: np.ndarray
    parameters: tuple[sp.Symbol, ...] | None = None
    values: np.ndarray | None = None

    def __post_init__(self) -> None:
        model = self.equations.model
        K = len(self.coordinates)
        object.__setattr__(self, "coordinates", _index_array(self.coordinates, K, model.coords.n))
        object.__setattr__(self, "rows", _index_array(self.rows, K, model.constraints.m))
        if self.parameters is None:
            object.__setattr__(self, "parameters", tuple(model.parameters))
        symbols = tuple(self.parameters or ())
        values = np.empty((K, len(symbols)), dtype=object)
        if self.values is None:
            values[:] = symbols
        else:
            values[:] = np.asarray(self.values, dtype=object).reshape(K, len(symbols))
        object.__setattr__(self, "values", values)

    @property
    def instances(self) -> int:
        return len(self.coordinates)


def _index_array(values: object, K: int, width: int) -> np.ndarray:
    return np.asarray(values, dtype=np.intp).reshape(K, width)


@dataclass(frozen=True)
class ParameterLayout:
    """Where every part instance finds its parameter values.

    The parameter vector the kernels read is ``[the model's parameters, derived
    values]``: an instance value that is one of the model's parameters is read in
    place, any other expression (``2 * l``) gets a slot of its own after them,
    computed when values are bound (:meth:`expand`), never compiled.
    """

    parameters: tuple[sp.Symbol, ...]
    derived: tuple[sp.Expr, ...]
    index: tuple[np.ndarray, ...]  # per part, (K, its parameters): places in the vector

    @classmethod
    def of(cls, parts: Sequence[Part], parameters: Sequence[sp.Symbol]) -> ParameterLayout:
        place = {s: k for k, s in enumerate(parameters)}
        derived: dict[sp.Expr, int] = {}
        index = []
        for part in parts:
            values = part.values if part.values is not None else np.empty((part.instances, 0))
            at = np.empty(values.shape, dtype=np.intp)
            for kj, value in np.ndenumerate(values):
                expr = sp.sympify(value)
                missing = expr.free_symbols - set(parameters)
                if missing:
                    names = ", ".join(sorted(str(s) for s in missing))
                    raise ValueError(f"a part's parameter value {expr} uses {names}, which "
                                     "is not among the model's parameters")
                if expr in place:
                    at[kj] = place[expr]
                else:
                    at[kj] = len(parameters) + derived.setdefault(expr, len(derived))
            index.append(at)
        return cls(tuple(parameters), tuple(derived), tuple(index))

    @property
    def size(self) -> int:
        return len(self.parameters) + len(self.derived)

    def expand(self, p: np.ndarray) -> np.ndarray:
        """The kernels' parameter vector from the model's parameter values ``p``."""
        p = np.asarray(p, dtype=float)
        if not self.derived:
            return p
        return np.concatenate([p, expression_values(self.parameters, self.derived, p)])


def compile_parts(
    parts: Sequence[Part], n: int, m: int, parameters: Sequence[sp.Symbol] = (),
    backend: str | None = None, inputs: Sequence[sp.Symbol] = (),
) -> CompiledEquations:
    """The numeric functions of the model made of ``parts`` (``n`` coordinates, ``m`` rows).

    Every coordinate index and constraint row must be in range and every row
    covered exactly once. ``parameters`` are the model's parameter symbols, in which
    the parts' parameter values are written (:class:`Part`); the compiled functions
    take the vector :meth:`ParameterLayout.expand` makes of their values (``bind``
    does it). ``inputs`` are the model's input symbols, whose values follow the
    parameters'. The static function (:mod:`.static`) is generated from the same parts
    when statics first asks for it.
    """
    _check_rows(parts, m)
    holonomic = _holonomic_rows(parts)
    pattern = _pattern(parts, n, m)
    layout = _Layout(pattern, holonomic)
    values = ParameterLayout.of(parts, [*parameters, *inputs])
    kinds: dict[str, tuple[list, list]] = {kind: ([], []) for kind in _KINDS}
    for g, part in enumerate(parts):
        for kind, exprs, target in _outputs(part, layout):
            kinds[kind][0].append((f"{kind}_{g}", _arguments(part, kind), exprs))
            kinds[kind][1].append(target)
    sizes = layout.sizes(n, m)
    use = c_backend.backend() if backend is None else backend
    functions = _evaluators([(k, *kinds[k], sizes[k], k in _STATE) for k in _KINDS], parts,
                            values, n, use)
    used = "numpy" if isinstance(functions[0], _NumpyEvaluator) else "c"
    kkt, velocity, position, energy = functions
    return CompiledEquations(kkt, velocity, position, energy, pattern, tuple(holonomic), used,
                             partial(compile_static_parts, parts, n, m,
                                     [*parameters, *inputs], used),
                             values.expand, tuple(u.name for u in inputs), len(parameters))


def compile_static_parts(parts: Sequence[Part], n: int, m: int,
                         parameters: Sequence[sp.Symbol], use: str) -> StaticFunctions:
    """The static function (:mod:`.static`) of the model made of ``parts``: each part's
    derivatives generated once, on its own equations, and added into the global
    pattern (the union of the parts' entries) at every instance.

    Parameters
    ----------
    parts, n, m, parameters
        As for :func:`compile_parts`.
    use
        ``"c"`` or ``"numpy"``.
    """
    local = [static_entries(part.equations) for part in parts]
    keys: list[list[np.ndarray]] = [[], [], [], []]  # per group, per part and entry
    for part, entries in zip(parts, local):
        idx, rows, K = part.coordinates, part.rows, part.instances
        keys[0].append(_keys([idx[:, i] * n + idx[:, j] for i, j in entries.stiffness], K))
        keys[1].append(_keys([(rows[:, k] * n + idx[:, j]) * n + idx[:, i]
                              for k, j, i in entries.curvature], K))
        keys[2].append(_keys([idx[:, i] * n + idx[:, j] for i, j in entries.damping], K))
        keys[3].append(_keys([rows[:, k] * n + idx[:, j] for k, j in entries.rest], K))
    unique = [np.unique(np.concatenate([k.reshape(-1) for k in group] or [_NO_INDEX]))
              for group in keys]
    offsets = np.cumsum([0, *(len(u) for u in unique)])
    specs, targets = [], []
    for g, (part, entries) in enumerate(zip(parts, local)):
        groups = (entries.stiffness, entries.curvature, entries.damping, entries.rest)
        exprs = [e for group in groups for e in group.values()]
        at = [offsets[c] + np.searchsorted(unique[c], keys[c][g]) for c in range(4)]
        specs.append((f"static_{g}", _arguments(part, "static"), exprs))
        targets.append(np.concatenate(at, axis=1).reshape(-1))
    (values,) = _evaluators([("static_values", specs, targets, int(offsets[-1]), False)],
                            parts, ParameterLayout.of(parts, parameters), n, use)
    rest_rows = sorted(int(r) for part, entries in zip(parts, local)
                       for k in entries.rest_rows for r in part.rows[:, k])
    pattern = StaticPattern(
        n, m, (unique[0] // n, unique[0] % n), (unique[1] // (n * n), unique[1] // n % n,
                                                 unique[1] % n),
        (unique[2] // n, unique[2] % n), (unique[3] // n, unique[3] % n), tuple(rest_rows))
    return StaticFunctions(values, pattern)


_NO_INDEX = np.zeros(0, dtype=np.intp)


def _keys(columns: list[np.ndarray], K: int) -> np.ndarray:
    """Per instance, the global keys of a part's entries: shape ``(K, entries)``."""
    if not columns:
        return np.zeros((K, 0), dtype=np.intp)
    return np.stack(columns, axis=1).astype(np.intp)


def _evaluators(kinds: Sequence[tuple[str, list, list, int, bool]], parts: Sequence[Part],
                values: ParameterLayout, n: int, use: str) -> list[Callable]:
    """One evaluator per kind ``(name, specs, targets, size, takes_qd)``: a driver of one
    compiled library when ``use`` is ``"c"`` (NumPy, with a warning, if that fails).
    Each instance's index row holds its coordinates' places, then its parameters'."""
    indices = [np.hstack([part.coordinates, at]) for part, at in zip(parts, values.index)]
    if use == "c":
        try:
            lib = c_backend.scatter_library([(k, specs) for k, specs, *_ in kinds],
                                            [("q", "qd"), ("p",)])
            return [_CEvaluator(getattr(lib, k), (n, values.size, size), indices, targets,
                                takes_qd, lib) for k, _, targets, size, takes_qd in kinds]
        except c_backend.CompileError as exc:
            c_backend.warn_unavailable(c_backend.MODEL_CODE, exc)
    return [_numpy_evaluator(specs, parts, values.index, targets, size)
            for _, specs, targets, size, _ in kinds]


_KINDS = ("kkt", "velocity", "position", "energy")
_STATE = ("kkt", "energy")


@dataclass(frozen=True)
class _Layout:
    """Where each global quantity sits in the flat output vectors."""

    pattern: SparsePattern
    holonomic: list[int]

    def sizes(self, n: int, m: int) -> dict[str, int]:
        nM, nA = len(self.pattern.M_rows), len(self.pattern.A_rows)
        return {"kkt": nM + n + nA + m, "velocity": nA + m,
                "position": len(self.holonomic), "energy": 3}

    @cached_property
    def _M_keys(self) -> np.ndarray:
        return self.pattern.M_rows * self.pattern.n + self.pattern.M_cols

    @cached_property
    def _A_keys(self) -> np.ndarray:
        return self.pattern.A_rows * self.pattern.n + self.pattern.A_cols

    def M_position(self, rows: np.ndarray, cols: np.ndarray) -> np.ndarray:
        """Where the ``M`` entries ``(rows, cols)`` sit among the pattern's values."""
        return np.searchsorted(self._M_keys, rows * self.pattern.n + cols)

    def A_position(self, rows: np.ndarray, cols: np.ndarray) -> np.ndarray:
        return np.searchsorted(self._A_keys, rows * self.pattern.n + cols)


def _outputs(part: Part, layout: _Layout) -> list[tuple[str, list[sp.Expr], np.ndarray]]:
    """Per kind: the part's output expressions and, per instance, their global targets."""
    eqs, idx, rows = part.equations, part.coordinates, part.rows
    pat = layout.pattern
    nM, n, nA = len(pat.M_rows), pat.n, len(pat.A_rows)
    M, A = nonzero_entries(eqs.M), nonzero_entries(eqs.A)
    f, c, b = _nonzero(eqs.f), _nonzero(eqs.c), _nonzero(eqs.b)
    M_at = [layout.M_position(idx[:, i], idx[:, j]) for i, j in M]
    A_at = [layout.A_position(rows[:, r], idx[:, j]) for r, j in A]
    f_at = [nM + idx[:, i] for i in f]
    c_at = [nM + n + nA + rows[:, r] for r in c]
    b_at = [nA + rows[:, r] for r in b]
    hol = {row: k for k, row in enumerate(layout.holonomic)}
    local_hol = eqs.model.constraints.holonomic_rows
    psi_at = [np.array([hol[r] for r in rows[:, i]], dtype=np.intp) for i in local_hol]
    K = part.instances
    energy_at = [np.full(K, k, dtype=np.intp) for k in range(3)]
    return [
        ("kkt", [*M.values(), *f.values(), *A.values(), *c.values()],
         _columns([*M_at, *f_at, *[nM + n + a for a in A_at], *c_at], K)),
        ("velocity", [*A.values(), *b.values()], _columns([*A_at, *b_at], K)),
        ("position", list(eqs.model.constraints.psi), _columns(psi_at, K)),
        ("energy", list(_energy_vector(eqs)), _columns(energy_at, K)),
    ]


def _nonzero(vector: sp.Matrix) -> dict[int, sp.Expr]:
    return {i: e for i, e in enumerate(vector) if e != 0}


def _columns(targets: list[np.ndarray], K: int) -> np.ndarray:
    """Targets ``(K, outputs)`` flattened in the kernels' row-major output order."""
    if not targets:
        return np.zeros(0, dtype=np.intp)
    return np.stack(targets, axis=1).reshape(-1)


def _arguments(part: Part, kind: str) -> list:
    """The kernel's arguments: ``(t, q, [qd,] p)``, ``qd`` for the kinds of the state,
    ``p`` the part's own parameters."""
    coords = part.equations.model.coords
    state = [("t", [t]), ("q", coords.q)]
    if kind in _STATE:
        state.append(("qd", coords.qd))
    return [*state, ("p", list(part.parameters or ()))]


class _CEvaluator:
    """``fn(t, q, [qd,] p)``: one call of a generated driver that sums every part.

    The index and target tables are fixed, so they are handed to C once; the
    arguments are copied into buffers whose addresses are fixed too (getting an
    array's address from Python costs more than the copy). A lock keeps two threads
    from sharing the buffers, since the call releases the GIL.
    """

    def __init__(self, cfun, shape: tuple[int, int, int], indices: list[np.ndarray],
                 targets: list[np.ndarray], velocities: bool, library) -> None:
        n, n_parameters, size = shape
        self._library = library  # keeps the code loaded while this lives
        self._K = np.array([len(i) for i in indices], dtype=np.int64)
        self._tables = [np.ascontiguousarray(a, dtype=np.int64) for a in (*indices, *targets)]
        G = len(indices)
        pointers = [a.ctypes.data for a in self._tables]
        self._index = (ctypes.c_void_p * max(G, 1))(*pointers[:G])
        self._target = (ctypes.c_void_p * max(G, 1))(*pointers[G:])
        self._time, self._q, self._qd = np.zeros(1), np.zeros(n), np.zeros(n)
        self._p, self._out = np.zeros(n_parameters), np.zeros(size)
        arrays = (self._time, self._q, *([self._qd] if velocities else []), self._p, self._out)
        self._args = (self._K.ctypes.data, ctypes.addressof(self._index),
                      ctypes.addressof(self._target), *(a.ctypes.data for a in arrays))
        cfun.restype = None
        cfun.argtypes = [ctypes.c_void_p] * len(self._args)
        self._cfun = cfun
        self._lock = threading.Lock()
        #: For C loops (:mod:`dalembert.solvers.native`); the tables live as long as self.
        K, index, target = self._args[:3]
        self.native = c_backend.NativeHandle(c_backend.function_address(cfun), K, index,
                                             target, size, tuple(self._tables[G:]))

    def __call__(self, time, q, *rest):
        with self._lock:
            self._time[0] = time
            self._q[:] = q
            if len(rest) == 2:
                self._qd[:] = rest[0]
            self._p[:] = rest[-1]
            self._out[:] = 0.0
            self._cfun(*self._args)
            return self._out.copy()


class _NumpyEvaluator:
    """The same sums with NumPy kernels called instance by instance (no C compiler)."""

    def __init__(self, kernels: list, coordinates: list[np.ndarray],
                 parameters: Sequence[np.ndarray], targets: list[np.ndarray],
                 size: int) -> None:
        self._kernels, self._size = kernels, size
        self._rows = list(zip(coordinates, parameters))
        self._where = np.concatenate(targets) if targets else np.zeros(0, dtype=np.intp)

    def __call__(self, time, q, *rest):
        *qd, p = rest
        outputs = []
        for kernel, (idx, at) in zip(self._kernels, self._rows):
            for row, where in zip(idx, at):
                outputs.append(kernel(time, q[row], *(v[row] for v in qd), p[where]))
        weights = np.concatenate(outputs) if outputs else np.zeros(0)
        return np.bincount(self._where, weights=weights, minlength=self._size)


def _numpy_evaluator(specs: list, parts: Sequence[Part], parameters: Sequence[np.ndarray],
                     targets: list[np.ndarray], size: int) -> _NumpyEvaluator:
    kernels = c_backend.build_flat_functions(specs, use="numpy")
    return _NumpyEvaluator(kernels, [part.coordinates for part in parts], parameters,
                           targets, size)


def _pattern(parts: Sequence[Part], n: int, m: int) -> SparsePattern:
    """The union of the parts' ``M`` and ``A`` entries, sorted by row then column."""
    M_keys, A_keys = [np.zeros(0, dtype=np.intp)], [np.zeros(0, dtype=np.intp)]
    for part in parts:
        idx, rows = part.coordinates, part.rows
        _check_coordinates(idx, n)
        M_keys += [idx[:, i] * n + idx[:, j] for i, j in nonzero_entries(part.equations.M)]
        A_keys += [rows[:, r] * n + idx[:, j] for r, j in nonzero_entries(part.equations.A)]
    M_unique = np.unique(np.concatenate(M_keys))
    A_unique = np.unique(np.concatenate(A_keys))
    return SparsePattern(n, m, M_unique // n, M_unique % n, A_unique // n, A_unique % n)


def _check_coordinates(idx: np.ndarray, n: int) -> None:
    if idx.size and (idx.min() < 0 or idx.max() >= n):
        raise ValueError(f"a part's coordinate index is outside 0..{n - 1}")


def _check_rows(parts: Sequence[Part], m: int) -> None:
    rows = np.concatenate([p.rows.reshape(-1) for p in parts] or [np.zeros(0, dtype=np.intp)])
    if len(rows) != m or not np.array_equal(np.sort(rows), np.arange(m)):
        raise ValueError(f"the parts' constraint rows must cover 0..{m - 1} exactly once")


def _holonomic_rows(parts: Sequence[Part]) -> list[int]:
    rows = [int(r) for p in parts
            for i in p.equations.model.constraints.holonomic_rows for r in p.rows[:, i]]
    return sorted(rows)
