"""Through a singular configuration in the Python loop: the rows losing rank left out.

Near a singular configuration (:mod:`dalembert.numerics.singular`) the kept rows of
``A`` are nearly dependent, and the KKT solve enforces them with multipliers that
grow like ``1 / sigma_min``: the accelerations carry rounding errors amplified as
much, the step size collapses, and the motion may leave its branch. While *careful*,
every evaluation factors the Gram matrix ``A A^T`` (Cholesky, rows in a fixed
bandwidth-reducing order) and leaves out the rows whose pivot falls below
``TRUNCATE**2`` of the largest diagonal: the rank-revealing, minimum-norm treatment
of dependent rows, for a moment. The rows left out are enforced again as soon as
they are independent enough; the velocity projection of a careful step works in the
kinetic-energy metric, so that their return changes the energy to second order only.

The step after one that ends near a singular configuration (``A A^T``, rows scaled
to unit length, worse conditioned than ``NEAR**-2``) is careful: :class:`CarefulModel`
measures it after every projection (a Cholesky factorization and LAPACK's condition
estimate, dense, for models of at most :data:`DENSE_ROWS` rows; larger ones rely on
the step-collapse watch alone). The C loop measures it after every stretch of steps
and takes the careful steps the Python way (:class:`CarefulSteps`), handing back to C
once the state is clear of the singular configuration.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from scipy.integrate import OdeSolver

from ..codegen.compiled import NumericModel
from ..errors import SingularSystemError
from ..numerics.conditioning import spd_condition
from ..numerics.singular import DENSE_ROWS, NEAR, TRUNCATE


def unit_rows(A: np.ndarray) -> np.ndarray:
    """``D^-1``, the inverse row norms of ``A``: the rows scaled to unit length have the
    same dependencies, whatever the units of each constraint."""
    norms = np.linalg.norm(A, axis=1)
    return 1.0 / np.maximum(norms, np.finfo(float).tiny)


def combinations(A: np.ndarray, below: float = TRUNCATE) -> np.ndarray:
    """``U_k^T D^-1``: the combinations of the rows of ``A`` (scaled to unit length)
    whose singular values are at least ``below`` times the largest (the rank-revealing,
    minimum-norm part).

    >>> combinations(np.array([[1.0, 0.0], [1.0, 1e-9]])).shape
    (1, 2)
    """
    if A.shape[0] == 0:
        return np.zeros((0, 0))
    scale = unit_rows(A)
    u, s, _ = np.linalg.svd(A * scale[:, None], full_matrices=False)
    return u[:, s >= below * s[0]].T * scale[None, :]


def gram_condition(A: np.ndarray) -> float:
    """The condition number of ``A A^T`` (rows scaled to unit length), ``~(s_max /
    s_min)^2``: an estimate from its Cholesky factorization (LAPACK ``pocon``), cheap
    beside a step.

    >>> f"{gram_condition(np.array([[1.0, 0.0], [1.0, 1e-6]])):.0e}"
    '4e+12'
    """
    An = A * unit_rows(A)[:, None]
    return spd_condition(An @ An.T)


class CarefulModel:
    """The careful right-hand side and projection of a model, and the switch between
    them and the ordinary ones (see the module docstring).

    Parameters
    ----------
    num
        The compiled equations bound to parameter values.
    kept
        The independent rows at the start (``None``: all).
    rhs, project
        The ordinary right-hand side and projection.
    t_span
        The run's time span (the direction of its steps).
    """

    def __init__(self, num: NumericModel, kept: np.ndarray | None,
                 rhs: Callable[[float, np.ndarray], np.ndarray],
                 project: Callable[[float, np.ndarray], np.ndarray],
                 t_span: tuple[float, float] = (0.0, 1.0)) -> None:
        self.num, self._rhs, self._project = num, rhs, project
        self.direction = 1.0 if t_span[1] >= t_span[0] else -1.0
        self._reached = t_span[0]
        self.rows = np.arange(num.m) if kept is None else np.asarray(kept)
        self.careful = False
        self._U: np.ndarray | None = None
        #: The last :func:`gram_condition` measured (``nan`` if not measured).
        self.condition = np.nan
        self.measured = num.m <= DENSE_ROWS
        place = {int(r): k for k, r in enumerate(num.holonomic_rows)}  # row -> entry of psi
        self.holonomic = np.array([int(r) in place for r in self.rows], dtype=bool)
        self._psi_at = np.array([place[int(r)] for r in self.rows[self.holonomic]], dtype=int)

    def restart(self, t: float, q: np.ndarray) -> None:
        """Ready for a run from ``(t, q)``."""
        self._reached = t
        self.measure(t, q)

    def measure(self, t: float, q: np.ndarray) -> None:
        """Careful from here if ``q`` is near a singular configuration."""
        if self.measured:
            A = self._A(t, q)[0]
            self.condition = gram_condition(A)
            self.careful = self.condition > NEAR**-2
            # the combinations enforced, fixed over the step: its right-hand side smooth
            self._U = combinations(A) if self.careful else None

    def _A(self, t: float, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        A, b = self.num.velocity_constraint(t, q)
        return A[self.rows], b[self.rows]

    def rhs(self, t: float, y: np.ndarray) -> np.ndarray:
        if not self.careful:
            return self._rhs(t, y)
        num, n = self.num, self.num.n
        q, qd = y[:n], y[n:]
        Mv, f, Av, c = num.kkt_sparse(t, q, qd)
        M, A = num.pattern.dense_M(Mv), num.pattern.dense_A(Av)[self.rows]
        U = self._U if self._U is not None else combinations(A)
        Ak = U @ A
        mk = len(Ak)
        K = np.block([[M, Ak.T], [Ak, np.zeros((mk, mk))]])
        try:
            x = np.linalg.solve(K, np.concatenate([f, U @ c[self.rows]]))
        except np.linalg.LinAlgError as exc:  # the mass matrix, then: the loop says so
            raise SingularSystemError(f"the KKT matrix is singular at t={t:.6g} although "
                                      "the nearly dependent constraints are left out") from exc
        return np.concatenate([qd, x[:n]])

    def project(self, t: float, y: np.ndarray) -> np.ndarray:
        """The projection, careful or not; at a step's end (a time beyond every one
        projected before: not an output inside the step) the switch for the next step."""
        y = self._careful_project(t, y) if self.careful else self._project(t, y)
        if self.direction * (t - self._reached) > 0:
            self._reached = t
            self.measure(t, y[:self.num.n])
        return y

    def _careful_project(self, t: float, y: np.ndarray) -> np.ndarray:
        num, n = self.num, self.num.n
        q, qd = y[:n].copy(), y[n:].copy()
        hol = self.rows[self.holonomic]
        for _ in range(8):
            psi = num.position_constraint(t, q)[self._psi_at]
            J = num.velocity_constraint(t, q)[0][hol]
            U = combinations(J)
            residual = U @ psi if len(hol) else psi
            if not len(hol) or np.abs(residual).max(initial=0.0) < 1e-14 * max(
                    1.0, float(np.abs(q).max())):
                break
            Jk = U @ J
            q -= Jk.T @ np.linalg.solve(Jk @ Jk.T, residual)  # minimum-norm Newton step
        A, b = self._A(t, q)
        U = combinations(A)
        Ak, r = U @ A, U @ (A @ qd + b)
        M = num.pattern.dense_M(num.kkt_sparse(t, q, qd)[0])
        mk = len(Ak)
        K = np.block([[M, Ak.T], [Ak, np.zeros((mk, mk))]])
        try:
            dqd = np.linalg.solve(K, np.concatenate([np.zeros(n), -r]))[:n]
        except np.linalg.LinAlgError as exc:
            raise SingularSystemError(f"the velocity projection at t={t:.6g} is singular "
                                      "although the nearly dependent constraints are left "
                                      "out") from exc
        return np.concatenate([q, qd + dqd])


@dataclass(frozen=True)
class CarefulSteps:
    """The careful model of a run (its ``rhs``, ``project`` and ``measure``) and, for the
    C loop, ``solver(t, y, h_abs)``: a Python solver of the same method and tolerances
    starting there with that step, to take the careful steps the Python way."""

    model: CarefulModel
    solver: Callable[[float, np.ndarray, float], OdeSolver] | None = None
