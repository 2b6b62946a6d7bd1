"""Numeric functions of a model, generated once and bound to parameter values.

:func:`compile_equations` turns the symbolic equations into the flat functions of
the registry (:mod:`.registry`: KKT blocks, velocity-level constraint,
position-level constraint, energies; the residuals' Jacobians on first use),
compiled C when a compiler exists, else NumPy (:mod:`.c_backend` says why, with
numbers). ``M`` and ``A`` come out as the values of a fixed sparsity pattern
(:class:`SparsePattern`, computed once), so an evaluation costs time in
proportion to the nonzeros; dense views are built on request. The functions take
the parameter values as an array, so a :class:`CompiledEquations` is generated
once per System and re-bound to new values at no cost.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from functools import cached_property, partial
from typing import TypeVar

import numpy as np

from ..equations.lagrange import Equations
from ..numerics.state_layout import StateLayout
from . import c_backend
from .registry import (
    REGISTRY,
    Declaration,
    Generated,
    GeneratedFunctions,
    argument_symbols,
    global_outputs,
)
from .static import StaticFunctions, StaticValues, compile_static

T = TypeVar("T")


@dataclass(frozen=True, eq=False)
class SparsePattern:
    """Fixed sparsity of ``M`` (``n x n``) and ``A`` (``m x n``): row and column of each value.

    The generated functions return only these entries, in this order; the pattern
    is computed once from the symbolic matrices (an entry that is zero symbolically
    is zero at every state). Compared by identity and hashed so: what the solvers
    compute from the pattern alone (index maps, orders) is kept in their typed caches
    keyed by it (:mod:`dalembert.solvers.pattern_cache`), so that a model simulated
    many times computes it once.
    """

    n: int
    m: int
    M_rows: np.ndarray
    M_cols: np.ndarray
    A_rows: np.ndarray
    A_cols: np.ndarray
    _remembered: dict = field(default_factory=dict, init=False, repr=False)

    def remember(self, key: object, make: Callable[[], T]) -> T:
        """The value remembered under ``key``, made by ``make()`` the first time.

        The C package's own keyed cache (:mod:`dalembert.solvers.native`); the Python
        solvers keep theirs in typed :class:`~dalembert.solvers.pattern_cache.PatternCache`
        objects. A value kept here is shared by every run and thread of the model.

        >>> p = SparsePattern(1, 0, np.zeros(1, int), np.zeros(1, int), np.zeros(0, int),
        ...                   np.zeros(0, int))
        >>> p.remember("size", lambda: 1) + p.remember("size", lambda: 2)
        2
        """
        if key not in self._remembered:
            self._remembered[key] = make()
        return self._remembered[key]

    def dense_M(self, values: np.ndarray) -> np.ndarray:
        M = np.zeros((self.n, self.n))
        M[self.M_rows, self.M_cols] = values
        return M

    def dense_A(self, values: np.ndarray) -> np.ndarray:
        A = np.zeros((self.m, self.n))
        A[self.A_rows, self.A_cols] = values
        return A


@dataclass(frozen=True)
class CompiledEquations:
    """Generated functions of a model; see :class:`NumericModel`.

    ``functions[name]`` is the compiled function ``name`` of the registry
    (:mod:`.registry`) with its layout, generated on first lookup unless the model made
    it: ``kkt`` returns ``[M values, f, A values, c]`` from ``(t, q, qd, p)`` and
    ``velocity`` ``[A values, b]`` from ``(t, q, p)`` (values in ``pattern`` order);
    ``kkt_values`` and the like are these functions' calls. ``backend`` is ``"c"`` or
    ``"numpy"`` (see :mod:`dalembert.codegen.c_backend`).
    """

    functions: GeneratedFunctions
    pattern: SparsePattern
    holonomic_rows: tuple[int, ...]
    backend: str = "numpy"
    #: Generates the static function (:mod:`.static`) when statics first asks for it.
    static_builder: Callable[[], StaticFunctions] | None = field(default=None, repr=False)
    #: The functions' parameter vector from the model's parameter values (a model
    #: assembled from parts appends values derived from them; default: as given).
    expand_parameters: Callable[[np.ndarray], np.ndarray] | None = field(default=None,
                                                                         repr=False)
    #: The model's inputs (:class:`~dalembert.System` ``inputs=``): their values sit in
    #: the parameter vector right after the parameters', from ``input_offset`` on.
    input_names: tuple[str, ...] = ()
    input_offset: int = 0

    @property
    def kkt_values(self) -> Callable[..., np.ndarray]:
        return self.functions["kkt"].call

    @property
    def velocity_values(self) -> Callable[..., np.ndarray]:
        return self.functions["velocity"].call

    @property
    def position_values(self) -> Callable[..., np.ndarray]:
        return self.functions["position"].call

    @property
    def energy_values(self) -> Callable[..., np.ndarray]:
        return self.functions["energy"].call

    @cached_property
    def static(self) -> StaticFunctions:
        """The static function, generated by the route and backend of the others."""
        if self.static_builder is None:
            raise ValueError("these equations were compiled without their static function")
        return self.static_builder()

    @property
    def n(self) -> int:
        return self.pattern.n

    @property
    def m(self) -> int:
        return self.pattern.m

    def kkt_blocks(self, t: float, q: np.ndarray, qd: np.ndarray, p: np.ndarray):
        """Dense ``(M, f, A, c)``."""
        Mv, f, Av, c = self.split_kkt(self.kkt_values(t, q, qd, p))
        return self.pattern.dense_M(Mv), f, self.pattern.dense_A(Av), c

    def split_kkt(self, values: np.ndarray) -> tuple[np.ndarray, ...]:
        """``[M values, f, A values, c]`` cut into its four parts (views)."""
        k1 = len(self.pattern.M_rows)
        k2 = k1 + self.n
        k3 = k2 + len(self.pattern.A_rows)
        return values[:k1], values[k1:k2], values[k2:k3], values[k3:]

    def velocity_constraint(self, t: float, q: np.ndarray, p: np.ndarray):
        """Dense ``(A, b)``."""
        k = len(self.pattern.A_rows)
        values = self.velocity_values(t, q, p)
        return self.pattern.dense_A(values[:k]), values[k:]

    def bind(self, p: np.ndarray) -> NumericModel:
        """The functions bound to the model's parameter values ``p`` (the inputs at 0;
        read-only: a run writes its inputs into its own copy, :meth:`NumericModel.for_run`)."""
        p = np.concatenate([np.asarray(p, dtype=float), np.zeros(len(self.input_names))])
        values = p if self.expand_parameters is None else self.expand_parameters(p)
        values.flags.writeable = False
        return NumericModel(self, values)


@dataclass(frozen=True)
class SparseBlock:
    """One block of a generated function at one state: ``values`` at ``(rows, cols)`` of
    a ``shape`` matrix (each position once)."""

    rows: np.ndarray
    cols: np.ndarray
    values: np.ndarray
    shape: tuple[int, int]

    def dense(self) -> np.ndarray:
        """The block as a dense array.

        >>> SparseBlock(np.array([1]), np.array([0]), np.array([2.5]), (2, 2)).dense()
        array([[0. , 0. ],
               [2.5, 0. ]])
        """
        out = np.zeros(self.shape)
        out[self.rows, self.cols] = self.values
        return out


@dataclass(frozen=True)
class ResidualJacobians:
    """``d r1/dq``, ``d r1/dqd`` (``n x n``), ``d r2/dq``, ``d r2/dqd`` (``m x n``) of the
    KKT residuals ``r1 = M qdd - f - A^T lambda`` and ``r2 = A qdd - c`` at one state
    (:mod:`dalembert.equations.residual`)."""

    r1_q: SparseBlock
    r1_qd: SparseBlock
    r2_q: SparseBlock
    r2_qd: SparseBlock

    def dense(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """The four blocks as dense arrays, in the order of the fields."""
        return self.r1_q.dense(), self.r1_qd.dense(), self.r2_q.dense(), self.r2_qd.dense()


@dataclass(frozen=True)
class NumericModel:
    """The compiled equations with numeric parameter values.

    - ``kkt_blocks(t, q, qd) -> (M, f, A, c)`` (dense arrays)
    - ``kkt_sparse(t, q, qd) -> (M values, f, A values, c)`` in ``pattern`` order
    - ``velocity_constraint(t, q) -> (A, b)`` with ``A qd + b = 0`` (dense ``A``)
    - ``velocity_sparse(t, q) -> (A values, b)``
    - ``position_constraint(t, q) -> psi`` (holonomic rows only)
    - ``energies(t, q, qd) -> [T, V, h]`` with ``h = qd . dL/dqd - L`` (Jacobi)
    - ``forces_at_rest(t, q) -> f(q, 0, t)`` and ``static_derivatives(t, q)`` (statics)
    - ``residual_jacobians(t, q, qd, qdd, lam)``: the KKT residuals' Jacobians
    - ``evaluate(name, *arguments)``: any function of the registry (:mod:`.registry`)
    """

    compiled: CompiledEquations
    p: np.ndarray

    @property
    def n(self) -> int:
        return self.compiled.n

    @property
    def m(self) -> int:
        return self.compiled.m

    @property
    def pattern(self) -> SparsePattern:
        return self.compiled.pattern

    @property
    def layout(self) -> StateLayout:
        """Where ``q`` and ``qd`` sit in a first-order state of this model."""
        return StateLayout(self.n)

    @property
    def holonomic_rows(self) -> tuple[int, ...]:
        return self.compiled.holonomic_rows

    def evaluate(self, name: str, *arguments: object) -> np.ndarray:
        """The values of the registry's function ``name`` (generated on first use) at
        ``arguments``: those of its declaration but the parameter vector, in order.

        Parameters
        ----------
        name
            The function's name in :data:`~.registry.REGISTRY`.
        *arguments
            ``t``, ``q``, ... as the declaration lists them, ``p`` excepted.

        Examples
        --------
        >>> from dalembert.examples import cartesian_pendulum
        >>> num = cartesian_pendulum.build().numeric()
        >>> num.evaluate("position", 0.0, np.array([0.0, -2.0]))  # x^2 + y^2 - l^2, l = 1
        array([3.])
        """
        return self.compiled.functions[name].call(*arguments, self.p)

    def kkt_blocks(self, t: float, q: np.ndarray, qd: np.ndarray):
        return self.compiled.kkt_blocks(t, q, qd, self.p)

    def kkt_sparse(self, t: float, q: np.ndarray, qd: np.ndarray):
        return self.compiled.split_kkt(self.compiled.kkt_values(t, q, qd, self.p))

    def velocity_constraint(self, t: float, q: np.ndarray):
        return self.compiled.velocity_constraint(t, q, self.p)

    def velocity_sparse(self, t: float, q: np.ndarray):
        k = len(self.pattern.A_rows)
        values = self.compiled.velocity_values(t, q, self.p)
        return values[:k], values[k:]

    def position_constraint(self, t: float, q: np.ndarray) -> np.ndarray:
        return self.compiled.position_values(t, q, self.p)

    def energies(self, t: float, q: np.ndarray, qd: np.ndarray) -> np.ndarray:
        return self.compiled.energy_values(t, q, qd, self.p)

    def residual_jacobians(self, t: float, q: np.ndarray, qd: np.ndarray, qdd: np.ndarray,
                           lam: np.ndarray) -> ResidualJacobians:
        """The Jacobians by ``q`` and ``qd`` of ``r1 = M qdd - f - A^T lam`` and
        ``r2 = A qdd - c`` at one state, as sparse blocks (generated, exactly, on the
        first call).

        Parameters
        ----------
        t, q, qd
            The state.
        qdd, lam
            The accelerations and multipliers the residuals are taken at (any values:
            the residuals need not vanish).

        Examples
        --------
        A particle on a circle, ``r1 = m qdd - 2 lam q - f``: ``d r1/dq = -2 lam I``.

        >>> from dalembert.examples import cartesian_pendulum
        >>> num = cartesian_pendulum.build().numeric()
        >>> J = num.residual_jacobians(0.0, np.array([0.6, -0.8]), np.zeros(2),
        ...                            np.zeros(2), np.array([3.0]))
        >>> J.r1_q.dense()
        array([[-6.,  0.],
               [ 0., -6.]])
        """
        found = self.compiled.functions["residual_jacobians"]
        values = found.call(t, q, qd, qdd, lam, self.p)
        blocks = [SparseBlock(b.index[0], b.index[1], v, (b.shape[0], b.shape[1]))
                  for b, v in zip(found.layout.blocks, found.layout.split(values))]
        return ResidualJacobians(*blocks)

    @property
    def inputs(self) -> np.ndarray:
        """The inputs' current values (a view into the parameter vector)."""
        start = self.compiled.input_offset
        return self.p[start:start + len(self.compiled.input_names)]

    def for_run(self) -> NumericModel:
        """The same functions and values with a parameter vector of the run's own, whose
        inputs :meth:`set_inputs` sets (a bound model's values are read-only: whoever
        shares it, another run or thread, sees them unchanged).

        Examples
        --------
        >>> from dalembert.examples import cartesian_pendulum
        >>> num = cartesian_pendulum.build().numeric()
        >>> run = num.for_run()
        >>> run.p is num.p, bool(np.array_equal(run.p, num.p)), num.p.flags.writeable
        (False, True, False)
        """
        return NumericModel(self.compiled, self.p.copy())

    def set_inputs(self, values: np.ndarray) -> None:
        """Set the inputs' values, which every evaluation from now on reads (on a run's
        model, :meth:`for_run`; a bound model's values are read-only)."""
        self.inputs[:] = values

    def forces_at_rest(self, t: float, q: np.ndarray) -> np.ndarray:
        """``f(q, 0, t)``: the generalized forces with every velocity zero."""
        return self.kkt_sparse(t, q, np.zeros(self.n))[1]

    def static_derivatives(self, t: float, q: np.ndarray) -> StaticValues:
        """The derivatives statics needs at ``(t, q)`` (:mod:`.static`; the static
        function is generated on the first call)."""
        return self.compiled.static.evaluate(t, q, self.p)


def compile_equations(eqs: Equations, backend: str | None = None) -> CompiledEquations:
    """Generate the numeric functions of ``eqs`` (C when a compiler exists, else NumPy):
    the registry's eager ones now, the others on first use.

    ``backend`` (``"c"`` or ``"numpy"``) overrides :func:`~.c_backend.backend`.
    """
    model = eqs.model
    cons = model.constraints
    use = c_backend.backend() if backend is None else backend
    made = generate_global(eqs, use, [d for d in REGISTRY.values() if d.eager])
    used = "c" if hasattr(made["kkt"].call, "library") else "numpy"
    kkt = made["kkt"].layout
    M, A = kkt.block("M"), kkt.block("A")
    pattern = SparsePattern(model.coords.n, cons.m, *M.index, *A.index)
    return CompiledEquations(GeneratedFunctions(made, partial(generate_global, eqs, used)),
                             pattern, cons.holonomic_rows, used,
                             partial(compile_static, eqs, used),
                             input_names=tuple(u.name for u in model.inputs),
                             input_offset=len(model.parameters))


def generate_global(eqs: Equations, use: str,
                    declarations: Sequence[Declaration]) -> dict[str, Generated]:
    """The functions of ``declarations`` for the whole model's ``eqs``, in one library.

    Parameters
    ----------
    eqs
        The model's equations.
    use
        ``"c"`` or ``"numpy"``.
    declarations
        The functions to generate.
    """
    model = eqs.model
    sizes = {"q": model.coords.n, "row": model.constraints.m,
             "holonomic": len(model.constraints.holonomic_rows)}
    values = [*model.parameters, *model.inputs]  # the parameter vector: inputs last
    specs, layouts = [], []
    for decl in declarations:
        exprs, layout = global_outputs(decl, eqs, sizes)
        arguments = [(a, argument_symbols(eqs, a, values)) for a in decl.arguments]
        specs.append((decl.symbol, arguments, exprs))
        layouts.append(layout)
    functions = c_backend.build_flat_functions(specs, use=use)
    return {d.name: Generated(d, layout, fn)
            for d, layout, fn in zip(declarations, layouts, functions)}
