"""Which functions a simulation runs on: the C loop when it applies, else Python's.

Both give the same trajectory to rounding; :mod:`dalembert.solvers.native` says
when the C loop applies and why it is faster.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from functools import partial

import numpy as np
from scipy.integrate import OdeSolver

from ..codegen.compiled import NumericModel
from .dynamics import first_order_rhs
from .integrate import solver_class
from .native import NATIVE_METHODS, NotApplicable, native_solver
from .outputs import evaluate_outputs
from .projection import StepProjector


@dataclass(frozen=True)
class Engine:
    """``rhs(t, y)``, ``project(t, y)`` (or ``None``), the solver class and its extra
    options; ``outputs(t, y)``: the trajectory's derived arrays, as
    :func:`~dalembert.solvers.outputs.evaluate_outputs` computes them."""

    rhs: Callable
    project: Callable | None
    method: type[OdeSolver]
    options: dict
    outputs: Callable


def choose_engine(
    num: NumericModel, t0: float, y0: np.ndarray, method: str | type[OdeSolver], *,
    projection: bool, baumgarte: float = 0.0, kept: np.ndarray | None = None,
    native: bool | None = None,
) -> Engine:
    """The engine for one simulation. ``native``: ``None`` uses the C loop when it
    applies, ``True`` requires it (``ValueError`` saying why not), ``False`` never."""
    cls = solver_class(method)
    if native is not False:
        try:
            solver = native_solver(num, y0, t0, baumgarte, kept)
        except NotApplicable as exc:
            if native:
                raise ValueError(f"native=True, but the C loop does not apply: {exc}") from exc
        else:
            stepper = NATIVE_METHODS.get(cls)
            return Engine(solver.rhs, solver.project if projection else None, stepper or cls,
                          {"native": solver} if stepper else {}, solver.outputs)
    project = StepProjector(num, kept) if projection else None
    return Engine(first_order_rhs(num, baumgarte, kept), project, cls, {},
                  partial(evaluate_outputs, num, kept=kept))
