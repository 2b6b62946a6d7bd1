"""Static equilibrium of a constrained :class:`~dalembert.System`.

At rest (``qd = 0``) the accelerations vanish, so ``M qdd = f + A^T lambda``
becomes

    f(q, 0, t) + A(q, t)^T lambda = 0,      psi(q, t) = 0,

``n + h`` equations for the ``n`` coordinates and ``m`` multipliers (``h`` holonomic
constraints; a Pfaffian row ``A_k qd + b_k = 0`` only adds ``b_k(q, t) = 0`` when
its ``b_k`` is not identically zero). For a conservative system ``f = -dV/dq``;
using the whole ``f`` also covers non-conservative position forces and
rotating-frame terms (``T`` containing ``Omega^2 x^2`` gives the centrifugal
force). These are the stationarity conditions of
:mod:`dalembert.statics.extremum` with ``-dV/dq`` replaced by ``f``, and they are
solved the same way: Newton's method on the KKT system with the exact Jacobian
(generated once per System), a backtracking line search, and
:func:`scipy.optimize.root` as a fallback.

Stability is read from the constrained stiffness
``K = -(df/dq + sum_k lambda_k d2psi_k/dq2)`` at ``(q*, 0)`` restricted to the
tangent space of the constraints, ``Z^T K Z`` (see
:mod:`dalembert.statics.linearize`).
"""

from __future__ import annotations

import warnings
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import scipy.linalg
from numpy.typing import NDArray

from ..errors import (
    EquilibriumNotFoundError,
    InconsistentConstraintsError,
    MarginalStabilityError,
    RedundantConstraintsWarning,
    user_stacklevel,
)
from ..model.coordinates import key_name
from ..model.values import coordinate_values, free_mask
from ..numerics.gauss_newton import ACCEPT_TOL, gauss_newton
from ..numerics.rank import dependent_error, min_norm_multipliers, sparse_constraint_rank
from ..options import FIXED, PARAMETER_VALUES, REDUNDANT_CONSTRAINTS, RedundantConstraints
from ..rules import NONE, FiniteNumber, OneOf, PositiveInteger, PositiveNumber, checked_keywords

# The Newton iteration (exact Jacobian, lstsq steps, Armijo backtracking, rounding-level
# acceptance) and its scipy.optimize.root fallback are shared with extremum().
from .newton import Attempt, newton_iterations, root_then_newton
from .static_system import StaticsModel, StaticSystem, static_system

__all__ = [
    "STABILITIES",
    "Equilibrium",
    "classify_stiffness",
    "equilibrium",
    "tangent_basis",
]

#: Possible values of :attr:`Equilibrium.stability`.
STABILITIES = ("stable", "unstable", "marginal", "undetermined")

#: An eigenvalue of ``Z^T K Z`` with ``|k| <= MARGINAL_RTOL * max|K|`` counts as zero.
MARGINAL_RTOL = 1e-8
#: What to do where the constrained stiffness is singular.
ON_MARGINAL = [OneOf(("report", "raise"))]

#: Gauss-Newton iterations of the projection of the guess (a guess may be far off).
_PROJECTION_ITER = 100

Array = NDArray[np.float64]


# --------------------------------------------------------------------------- result


@dataclass(frozen=True, eq=False)
class Equilibrium:
    """A static equilibrium ``f(q*, 0, t) + A^T lambda* = 0`` on the constraints.

    Attributes
    ----------
    q : numpy.ndarray
        Coordinates at equilibrium, in the System's coordinate order.
    multipliers : numpy.ndarray
        ``lambda*``, one per constraint (constraint order).
    constraint_forces : numpy.ndarray
        Generalized constraint (reaction) forces ``A^T lambda*`` (also ``reaction``).
    residual : float
        Largest absolute value of the equations solved at the point.
    stability : str
        One of :data:`STABILITIES`, from the eigenvalues of the constrained
        stiffness ``Z^T K Z`` (``K = -(df/dq + sum lambda_k d2psi_k/dq2)``,
        ``Z`` an orthonormal basis of the tangent space of the holonomic
        constraints and of the ``fixed`` coordinates): ``"stable"`` if all are
        positive (a strict minimum of ``V`` on the constraints for a conservative
        system; Lyapunov stable by Lagrange-Dirichlet, also with gyroscopic and
        dissipative forces), ``"unstable"`` if one is negative (rigorous without
        gyroscopic terms, or with an odd number of negative ones; otherwise check
        :attr:`Linearization.eigenvalues`), ``"marginal"`` if none is negative and
        one is zero (the linear analysis cannot decide). With Pfaffian
        (nonholonomic) constraints the velocities are confined to ``null(A)``
        but the positions are not, equilibria form families and no stiffness
        criterion applies: ``"undetermined"``. With every direction ``fixed``,
        there is no free motion and the point counts as ``"stable"``.
    stiffness_eigenvalues : numpy.ndarray
        Ascending eigenvalues of the symmetric part of ``Z^T K Z``.
    holding_forces : numpy.ndarray
        Generalized force ``-(f0 + A^T lambda)`` that must be applied to each
        ``fixed`` coordinate to hold it (zero for the free ones).
    iterations : int
        Newton iterations used.
    method : str
        ``"newton"`` or ``"newton after scipy.optimize.root(hybr)"`` (or ``lm``).
    coordinate_names, constraint_names : tuple of str
    t : float
        Time at which ``f`` and the constraints were evaluated.
    parameter_values : dict
        Parameter values used, by name.
    fixed : tuple of str
        Coordinates held at their guess values.
    dependent_constraints : tuple of str
        Constraints that are combinations of those listed before them at the
        equilibrium (a closed loop built from 3D joints): ``constraint_forces``
        ``A^T lambda`` are unique, ``multipliers`` are the minimum-norm ones.
    """

    q: Array
    multipliers: Array
    constraint_forces: Array
    residual: float
    stability: str
    stiffness_eigenvalues: Array
    holding_forces: Array
    iterations: int
    method: str
    coordinate_names: tuple[str, ...]
    constraint_names: tuple[str, ...]
    t: float = 0.0
    parameter_values: dict[str, float] = field(default_factory=dict)
    fixed: tuple[str, ...] = ()
    dependent_constraints: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        for name in ("q", "multipliers", "constraint_forces", "stiffness_eigenvalues",
                     "holding_forces"):
            array = np.array(getattr(self, name), dtype=float)
            array.setflags(write=False)
            object.__setattr__(self, name, array)

    @property
    def reaction(self) -> Array:
        """The generalized constraint forces ``A^T lambda*``."""
        return self.constraint_forces

    def __getitem__(self, name: object) -> float:
        """The equilibrium value of a coordinate (by name or symbol)."""
        return float(self.q[self._coordinate(name)])

    def multiplier(self, name: str) -> float:
        """The multiplier of the constraint called ``name``."""
        if name not in self.constraint_names:
            raise KeyError(f"{name!r} is not a constraint; the constraints are "
                           f"{', '.join(self.constraint_names) or 'none'}")
        return float(self.multipliers[self.constraint_names.index(name)])

    def constraint_force(self, name: str) -> float:
        """The generalized constraint force ``(A^T lambda)`` on coordinate ``name``."""
        return float(self.constraint_forces[self._coordinate(name)])

    def by_name(self) -> dict[str, float]:
        """Coordinate name -> equilibrium value."""
        return {n: float(v) for n, v in zip(self.coordinate_names, self.q)}

    def multipliers_by_name(self) -> dict[str, float]:
        """Constraint name -> multiplier."""
        return {n: float(v) for n, v in zip(self.constraint_names, self.multipliers)}

    def _coordinate(self, key: object) -> int:
        name = key_name(key)
        if name not in self.coordinate_names:
            raise KeyError(f"{name!r} is not a coordinate; the coordinates are "
                           f"{', '.join(self.coordinate_names)}")
        return self.coordinate_names.index(name)

    def __str__(self) -> str:
        def listing(names: Sequence[str], values: Array) -> str:
            return ", ".join(f"{n} = {v:.10g}" for n, v in zip(names, values)) or "none"

        lines = [
            f"{self.stability} equilibrium (t = {self.t:g})",
            f"  at {listing(self.coordinate_names, self.q)}",
            f"  multipliers: {listing(self.constraint_names, self.multipliers)}",
            f"  constraint forces A^T lambda: "
            f"{listing(self.coordinate_names, self.constraint_forces)}",
        ]
        if self.fixed:
            index = [self.coordinate_names.index(n) for n in self.fixed]
            lines.append(f"  holding forces on fixed coordinates: "
                         f"{listing(self.fixed, self.holding_forces[index])}")
        eigenvalues = ", ".join(f"{v:.6g}" for v in self.stiffness_eigenvalues) or "none"
        lines += [
            f"  constrained stiffness eigenvalues: {eigenvalues}",
            f"  residual {self.residual:.3g} after {self.iterations} iterations ({self.method})",
        ]
        return "\n".join(lines)


# --------------------------------------------------------------------------- public API


@checked_keywords({
    "parameters": PARAMETER_VALUES, "t": [FiniteNumber()], "fixed": FIXED,
    "tol": [PositiveNumber()], "max_iter": [PositiveInteger()], "on_marginal": ON_MARGINAL,
    "redundant_constraints": [*REDUNDANT_CONSTRAINTS, NONE],
})
def equilibrium(
    system: StaticsModel,
    guess: Mapping[object, float] | Sequence[float] | Array,
    *,
    parameters: Mapping[Any, object] | None = None,
    t: float = 0.0,
    fixed: Sequence[object] | None = None,
    tol: float = 1e-12,
    max_iter: int = 50,
    on_marginal: str = "report",
    redundant_constraints: RedundantConstraints | None = None,
) -> Equilibrium:
    """Find a static equilibrium of ``system`` near ``guess`` and classify it.

    The guess is first projected onto the holonomic constraints (least change,
    ``fixed`` coordinates held); the multipliers start from least squares
    there; then Newton's method solves ``f(q, 0, t) + A^T lambda = 0``,
    ``psi(q, t) = 0`` (the force balance of ``fixed`` coordinates is dropped:
    whatever holds them supplies :attr:`Equilibrium.holding_forces`).

    Parameters
    ----------
    system : System
    guess : mapping or sequence of float
        Starting configuration, by coordinate (name, symbol) or in coordinate
        order; coordinates missing from a mapping start at 0.
    parameters : mapping, optional
        Parameter values overriding the System's.
    t : float
        Time (for models that depend on it explicitly).
    fixed : sequence, optional
        Coordinates held at their guess values.
    tol : float
        Absolute tolerance on each equation (accepted at its rounding level when
        that is larger, as in :func:`~dalembert.statics.extremum.extremum`).
    max_iter : int
        Newton iterations per attempt.
    on_marginal : {"report", "raise"}
        What to do when the constrained stiffness is singular.
    redundant_constraints : {"minimum-norm", "error"}, optional
        Dependent constraints at the equilibrium: reported with a
        :class:`~dalembert.errors.RedundantConstraintsWarning` and the minimum-norm
        multipliers (the reactions ``A^T lambda`` are unique), or an error; default
        the System's option of that name, as in dynamics.

    Returns
    -------
    Equilibrium

    Raises
    ------
    InconsistentConstraintsError
        The constraints cannot be satisfied near the guess.
    EquilibriumNotFoundError
        No equilibrium found from the projected guess.
    ConstraintError
        With ``redundant_constraints="error"``, the constraints are dependent at the
        equilibrium.
    MarginalStabilityError
        With ``on_marginal="raise"``, the constrained stiffness is singular.

    Examples
    --------
    >>> from dalembert.examples import cartesian_pendulum
    >>> eq = equilibrium(cartesian_pendulum.build(), {"x": 0.3, "y": -0.9})
    >>> eq.stability, round(eq["x"], 12) + 0.0, round(eq["y"], 12)
    ('stable', 0.0, -1.0)
    >>> round(-2 * eq.multiplier("rod") * 1.0, 10)  # rod tension m g
    9.81
    """
    t = float(t)
    sm = static_system(system, parameters)
    names = sm.coordinate_names
    q_guess = coordinate_values(guess, names, "guess")
    free = free_mask(fixed, names)
    q_start = project_onto_constraints(sm, t, q_guess, free)
    problem = _Newton(sm, t, q_start, free)
    z0 = np.concatenate([q_start[free], problem.initial_multipliers()])
    attempt = _solve(problem, z0, tol, max_iter, q_guess)
    # None: the model's own option (a System's, checked when it was made)
    mode = redundant_constraints if redundant_constraints is not None else \
        str(getattr(system, "redundant_constraints", "minimum-norm"))
    return _make_equilibrium(problem, attempt, on_marginal, mode)


def tangent_basis(sm: StaticSystem, A: Array, free: Array) -> Array:
    """Orthonormal basis of ``{dq : A_hol dq = 0, dq_fixed = 0}`` (``n x r``)."""
    rows = [A[list(sm.holonomic_rows)]] if sm.holonomic_rows else []
    rows += [np.eye(sm.n)[~np.asarray(free, dtype=bool)]]
    blocks = np.vstack([np.zeros((0, sm.n)), *rows])
    return np.eye(sm.n) if blocks.shape[0] == 0 else scipy.linalg.null_space(blocks)


def classify_stiffness(eigenvalues: Array, scale: float) -> str:
    """``"stable"``/``"unstable"``/``"marginal"`` from stiffness eigenvalues.

    ``scale`` is the size of the stiffness (``max|K|``); eigenvalues below
    ``MARGINAL_RTOL * scale`` in magnitude count as zero.

    >>> classify_stiffness(np.array([1.0, 2.0]), 2.0)
    'stable'
    >>> classify_stiffness(np.array([-1.0, 1e-12]), 2.0)
    'unstable'
    >>> classify_stiffness(np.array([1e-12, 1.0]), 2.0)
    'marginal'
    """
    threshold = MARGINAL_RTOL * scale
    if np.any(eigenvalues < -threshold):
        return "unstable"
    if np.any(eigenvalues <= threshold):
        return "marginal"
    return "stable"


def marginal_message(names: Sequence[str], Z: Array, eigenvalues: Array, vectors: Array,
                     scale: float) -> str:
    """Describe the zero-stiffness directions in the original coordinates."""
    zero = np.abs(eigenvalues) <= MARGINAL_RTOL * scale
    parts = []
    for k in np.flatnonzero(zero):
        direction = Z @ vectors[:, k]
        direction = direction / np.abs(direction).max()
        shown = ", ".join(f"{n}: {v:+.4g}" for n, v in zip(names, direction) if abs(v) > 1e-8)
        parts.append(f"eigenvalue {eigenvalues[k]:.3g} along ({shown})")
    return (
        "the constrained stiffness Z^T K Z is singular: " + "; ".join(parts) + ". The "
        "linear analysis cannot decide stability here (a bifurcation point, or a "
        "neutral direction such as a symmetry); higher-order terms decide it"
    )


# --------------------------------------------------------------------------- checks


#: Coordinates a message shows of a point (a long chain's would fill pages).
SHOWN_COORDINATES = 8


def _point(names: Sequence[str], q: Array) -> str:
    """``x=0.1, y=-0.9``, the first :data:`SHOWN_COORDINATES` of them.

    >>> _point([f"q{k}" for k in range(10)], np.arange(10.0))
    'q0=0, q1=1, q2=2, q3=3, q4=4, q5=5, q6=6, q7=7, ... (2 more)'
    """
    shown = ", ".join(f"{n}={v:.6g}" for n, v in list(zip(names, q))[:SHOWN_COORDINATES])
    rest = len(names) - SHOWN_COORDINATES
    return shown + (f", ... ({rest} more)" if rest > 0 else "")


# --------------------------------------------------------------------------- projection


def project_onto_constraints(sm: StaticSystem, t: float, q: Array, free: Array) -> Array:
    """Nearest ``q`` (over the ``free`` coordinates) with ``psi(q, t) = 0``.

    Gauss-Newton with minimum-norm steps and backtracking; raises
    :class:`InconsistentConstraintsError` if the residual cannot be driven to
    rounding level.
    """
    rows = list(sm.holonomic_rows)
    q = np.array(q, dtype=float)
    if not rows:
        return q
    found = gauss_newton(lambda x: sm.num.position_constraint(t, x),
                         lambda x: sm.num.velocity_constraint(t, x)[0][rows], q, free,
                         line_search=True, max_iter=_PROJECTION_ITER)
    if found.converged or found.residual <= ACCEPT_TOL * max(1.0, float(np.abs(q).max())):
        return found.q
    raise InconsistentConstraintsError(_inconsistent_message(sm, t, found.q, free))


def _inconsistent_message(sm: StaticSystem, t: float, q: Array, free: Array) -> str:
    psi, A, *_ = sm.constraints(t, q)
    rows = list(sm.holonomic_rows)
    worst = rows[int(np.argmax(np.abs(psi)))]
    J = A[rows][:, free]
    rank = np.linalg.matrix_rank(J) if J.size else 0
    held = [n for n, f in zip(sm.coordinate_names, free) if not f]
    message = (
        "the constraints cannot be satisfied near the guess"
        + (f" with {', '.join(held)} held fixed" if held else "")
        + f": least-change Gauss-Newton stalled at ({_point(sm.coordinate_names, q)}) where "
        f"{sm.constraint_labels[worst]} is still off by {abs(psi[rows.index(worst)]):.3g}"
    )
    if rank < len(rows):
        message += (f"; the constraint Jacobian there has rank {rank} < {len(rows)} "
                    "(gradients vanish or are dependent, e.g. a guess at a singular point)")
    return message + (
        ". Start from a configuration closer to one satisfying the constraints, check the "
        "constraint parameters (they may admit no solution)"
        + ("; or fix fewer coordinates" if held else "")
    )


# --------------------------------------------------------------------------- Newton


class _Newton:
    """The equilibrium equations over ``z = (q_free, lambda)`` and their Jacobian."""

    def __init__(self, sm: StaticSystem, t: float, q_start: Array, free: Array):
        self.sm, self.t, self.free = sm, t, free
        self.cols = np.flatnonzero(free)
        self.q_template = np.array(q_start, dtype=float)
        self.hol = list(sm.holonomic_rows)
        self.rest = list(sm.rest_rows)

    @property
    def size(self) -> tuple[int, int]:
        equations = len(self.cols) + len(self.hol) + len(self.rest)
        return equations, len(self.cols) + self.sm.m

    def split(self, z: Array) -> tuple[Array, Array]:
        q = self.q_template.copy()
        q[self.cols] = z[: len(self.cols)]
        return q, z[len(self.cols):]

    def evaluate(self, q: Array, lam: Array):
        psi, A, b, Jb = self.sm.constraints(self.t, q)
        f0, G = self.sm.forces(self.t, q, lam)
        return psi, A, b, Jb, f0, G

    def initial_multipliers(self) -> Array:
        if self.sm.m == 0:
            return np.zeros(0)
        q = self.q_template
        _, A, _, _, f0, _ = self.evaluate(q, np.zeros(self.sm.m))
        return np.linalg.lstsq(A[:, self.cols].T, -f0[self.cols], rcond=None)[0]

    def __call__(self, z: Array) -> tuple[Array, Array]:
        q, lam = self.split(z)
        with np.errstate(all="ignore"):
            psi, A, b, Jb, f0, G = self.evaluate(q, lam)
        c, k = self.cols, len(self.cols)
        residual = np.concatenate([(f0 + A.T @ lam)[c], psi, b[self.rest]])
        matrix = np.zeros(self.size)
        matrix[:k, :k] = G[c][:, c]
        matrix[:k, k:] = A.T[c]
        matrix[k:k + len(self.hol), :k] = A[self.hol][:, c]
        matrix[k + len(self.hol):, :k] = Jb[self.rest][:, c]
        return residual, matrix


def _solve(problem: _Newton, z0: Array, tol: float, max_iter: int, q_guess: Array) -> Attempt:
    first = newton_iterations(problem, z0, tol, max_iter, "newton")
    if first.converged:
        return first
    attempts = [first]
    rows, cols = problem.size
    # scipy's hybr and lm need at least as many equations as unknowns.
    methods = ("hybr", "lm") if rows == cols else ("lm",) if rows > cols else ()
    for method in methods:
        attempt = root_then_newton(problem, z0, tol, max_iter, method)
        if attempt.converged:
            total = first.iterations + attempt.iterations
            return Attempt(attempt.z, attempt.residual, total, True, attempt.label)
        attempts.append(attempt)
    raise EquilibriumNotFoundError(_not_found_message(problem, z0, attempts, tol, max_iter,
                                                      q_guess))


def _not_found_message(problem: _Newton, z0: Array, attempts: list[Attempt], tol: float,
                       max_iter: int, q_guess: Array) -> str:
    names = problem.sm.coordinate_names
    first, *others = attempts
    best = min(attempts, key=lambda a: a.residual)
    tried = "".join(f"; then {a.label} reached residual {a.residual:.3g}" for a in others)
    q_best, _ = problem.split(best.z)
    unbalanced = ""
    if np.all(np.isfinite(best.z)):
        residual, _ = problem(best.z)
        k = len(problem.cols)
        if k and np.all(np.isfinite(residual)):
            i = int(np.argmax(np.abs(residual[:k])))
            unbalanced = (f" There the largest unbalanced generalized force is "
                          f"{residual[i]:.3g} on {names[problem.cols[i]]}.")
    q_start, _ = problem.split(z0)
    return (
        f"no static equilibrium found near the guess ({_point(names, q_guess)}; projected "
        f"onto the constraints: {_point(names, q_start)}). Newton's method on "
        f"f(q, 0, t) + A^T lambda = 0, psi(q) = 0 stopped after {first.iterations} of at "
        f"most {max_iter} iterations ({first.note}) with residual {first.residual:.3g} > "
        f"tol = {tol:g}{tried}. Best point reached: ({_point(names, q_best)}).{unbalanced} "
        "Try a guess closer to the expected equilibrium, check the parameter values (an "
        "equilibrium may not exist for them, e.g. a forcing no constraint can balance), or "
        "hold some coordinates with fixed=[...]."
    )


# --------------------------------------------------------------------------- result


def _make_equilibrium(problem: _Newton, attempt: Attempt, on_marginal: str,
                      redundant_constraints: str) -> Equilibrium:
    sm, free = problem.sm, problem.free
    q, lam = problem.split(attempt.z)
    _, A, _, _, f0, G = problem.evaluate(q, lam)
    dependent: tuple[str, ...] = ()
    forces = A.T @ lam  # unique, whatever multipliers Newton settled on
    if sm.m:
        pattern, Av = sm.num.pattern, sm.num.velocity_sparse(problem.t, q)[0]
        rank = sparse_constraint_rank(pattern.A_rows, pattern.A_cols, Av, (sm.m, sm.n),
                                      sm.constraint_names)
        if rank.dependent and redundant_constraints == "error":
            raise dependent_error([sm.constraint_labels[i] for i in rank.dependent],
                                  f"at the equilibrium ({_point(sm.coordinate_names, q)})")
        if rank.dependent:
            # As dynamics reports them: the minimum-norm multipliers of the same force.
            # The stiffness on the tangent space does not depend on the choice (the
            # dependence holds near the equilibrium too, so the extra curvature terms
            # vanish on the tangent space).
            lam = min_norm_multipliers(A, forces)
            dependent = tuple(rank.dependent_names)
            warnings.warn(str(rank), RedundantConstraintsWarning,
                          stacklevel=user_stacklevel())  # the user's call
    stability, eigenvalues = _stability(sm, A, -G, free, on_marginal)
    holding = np.where(free, 0.0, -(f0 + forces))
    return Equilibrium(
        q=q, multipliers=lam, constraint_forces=forces, residual=attempt.residual,
        stability=stability, stiffness_eigenvalues=eigenvalues, holding_forces=holding,
        iterations=attempt.iterations, method=attempt.label,
        coordinate_names=sm.coordinate_names, constraint_names=sm.constraint_names,
        t=problem.t, parameter_values=dict(sm.parameter_values),
        fixed=tuple(n for n, f in zip(sm.coordinate_names, free) if not f),
        dependent_constraints=dependent,
    )


def _stability(sm: StaticSystem, A: Array, K: Array, free: Array,
               on_marginal: str) -> tuple[str, Array]:
    if sm.pfaffian_rows:
        return "undetermined", np.zeros(0)
    Z = tangent_basis(sm, A, free)
    if Z.shape[1] == 0:
        return "stable", np.zeros(0)
    reduced = Z.T @ (0.5 * (K + K.T)) @ Z
    eigenvalues, vectors = np.linalg.eigh(reduced)
    scale = float(np.abs(K).max())
    stability = classify_stiffness(eigenvalues, scale)
    if stability == "marginal" and on_marginal == "raise":
        raise MarginalStabilityError(
            marginal_message(sm.coordinate_names, Z, eigenvalues, vectors, scale)
        )
    return stability, eigenvalues
