"""The simulation loop in C: KKT solves, Runge-Kutta steps and projections.

Python around SciPy's integrators costs ~100 us per right-hand side, more than
the mechanics of a 16-link chain. Here the right-hand side, whole explicit
Runge-Kutta steps and the projection after each step run in C (``runtime.h`` and
its sources, hand-written, compiled together once per machine and cached like
generated code, see :mod:`.library`), calling the model's generated C functions
through pointers.

What runs where: with the step projection and without dense output or events
(but those C screens, :mod:`.screens`: the contact events), whole stretches of the
loop run in C (``dl_rk_run``, :mod:`.run`): steps, the projection of each step's
end, the outputs at ``t_eval`` (the step's interpolant as SciPy makes it,
projected) and the restart, returning to Python every fraction of a second; a step
C cannot finish, or whose end a screen flags, is taken the step-by-step way. Otherwise
Python sees each accepted step (:mod:`.runge_kutta`: the steps in C, SciPy's
solver object around them) and the regular loop does the rest. Radau's steps run in
C too (:mod:`.radau`, whole stretches of them as well), its Newton systems reduced to
the KKT matrix's size and factored by a band LU. Initial values
and the trajectory's outputs are the regular path's, so results match it to
rounding (tested).

The KKT solve is a range-space (Schur complement) method, linear in the size of
the mechanism: ``M`` is block diagonal (one block per body), constraint rows
that lie inside one block (a quaternion's unit norm) are folded into it,
``Mt = M_b + w a a^T`` (true at every solution, and it makes a quaternion body's
block positive definite), each block gets a dense Cholesky factor, and the
multipliers solve ``A Mt^-1 A^T lambda = c - A Mt^-1 f``. The rows inside a
block couple nothing else, so they are eliminated there (Gaussian pivots on the
block's part of ``S``); the rest is a banded positive definite system for chains
and trees (band LDL^T in reverse Cuthill-McKee order; see :mod:`.structure`).
This is Baraff's linear-time multiplier method in sparse form. The projections
solve ``J J^T`` with the same code.

Dependent constraint rows (a planar loop closed with 3D hinges) are handled as the
Python loop handles them: the rows that depend on others at the initial state are
dropped for the whole run, the solve and the projections use the kept rows (their
pairs alone enter the blocks and the band), the dropped rows' multipliers are zero
during the run and the reported ones are the minimum-norm multipliers over all
rows. Each solve checks that the accelerations still meet the dropped rows; if the
rank changed, the C loop stops with an error naming the Python loop.

:func:`native_solver` says when it applies: C-generated model functions, blocks
of ``M`` and a band of at most 64, ``M`` positive definite on each block once
folded (checked at the initial state).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from ...codegen.c_backend import CompileError
from ...codegen.compiled import NumericModel
from ...errors import DalembertError
from .library import LayoutError
from .solver import NativeSolver
from .structure import NotApplicable

if TYPE_CHECKING:
    from .radau import NativeRadau
    from .runge_kutta import NATIVE_METHODS, NativeDOP853, NativeRK23, NativeRK45

__all__ = ["NATIVE_METHODS", "NativeDOP853", "NativeRK23", "NativeRK45", "NativeRadau",
           "NativeSolver", "NotApplicable", "native_solver"]

#: Made on first use (PEP 562): they subclass SciPy's solvers, and ``scipy.integrate``
#: is a large import that ``import dalembert`` (through the ensemble's thread turns,
#: :mod:`.turns`) should not make.
_STEPPERS = ("NATIVE_METHODS", "NativeDOP853", "NativeRK23", "NativeRK45")


def __getattr__(name: str) -> object:
    if name in _STEPPERS:
        from . import runge_kutta

        return getattr(runge_kutta, name)
    if name == "NativeRadau":
        from . import radau

        return radau.NativeRadau
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def native_solver(num: NumericModel, y0: np.ndarray, t0: float = 0.0, baumgarte: float = 0.0,
                  kept: np.ndarray | None = None) -> NativeSolver:
    """A :class:`NativeSolver` for ``num``, checked at ``(t0, y0)``.

    Parameters
    ----------
    num
        The compiled equations bound to parameter values.
    y0, t0
        The initial state ``[q, qd]`` and time, where the solve is tried.
    baumgarte
        The Baumgarte gain (0: none).
    kept
        The independent constraint rows when some are dependent (measured at the
        initial state, fixed for the run as in the Python loop), else ``None``.

    Raises
    ------
    NotApplicable
        With the reason, when the C loop cannot be used.
    """
    try:
        solver = NativeSolver(num, baumgarte, kept)
    except LayoutError as exc:
        raise NotApplicable(f"the C runtime does not match its Python mirrors: {exc}") from exc
    except CompileError as exc:
        raise NotApplicable(f"the C runtime could not be compiled: {exc}") from exc
    try:
        solver.rhs(t0, y0)
    except DalembertError as exc:
        raise NotApplicable(f"the block solve does not apply at the initial state: {exc}") \
            from exc
    return solver
