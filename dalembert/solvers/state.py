"""The dynamics at one state, forward and inverse.

Forward: ``qdd`` and ``lambda`` from the KKT system at ``(t, q, qd)``, with the rank
of ``A`` measured there (dependent rows: the minimum-norm multipliers).

Inverse: for a given motion ``(q, qd, qdd)``, the generalized force ``M qdd - f`` it
needs, split into what the constraints supply, ``A^T lambda`` (the minimum-norm
``lambda``), and the rest, ``applied``, which lies in the directions the constraints
leave free (orthogonal to every row of ``A``): the actuation an applied generalized
force must provide. A motion with no freedom left (every direction prescribed by
rheonomic constraints) needs no ``applied`` force: its multipliers are the driving
forces.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..codegen.compiled import NumericModel
from ..numerics.rank import min_norm_multipliers, sparse_constraint_rank
from .kkt.sparse import kkt_solver, matvec

#: The given accelerations may miss ``A qdd = c`` by this much, relative to its terms.
CONSTRAINT_RTOL = 1e-8


def accelerations_at(num: NumericModel, t: float, q: np.ndarray,
                     qd: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(qdd, lambda)`` at ``(t, q, qd)`` (see module docstring).

    Parameters
    ----------
    num
        The compiled equations bound to parameter values.
    t, q, qd
        The state.
    """
    Mv, f, Av, c = num.kkt_sparse(t, q, qd)
    pattern = num.pattern
    rank = sparse_constraint_rank(pattern.A_rows, pattern.A_cols, Av, (num.m, num.n),
                                  [str(i) for i in range(num.m)])
    return kkt_solver(pattern, rank.kept).solve(Mv, f, Av, c)


@dataclass(frozen=True)
class InverseDynamics:
    """The generalized forces a given motion needs (see :mod:`dalembert.solvers.state`).

    Attributes
    ----------
    multipliers
        ``lambda``, minimum norm: what the constraints supply is ``A^T lambda``.
    constraint_forces
        ``A^T lambda``.
    applied
        The generalized force applied forces must supply, orthogonal to the rows of
        ``A`` (zero where the constraints prescribe every direction).
    required
        ``M qdd - f``, their sum.
    """

    multipliers: np.ndarray
    constraint_forces: np.ndarray
    applied: np.ndarray
    required: np.ndarray


def inverse_dynamics_at(num: NumericModel, t: float, q: np.ndarray, qd: np.ndarray,
                        qdd: np.ndarray, names: tuple[str, ...]) -> InverseDynamics:
    """The forces the motion ``(q, qd, qdd)`` at ``t`` needs.

    Parameters
    ----------
    num
        The compiled equations bound to parameter values.
    t, q, qd, qdd
        The motion at one instant.
    names
        The constraints' descriptions, for the error.

    Raises
    ------
    ValueError
        ``qdd`` violates the differentiated constraints ``A qdd = c`` (naming the
        constraint): no force can produce a motion the constraints forbid.
    """
    Mv, f, Av, c = num.kkt_sparse(t, q, qd)
    pattern = num.pattern
    if num.m:
        miss = matvec(pattern.A_rows, pattern.A_cols, Av, qdd, num.m) - c
        scale = 1.0 + np.abs(c).max() + np.abs(Av).max() * np.abs(qdd).max()
        worst = int(np.argmax(np.abs(miss)))
        if not abs(miss[worst]) <= CONSTRAINT_RTOL * scale:
            raise ValueError(
                f"the accelerations violate {names[worst]}: A qdd - c = {miss[worst]:.3g} "
                "there; give a motion the constraints allow (its qdd must satisfy the "
                "constraints differentiated twice)")
    required = matvec(pattern.M_rows, pattern.M_cols, Mv, qdd, num.n) - f
    lam = min_norm_multipliers(pattern.dense_A(Av), required) if num.m else np.zeros(0)
    forces = matvec(pattern.A_cols, pattern.A_rows, Av, lam, num.n)
    return InverseDynamics(lam, forces, required - forces, required)
