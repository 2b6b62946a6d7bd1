"""Classifying a constrained stationary point from the Jacobian and the Hessian.

The constraint gradients (rows of ``J``) must be independent for the multipliers
to be determined; then the point is classified from the Hessian ``H`` of the
augmented function restricted to the tangent space of the constraints,
``H_red = Z^T H Z`` with ``Z`` an orthonormal basis of the null space of ``J``.
"""

from __future__ import annotations

import numpy as np
import scipy.linalg

from ..errors import DependentConstraintsError
from .problem import Array, Problem, max_abs, point_text

#: Possible values of :attr:`Extremum.kind`. ``"isolated"`` is used when there
#: are as many independent constraints as variables: the feasible set is locally
#: the point itself, so there is no tangent direction to classify.
KINDS = ("minimum", "maximum", "saddle", "degenerate", "isolated")

_DEGENERACY_RTOL = 1e-8  # |eigenvalue| <= this * max(1, max|H|) counts as zero
_RANK_RTOL = 1e-8  # singular value <= this * largest one counts as zero


def dependent_constraints(jacobian: Array, rtol: float = _RANK_RTOL) -> tuple[int, ...]:
    """0-based indices of all constraints taking part in a linear dependency.

    Unlike :func:`dalembert.numerics.rank.dependent_rows`, which names only the rows
    that repeat earlier ones, this names every participant (for ``x + y - 1`` and
    ``2x + 2y - 2``, both), and the rank test is relative to the largest singular
    value alone. Empty if ``jacobian`` has full row rank.
    """
    if jacobian.shape[0] == 0:
        return ()
    u, s, _ = np.linalg.svd(jacobian)
    small = s <= rtol * s[0]
    if not small.any():
        return ()
    # Rows with weight in a left null vector are the ones combined in a dependency.
    weights = np.max(np.abs(u[:, small]), axis=1)
    return tuple(int(i) for i in np.flatnonzero(weights > 1e-6))


def raise_if_dependent(problem: Problem, x: Array, jacobian: Array, context: str = "") -> None:
    """Raise :class:`DependentConstraintsError` if ``jacobian`` is rank-deficient at ``x``.

    ``context`` is prepended to the message.
    """
    indices = dependent_constraints(jacobian)
    if not indices:
        return
    listed = ", ".join(f"{i} ({problem.constraint_text[i]})" for i in indices)
    raise DependentConstraintsError(
        f"{context}the constraint Jacobian is rank-deficient at ({point_text(problem, x)}): "
        f"the gradients of constraints {listed} (0-based indices) are linearly "
        "dependent, so the multipliers are not determined there. Remove redundant "
        "constraints, or check that the constraints are not tangent at this point.",
        indices,
    )


def classify_point(hessian: Array, jacobian: Array) -> tuple[Array, str]:
    """Ascending eigenvalues of ``Z^T H Z`` and the kind (one of :data:`KINDS`).

    An eigenvalue counts as zero if its magnitude is at most ``1e-8 max(1,
    max|H|)``.
    """
    eigenvalues = _reduced_hessian_eigenvalues(hessian, jacobian)
    return eigenvalues, _kind(eigenvalues, max(1.0, max_abs(hessian)))


def _reduced_hessian_eigenvalues(hessian: Array, jacobian: Array) -> Array:
    n = hessian.shape[0]
    basis = np.eye(n) if jacobian.shape[0] == 0 else scipy.linalg.null_space(jacobian)
    if basis.shape[1] == 0:
        return np.zeros(0)
    symmetric = 0.5 * (hessian + hessian.T)
    return np.linalg.eigvalsh(basis.T @ symmetric @ basis)


def _kind(eigenvalues: Array, scale: float) -> str:
    if eigenvalues.size == 0:
        return "isolated"
    threshold = _DEGENERACY_RTOL * scale
    positive, negative = eigenvalues > threshold, eigenvalues < -threshold
    if positive.any() and negative.any():
        return "saddle"
    if not (positive | negative).all():
        return "degenerate"
    return "minimum" if positive.all() else "maximum"
