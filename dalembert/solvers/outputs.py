"""Derived quantities along a computed trajectory.

At every output time: accelerations and multipliers from the (unstabilized) KKT
system, the generalized constraint force ``A^T lambda``, the largest position and
velocity constraint residuals, and the energies ``T``, ``V`` and the Jacobi
integral ``h = qd . dL/dqd - L``.

With dependent constraints (``kept`` given) the multipliers are the minimum-norm
solution of ``A^T lambda = M qdd - f``: one choice among infinitely many, while
``qdd`` and the constraint force ``A^T lambda`` are unique.
"""

from __future__ import annotations

from collections.abc import Callable
from functools import partial

import numpy as np

from ..codegen.compiled import NumericModel
from .kkt.sparse import kkt_solver, matvec

#: The outputs that take a solve of the KKT system (NaN when it is left out).
SOLVED = ("qdd", "multipliers", "constraint_forces")


def output_arrays(k: int, n: int, m: int, dynamics: bool = True) -> dict[str, np.ndarray]:
    """The outputs' arrays for ``k`` states of ``n`` coordinates and ``m`` constraints,
    zero; without ``dynamics`` those of :data:`SOLVED` are NaN (nothing fills them).

    Parameters
    ----------
    k, n, m
        States, coordinates, constraints.
    dynamics
        Whether the KKT system is solved at each state.

    Examples
    --------
    >>> out = output_arrays(2, 3, 1, dynamics=False)
    >>> list(out), out["multipliers"].shape, bool(np.isnan(out["qdd"]).all())
    (['qdd', 'multipliers', 'constraint_forces', 'position_residual', \
'velocity_residual', 'energies'], (2, 1), True)
    """
    solved = np.zeros if dynamics else partial(np.full, fill_value=np.nan)
    return {"qdd": solved((k, n)), "multipliers": solved((k, m)),
            "constraint_forces": solved((k, n)), "position_residual": np.zeros(k),
            "velocity_residual": np.zeros(k), "energies": np.zeros((k, 3))}


def evaluate_outputs(
    num: NumericModel, t: np.ndarray, y: np.ndarray, kept: np.ndarray | None = None,
    inputs: Callable[[float, np.ndarray, np.ndarray], np.ndarray] | None = None,
    dynamics: bool = True,
) -> dict[str, np.ndarray]:
    """Arrays with one row per output time (see module docstring); ``inputs(t, q, qd)``
    sets the model's inputs at each state first, if given. Without ``dynamics`` the KKT
    system is not solved: ``qdd``, the multipliers and the constraint forces are NaN."""
    out = output_arrays(len(t), num.n, num.m, dynamics)
    solver = kkt_solver(num.pattern, kept) if dynamics else None
    rows, cols = num.pattern.A_rows, num.pattern.A_cols
    # The last state of a run stopped by a NaN or an overflow may overflow here too: its
    # outputs are then not finite, without NumPy's warnings (the run's message says why)
    with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
        _fill(out, num, solver, t, y, rows, cols, inputs)
    return out


def _fill(out: dict[str, np.ndarray], num: NumericModel, solver, t: np.ndarray,
          y: np.ndarray, rows: np.ndarray, cols: np.ndarray,
          inputs: Callable[[float, np.ndarray, np.ndarray], np.ndarray] | None) -> None:
    """The rows of ``out`` (``solver``: ``None`` leaves the KKT system unsolved)."""
    n, m, layout = num.n, num.m, num.layout
    for i, (ti, yi) in enumerate(zip(t, y)):
        q, qd = layout.split(yi)
        if inputs is not None:
            num.set_inputs(inputs(ti, q, qd))
        Av = None
        if solver is not None:
            Mv, f, Av, c = num.kkt_sparse(ti, q, qd)
            qdd, lam = solver.solve(Mv, f, Av, c)
            out["qdd"][i] = qdd
            out["multipliers"][i] = lam
            out["constraint_forces"][i] = matvec(cols, rows, Av, lam, n)
        if num.holonomic_rows:
            out["position_residual"][i] = np.abs(num.position_constraint(ti, q)).max()
        if m:
            A_values, b = num.velocity_sparse(ti, q)
            if Av is not None:  # the same A: the solve's, as the residual always took it
                A_values = Av
            out["velocity_residual"][i] = np.abs(matvec(rows, cols, A_values, qd, m) + b).max()
        out["energies"][i] = num.energies(ti, q, qd)
