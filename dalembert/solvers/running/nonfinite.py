"""Saying what is not finite at a state of a simulation, and where it likely comes from.

A NaN or an infinity in a step ends the run (:mod:`~dalembert.solvers.running.loop`): a
step size that is NaN never shrinks below the smallest step, so the step would be
retried forever, and a state that is not finite makes every later one so. The
loops then call the function :func:`nonfinite_diagnosis` makes, which looks at the
state and at each quantity of the model there, in the order they are computed,
and names the first that is not finite: the state (which coordinate), the mass
matrix, the applied forces (on which coordinate), the constraint Jacobian or its
velocity terms (which row), the Baumgarte gain, or the accelerations solved from
finite values (an overflow).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np

from ...codegen.compiled import NumericModel
from ...errors import DalembertError

#: ``diagnose(t, y)``: a sentence on what is not finite at ``(t, y)``, or ``""``.
Diagnosis = Callable[[float, np.ndarray], str]

#: At most this many entries are named in a message.
NAMED = 3


def nonfinite_diagnosis(num: NumericModel, names: Sequence[str],
                        constraint_names: Sequence[str] | None = None, gain: float = 0.0,
                        rhs: Callable[[float, np.ndarray], np.ndarray] | None = None,
                        ) -> Diagnosis:
    """The function saying what is not finite at a state ``y = [q, qd]`` of ``num``.

    Parameters
    ----------
    num
        The compiled equations bound to parameter values.
    names
        The coordinates' names.
    constraint_names
        The constraint rows' names (default: ``row 0``, ``row 1``...).
    gain
        The Baumgarte gain (0: none).
    rhs
        ``rhs(t, y) = [qd, qdd]`` as the loop evaluates it: checked last, for
        accelerations that overflow although every input is finite.

    Examples
    --------
    >>> from dalembert.examples import load
    >>> pendulum = load("pendulum").build()
    >>> diagnose = nonfinite_diagnosis(pendulum.numeric(), ["x", "y"], ["rod"])
    >>> diagnose(0.0, np.array([1.0, 0.0, 0.0, 1e200]))  # doctest: +ELLIPSIS
    'the velocity terms c of the constraints are not finite (rod: -inf)...'
    >>> diagnose(0.0, np.array([1.0, 0.0, 0.0, 1.0]))
    ''
    """
    n, layout = num.n, num.layout
    state_names = [*names, *(f"{name}_dot" for name in names)]
    rows = list(constraint_names) if constraint_names is not None else \
        [f"row {k}" for k in range(num.m)]
    holonomic = [rows[k] for k in num.holonomic_rows]

    def diagnose(t: float, y: np.ndarray) -> str:
        y = np.asarray(y, dtype=float)
        q, qd = layout.split(y)
        if not np.isfinite(t):
            return f"the time is {t}"
        if bad := _named(y, state_names):
            return (f"the state is not finite ({bad}): the motion diverged (an unstable "
                    "system, or a step too large for a stiff one)")
        speed = f"|qd| up to {np.abs(qd).max():.3g}" if n else ""
        Mv, f, Av, c = num.kkt_sparse(t, q, qd)
        if not np.all(np.isfinite(Mv)):
            return ("the mass matrix is not finite: the kinetic energy is undefined or "
                    "overflows at this state")
        if bad := _named(f, names):
            return (f"the applied forces are not finite ({bad}): a force is undefined or "
                    "overflows at this state (a square root or logarithm of a negative "
                    "number, a division by zero...)")
        if not np.all(np.isfinite(Av)):
            return ("the constraint Jacobian is not finite: a constraint is undefined or "
                    "overflows at this state")
        if bad := _named(c, rows):
            return (f"the velocity terms c of the constraints are not finite ({bad}): the "
                    f"velocities are too large ({speed}), or a constraint is undefined here")
        if gain and num.m:
            if not np.isfinite(gain):
                return f"the Baumgarte gain is {gain}: it must be a finite positive number"
            _, b = num.velocity_sparse(t, q)
            if bad := _named(b, rows):
                return f"the constraint terms b are not finite ({bad})"
            if bad := _named(num.position_constraint(t, q), holonomic):
                return f"the position constraints are not finite ({bad})"
        if rhs is not None:
            try:
                qdd = layout.qd(np.asarray(rhs(t, y), dtype=float))
            except DalembertError:  # a KKT solve may refuse what overflows in it
                qdd = np.full(n, np.nan)
            if bad := _named(qdd, names):
                return (f"the accelerations are not finite ({bad}) although the mass matrix, "
                        "forces and constraints are: the solve overflowed, the state is too "
                        f"far out of range ({speed})")
        return ""

    return diagnose


def _named(values: np.ndarray, names: Sequence[str]) -> str:
    """``"x: nan, y_dot: inf"`` for the entries that are not finite (at most NAMED)."""
    values = np.asarray(values, dtype=float).ravel()
    bad = np.flatnonzero(~np.isfinite(values))
    named = [f"{names[i]}: {values[i]}" for i in bad[:NAMED]]
    if len(bad) > NAMED:
        named.append(f"{len(bad) - NAMED} more")
    return ", ".join(named)
