"""Consistent initial values: read them, check them, project them onto the constraints."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from ..codegen.compiled import NumericModel
from ..errors import InitialConditionError
from ..model.coordinates import key_name
from .kkt import check_constraint_rank, check_kkt
from .projection import project_positions, project_velocities

#: Changes smaller than this (relative) are rounding, not worth reporting.
REPORT_TOL = 1e-10


@dataclass(frozen=True)
class InitializationReport:
    """What consistent initialization changed: per-coordinate position and velocity changes."""

    names: tuple[str, ...]
    q_given: np.ndarray
    qd_given: np.ndarray
    q: np.ndarray
    qd: np.ndarray

    @property
    def changed(self) -> bool:
        return bool(self.changed_positions() or self.changed_velocities())

    def changed_positions(self) -> list[str]:
        return _changed(self.names, self.q_given, self.q)

    def changed_velocities(self) -> list[str]:
        return _changed(self.names, self.qd_given, self.qd)

    def __str__(self) -> str:
        if not self.changed:
            return "initial conditions satisfy the constraints; nothing changed"
        lines = ["initial conditions were projected onto the constraints:"]
        for i, name in enumerate(self.names):
            for label, given, new in (("", self.q_given, self.q), ("_dot", self.qd_given, self.qd)):
                if name in _changed(self.names[i : i + 1], given[i : i + 1], new[i : i + 1]):
                    lines.append(f"  {name}{label}: {given[i]:.10g} -> {new[i]:.10g}")
        return "\n".join(lines)


def _changed(names: Sequence[str], given: np.ndarray, new: np.ndarray) -> list[str]:
    scale = max(1.0, float(np.abs(given).max(initial=0.0)))
    return [n for n, a, b in zip(names, given, new) if abs(a - b) > REPORT_TOL * scale]


def state_vector(values: object, names: Sequence[str], what: str) -> np.ndarray:
    """Read ``q0`` or ``qd0``: a dict by coordinate (or name), or an array in order.

    Coordinates missing from a dict default to zero.

    >>> state_vector({"y": -1.0}, ("x", "y"), "q0")
    array([ 0., -1.])
    """
    n = len(names)
    if values is None:
        return np.zeros(n)
    if isinstance(values, Mapping):
        vec = np.zeros(n)
        for key, value in values.items():
            name = key_name(key)
            if name not in names:
                raise InitialConditionError(
                    f"{what} names {name!r}, which is not a coordinate "
                    f"(the coordinates are {', '.join(names)})"
                )
            vec[names.index(name)] = _number(value, f"{what}[{name!r}]")
    else:
        try:
            vec = np.asarray(values, dtype=float).ravel()
        except (TypeError, ValueError) as exc:
            raise InitialConditionError(f"{what} must be numbers, got {values!r}") from exc
        if vec.size != n:
            raise InitialConditionError(
                f"{what} has {vec.size} values for {n} coordinates ({', '.join(names)})"
            )
    bad = [names[i] for i in np.flatnonzero(~np.isfinite(vec))]
    if bad:
        raise InitialConditionError(f"{what} is not finite for {', '.join(bad)}")
    return vec


def _number(value: object, what: str) -> float:
    try:
        return float(value)
    except (TypeError, ValueError) as exc:
        raise InitialConditionError(f"{what} = {value!r} is not a number") from exc


def free_mask(fixed: Sequence[object] | None, names: Sequence[str]) -> np.ndarray:
    """Boolean mask of the coordinates initialization may change."""
    free = np.ones(len(names), dtype=bool)
    for key in fixed or ():
        name = key_name(key)
        if name not in names:
            raise InitialConditionError(f"fixed names {name!r}, which is not a coordinate")
        free[names.index(name)] = False
    return free


def consistent_state(
    num: NumericModel,
    t0: float,
    q0: np.ndarray,
    qd0: np.ndarray,
    names: Sequence[str],
    constraint_labels: Sequence[str],
    fixed: Sequence[object] | None = None,
) -> InitializationReport:
    """Project ``(q0, qd0)`` onto the constraints and check the KKT matrix there."""
    free = free_mask(fixed, names)
    try:
        q = project_positions(num, t0, q0, free)
        if num.m:
            A, _ = num.velocity_constraint(t0, q)
            check_constraint_rank(A, constraint_labels, "at the initial state")
        qd = project_velocities(num, t0, q, qd0, free)
    except np.linalg.LinAlgError as exc:
        raise InitialConditionError(f"could not project the initial state: {exc}") from exc
    except InitialConditionError as exc:
        held = [n for n, f in zip(names, free) if not f]
        hint = f" with {', '.join(held)} held fixed" if held else ""
        raise InitialConditionError(
            f"the initial conditions cannot be made consistent{hint}: {exc}. "
            "Start closer to a configuration that satisfies the constraints"
            + ("; or fix fewer coordinates" if held else "")
        ) from exc
    _check_consistent(num, t0, q, qd, free, names)
    M, *_ = num.kkt_blocks(t0, q, qd)
    check_kkt(M, num.velocity_constraint(t0, q)[0], names, "at the initial state")
    return InitializationReport(tuple(names), q0, qd0, q, qd)


def _check_consistent(
    num: NumericModel, t0: float, q: np.ndarray, qd: np.ndarray, free: np.ndarray,
    names: Sequence[str],
) -> None:
    """The velocity projection is exact only if the free coordinates can reach it."""
    if num.m == 0:
        return
    A, b = num.velocity_constraint(t0, q)
    residual = np.abs(A @ qd + b).max()
    if residual > 1e-10 * max(1.0, np.abs(qd).max()):
        held = [n for n, f in zip(names, free) if not f]
        raise InitialConditionError(
            f"the initial velocities cannot satisfy the constraints (residual {residual:.2e})"
            + (f" with {', '.join(held)} held fixed; fix fewer coordinates" if held else "")
        )

