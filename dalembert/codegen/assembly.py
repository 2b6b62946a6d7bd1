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
from ..equations.static import static_entries
from . import c_backend
from .compiled import CompiledEquations, SparsePattern
from .numpy_printer import expression_values
from .registry import (
    ARGUMENTS,
    REGISTRY,
    BlockPattern,
    Declaration,
    FunctionLayout,
    Generated,
    GeneratedFunctions,
    argument_symbols,
    block_shape,
)
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
    parameters'. The registry's eager functions (:mod:`.registry`) are generated now,
    the others, and the static function (:mod:`.static`), from the same parts when
    first asked for.
    """
    _check_rows(parts, m)
    holonomic = _holonomic_rows(parts)
    for part in parts:
        _check_coordinates(part.coordinates, n)
    places = _Places(n, m, holonomic)
    values = ParameterLayout.of(parts, [*parameters, *inputs])
    use = c_backend.backend() if backend is None else backend
    made = generate_parts(parts, places, values, use,
                          [d for d in REGISTRY.values() if d.eager])
    used = "numpy" if isinstance(made["kkt"].call, _NumpyEvaluator) else "c"
    kkt = made["kkt"].layout
    M, A = kkt.block("M"), kkt.block("A")
    pattern = SparsePattern(n, m, *M.index, *A.index)
    return CompiledEquations(GeneratedFunctions(made, partial(generate_parts, parts, places,
                                                              values, used)),
                             pattern, tuple(holonomic), used,
                             partial(compile_static_parts, parts, n, m,
                                     [*parameters, *inputs], used),
                             values.expand, tuple(u.name for u in inputs), len(parameters))


@dataclass(frozen=True)
class _Places:
    """The sizes of the index spaces (:data:`~.registry.SPACES`) and where a part's local
    indices of each sit in the whole model, instance by instance."""

    n: int
    m: int
    holonomic: list[int]

    @cached_property
    def sizes(self) -> dict[str, int]:
        return {"q": self.n, "row": self.m, "holonomic": len(self.holonomic)}

    @cached_property
    def _holonomic_at(self) -> np.ndarray:
        at = np.full(self.m, -1, dtype=np.intp)
        at[self.holonomic] = np.arange(len(self.holonomic))
        return at

    def of(self, part: Part, space: str | int) -> np.ndarray:
        """``(K, local size)``: the global index of each local index of ``space``."""
        if space == "q":
            return part.coordinates
        if space == "row":
            return part.rows
        if space == "holonomic":
            local = list(part.equations.model.constraints.holonomic_rows)
            return self._holonomic_at[part.rows[:, local]]
        return np.broadcast_to(np.arange(int(space)), (part.instances, int(space)))


def generate_parts(parts: Sequence[Part], places: _Places, values: ParameterLayout, use: str,
                   declarations: Sequence[Declaration]) -> dict[str, Generated]:
    """The functions of ``declarations`` for the model made of ``parts``, in one library:
    per function, one kernel per part (its ``derive`` applied to the part's equations)
    and a driver adding every instance's values into place.

    Parameters
    ----------
    parts
        The model's parts.
    places
        The index spaces' sizes and maps.
    values
        Where each instance finds its parameter values.
    use
        ``"c"`` or ``"numpy"``.
    declarations
        The functions to generate.
    """
    kinds, layouts = [], []
    for decl in declarations:
        specs, targets, layout = _part_outputs(decl, parts, places)
        kinds.append(_Kind(decl.name, decl.arguments, specs, targets, layout.size))
        layouts.append(layout)
    functions = _evaluators(kinds, parts, values, places.sizes, use)
    return {d.name: Generated(d, layout, fn)
            for d, layout, fn in zip(declarations, layouts, functions)}


def _part_outputs(decl: Declaration, parts: Sequence[Part],
                  places: _Places) -> tuple[list, list[np.ndarray], FunctionLayout]:
    """Per part, the kernel's spec and, per instance, the place of each of its values in
    the function's output; and the output's layout. A dense block's values sit at their
    global indices; a sparse block's pattern is the union of the parts' entries, sorted."""
    local = [decl.derive(part.equations) for part in parts]
    shapes = [block_shape(block, places.sizes) for block in decl.blocks]
    # per block, per part: the flat global index of each entry, (K, entries)
    keys = [[_flat_keys(part, block.spaces, found[block.name], places, shape)
             for part, found in zip(parts, local)]
            for block, shape in zip(decl.blocks, shapes)]
    patterns, positions, start = [], [], 0
    for block, shape, block_keys in zip(decl.blocks, shapes, keys):
        if block.dense:
            flat = np.arange(int(np.prod(shape)), dtype=np.intp)
            positions.append(block_keys)
        else:
            flat = np.unique(np.concatenate([k.reshape(-1) for k in block_keys] or [_NO_INDEX]))
            positions.append([np.searchsorted(flat, k) for k in block_keys])
        index = np.unravel_index(flat, shape) if shape else ()
        patterns.append(BlockPattern(block.name, shape,
                                     tuple(np.asarray(i, dtype=np.intp) for i in index), start))
        start += len(flat)
    specs, targets = [], []
    for g, (part, found) in enumerate(zip(parts, local)):
        exprs = [e for block in decl.blocks for e in found[block.name].values()]
        specs.append((f"{decl.name}_{g}", _arguments(part, decl.arguments), exprs))
        at = [pattern.start + place[g] for pattern, place in zip(patterns, positions)]
        targets.append(np.concatenate(at, axis=1).reshape(-1).astype(np.intp))
    return specs, targets, FunctionLayout(decl.name, tuple(patterns))


def _flat_keys(part: Part, spaces: tuple[str | int, ...], entries: dict, places: _Places,
               shape: tuple[int, ...]) -> np.ndarray:
    """Per instance, the flat (row-major) global index of each of a part's entries."""
    maps = [places.of(part, space) for space in spaces]
    flat = np.zeros((part.instances, len(entries)), dtype=np.intp)
    for e, key in enumerate(entries):
        for d, (local, size) in enumerate(zip(key, shape)):
            flat[:, e] = flat[:, e] * size + maps[d][:, local]
    return flat


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
        specs.append((f"static_{g}", _arguments(part, _STATIC), exprs))
        targets.append(np.concatenate(at, axis=1).reshape(-1))
    (values,) = _evaluators([_Kind("static_values", _STATIC, specs, targets, int(offsets[-1]))],
                            parts, ParameterLayout.of(parts, parameters), {"q": n, "row": m},
                            use)
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


@dataclass(frozen=True)
class _Kind:
    """One function of the part route: its driver's name, its arguments, the parts'
    kernels (specs) and, per part, the place of each kernel value; ``size`` outputs."""

    name: str
    arguments: tuple[str, ...]
    specs: list
    targets: list[np.ndarray]
    size: int


_STATIC = ("t", "q", "p")


def _evaluators(kinds: Sequence[_Kind], parts: Sequence[Part], values: ParameterLayout,
                sizes: dict[str, int], use: str) -> list[Callable]:
    """One evaluator per kind: a driver of one compiled library when ``use`` is ``"c"``
    (NumPy, with a warning, if that fails). An instance's index row holds the places of
    the arguments it gathers, group by group (:func:`_gathered`)."""
    groups = _gathered({a for kind in kinds for a in kind.arguments})
    if use == "c":
        try:
            lib = c_backend.scatter_library([(k.name, k.specs) for k in kinds], groups)
            return [_CEvaluator(getattr(lib, k.name), k.arguments, sizes, values.size,
                                _index_rows(parts, values, groups, k.arguments), k.targets,
                                k.size, lib) for k in kinds]
        except c_backend.CompileError as exc:
            c_backend.warn_unavailable(c_backend.MODEL_CODE, exc)
    return [_numpy_evaluator(k, parts, values.index) for k in kinds]


def _gathered(names: set[str]) -> list[tuple[str, ...]]:
    """The groups of gathered arguments (:func:`~.c_backend.scatter_library`): those
    indexed by coordinates, by constraint rows, then the parameters."""
    coordinates = ("q", "qd", *(a for a in ("qdd",) if a in names))
    return [coordinates, *((("lam",),) if "lam" in names else ()), ("p",)]


def _index_rows(parts: Sequence[Part], values: ParameterLayout,
                groups: list[tuple[str, ...]], arguments: tuple[str, ...]) -> list[np.ndarray]:
    """Per part, each instance's index row: the columns of the groups ``arguments`` uses."""
    rows = []
    for part, at in zip(parts, values.index):
        columns = {"q": part.coordinates, "lam": part.rows, "p": at}
        rows.append(np.hstack([columns[group[0]] for group in groups
                               if any(a in arguments for a in group)]))
    return rows


def _arguments(part: Part, names: tuple[str, ...]) -> list:
    """The kernel's arguments ``names`` as the part's equations spell them, ``p`` the
    part's own parameters."""
    return [(a, argument_symbols(part.equations, a, list(part.parameters or ())))
            for a in names]


class _CEvaluator:
    """``fn(*arguments)``: one call of a generated driver that sums every part.

    The index and target tables are fixed, so they are handed to C once; the
    arguments are copied into buffers whose addresses are fixed too (getting an
    array's address from Python costs more than the copy). A lock keeps two threads
    from sharing the buffers, since the call releases the GIL.
    """

    def __init__(self, cfun, arguments: tuple[str, ...], sizes: dict[str, int],
                 n_parameters: int, indices: list[np.ndarray], targets: list[np.ndarray],
                 size: int, library) -> None:
        self._library = library  # keeps the code loaded while this lives
        self._K = np.array([len(i) for i in indices], dtype=np.int64)
        self._tables = [np.ascontiguousarray(a, dtype=np.int64) for a in (*indices, *targets)]
        G = len(indices)
        pointers = [a.ctypes.data for a in self._tables]
        self._index = (ctypes.c_void_p * max(G, 1))(*pointers[:G])
        self._target = (ctypes.c_void_p * max(G, 1))(*pointers[G:])
        self._buffers = [np.zeros(1 if a == "t" else n_parameters if a == "p"
                                  else sizes[str(ARGUMENTS[a])]) for a in arguments]
        self._out = np.zeros(size)
        self._args = (self._K.ctypes.data, ctypes.addressof(self._index),
                      ctypes.addressof(self._target),
                      *(a.ctypes.data for a in (*self._buffers, self._out)))
        cfun.restype = None
        cfun.argtypes = [ctypes.c_void_p] * len(self._args)
        self._cfun = cfun
        self._lock = threading.Lock()
        #: For C loops (:mod:`dalembert.solvers.native`); the tables live as long as self.
        K, index, target = self._args[:3]
        self.native = c_backend.NativeHandle(c_backend.function_address(cfun), K, index,
                                             target, size, tuple(self._tables[G:]))

    def __call__(self, *arguments):
        with self._lock:
            for buffer, value in zip(self._buffers, arguments):
                buffer[:] = value
            self._out[:] = 0.0
            self._cfun(*self._args)
            return self._out.copy()


class _NumpyEvaluator:
    """The same sums with NumPy kernels called instance by instance (no C compiler)."""

    def __init__(self, kernels: list, gathers: list[list[tuple]], targets: list[np.ndarray],
                 size: int) -> None:
        self._kernels, self._gathers, self._size = kernels, gathers, size
        self._where = np.concatenate(targets) if targets else np.zeros(0, dtype=np.intp)

    def __call__(self, *arguments):
        outputs = []
        for kernel, instances in zip(self._kernels, self._gathers):
            for gather in instances:
                outputs.append(kernel(*(a if g is None else np.asarray(a)[g]
                                        for a, g in zip(arguments, gather))))
        weights = np.concatenate(outputs) if outputs else np.zeros(0)
        return np.bincount(self._where, weights=weights, minlength=self._size)


def _numpy_evaluator(kind: _Kind, parts: Sequence[Part],
                     parameters: Sequence[np.ndarray]) -> _NumpyEvaluator:
    kernels = c_backend.build_flat_functions(kind.specs, use="numpy")
    gathers = []
    for part, at in zip(parts, parameters):
        columns = {"q": part.coordinates, "row": part.rows}
        gathers.append([tuple(k_at if a == "p" else None if a == "t"
                              else columns[str(ARGUMENTS[a])][k] for a in kind.arguments)
                        for k, k_at in enumerate(at)])
    return _NumpyEvaluator(kernels, gathers, kind.targets, kind.size)


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
