"""One model's state in the C runtime: accelerations, multipliers and projections."""

from __future__ import annotations

import ctypes
from collections.abc import Callable
from typing import TYPE_CHECKING

import numpy as np

from ...codegen.c_backend import NativeHandle
from ...codegen.compiled import NumericModel
from ...codegen.registry import REGISTRY
from ...errors import SingularSystemError
from ...numerics.rank import min_norm_multipliers
from ..kkt.dense import DROPPED_ROW_RTOL
from ..kkt.sparse import SINGULAR_MESSAGE, matvec
from ..outputs import SOLVED, output_arrays
from ..projection import ACCEPT_TOL, FAST_NEWTON, MAX_NEWTON, POSITION_TOL, StepProjector
from . import library
from .structure import NotApplicable, SchurStructure, model_struct, schur_structure, work_sizes
from .turns import outside_python

if TYPE_CHECKING:
    from .friction import FrictionTable

DOUBLE = np.dtype(np.float64).itemsize  # bytes, for addresses inside a buffer
#: Output points per call of dl_outputs (a few milliseconds for a large mechanism).
OUTPUT_CHUNK = 1024
_MESSAGES = {
    library.SINGULAR_MASS: "a block of the mass matrix is singular even with the constraints "
                           "inside it folded in",
    library.SINGULAR_CONSTRAINTS: SINGULAR_MESSAGE,
    library.RANK_CHANGED: "the dependent constraints measured at the initial state no longer "
                          "follow from the others (the rank of the constraints changed); "
                          "the Python loop (backend='python') solves such states",
}


class Pinned:
    """The arrays a C struct points to, kept alive with it: each added as a
    contiguous array of its type, its address returned for the struct.

    Examples
    --------
    >>> pinned = Pinned()
    >>> address = pinned.array([1, 2, 3])
    >>> pinned.arrays[-1].ctypes.data == address, pinned.arrays[-1].dtype
    (True, dtype('int64'))
    >>> _ = pinned.zeros(0)
    >>> pinned.arrays[-1].tolist()
    [0.0]
    """

    def __init__(self) -> None:
        self.arrays: list[np.ndarray] = []

    def array(self, values, dtype=np.int64) -> int:
        """The address of ``values`` as a contiguous array of ``dtype`` (``values``
        itself if it is one already: C then reads and writes that array).

        Parameters
        ----------
        values
            An array or a sequence.
        dtype
            Its type in C.
        """
        array = np.ascontiguousarray(values, dtype=dtype)
        self.arrays.append(array)
        return array.ctypes.data

    def zeros(self, size: int) -> int:
        """The address of ``size`` doubles (at least one), zeroed.

        Parameters
        ----------
        size
            How many.
        """
        return self.array(np.zeros(max(int(size), 1)), np.float64)


class NativeSolver:
    """The right-hand side ``y' = F(t, y)`` and the step projection, evaluated in C.

    Same equations as :func:`~dalembert.solvers.dynamics.first_order_rhs` and
    :class:`~dalembert.solvers.projection.StepProjector`, solved by the method of
    :mod:`dalembert.solvers.native`. Raises :class:`NotApplicable` (saying why) for
    models it does not cover: NumPy-generated functions, wide mass blocks or bands.
    One instance per simulation: its ``dl_data`` (:attr:`data`: the parameter vector,
    the work buffers, the inputs) is its own, never shared between threads; its
    ``dl_model`` (:attr:`model`, constant) is shared by every instance over the same
    compiled model, kept rows and Baumgarte gain.

    Parameters
    ----------
    num
        The compiled equations bound to parameter values.
    baumgarte
        The Baumgarte gain (0: none).
    kept
        The independent constraint rows when some are dependent (as the Python loop
        takes them): accelerations and projections from these rows alone, the
        multipliers of the others zero in :meth:`solve` and minimum-norm over all rows
        in :meth:`outputs`, as the Python loop reports them.
    """

    def __init__(self, num: NumericModel, baumgarte: float = 0.0,
                 kept: np.ndarray | None = None) -> None:
        functions = num.compiled.functions
        # the registry's functions the runtime has a place for, as far as generated (the
        # eager ones always: the loop calls them)
        handles = {name: functions[name].native for name in library.FUNCTIONS
                   if REGISTRY[name].eager or name in functions}
        if any(handles[name] is None for name in handles if REGISTRY[name].eager):
            raise NotApplicable("the model's functions were not generated in C")
        kkt = handles["kkt"]
        assert isinstance(kkt, NativeHandle)
        self.num, self.n, self.m = num, num.n, num.m
        self.lib = library.runtime()
        self.kept = None if kept is None else np.asarray(kept, dtype=np.int64)
        self.structure = schur_structure(num.pattern, self.kept)
        kept_key = None if self.kept is None else self.kept.tobytes()
        tables = num.pattern.remember(("native tables", kept_key),
                                      lambda: _Tables(self.structure, num, kkt))
        generated = tuple(name for name, h in handles.items() if h is not None)
        #: the model's constant part, shared by every solver over the same compiled model,
        #: kept rows and stabilization (C only reads it)
        self.shared = num.pattern.remember(
            ("native model", kept_key, float(baumgarte), generated),
            lambda: _SharedModel(tables, self.structure, num, handles, baumgarte))
        self.model = self.shared.model
        self._pinned = Pinned()  # every array the run's struct points to
        self.data = self._data()
        self._at = (ctypes.addressof(self.model), ctypes.addressof(self.data))
        self._holonomic_mask = tables.address["holonomic_mask"]
        self._fallback: StepProjector | None = None  # made on first need
        self._io()
        self._input_error: BaseException | None = None  # what the inputs' callback raised
        self._callback: object = None
        self._friction: FrictionTable | None = None
        self.set_inputs(None)

    def _data(self) -> library.Data:
        """This run's ``dl_data``: its parameter vector and work arrays."""
        num, s, shared = self.num, self.structure, self.shared
        n, m = self.n, self.m
        # the vector itself (no copy): the inputs' callback writes into it
        self._parameters = num.p
        data = library.Data(p=self._pinned.array(num.p, np.float64), conditioning=np.inf)
        sizes = {"vel_values": len(num.pattern.A_rows) + m, "psi": len(num.holonomic_rows),
                 "lambda": m, "qdd": n, "q_trial": n, "error_work": 4 * n,
                 "gram_diagonal": m, **work_sizes(s, n, m)}
        for name, size in sizes.items():
            owner, _, field = name.rpartition(".")
            # zeroed: kkt.c's pair vectors rely on it (load_pairs writes only A's slots)
            setattr(data.factor if owner else data, field, self._pinned.zeros(size))
        data.factor.mask = self._pinned.array(np.zeros(max(m, 1)), np.uint8)
        values = self._pinned.zeros(shared.values_size)
        data.values, data.c = values, values + DOUBLE * shared.c_at
        for name, size in shared.parts.items():  # the solve's layout [blocks, u, a]
            at = shared.part_at.get(name)
            setattr(data, name, self._pinned.zeros(size) if at is None
                    else values + DOUBLE * at)
        return data

    def _check(self, status: int) -> None:
        if status == library.INPUT and self._input_error is not None:
            error, self._input_error = self._input_error, None
            raise error  # what the inputs' callback raised (an InputError, a Ctrl-C)
        if status != library.OK:
            raise SingularSystemError(_MESSAGES.get(status, f"native runtime error {status}"))

    def set_inputs(self, signal: Callable[[float, np.ndarray, np.ndarray], np.ndarray]
                   | None) -> None:
        """Have C ask ``signal(t, q, qd)`` for the model's inputs before every evaluation
        (``None``: the inputs stay as they are in the parameter vector). The callback
        writes into the vector C reads; an exception it raises ends C's call with
        ``DL_INPUT`` and is raised again by the Python side (:meth:`_check`)."""
        self._input_error = None
        if signal is None:
            self.data.inputs = None
            self._callback = None
            return
        n, p = self.n, self._parameters
        start = self.num.compiled.input_offset
        slots = slice(start, start + len(self.num.compiled.input_names))
        state = np.zeros(2 * n)  # C copies [q, qd] here before each call
        q, qd = state[:n], state[n:]
        self.data.input_state = self._pinned.array(state, np.float64)

        def inputs(t: float) -> int:
            try:
                p[slots] = signal(t, q, qd)
                return 0
            except BaseException as exc:  # raised again in Python once C has returned
                self._input_error = exc
                return 1

        self._callback = library.INPUTS_CALLBACK(inputs)  # kept alive while C may call it
        self.data.inputs = ctypes.cast(self._callback, ctypes.c_void_p).value

    def set_friction(self, table: FrictionTable | None) -> None:
        """Have C compute sliding contacts' friction forces into their inputs before
        every evaluation, after the inputs' callback (``None``: not; see
        :mod:`.friction`).

        Parameters
        ----------
        table
            The sliding contacts of this run's model, or ``None``.
        """
        self._friction = table  # kept alive while C may read it
        self.data.friction = None if table is None else table.address

    def _io(self) -> None:
        """Fixed input/output buffers: taking a new array's address costs more than a copy."""
        self._y, self._ydot, self._lam = np.zeros(2 * self.n), np.zeros(2 * self.n), \
            np.zeros(max(self.m, 1))
        self._y_at, self._ydot_at, self._lam_at = (a.ctypes.data for a in (
            self._y, self._ydot, self._lam))

    def _evaluate(self, t: float, y: np.ndarray, lam_at: int | None) -> None:
        self._y[:] = y
        self._check(self.lib.dl_rhs(*self._at, t, self._y_at, self._ydot_at, lam_at))

    def generate(self, name: str) -> None:
        """Generate the registry's function ``name`` (if not yet) and give C its place
        in the model (a function only an implicit step calls, made when a run first
        needs it: ``method="auto"`` switching to Radau).

        Parameters
        ----------
        name
            A function of the registry with a place in C (``"residual_jacobians"``).
        """
        place = library.FUNCTIONS[name]
        if self.model.fn[place].fn:
            return
        handle = self.num.compiled.functions[name].native
        if handle is None:
            raise NotApplicable(f"the model's {name} were not generated in C")
        # the shared model gains a function the loop's own code never calls: any run
        # reading it finds it set, or had set it itself (the same values)
        self.model.fn[place] = c_function(name, handle)

    def rhs(self, t: float, y: np.ndarray) -> np.ndarray:
        """``[qd, qdd]`` at ``(t, y)``, ``y = [q, qd]``."""
        self._evaluate(t, y, None)
        return self._ydot.copy()

    def solve(self, t: float, q: np.ndarray, qd: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``(qdd, lambda)`` at one state (with the Baumgarte terms, if any)."""
        self._evaluate(t, np.concatenate([q, qd]), self._lam_at)
        return self._ydot[self.n:].copy(), self._lam[: self.m].copy()

    def outputs(self, t: np.ndarray, y: np.ndarray, dynamics: bool = True
                ) -> dict[str, np.ndarray]:
        """What :func:`~dalembert.solvers.outputs.evaluate_outputs` returns, in one call
        (without ``dynamics``, no KKT solve: ``qdd``, multipliers and forces NaN)."""
        k, n, m = len(t), self.n, self.m
        times = np.ascontiguousarray(t, dtype=float)
        states = np.ascontiguousarray(y, dtype=float).reshape(k, 2 * n)
        out = output_arrays(k, n, m, dynamics)  # in dl_outputs' order of arguments
        # in chunks, so that a Ctrl-C is served between calls on a long trajectory
        for lo in range(0, k, OUTPUT_CHUNK):
            hi = min(k, lo + OUTPUT_CHUNK)
            at = [a[lo:].ctypes.data if dynamics or name not in SOLVED else None
                  for name, a in out.items()]  # NULL: C leaves the solves out
            with outside_python():  # the GIL is released: other threads run their Python
                status = self.lib.dl_outputs(*self._at, hi - lo, times[lo:].ctypes.data,
                                             states[lo:].ctypes.data, *at)
            self._check(status)
        if self.kept is not None and dynamics:
            self._minimum_norm(times, states, out)
        return out

    def inputs(self, t: np.ndarray, y: np.ndarray) -> np.ndarray:
        """The model's inputs at the states ``y`` (one row per time of ``t``) as C's
        evaluations set them: the inputs' callback's, then the sliding friction computed
        in C (:meth:`set_friction`); one row per state."""
        k, count = len(t), len(self.num.compiled.input_names)
        times = np.ascontiguousarray(t, dtype=float)
        states = np.ascontiguousarray(y, dtype=float).reshape(k, 2 * self.n)
        out = np.zeros((k, count))
        self._check(self.lib.dl_inputs(*self._at, k, times.ctypes.data, states.ctypes.data,
                                       self.num.compiled.input_offset, count,
                                       out.ctypes.data))
        return out

    def _minimum_norm(self, times: np.ndarray, states: np.ndarray,
                      out: dict[str, np.ndarray]) -> None:
        """With dependent rows, the multipliers as the Python loop reports them: C left
        the kept rows' ``mu`` and the force ``A_k^T mu`` (unique); the multipliers are
        the minimum-norm solution of ``A^T lambda = A_k^T mu`` over all rows (the same
        function as :func:`~dalembert.solvers.outputs.evaluate_outputs`), and the force
        is recomputed from them."""
        pattern, n = self.num.pattern, self.n
        for i, (t, y) in enumerate(zip(times, states)):
            Av = self.num.velocity_sparse(t, y[:n])[0]
            lam = min_norm_multipliers(pattern.dense_A(Av), out["constraint_forces"][i])
            out["multipliers"][i] = lam
            out["constraint_forces"][i] = matvec(pattern.A_cols, pattern.A_rows, Av, lam, n)

    def projection_arguments(self) -> tuple[int, int, int, float, float]:
        """The arguments of ``dl_project`` after ``(model, data, t, y)``, as :meth:`project`
        passes them (the C loop projects with the same)."""
        return self._holonomic_mask, FAST_NEWTON, MAX_NEWTON, POSITION_TOL, ACCEPT_TOL

    def project(self, t: float, y: np.ndarray) -> np.ndarray:
        """``y`` projected onto the constraints; the Python projector if C cannot."""
        self._y[:] = y
        status = self.lib.dl_project(*self._at, t, self._y_at, *self.projection_arguments())
        projected = self._y.copy()
        if status == library.OK:
            return projected
        if self._fallback is None:
            self._fallback = StepProjector(self.num, self.kept)
        return self._fallback(t, np.asarray(y, dtype=float))


class _Tables:
    """The index tables a :class:`NativeSolver`'s C struct points to, made once per
    pattern and set of kept rows (C only reads them): the Schur structure's, the
    holonomic rows and their mask, and, where the kkt function scatters, the targets
    that make it write each value where the solve reads it. ``address[name]`` is the
    address C reads."""

    def __init__(self, structure: SchurStructure, num: NumericModel,
                 kkt: NativeHandle) -> None:
        m = num.m
        arrays = {name: np.ascontiguousarray(a, dtype=np.int64)
                  for name, a in structure.arrays().items()}
        arrays["holonomic"] = np.ascontiguousarray(num.holonomic_rows, dtype=np.int64)
        arrays["holonomic_mask"] = np.isin(np.arange(m), num.holonomic_rows).astype(np.uint8)
        self._arrays = arrays
        self.kkt_place = np.arange(kkt.size)  # [M, f, A, c] as they are, unless remapped
        self.address = {name: a.ctypes.data for name, a in arrays.items()}
        s, n = structure, num.n
        #: sizes and offsets of the solve's layout [blocks, u, a, c] in the KKT buffer
        self.parts = {"blocks": int(s.block_mat[-1]), "u": n, "a": int(s.pair_vec[-1])}
        self.start = dict(zip(self.parts, np.cumsum([0, *self.parts.values()]).tolist()))
        if kkt.K and kkt.targets:
            start = self.start
            slot = np.empty(n, dtype=np.int64)
            slot[s.slot_coord] = np.arange(n)
            c_at = start["a"] + self.parts["a"]
            place = np.concatenate([s.M_at, start["u"] + slot, start["a"] + s.A_at,
                                    c_at + np.arange(m)])
            assert len(place) == kkt.size  # [M, f, A, c]
            #: where each of the kkt function's values [M, f, A, c] lands in its buffer
            self.kkt_place = place
            self._targets = [np.ascontiguousarray(place[t], dtype=np.int64)
                             for t in kkt.targets]
            self._table = (ctypes.c_void_p * len(self._targets))(
                *(t.ctypes.data for t in self._targets))
            self.address["kkt_targets"] = ctypes.addressof(self._table)


class _SharedModel:
    """The ``dl_model`` of a compiled model, set of kept rows and stabilization: its
    tables, its generated functions and where the KKT values go in a run's buffer. C
    only reads it, so every :class:`NativeSolver` over it (runs with other parameter
    values, on other threads) shares it; each has its own ``dl_data``."""

    def __init__(self, tables: _Tables, structure: SchurStructure, num: NumericModel,
                 handles: dict, baumgarte: float) -> None:
        self._tables = tables  # kept alive: the struct points into it
        model = model_struct(structure, num.pattern, tables.address)
        model.n_hol, model.holonomic = len(num.holonomic_rows), tables.address["holonomic"]
        model.baumgarte, model.dropped_rtol = baumgarte, DROPPED_ROW_RTOL
        for name, h in handles.items():
            if name != "kkt" and h is not None:
                model.fn[library.FUNCTIONS[name]] = c_function(name, h)
        kkt, m, parts, start = handles["kkt"], num.m, tables.parts, tables.start
        #: the sizes of the solve's layout [blocks, u, a]; part_at: their places in the
        #: KKT values' buffer when the kkt function writes there (else buffers apart)
        self.parts: dict[str, int] = parts
        model.kkt_in_layout = bool(kkt.K and kkt.targets)
        if model.kkt_in_layout:  # the targets remapped: each value lands where it is read
            c_at = start["a"] + parts["a"]
            model.fn[library.FUNCTIONS["kkt"]] = c_function(
                "kkt", kkt, tables.address["kkt_targets"], c_at + m)
            self.part_at = {name: start[name] for name in parts}
            self.values_size, self.c_at = c_at + m, c_at
        else:  # [M, f, A, c], moved into the layout by load_kkt
            model.fn[library.FUNCTIONS["kkt"]] = c_function("kkt", kkt)
            self.part_at = {}
            self.values_size, self.c_at = kkt.size, kkt.size - m
        #: where each of the kkt function's values [M, f, A, c] is in a run's buffer
        self.kkt_place: np.ndarray = tables.kkt_place
        self.model = model


def c_function(name: str, h, target: int | None = None, size: int | None = None
              ) -> library.Function:
    """The generated function ``name`` as ``dl_model.fn`` holds it."""
    return library.Function(h.address or None, h.K or None, h.index or None,
                            target or h.target or None, size or h.size,
                            len(REGISTRY[name].arguments))
