"""Small oscillations of a constrained :class:`~dalembert.System` about an equilibrium.

Near an equilibrium ``(q*, lambda*)`` of ``M qdd = f(q, qd, t) + A^T lambda``
with holonomic constraints ``psi(q) = 0``, put ``q = q* + Z eta`` with ``Z`` an
orthonormal basis of the tangent space ``null(dpsi/dq)`` at ``q*``. To first order

    M Z eta'' = -K Z eta - C Z eta' + A^T dlambda + u,
    K = -(df/dq + sum_k lambda*_k d2psi_k/dq2),     C = -df/dqd      at (q*, 0),

and ``Z^T A^T = 0`` removes the multiplier change, leaving the reduced system

    Mr eta'' + Cr eta' + Kr eta = Z^T u,   Mr = Z^T M Z, Cr = Z^T C Z, Kr = Z^T K Z.

The ``lambda*`` term is the curvature of the constraints weighted by the static
reaction: it is what makes a Cartesian pendulum's ``K`` equal ``m g / l``
although gravity is uniform. ``lambda*`` is computed at ``q*`` (least squares of
``A^T lambda = -f``), so it never has to be supplied.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any, cast

import numpy as np
import scipy.linalg
from numpy.typing import NDArray

from ..errors import (
    InputError,
    NonholonomicLinearizationError,
    NotAnEquilibriumError,
    SingularSystemError,
)
from ..model.coordinates import key_name
from ..model.values import CoordinateValues, coordinate_values, free_mask
from ..options import FIXED, INPUT_VALUES, PARAMETER_VALUES
from ..rules import NONE, FiniteNumber, PositiveNumber, checked_keywords
from .equilibrium import (
    ON_MARGINAL,
    Equilibrium,
    MarginalStabilityError,
    classify_stiffness,
    marginal_message,
    tangent_basis,
)
from .static_system import StaticsModel, StaticSystem, static_system

__all__ = [
    "Linearization",
    "StateSpace",
    "linearize",
]

Array = NDArray[np.float64]

#: The step of the central differences by an input, relative to ``max(1, |u|)`` (two
#: of them, combined by Richardson's rule: exact for forces affine in the inputs).
_INPUT_STEP = 1e-3

#: Relative asymmetry of Kr above which the general (non-symmetric) eigenproblem is used.
_SYMMETRY_RTOL = 1e-10


@dataclass(frozen=True, eq=False)
class Linearization:
    """The linearized motion about an equilibrium, on the constraints' tangent space.

    Attributes
    ----------
    q, multipliers : numpy.ndarray
        The equilibrium ``q*`` and its multipliers ``lambda*``.
    M, K, C : numpy.ndarray
        ``n x n`` mass, stiffness ``-(df/dq + sum lambda*_k d2psi_k/dq2)`` and
        damping/gyroscopic ``-df/dqd`` matrices at ``(q*, 0)``, original coordinates.
    Z : numpy.ndarray
        ``n x r`` orthonormal basis of the tangent space (``q - q* = Z eta``); it
        also excludes the ``fixed`` coordinates.
    Mr, Kr, Cr : numpy.ndarray
        ``Z^T M Z``, ``Z^T K Z``, ``Z^T C Z`` (``r x r``).
    omega_squared : numpy.ndarray
        Ascending generalized eigenvalues of ``(Kr, Mr)`` (complex only if ``Kr``
        is not symmetric, i.e. circulatory forces).
    natural_frequencies : numpy.ndarray
        ``sqrt(omega_squared)`` as complex numbers: a real value is an angular
        frequency, an imaginary one ``i s`` an exponential growth rate ``s``
        (a negative ``omega^2``, unstable). Damping ``Cr`` is not included.
    mode_shapes : numpy.ndarray
        ``n x r``, column ``k`` the mode of ``omega_squared[k]`` in the original
        (redundant) coordinates, ``Z @ v_k``, mass-normalized
        (``mode_shapes.T @ M @ mode_shapes = I`` in the symmetric case).
    A_ss, B_ss : numpy.ndarray
        State space ``x' = A_ss x + B_ss u`` with ``x = (eta, eta')`` (``2r``) and
        ``u`` the generalized forces in the original coordinates (``n``):
        ``A_ss = [[0, I], [-Mr^-1 Kr, -Mr^-1 Cr]]``, ``B_ss = [[0], [Mr^-1 Z^T]]``.
    stability : str
        From the eigenvalues of ``Kr`` as :attr:`Equilibrium.stability`.
    coordinate_names : tuple of str
    t : float
    input_names : tuple of str
        The model's inputs (``System(inputs=...)``).
    input_forces : numpy.ndarray
        ``n x p``: the generalized forces per unit of each input, ``df/du`` at the
        equilibrium (the inputs at the values ``linearize`` was given);
        :attr:`B_inputs` is the state-space input matrix.
    """

    q: Array
    multipliers: Array
    M: Array
    K: Array
    C: Array
    Z: Array
    Mr: Array
    Kr: Array
    Cr: Array
    omega_squared: Array
    natural_frequencies: Array
    mode_shapes: Array
    A_ss: Array
    B_ss: Array
    stability: str
    coordinate_names: tuple[str, ...]
    t: float = 0.0
    input_names: tuple[str, ...] = ()
    input_forces: Array = field(default_factory=lambda: np.zeros((0, 0)))

    def __post_init__(self) -> None:
        if not np.size(self.input_forces):
            object.__setattr__(self, "input_forces",
                               np.zeros((len(self.coordinate_names), len(self.input_names))))
        for name in ("q", "multipliers", "M", "K", "C", "Z", "Mr", "Kr", "Cr", "omega_squared",
                     "natural_frequencies", "mode_shapes", "A_ss", "B_ss", "input_forces"):
            array = np.array(getattr(self, name))
            array.setflags(write=False)
            object.__setattr__(self, name, array)

    @property
    def degrees_of_freedom(self) -> int:
        """``r``, the dimension of the tangent space."""
        return self.Z.shape[1]

    @property
    def growth_rates(self) -> Array:
        """Exponential growth rate of each mode from the stiffness (0 for oscillating ones)."""
        return np.abs(np.asarray(self.natural_frequencies).imag).astype(np.float64)

    @property
    def eigenvalues(self) -> NDArray[np.complex128]:
        """Eigenvalues of ``A_ss`` (include damping and gyroscopic coupling)."""
        if not self.A_ss.size:
            return np.zeros(0, np.complex128)
        return np.linalg.eigvals(self.A_ss).astype(np.complex128)

    @property
    def state_to_coordinates(self) -> Array:
        """``2n x 2r`` map from ``x = (eta, eta')`` to ``(q - q*, qd)``."""
        n, r = self.Z.shape
        out = np.zeros((2 * n, 2 * r))
        out[:n, :r] = self.Z
        out[n:, r:] = self.Z
        return out

    @property
    def B_inputs(self) -> Array:
        """``2r x p``: ``x' = A_ss x + B_inputs du`` for changes ``du`` of the inputs
        (``B_ss @ input_forces``)."""
        return np.asarray(self.B_ss @ self.input_forces, dtype=np.float64)

    def in_coordinates(self, jacobian: Sequence[Sequence[float]] | Array | Sequence[str],
                       names: Sequence[str] | None = None) -> StateSpace:
        """The state space in ``r`` coordinates of one's choosing, ``y - y* = J (q - q*)``
        to first order, with the state ``(y - y*, y')`` and the model's inputs.

        With ``T = J Z`` (``r x r``, invertible when the chosen coordinates fix the
        motion near the equilibrium) ``eta = T^-1 (y - y*)``, so
        ``A = S A_ss S^-1`` and ``B = S B_inputs`` with ``S = diag(T, T)``: the same
        dynamics, ready for :mod:`scipy.signal` or an LQR design
        (``scipy.linalg.solve_continuous_are``).

        Parameters
        ----------
        jacobian
            ``J``, ``r x n`` (the chosen coordinates' derivatives by the model's), or
            ``r`` of the model's coordinate names.
        names
            The chosen coordinates' names (default the coordinate names given, else
            ``y1, y2, ...``); the rates are named ``<name>_dot``.

        Returns
        -------
        StateSpace

        Raises
        ------
        ValueError
            ``J`` has not ``r`` rows of ``n`` columns, or ``J Z`` is singular (the
            coordinates do not fix the motion; the message names them).

        Examples
        --------
        The Cartesian pendulum hanging at rest, in its coordinate ``x``: ``x'' = -g/l x``:

        >>> from dalembert.examples import cartesian_pendulum
        >>> lin = linearize(cartesian_pendulum.build(), {"x": 0.0, "y": -1.0})
        >>> ss = lin.in_coordinates(["x"])
        >>> ss.state_names, ss.A.round(12).tolist()
        (('x', 'x_dot'), [[0.0, 1.0], [-9.81, 0.0]])
        """
        n, r = self.Z.shape
        if len(jacobian) and all(isinstance(v, str) for v in jacobian):
            chosen = [str(v) for v in jacobian]
            J = np.zeros((len(chosen), n))
            for i, name in enumerate(chosen):
                if name not in self.coordinate_names:
                    raise ValueError(f"{name!r} is not a coordinate; the coordinates are "
                                     f"{', '.join(self.coordinate_names)}")
                J[i, self.coordinate_names.index(name)] = 1.0
            names = chosen if names is None else names
        else:
            J = np.asarray(jacobian, dtype=float)
        names = [f"y{i + 1}" for i in range(len(J))] if names is None else list(names)
        if J.shape != (r, n) or len(names) != r:
            raise ValueError(f"the linearization has {r} degrees of freedom: give {r} "
                             f"coordinates (a {r} x {n} Jacobian), got {len(names)} "
                             f"({', '.join(names)}) and shape {J.shape}")
        T = J @ self.Z
        singular = np.linalg.svd(T, compute_uv=False) if r else np.ones(1)
        if r and not singular[-1] > 1e-9 * max(singular[0], 1e-300):
            raise ValueError(
                f"the coordinates {', '.join(names)} do not fix the motion near the "
                "equilibrium (J Z is singular there): some small motion leaves them all "
                "unchanged; choose coordinates that describe every degree of freedom")
        S = np.zeros((2 * r, 2 * r))
        S[:r, :r] = S[r:, r:] = T
        A = S @ self.A_ss @ np.linalg.inv(S)
        return StateSpace(A, S @ self.B_inputs, (*names, *(f"{v}_dot" for v in names)),
                          self.input_names)

    def mode(self, k: int) -> dict[str, float]:
        """Mode shape ``k`` by coordinate name."""
        return {n: float(v) for n, v in zip(self.coordinate_names, self.mode_shapes[:, k])}

    def __str__(self) -> str:
        rows = []
        for k, (w2, w) in enumerate(zip(self.omega_squared, self.natural_frequencies)):
            w = complex(w)
            kind = f"omega = {w.real:.10g}" if abs(w.imag) <= abs(w.real) * 1e-12 \
                else f"growth rate {abs(w.imag):.10g} (unstable)"
            shape = ", ".join(f"{n}: {v:+.4g}" for n, v in self.mode(k).items())
            rows.append(f"  mode {k + 1}: omega^2 = {complex(w2).real:.10g}, {kind}; "
                        f"shape ({shape})")
        point = ", ".join(f"{n} = {v:.10g}" for n, v in zip(self.coordinate_names, self.q))
        return "\n".join([
            f"linearization about the {self.stability} equilibrium at {point} "
            f"({self.degrees_of_freedom} degrees of freedom)", *rows,
        ])


@dataclass(frozen=True, eq=False)
class StateSpace:
    """``x' = A x + B u``: a linearization in chosen coordinates
    (:meth:`Linearization.in_coordinates`).

    Attributes
    ----------
    A, B : numpy.ndarray
        ``2r x 2r`` and ``2r x p``.
    state_names : tuple of str
        The state: the ``r`` coordinates' changes from the equilibrium, then their rates.
    input_names : tuple of str
        The inputs (``u``: their changes from the values at the equilibrium).
    """

    A: Array
    B: Array
    state_names: tuple[str, ...]
    input_names: tuple[str, ...]


@checked_keywords({
    "parameters": PARAMETER_VALUES, "t": [FiniteNumber(), NONE], "fixed": FIXED,
    "tol": [PositiveNumber()], "on_marginal": ON_MARGINAL, "inputs": INPUT_VALUES,
})
def linearize(
    system: StaticsModel,
    q_eq: Equilibrium | Mapping[object, float] | Sequence[float] | Array,
    *,
    parameters: Mapping[Any, object] | None = None,
    t: float | None = None,
    fixed: Sequence[object] | None = None,
    tol: float = 1e-8,
    on_marginal: str = "report",
    inputs: Mapping[Any, float] | None = None,
) -> Linearization:
    """Linearize ``system`` about the equilibrium ``q_eq``.

    Parameters
    ----------
    system : System
    q_eq : Equilibrium, mapping or sequence of float
        The equilibrium configuration. An :class:`Equilibrium` also supplies its
        time, parameter values and fixed coordinates (``parameters`` still
        overrides them).
    parameters : mapping, optional
        Parameter values overriding the System's.
    t : float, optional
        Time (default: the Equilibrium's, else 0).
    fixed : sequence, optional
        Coordinates held fixed (removed from the motion).
    tol : float
        Relative tolerance of the check that ``q_eq`` is on the constraints and
        in equilibrium.
    on_marginal : {"report", "raise"}
        What to do when ``Kr`` is singular.
    inputs : mapping, optional
        The values of the model's inputs at the equilibrium, by input (symbol or
        name; left out: 0). The linearization's :attr:`~Linearization.B_inputs` maps
        changes of them.

    Returns
    -------
    Linearization

    Raises
    ------
    NonholonomicLinearizationError
        The system has Pfaffian constraints: the velocities are confined to
        ``null(A)`` but the positions are not, so the linearization is not a
        second-order system on one tangent space.
    NotAnEquilibriumError
        ``q_eq`` violates the constraints, or the forces there are not balanced.
    MarginalStabilityError
        With ``on_marginal="raise"``, ``Kr`` is singular.

    Examples
    --------
    >>> from dalembert.examples import cartesian_pendulum
    >>> lin = linearize(cartesian_pendulum.build(), {"x": 0.0, "y": -1.0})
    >>> round(float(lin.natural_frequencies[0].real) ** 2, 10)  # g / l
    9.81
    """
    given = q_eq if isinstance(q_eq, Equilibrium) else None
    sm = static_system(system, given.parameter_values if given else None, parameters)
    _reject_pfaffian(sm)
    q = np.array(given.q) if given is not None else coordinate_values(
        cast(CoordinateValues, q_eq), sm.coordinate_names, "q_eq")
    t = float(given.t if given and t is None else t or 0.0)
    fixed = given.fixed if given and fixed is None else fixed
    free = free_mask(fixed, sm.coordinate_names)
    u0 = _input_values(sm, inputs)
    if len(u0):
        num = sm.num.for_run()
        num.set_inputs(u0)
        sm = dataclasses.replace(sm, num=num)
    _check_on_constraints(sm, t, q, tol)
    lam = _static_multipliers(sm, t, q, free, tol)
    lin = _linearization(sm, t, q, lam, free, on_marginal)
    if not len(u0):
        return lin
    return dataclasses.replace(lin, input_names=sm.num.compiled.input_names,
                               input_forces=_input_forces(sm, t, q, u0))


def _input_values(sm: StaticSystem, inputs: Mapping[Any, float] | None) -> Array:
    """The inputs' values at the equilibrium, in the model's order (0 if left out)."""
    names = sm.num.compiled.input_names
    values = np.zeros(len(names))
    if inputs is not None and not isinstance(inputs, Mapping):
        raise InputError(f"linearize takes the inputs' values at the equilibrium as a dict "
                         f"{{input: number}}, got {inputs!r}")
    for key, value in (inputs or {}).items():
        name = key_name(key)
        if name not in names:
            raise InputError(f"{name!r} is not an input of the model; its inputs are "
                             f"{', '.join(names) or 'none'}")
        try:
            number = float(value)
        except (TypeError, ValueError):
            raise InputError(f"the value of input {name!r} at the equilibrium must be a "
                             f"number, got {value!r}") from None
        if not np.isfinite(number):
            raise InputError(f"the value of input {name!r} is {number}, not finite")
        values[names.index(name)] = number
    return values


def _input_forces(sm: StaticSystem, t: float, q: Array, u0: Array) -> Array:
    """``df/du`` at ``(q, qd = 0, u0)`` by central differences at two steps, combined
    by Richardson's rule (exact to rounding for forces affine in the inputs)."""
    num = sm.num

    def forces(k: int, step: float) -> Array:
        u = u0.copy()
        u[k] += step
        num.set_inputs(u)
        return num.forces_at_rest(t, q)

    columns = []
    for k in range(len(u0)):
        h = _INPUT_STEP * max(1.0, abs(u0[k]))
        wide = (forces(k, h) - forces(k, -h)) / (2 * h)
        narrow = (forces(k, h / 2) - forces(k, -h / 2)) / h
        columns.append((4 * narrow - wide) / 3)
    num.set_inputs(u0)
    return np.column_stack(columns)


def _reject_pfaffian(sm: StaticSystem) -> None:
    if not sm.pfaffian_rows:
        return
    names = ", ".join(sm.constraint_labels[i] for i in sm.pfaffian_rows)
    raise NonholonomicLinearizationError(
        f"linearize handles holonomic constraints only, and this system has Pfaffian "
        f"constraint(s) {names}. With nonholonomic constraints the velocities are confined "
        "to null(A) but the positions are not: equilibria come in families and the small "
        "motions are not a second-order system on one tangent space, so no natural "
        "frequencies follow from a stiffness matrix. equilibrium() still finds the "
        "equilibria; if a constraint is integrable, give it as Holonomic instead."
    )


def _check_on_constraints(sm: StaticSystem, t: float, q: Array, tol: float) -> None:
    rows = list(sm.holonomic_rows)
    if not rows:
        return
    psi = sm.num.position_constraint(t, q)
    A = sm.num.velocity_constraint(t, q)[0]
    # Distance to the constraint set, to first order: the minimum-norm correction.
    distance = np.abs(np.linalg.lstsq(A[rows], psi, rcond=None)[0]).max()
    if not np.isfinite(distance) or distance > tol * max(1.0, float(np.abs(q).max())):
        worst = rows[int(np.argmax(np.abs(psi)))]
        raise NotAnEquilibriumError(
            f"q_eq does not satisfy the constraints: {sm.constraint_labels[worst]} is off by "
            f"{abs(psi[rows.index(worst)]):.3g} (a correction of size {distance:.3g} is "
            "needed). Pass the Equilibrium returned by equilibrium(), or its q."
        )


def _static_multipliers(sm: StaticSystem, t: float, q: Array, free: Array,
                        tol: float) -> Array:
    """``lambda*`` from ``A^T lambda = -f0`` on the free coordinates; check the balance."""
    A = sm.num.velocity_constraint(t, q)[0]
    f0 = sm.num.forces_at_rest(t, q)
    lam = np.linalg.lstsq(A[:, free].T, -f0[free], rcond=None)[0] if sm.m else np.zeros(0)
    unbalanced = (f0 + A.T @ lam)[free]
    scale = max(float(np.abs(f0).max(initial=0.0)), float(np.abs(A.T @ lam).max(initial=0.0)))
    if unbalanced.size and np.abs(unbalanced).max() > tol * scale:
        i = int(np.argmax(np.abs(unbalanced)))
        name = sm.coordinate_names[np.flatnonzero(free)[i]]
        raise NotAnEquilibriumError(
            f"q_eq is not an equilibrium: no multipliers balance the forces there (the "
            f"unbalanced generalized force on {name} is {unbalanced[i]:.3g}, relative "
            f"{abs(unbalanced[i]) / scale:.3g} > tol = {tol:g}). Find the equilibrium first "
            "with equilibrium(system, guess) and pass the result."
        )
    return lam


def _linearization(sm: StaticSystem, t: float, q: Array, lam: Array, free: Array,
                   on_marginal: str) -> Linearization:
    A = sm.num.velocity_constraint(t, q)[0]
    K = -sm.forces(t, q, lam)[1]
    M, C = sm.inertia(t, q)
    Z = tangent_basis(sm, A, free)
    Mr, Kr, Cr = Z.T @ M @ Z, Z.T @ K @ Z, Z.T @ C @ Z
    omega2, vectors = _modes(Mr, Kr)
    stability = _stability(sm, Z, Kr, float(np.abs(K).max(initial=0.0)), on_marginal)
    A_ss, B_ss = _state_space(Mr, Kr, Cr, Z)
    return Linearization(
        q=q, multipliers=lam, M=M, K=K, C=C, Z=Z, Mr=Mr, Kr=Kr, Cr=Cr,
        omega_squared=omega2, natural_frequencies=np.sqrt(omega2.astype(complex)),
        mode_shapes=Z @ vectors, A_ss=A_ss, B_ss=B_ss, stability=stability,
        coordinate_names=sm.coordinate_names, t=t,
    )


def _stability(sm: StaticSystem, Z: Array, Kr: Array, scale: float, on_marginal: str) -> str:
    """Classify from the eigenvalues of ``Kr`` (same test as :func:`equilibrium`)."""
    if Kr.size == 0:
        return "stable"
    eigenvalues, vectors = np.linalg.eigh(0.5 * (Kr + Kr.T))
    stability = classify_stiffness(eigenvalues, scale)
    if stability == "marginal" and on_marginal == "raise":
        raise MarginalStabilityError(
            marginal_message(sm.coordinate_names, Z, eigenvalues, vectors, scale)
        )
    return stability


def _modes(Mr: Array, Kr: Array) -> tuple[Array, Array]:
    """Generalized eigenpairs of ``(Kr, Mr)``, ascending; mass-normalized vectors."""
    r = Mr.shape[0]
    if r == 0:
        return np.zeros(0), np.zeros((0, 0))
    Ms = 0.5 * (Mr + Mr.T)
    asymmetry = np.abs(Kr - Kr.T).max()
    try:
        if asymmetry <= _SYMMETRY_RTOL * max(np.abs(Kr).max(), 1e-300):
            return scipy.linalg.eigh(0.5 * (Kr + Kr.T), Ms)
        values, vectors = scipy.linalg.eig(Kr, Ms)
    except np.linalg.LinAlgError as exc:
        raise SingularSystemError(
            "the reduced mass matrix Z^T M Z is not positive definite at the equilibrium: "
            "some direction the constraints leave free has no inertia; check the kinetic "
            "energy or add the missing constraint"
        ) from exc
    order = np.argsort(values.real)
    vectors = vectors[:, order]
    norms = np.sqrt(np.einsum("ik,ij,jk->k", vectors.conj(), Ms, vectors))
    return values[order], vectors / norms


def _state_space(Mr: Array, Kr: Array, Cr: Array, Z: Array) -> tuple[Array, Array]:
    r, n = Mr.shape[0], Z.shape[0]
    A_ss = np.zeros((2 * r, 2 * r))
    B_ss = np.zeros((2 * r, n))
    if r == 0:
        return A_ss, B_ss
    A_ss[:r, r:] = np.eye(r)
    A_ss[r:, :r] = -np.linalg.solve(Mr, Kr)
    A_ss[r:, r:] = -np.linalg.solve(Mr, Cr)
    B_ss[r:] = np.linalg.solve(Mr, Z.T)
    return A_ss, B_ss
