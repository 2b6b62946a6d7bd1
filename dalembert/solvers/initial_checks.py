"""Checks of the model at the initial state that no error downstream would name.

Each turns a silently wrong answer, or a misleading error deep in a solve, into
a message naming the culprit:

- :func:`check_finite`: the model's values there (``M``, ``f``, ``A``, ``c``, ``b``,
  ``psi``) are finite. The inputs are checked at the door, so a value that is not
  finite here overflows or divides by zero (``qd0 = 1e200`` squared); without this
  check the first KKT solve reports a "singular" matrix.
- :func:`check_kinetic_energy`: ``T = 1/2 qd^T M qd`` is not negative. A negative
  mass makes the KKT matrix regular and the motion wrong (a spring then runs
  away). ``M`` must be positive semidefinite; if it is not, it must at least be
  positive definite on the velocities the constraints allow (the KKT condition),
  which a quaternion's singular inertia block satisfies.
- :func:`check_resolvable`: each holonomic constraint can be met to the projection's
  tolerance. That tolerance is absolute (``POSITION_TOL`` on ``psi``, for systems
  whose coordinates are of order one), so a constraint whose gradient is tiny
  (``x^2 + y^2 - l^2`` with ``l = 1e-300``: ``l^2`` underflows to 0, and Newton
  stops at ``|r| = 1e-7`` with ``|psi| = 1e-14``) would count as satisfied far from
  its zero set. A scale-aware test would be relative to the constraint's own size,
  which a linear row at the origin (``z = 0``) does not have; the test here is
  the distance to the constraint that the tolerance allows, ``max(|psi|, tol) /
  |grad psi|``, against :data:`RESOLUTION` times the system's size, and a constraint
  failing it is refused with the advice to rescale it, rather than solved wrongly.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np
import scipy.linalg
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

from ..codegen.compiled import NumericModel, SparsePattern
from ..errors import ConstraintError, InitialConditionError, ModelError
from ..numerics.gauss_newton import POSITION_TOL
from ..numerics.rank import RANK_RTOL
from .pattern_cache import PatternCache

#: The largest distance from a holonomic constraint that its residual tolerance may
#: allow, relative to ``max(1, max|q|)``.
RESOLUTION = 1e-9
#: Above this many coordinates a mass matrix that is not positive semidefinite is
#: refused without testing the (dense) null space of ``A``.
NULL_SPACE_MAX = 500


def check_finite(num: NumericModel, t: float, q: np.ndarray, qd: np.ndarray | None,
                 names: Sequence[str], constraint_names: Sequence[str], where: str) -> None:
    """Raise :class:`InitialConditionError` naming the first model value that is not finite.

    Parameters
    ----------
    num
        The bound numeric model.
    t, q, qd
        The state (finite). Without ``qd`` only what the position projection uses is
        checked (``A``, ``b``, ``psi``): a model undefined where the given positions
        lie may be defined where they are projected to.
    names, constraint_names
        Coordinate and constraint names, for the message.
    where
        ``"at the initial state"`` or similar, for the message.

    >>> from dalembert.examples import load
    >>> pendulum = load("pendulum").build()
    >>> check_finite(pendulum.numeric(), 0.0, np.array([1.0, 0.0]), np.array([0.0, 1e200]),
    ...              ("x", "y"), ("rod",), "at the initial state")  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    dalembert.errors.InitialConditionError: the model is not finite at the initial state: ...
    """
    pat = num.pattern
    holonomic = num.holonomic_rows
    with np.errstate(all="ignore"):
        Av, b = num.velocity_sparse(t, q)
        psi = num.position_constraint(t, q)
        checks: list[tuple[np.ndarray, Callable[[int], str]]] = [
            (psi, lambda k: f"constraint {constraint_names[int(holonomic[k])]!r}"),
            (Av, lambda k: f"the derivative of constraint "
                           f"{constraint_names[int(pat.A_rows[k])]!r} by "
                           f"{names[int(pat.A_cols[k])]}"),
            (b, lambda k: f"the velocity term b of constraint {constraint_names[k]!r}"),
        ]
        if qd is not None:
            Mv, f, _, c = num.kkt_sparse(t, q, qd)
            checks += [
                (Mv, lambda k: f"the mass matrix entry M[{names[int(pat.M_rows[k])]}, "
                               f"{names[int(pat.M_cols[k])]}]"),
                (f, lambda k: f"the generalized force on {names[k]!r}"),
                (c, lambda k: f"the acceleration term c of constraint {constraint_names[k]!r}"),
            ]
    for values, describe in checks:
        bad = np.flatnonzero(~np.isfinite(values))
        if len(bad):
            largest = _largest_inputs(q, np.zeros(0) if qd is None else qd, num.p, names)
            raise InitialConditionError(
                f"the model is not finite {where}: {describe(int(bad[0]))} is "
                f"{values[bad[0]]}. The initial values and parameters are finite ({largest}), "
                "so an expression overflows or divides by zero there: start from a state "
                "where the model is defined, or rescale the values"
            )


def _largest_inputs(q: np.ndarray, qd: np.ndarray, p: np.ndarray, names: Sequence[str]) -> str:
    parts = []
    for label, values, suffix in (("q", q, ""), ("qd", qd, "_dot")):
        if values.size:
            k = int(np.argmax(np.abs(values)))
            parts.append(f"largest |{label}|: {abs(values[k]):.3g} for {names[k]}{suffix}")
    if p.size:
        parts.append(f"largest |parameter|: {np.abs(p).max():.3g}")
    return "; ".join(parts)


def check_kinetic_energy(num: NumericModel, t: float, q: np.ndarray, qd: np.ndarray,
                         names: Sequence[str], kept: np.ndarray | None) -> None:
    """Raise :class:`ModelError` where the kinetic energy can be negative.

    ``M`` positive semidefinite passes (block by block: each connected block of its
    pattern, a body's, is tested alone). Otherwise, up to :data:`NULL_SPACE_MAX`
    coordinates, ``M`` positive definite on the null space of ``A`` (the ``kept``
    rows) passes too: the KKT matrix is regular and the motion determined.

    Parameters
    ----------
    num
        The bound numeric model.
    t, q, qd
        The state.
    names
        Coordinate names, for the message.
    kept
        The independent rows of ``A`` (``None``: all).

    >>> import sympy as sp
    >>> from dalembert import System, coordinates
    >>> x, = coordinates("x")
    >>> spring = System([x], kinetic=-x.diff()**2 / 2, potential=x**2 / 2)
    >>> check_kinetic_energy(spring.numeric(), 0.0, np.ones(1), np.zeros(1), ("x",),
    ...                      None)  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    dalembert.errors.ModelError: the kinetic energy is negative for some velocities ...
    """
    pat = num.pattern
    Mv = num.kkt_sparse(t, q, qd)[0]
    found = _most_negative_block(pat, Mv)
    if found is None:
        return
    if num.n <= NULL_SPACE_MAX and _positive_on_null_space(num, t, q, Mv, kept):
        return
    value, block, direction, largest = found
    along = ", ".join(f"{names[i]}: {v:+.3g}" for i, v in zip(block, direction)
                      if abs(v) > 0.1 * np.abs(direction).max())
    diagonal = [f"M[{names[i]}, {names[i]}] = {d:.6g}" for i, d in
                zip(block, _block_matrix(pat, Mv, block).diagonal()) if d < 0]
    raise ModelError(
        f"the kinetic energy is negative for some velocities at the initial state: the mass "
        f"matrix M (T = 1/2 qd^T M qd) has the eigenvalue {value:.6g} "
        f"in the block of {', '.join(names[i] for i in block)}"
        + (f" (whose largest is {largest:.6g})" if len(block) > 1 else "")
        + f", along {along}"
        + (f"; {', '.join(diagonal)}" if diagonal else "")
        + ". A negative mass or inertia in T? M must be positive semidefinite, or at least "
        "positive definite on the velocities the constraints allow"
    )


def _most_negative_block(pat: SparsePattern, Mv: np.ndarray):
    """``(eigenvalue, coordinates, direction, largest eigenvalue)`` of the block of ``M``
    with the most negative eigenvalue (relative to its largest), or ``None``."""
    worst = None
    for size, indices, fill in _MASS_BLOCKS.get(pat):
        stacked = np.zeros((len(indices), size, size))
        stacked[fill[0], fill[1], fill[2]] = Mv[fill[3]]
        values = np.linalg.eigvalsh(stacked)
        scale = np.abs(values).max(axis=1)
        relative = values[:, 0] / np.where(scale > 0, scale, 1.0)
        k = int(np.argmin(relative))
        if relative[k] < -RANK_RTOL and (worst is None or relative[k] < worst[0]):
            worst = (relative[k], indices[k])
    if worst is None:
        return None
    block = worst[1]
    values, vectors = np.linalg.eigh(_block_matrix(pat, Mv, block))
    return values[0], block, vectors[:, 0], values[-1]


#: Blocks of one size: ``(size, coordinates of each block (count, size), (block, row,
#: column, value index) of every entry of ``M`` in them)``.
MassBlocks = list[tuple[int, np.ndarray, tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]]]


def _mass_blocks(pat: SparsePattern) -> MassBlocks:
    """The connected blocks of ``M``'s pattern grouped by size: ``(size, coordinates of
    each block (count, size), (block, row, column, value index) of every entry)``."""
    graph = coo_matrix((np.ones(len(pat.M_rows)), (pat.M_rows, pat.M_cols)), (pat.n, pat.n))
    _, label = connected_components(graph, directed=False)
    order = np.argsort(label, kind="stable")
    starts = np.flatnonzero(np.r_[True, np.diff(label[order]) != 0])
    members = np.split(order, starts[1:])
    size_of = np.array([len(m) for m in members])
    position = np.empty(pat.n, dtype=np.intp)
    for m in members:
        position[m] = np.arange(len(m))
    groups: MassBlocks = []
    for size in np.unique(size_of):
        chosen = np.flatnonzero(size_of == size)
        rank = np.full(len(members), -1)
        rank[chosen] = np.arange(len(chosen))
        entries = np.flatnonzero(size_of[label[pat.M_rows]] == size)
        block = rank[label[pat.M_rows[entries]]]
        fill = (block, position[pat.M_rows[entries]], position[pat.M_cols[entries]], entries)
        groups.append((int(size), np.array([members[i] for i in chosen]), fill))
    return groups


#: The connected blocks of each pattern's ``M``.
_MASS_BLOCKS: PatternCache[MassBlocks] = PatternCache(lambda p, _: _mass_blocks(p),
                                                      "mass matrix blocks")


def _block_matrix(pat: SparsePattern, Mv: np.ndarray, block: np.ndarray) -> np.ndarray:
    inside = np.isin(pat.M_rows, block) & np.isin(pat.M_cols, block)
    where = {int(c): i for i, c in enumerate(block)}
    B = np.zeros((len(block), len(block)))
    for r, c, v in zip(pat.M_rows[inside], pat.M_cols[inside], Mv[inside]):
        B[where[int(r)], where[int(c)]] = v
    return B


def _positive_on_null_space(num: NumericModel, t: float, q: np.ndarray, Mv: np.ndarray,
                            kept: np.ndarray | None) -> bool:
    M = num.pattern.dense_M(Mv)
    if num.m == 0:
        return False
    A = num.velocity_constraint(t, q)[0]
    Z = scipy.linalg.null_space(A if kept is None else A[kept], rcond=RANK_RTOL)
    if Z.shape[1] == 0:
        return True
    values = np.linalg.eigvalsh(Z.T @ M @ Z)
    return bool(values[0] > RANK_RTOL * np.abs(values).max())


def check_resolvable(num: NumericModel, t: float, q: np.ndarray,
                     constraint_labels: Sequence[str]) -> None:
    """Raise :class:`ConstraintError` for a holonomic constraint too flat to resolve.

    The projection stops at ``|psi| <= POSITION_TOL``; at a point where
    ``|grad psi|`` is tiny that can be far from ``psi = 0``. Rows whose gradient
    vanishes are the rank test's business (dependent rows), not this one's.

    Parameters
    ----------
    num
        The bound numeric model.
    t, q
        The consistent positions.
    constraint_labels
        Each constraint described, for the message.

    >>> import sympy as sp
    >>> from dalembert import Holonomic, System, coordinates
    >>> x, y = coordinates("x y")
    >>> rod = System([x, y], kinetic=(x.diff()**2 + y.diff()**2) / 2,
    ...              constraints=[Holonomic(x**2 + y**2 - sp.Float(1e-300)**2, name="rod")])
    >>> check_resolvable(rod.numeric(), 0.0, np.array([5.6e-8, 0.0]),
    ...                  ["constraint 'rod'"])  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    dalembert.errors.ConstraintError: constraint 'rod' cannot be resolved ...
    """
    rows = np.asarray(num.holonomic_rows, dtype=np.intp)
    if not len(rows):
        return
    pat = num.pattern
    psi = np.abs(num.position_constraint(t, q))
    Av, _ = num.velocity_sparse(t, q)
    gradient = np.zeros(num.m)  # the largest entry of each row (a square can underflow)
    np.maximum.at(gradient, pat.A_rows, np.abs(Av))
    gradient = gradient[rows]
    size = max(1.0, float(np.abs(q).max(initial=0.0)))
    allowed = np.maximum(psi, POSITION_TOL) / np.where(gradient > 0, gradient, np.inf)
    bad = np.flatnonzero(allowed > RESOLUTION * size)
    if len(bad):
        k = int(bad[np.argmax(allowed[bad])])
        raise ConstraintError(
            f"{constraint_labels[rows[k]]} cannot be resolved at the initial state: its "
            f"gradient there is only {gradient[k]:.3g}, so its residual tolerance "
            f"({POSITION_TOL:g}, absolute, for coordinates of order one) allows positions "
            f"{allowed[k]:.3g} off the constraint (residual now {psi[k]:.3g}). Rescale it "
            "so that its terms are of order one: choose units in which its lengths are near "
            "1 (micrometres for a 1e-6 m rod), or multiply it by the inverse of its scale "
            "(k * (x**2 + y**2) - 1 with k = 1/l**2); a length below 1e-154 squares to 0 in "
            "floating point"
        )
