"""The generated functions of a model, each declared once.

A :class:`Declaration` says everything both code generation routes need to know
about one generated function:

- its ``name`` (the compiled function is looked up by it);
- its ``arguments``, a selection of :data:`ARGUMENTS` (``t``, ``q``, ``qd``,
  ``qdd``, ``lam`` and the parameter vector ``p``, always last);
- its output: ``blocks``, each a vector or a matrix whose indices range over named
  index spaces (:data:`SPACES`: coordinates, constraint rows, holonomic rows) or a
  fixed range, concatenated in order; a ``dense`` block holds every position, a
  sparse one the union of the nonzero entries (its pattern, fixed at generation);
- ``derive``: the blocks' symbolic entries, keyed by their indices, from an
  :class:`~dalembert.equations.lagrange.Equations`. The global route
  (:func:`~.compiled.compile_equations`) applies it to the whole model's equations;
  the part route (:mod:`.assembly`) applies it to each part's and places every
  entry at its instances' global indices (a sum where several parts meet);
- whether it is generated with the model (``eager``) or on first use, and its
  place in the C runtime's function array (``native``, ``DL_FN_...`` in
  ``runtime.h``) when the C loop calls it.

Adding a generated function is one :func:`declare`; both routes, both backends and
the lookup (:class:`GeneratedFunctions`) follow from the declaration.
"""

from __future__ import annotations

import threading
from collections.abc import Callable, Iterator, Mapping, Sequence
from dataclasses import dataclass

import numpy as np
import sympy as sp

from ..equations.ggl import ggl_jacobian_entries
from ..equations.lagrange import Equations
from ..equations.residual import residual_jacobian_entries
from ..equations.sparse import gradient, nonzero_entries
from ..model.coordinates import t

#: Entries of one block, keyed by their indices (one per dimension).
Entries = dict[tuple[int, ...], sp.Expr]
#: Index spaces by name (sizes known once the model is): coordinates, constraint rows,
#: holonomic rows (the entries of ``psi``, in the order of ``holonomic_rows``).
SPACES = ("q", "row", "holonomic")
#: The arguments a generated function may take and the index space of each (``None``:
#: not indexed by the model's coordinates or rows). ``p`` is the parameter vector.
ARGUMENTS: dict[str, str | None] = {"t": None, "q": "q", "qd": "q", "qdd": "q",
                                    "lam": "row", "p": None}


@dataclass(frozen=True)
class Block:
    """One output block: ``name``, the index space (or fixed size) of each dimension, and
    whether it holds every position (``dense``) or only its pattern's."""

    name: str
    spaces: tuple[str | int, ...]
    dense: bool = False


@dataclass(frozen=True)
class Declaration:
    """One generated function (see the module)."""

    name: str
    arguments: tuple[str, ...]
    blocks: tuple[Block, ...]
    derive: Callable[[Equations], Mapping[str, Entries]]
    eager: bool = True
    native: int | None = None

    def __post_init__(self) -> None:
        unknown = [a for a in self.arguments if a not in ARGUMENTS]
        if unknown or not self.arguments or self.arguments[-1] != "p":
            raise ValueError(f"generated function {self.name!r}: the arguments must be "
                             f"among {tuple(ARGUMENTS)} and end with 'p', not {self.arguments}")
        for block in self.blocks:
            if not all(isinstance(s, int) or s in SPACES for s in block.spaces):
                raise ValueError(f"generated function {self.name!r}, block {block.name!r}: "
                                 f"an index space must be one of {SPACES} or a size")

    @property
    def symbol(self) -> str:
        """The compiled function's name in the global route's library."""
        return f"{self.name}_values"


REGISTRY: dict[str, Declaration] = {}


def declare(declaration: Declaration) -> Declaration:
    """Add ``declaration`` to :data:`REGISTRY` (its name must be new).

    Parameters
    ----------
    declaration
        The function's declaration.

    Examples
    --------
    >>> from dalembert.equations.lagrange import Equations
    >>> sorted(d.name for d in REGISTRY.values() if d.eager)
    ['energy', 'kkt', 'position', 'velocity']
    >>> declare(REGISTRY["kkt"])
    Traceback (most recent call last):
    ...
    ValueError: a generated function named 'kkt' is already declared
    """
    if declaration.name in REGISTRY:
        raise ValueError(f"a generated function named {declaration.name!r} is already declared")
    REGISTRY[declaration.name] = declaration
    return declaration


def declaration(name: str) -> Declaration:
    """The declaration of the generated function ``name``.

    Parameters
    ----------
    name
        A name in :data:`REGISTRY`.

    Examples
    --------
    >>> declaration("velocity").arguments
    ('t', 'q', 'p')
    >>> declaration("speed")
    Traceback (most recent call last):
    ...
    ValueError: no generated function named 'speed'; the registry has energy, ggl_jacobians, kkt, \
position, residual_jacobians, velocity
    """
    found = REGISTRY.get(name)
    if found is None:
        raise ValueError(f"no generated function named {name!r}; the registry has "
                         f"{', '.join(sorted(REGISTRY))}")
    return found


def argument_symbols(eqs: Equations, name: str, parameters: Sequence[sp.Symbol]) -> list:
    """The symbols argument ``name`` of a generated function unpacks into, for ``eqs``.

    Parameters
    ----------
    eqs
        The equations the function is generated from (a model's or a part's).
    name
        An argument in :data:`ARGUMENTS`.
    parameters
        The symbols of the parameter vector ``p``.

    Examples
    --------
    >>> from dalembert.examples import cartesian_pendulum
    >>> eqs = cartesian_pendulum.build().equations()
    >>> argument_symbols(eqs, "lam", []), argument_symbols(eqs, "qdd", [])
    ([lambda_1], [x_ddot, y_ddot])
    """
    coords = eqs.model.coords
    return {"t": lambda: [t], "q": lambda: list(coords.q), "qd": lambda: list(coords.qd),
            "qdd": lambda: list(coords.qdd), "lam": lambda: list(eqs.multipliers),
            "p": lambda: list(parameters)}[name]()


@dataclass(frozen=True, eq=False)
class BlockPattern:
    """Where a block's values sit: ``values[start:start + size]`` of the function's
    output, value ``k`` at indices ``(index[0][k], index[1][k], ...)`` of a
    ``shape`` array (no index twice)."""

    name: str
    shape: tuple[int, ...]
    index: tuple[np.ndarray, ...]
    start: int

    @property
    def size(self) -> int:
        return len(self.index[0]) if self.index else 0

    def dense(self, values: np.ndarray) -> np.ndarray:
        """The block as a dense array from its values.

        >>> b = BlockPattern("A", (2, 3), (np.array([0, 1]), np.array([2, 0])), 0)
        >>> b.dense(np.array([5.0, 7.0]))
        array([[0., 0., 5.],
               [7., 0., 0.]])
        """
        out = np.zeros(self.shape)
        out[self.index] = values
        return out


@dataclass(frozen=True, eq=False)
class FunctionLayout:
    """The blocks of one generated function's output, in order."""

    name: str
    blocks: tuple[BlockPattern, ...]

    @property
    def size(self) -> int:
        return sum(b.size for b in self.blocks)

    def block(self, name: str) -> BlockPattern:
        """The block called ``name``."""
        for b in self.blocks:
            if b.name == name:
                return b
        raise ValueError(f"generated function {self.name!r} has no block {name!r}")

    def split(self, values: np.ndarray) -> tuple[np.ndarray, ...]:
        """``values`` cut into the blocks' values (views)."""
        return tuple(values[b.start:b.start + b.size] for b in self.blocks)


def block_shape(block: Block, sizes: Mapping[str, int]) -> tuple[int, ...]:
    """The block's shape, given the size of each index space."""
    return tuple(sizes[s] if isinstance(s, str) else s for s in block.spaces)


def global_outputs(decl: Declaration, eqs: Equations,
                   sizes: Mapping[str, int]) -> tuple[list[sp.Expr], FunctionLayout]:
    """The expressions of ``decl`` for the whole model's ``eqs`` and their layout: a
    dense block every position in row-major order (the missing ones zero), a sparse
    one its entries in the order ``derive`` gives them.

    Parameters
    ----------
    decl
        The function.
    eqs
        The model's equations.
    sizes
        The size of each index space in :data:`SPACES`.
    """
    entries = decl.derive(eqs)
    exprs: list[sp.Expr] = []
    patterns = []
    for block in decl.blocks:
        shape = block_shape(block, sizes)
        found = entries[block.name]
        if block.dense:
            keys = [tuple(int(i) for i in k) for k in np.ndindex(*shape)]
            exprs += [found.get(k, sp.S.Zero) for k in keys]
        else:
            keys = list(found)
            exprs += list(found.values())
        index = np.array(keys, dtype=np.intp).reshape(-1, len(shape))
        patterns.append(BlockPattern(block.name, shape,
                                     tuple(index[:, d].copy() for d in range(len(shape))),
                                     len(exprs) - len(keys)))
    return exprs, FunctionLayout(decl.name, tuple(patterns))


@dataclass(frozen=True)
class Generated:
    """A compiled function and its layout: ``call(*arguments) -> values`` with the
    arguments of its declaration, in order; C functions carry ``native`` (a
    :class:`~.c_backend.NativeHandle`) and the library that holds them."""

    declaration: Declaration
    layout: FunctionLayout
    call: Callable[..., np.ndarray]

    @property
    def native(self) -> object | None:
        return getattr(self.call, "native", None)


class GeneratedFunctions:
    """The compiled functions of one model by name: the eager ones made with it, the
    others generated by ``generate`` the first time they are looked up (once, whatever
    the threads).

    Parameters
    ----------
    ready
        The functions generated so far.
    generate
        Makes the functions of the given declarations (one compiler run).

    Examples
    --------
    >>> from dalembert.examples import cartesian_pendulum
    >>> functions = cartesian_pendulum.build().compiled.functions
    >>> functions["kkt"].layout.size, "residual_jacobians" in functions
    (7, False)
    """

    def __init__(self, ready: dict[str, Generated],
                 generate: Callable[[Sequence[Declaration]], dict[str, Generated]]) -> None:
        self._ready = dict(ready)
        self._generate = generate
        self._lock = threading.Lock()

    def __getitem__(self, name: str) -> Generated:
        found = self._ready.get(name)
        if found is not None:
            return found
        decl = declaration(name)
        with self._lock:
            if name not in self._ready:
                self._ready.update(self._generate([decl]))
            return self._ready[name]

    def __contains__(self, name: object) -> bool:
        """Whether ``name`` has been generated (looking it up generates it)."""
        return name in self._ready

    def __iter__(self) -> Iterator[str]:
        return iter(list(self._ready))


# ---- the declarations --------------------------------------------------------------------

def _vector(values: Sequence[sp.Expr], nonzero: bool = True) -> Entries:
    return {(i,): e for i, e in enumerate(values) if not nonzero or e != 0}


def _kkt(eqs: Equations) -> dict[str, Entries]:
    return {"M": dict(nonzero_entries(eqs.M)), "f": _vector(eqs.f),
            "A": dict(nonzero_entries(eqs.A)), "c": _vector(eqs.c)}


def _velocity(eqs: Equations) -> dict[str, Entries]:
    return {"A": dict(nonzero_entries(eqs.A)), "b": _vector(eqs.b)}


def _position(eqs: Equations) -> dict[str, Entries]:
    return {"psi": _vector(eqs.model.constraints.psi, nonzero=False)}


def energy_vector(eqs: Equations) -> sp.Matrix:
    """``[T, V, h]`` with ``h = qd . dL/dqd - L`` (Jacobi); ``T`` and ``V`` are NaN when
    only a Lagrangian was given.

    Parameters
    ----------
    eqs
        The equations of a model (or of one part of a mechanism).

    Examples
    --------
    >>> from dalembert.examples import cartesian_pendulum
    >>> sp.expand(energy_vector(cartesian_pendulum.build().equations())[2])
    g*m*y + m*x_dot**2/2 + m*y_dot**2/2
    """
    model = eqs.model
    L = model.lagrangian
    qd = model.coords.qd
    jacobi = sp.Add(*(qd[k] * p for k, p in gradient(L, qd).items())) - L
    T = model.kinetic if model.kinetic is not None else sp.nan
    V = model.potential if model.potential is not None else sp.nan
    return sp.Matrix([T, V, jacobi])


def _energy(eqs: Equations) -> dict[str, Entries]:
    return {"energy": _vector(energy_vector(eqs), nonzero=False)}


def _residual_jacobians(eqs: Equations) -> dict[str, Entries]:
    found = residual_jacobian_entries(eqs)  # keyed (row, column)
    return {"r1_q": dict(found.r1_q), "r1_qd": dict(found.r1_qd), "r2_q": dict(found.r2_q),
            "r2_qd": dict(found.r2_qd)}


def _ggl_jacobians(eqs: Equations) -> dict[str, Entries]:
    found = ggl_jacobian_entries(eqs)  # keyed (row, column)
    return {"velocity_q": dict(found.velocity_q), "force_q": dict(found.force_q)}


_STATE = ("t", "q", "qd", "p")
_STATIC = ("t", "q", "p")

#: ``[M values, f, A values, c]``: ``M qdd = f + A^T lambda``, ``A qdd = c``.
KKT = declare(Declaration("kkt", _STATE, (
    Block("M", ("q", "q")), Block("f", ("q",), dense=True), Block("A", ("row", "q")),
    Block("c", ("row",), dense=True)), _kkt, native=0))
#: ``[A values, b]``: the velocity-level constraint ``A qd + b = 0``.
VELOCITY = declare(Declaration("velocity", _STATIC, (
    Block("A", ("row", "q")), Block("b", ("row",), dense=True)), _velocity, native=1))
#: ``psi``: the holonomic rows' position-level constraint.
POSITION = declare(Declaration("position", _STATIC, (
    Block("psi", ("holonomic",), dense=True),), _position, native=2))
#: ``[T, V, h]`` (:func:`energy_vector`).
ENERGY = declare(Declaration("energy", _STATE, (Block("energy", (3,), dense=True),),
                             _energy, native=3))
#: The Jacobians by ``q`` and ``qd`` of the KKT residuals ``r1 = M qdd - f - A^T lam``
#: (``n x n``) and ``r2 = A qdd - c`` (``m x n``), :mod:`dalembert.equations.residual`.
RESIDUAL_JACOBIANS = declare(Declaration(
    "residual_jacobians", ("t", "q", "qd", "qdd", "lam", "p"), (
        Block("r1_q", ("q", "q")), Block("r1_qd", ("q", "q")), Block("r2_q", ("row", "q")),
        Block("r2_qd", ("row", "q"))), _residual_jacobians, eager=False, native=4))
#: ``d (A qd + b)/dq`` (``m x n``) and ``d (A^T lam)/dq`` (``n x n``): what the stabilized
#: index-2 (GGL) form adds to the residuals' Jacobians (:mod:`dalembert.equations.ggl`).
GGL_JACOBIANS = declare(Declaration(
    "ggl_jacobians", ("t", "q", "qd", "lam", "p"), (
        Block("velocity_q", ("row", "q")), Block("force_q", ("q", "q"))),
    _ggl_jacobians, eager=False))
