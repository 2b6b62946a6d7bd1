"""The result of a simulation: states, multipliers, constraint forces and checks.

A :class:`Trajectory` is plain NumPy data (one row per output time) with access
by coordinate and constraint name, lossless ``save``/``load`` (``.npz``, written
atomically, read back checked: :mod:`dalembert.trajectory_file`) and
``to_dataframe`` when pandas is installed.
"""

from __future__ import annotations

import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from . import trajectory_file

if TYPE_CHECKING:
    import pandas as pd

    from .solvers.contact.driver import ContactHistory

#: A trajectory's repr lists its coordinates when there are at most this many, else
#: :func:`name_list` condenses them.
REPR_NAMES = 8
#: Names :func:`name_list` shows at the start and at the end of a long list.
HEAD_NAMES, TAIL_NAMES = 4, 2


def name_list(names: tuple[str, ...] | list[str], what: str) -> str:
    """``"<count> <what>: a, b, c, d, ..., y, z"``: a list of names, condensed when long.

    Parameters
    ----------
    names
        The names.
    what
        What they are, in the plural (``"coordinates"``; one name drops the ``s``).

    Examples
    --------
    >>> name_list([f"x{i}" for i in range(1, 49)], "coordinates")
    '48 coordinates: x1, x2, x3, x4, ..., x47, x48'
    >>> name_list(["rod"], "constraints")
    '1 constraint: rod'
    """
    shown = list(names)
    if len(shown) > HEAD_NAMES + TAIL_NAMES + 1:
        shown = [*shown[:HEAD_NAMES], "...", *shown[-TAIL_NAMES:]]
    if len(names) == 1:
        what = what.removesuffix("s")
    return f"{len(names)} {what}: {', '.join(shown)}"


@dataclass(eq=False)
class Trajectory:
    """States and derived quantities at the output times ``t``.

    Arrays have one row per time: ``q``, ``qd``, ``qdd`` (n columns),
    ``multipliers`` (m columns, constraint order), ``constraint_forces``
    (``A^T lambda``, n columns), energies, and the largest position and velocity
    constraint residuals. ``traj["x"]``, ``traj["x_dot"]``, ``traj["x_ddot"]`` give
    one coordinate's column; ``traj.multiplier("name")`` one constraint's.
    :meth:`System.simulate <dalembert.System.simulate>` makes it.

    Parameters
    ----------
    t
        Output times, shape ``(k,)``.
    q, qd, qdd
        Coordinates, velocities and accelerations, shape ``(k, n)``.
    multipliers
        Lagrange multipliers, shape ``(k, m)`` (minimum-norm ones where
        constraints are dependent).
    constraint_forces
        Generalized constraint forces ``A^T lambda``, shape ``(k, n)``.
    kinetic_energy, potential_energy, jacobi_integral
        ``T``, ``V`` and ``h = qd . dL/dqd - L``, shape ``(k,)``.
    position_residual, velocity_residual
        Largest ``|psi|`` and ``|A qd + b|`` at each time.
    coordinate_names, constraint_names
        Column names.
    status, message
        ``"finished"``, ``"event"``, ``"failed"``, ``"interrupted"`` or ``"timeout"``, and why.
    stats
        Evaluations, steps, projections.
    initialization
        What making the initial state consistent changed.
    parameters
        The parameter values the run used, by name.
    inputs, input_names
        The values of the model's inputs at each time, shape ``(k, inputs)``, and
        their names.
    t_events, y_events
        Event times and states, one array per event function.
    near_singular
        ``True`` at the times when the constraints were within a hair of losing rank
        (a linkage through its flat position): the steps there left the nearly
        dependent combinations of constraints out, and ``multipliers`` (and
        ``constraint_forces``) there are the minimum-norm ones, not unique; shape
        ``(k,)``.
    sol
        Dense output ``sol(t)`` (with ``dense_output=True``), else ``None``.
    energy_conserved
        Whether the model conserves ``T + V`` (no applied force, input or moving
        constraint; ``None``: not known), set by the System: :meth:`summary` calls a
        change of ``T + V`` an error only where it is conserved.
    contacts
        With unilateral constraints: the impacts (time, normal and friction impulse
        on each contact, energy lost, velocities before and after) and the contacts closed over time
        (:class:`~dalembert.solvers.contact.driver.ContactHistory`; ``closed_at(t)``);
        ``multipliers`` then have a column per unilateral constraint too (0 while open).

    Examples
    --------
    >>> from dalembert.examples import load
    >>> traj = load("pendulum").build().simulate((0, 1), {"x": 1.0, "y": 0.0},
    ...                                          t_eval=[0.0, 0.5, 1.0])
    >>> traj.q.shape, traj.coordinate_names, traj.success
    ((3, 2), ('x', 'y'), True)
    >>> bool(abs(traj["x"][0] - 1.0) < 1e-15 and traj.multiplier("rod").shape == (3,))
    True
    """

    t: np.ndarray
    q: np.ndarray
    qd: np.ndarray
    qdd: np.ndarray
    multipliers: np.ndarray
    constraint_forces: np.ndarray
    kinetic_energy: np.ndarray
    potential_energy: np.ndarray
    jacobi_integral: np.ndarray
    position_residual: np.ndarray
    velocity_residual: np.ndarray
    coordinate_names: tuple[str, ...]
    constraint_names: tuple[str, ...]
    status: str = "finished"
    message: str = ""
    stats: dict[str, Any] = field(default_factory=dict)
    initialization: str = ""
    parameters: dict[str, float] = field(default_factory=dict)
    inputs: np.ndarray = field(default_factory=lambda: np.zeros((0, 0)))
    input_names: tuple[str, ...] = ()
    t_events: list[np.ndarray] = field(default_factory=list)
    y_events: list[np.ndarray] = field(default_factory=list)
    near_singular: np.ndarray | None = None
    sol: Any = None
    energy_conserved: bool | None = None
    contacts: ContactHistory | None = None

    @property
    def success(self) -> bool:
        """True when the integration reached the end of ``t_span`` or a terminal event."""
        return self.status in ("finished", "event")

    @property
    def energy(self) -> np.ndarray:
        """Total energy ``T + V`` (NaN when the model was given as a Lagrangian only)."""
        return self.kinetic_energy + self.potential_energy

    def __getitem__(self, key: object) -> np.ndarray:
        name, order = _coordinate_key(key)
        names = self.coordinate_names
        arrays = (self.q, self.qd, self.qdd)
        # An exact coordinate name wins over reading a suffix (a coordinate may
        # itself be called "u_dot").
        if order is not None and name in names:
            return arrays[order][:, names.index(name)]
        if order is None:
            if name in names:
                return self.q[:, names.index(name)]
            for suffix, k in (("_ddot", 2), ("_dot", 1)):
                base = name[: -len(suffix)]
                if name.endswith(suffix) and base in names:
                    return arrays[k][:, names.index(base)]
        raise KeyError(
            f"{name!r} is not a coordinate; the coordinates are {', '.join(names)} "
            "(append _dot or _ddot for velocity or acceleration)"
        )

    def multiplier(self, name: str) -> np.ndarray:
        """The Lagrange multiplier of the constraint called ``name``."""
        if name not in self.constraint_names:
            raise KeyError(
                f"{name!r} is not a constraint; the constraints are "
                f"{', '.join(self.constraint_names) or 'none'}"
            )
        return self.multipliers[:, self.constraint_names.index(name)]

    def input(self, name: str) -> np.ndarray:
        """The values the input called ``name`` took at each time."""
        if name not in self.input_names:
            raise KeyError(f"{name!r} is not an input; the inputs are "
                           f"{', '.join(self.input_names) or 'none'}")
        return self.inputs[:, self.input_names.index(name)]

    def __post_init__(self) -> None:
        if self.inputs is None or (np.size(self.inputs) == 0 and not self.input_names):
            self.inputs = np.zeros((len(self.t), len(self.input_names)))
        if self.near_singular is None:
            self.near_singular = np.zeros(len(self.t), dtype=bool)

    def __len__(self) -> int:
        return len(self.t)

    def __repr__(self) -> str:
        span = f"t={self.t[0]:.4g}..{self.t[-1]:.4g}" if len(self.t) else "empty"
        names = self.coordinate_names
        listed = (f"coordinates={list(names)}" if len(names) <= REPR_NAMES
                  else name_list(names, "coordinates"))
        return f"Trajectory({len(self.t)} points, {span}, status={self.status!r}, {listed})"

    def summary(self) -> str:
        """A few lines with the measured drift and the change of energy ``T + V``: an
        error where the model conserves it, else the work of its applied forces, inputs
        and drivers (:attr:`energy_conserved`).

        Examples
        --------
        >>> from dalembert.examples import load
        >>> traj = load("pendulum").build().simulate((0, 1), {"x": 1.0, "y": 0.0})
        >>> print(traj.summary().splitlines()[-1])  # doctest: +ELLIPSIS
          relative change of T + V ...e-1... (an error where energy is conserved)
        """
        lines = [repr(self), f"  {self.message}"]
        if self.constraint_names:
            lines.append(f"  {name_list(self.constraint_names, 'constraints')}")
        if len(self.t):
            lines.append(f"  max position residual {self.position_residual.max():.2e}, "
                         f"max velocity residual {self.velocity_residual.max():.2e}")
            e = self.energy
            if np.all(np.isfinite(e)):
                # against the energy exchanged, not T + V alone (zero for a pendulum
                # released level with its pivot)
                scale = max(abs(e[0]), np.abs(self.kinetic_energy).max(),
                            np.abs(self.potential_energy).max(), 1e-300)
                rel = np.abs(e - e[0]).max() / scale
                if self.energy_conserved is False:
                    lines.append(
                        f"  change of T + V {e[-1] - e[0]:.6g} (relative {rel:.2e}): the work "
                        "of the applied forces, inputs and drivers, not an error")
                else:
                    lines.append(f"  relative change of T + V {rel:.2e} (an error where "
                                 "energy is conserved)")
        return "\n".join(lines)

    def save(self, path: str | os.PathLike) -> Path:
        """Write every array and name to ``path`` (a NumPy ``.npz`` file), atomically.

        The file appears whole or not at all (written beside it, synced, renamed)
        with the mode a plain ``open`` would give it under the umask; a save killed
        midway leaves the previous file as it was (and its temporary file is
        removed by a later save to the same path).

        Parameters
        ----------
        path
            The file; it must end in ``.npz``, the only format written (for a
            table, ``traj.to_dataframe().to_csv(...)``).

        Returns
        -------
        Path
            The file written.

        Raises
        ------
        TrajectoryFileError
            ``path`` does not end in ``.npz`` (nothing is written).

        Examples
        --------
        >>> import tempfile
        >>> from pathlib import Path
        >>> from dalembert.examples import load
        >>> traj = load("pendulum").build().simulate((0, 0.1), {"x": 1.0, "y": 0.0})
        >>> with tempfile.TemporaryDirectory() as folder:
        ...     again = Trajectory.load(traj.save(Path(folder) / "run.npz"))
        >>> bool((again.q == traj.q).all()), again.constraint_names
        (True, ('rod',))
        """
        path = trajectory_file.file_path(path, "Trajectory.save")
        meta: dict[str, Any] = {"coordinate_names": list(self.coordinate_names),
            "constraint_names": list(self.constraint_names), "status": self.status,
            "message": self.message, "stats": self.stats, "initialization": self.initialization,
            "parameters": {k: float(v) for k, v in self.parameters.items()},
            "input_names": list(self.input_names)}
        if self.energy_conserved is not None:
            meta["energy_conserved"] = bool(self.energy_conserved)
        arrays = {name: getattr(self, name) for name in trajectory_file.ARRAYS}
        if self.input_names:
            arrays["inputs"] = self.inputs
        if self.near_singular is not None and self.near_singular.any():
            arrays["near_singular"] = self.near_singular
        arrays.update({f"t_events_{k}": v for k, v in enumerate(self.t_events)})
        arrays.update({f"y_events_{k}": v for k, v in enumerate(self.y_events)})
        if self.contacts is not None:
            meta["contact_names"] = list(self.contacts.names)
            arrays.update(self.contacts.arrays(len(self.coordinate_names)))
        trajectory_file.write(path, arrays, meta)
        return path

    @classmethod
    def load(cls, path: str | os.PathLike, *, max_bytes: int | None = None) -> Trajectory:
        """Read a trajectory written by :meth:`save` (see there for an example).

        The file is not trusted: a path that is not a regular file (a FIFO) is
        refused without waiting on it, the number of members and their declared
        sizes are bounded before anything is decompressed, nothing in it is
        unpickled, and its metadata and array shapes are checked
        (:mod:`dalembert.trajectory_file`).

        Parameters
        ----------
        path
            A ``.npz`` file written by :meth:`save`.
        max_bytes
            The most bytes its arrays may take once read (default:
            :data:`~dalembert.trajectory_file.MAX_EXPANSION` times the file's size,
            at least :data:`~dalembert.trajectory_file.MIN_LIMIT`; a file written by
            :meth:`save` reads to about its own size).

        Raises
        ------
        TrajectoryFileError
            The file is not a regular file or not a trajectory file, would take
            more than ``max_bytes``, or holds inconsistent data (the message names
            the member or field).
        FileNotFoundError, PermissionError
            The file is not there or cannot be read.
        """
        fields = trajectory_file.read(trajectory_file.file_path(path, "Trajectory.load"),
                                      max_bytes)
        contacts = fields.pop("contacts", None)
        if contacts is not None:
            from .solvers.contact.driver import ContactHistory

            fields["contacts"] = ContactHistory.from_arrays(contacts)
        return cls(**fields)

    def to_dataframe(self) -> pd.DataFrame:
        """A pandas DataFrame indexed by time ``t``, one column per quantity.

        The columns, in this order (``x`` a coordinate, ``rod`` a constraint, ``u`` an
        input):

        ========================= ==================================================
        ``x``, ``x_dot``,         the coordinate, its velocity and acceleration
        ``x_ddot``
        ``lambda[rod]``           the constraint's Lagrange multiplier
        ``constraint_force[x]``   the generalized constraint force on ``x``, the
                                  column ``x`` of ``A^T lambda`` (in ``M qdd = f +
                                  A^T lambda``; :attr:`constraint_forces`)
        ``kinetic_energy``,       ``T`` and ``V``
        ``potential_energy``
        ``energy``                ``T + V`` (:attr:`energy`)
        ``jacobi_integral``       ``h = qd . dL/dqd - L``
        ``position_residual``,    the largest ``|psi|`` and ``|A qd + b|``
        ``velocity_residual``
        ``input[u]``              the input's value
        ========================= ==================================================

        Returns
        -------
        pandas.DataFrame
            The table (``to_csv``, ``to_parquet``, ``plot`` as for any other).

        Raises
        ------
        ImportError
            pandas is not installed (``pip install 'dalembert[pandas]'``).

        Examples
        --------
        >>> from dalembert.examples import load
        >>> traj = load("pendulum").build().simulate((0, 1), {"x": 1.0, "y": 0.0},
        ...                                          t_eval=[0.0, 0.5, 1.0])
        >>> df = traj.to_dataframe()
        >>> list(df.columns[6:10])
        ['lambda[rod]', 'constraint_force[x]', 'constraint_force[y]', 'kinetic_energy']
        >>> bool((df["energy"] == traj.energy).all())
        True
        """
        try:
            import pandas as pd
        except ImportError as exc:
            raise ImportError(
                "to_dataframe() needs pandas: pip install 'dalembert[pandas]'"
            ) from exc
        columns: dict[str, np.ndarray] = {}
        for i, name in enumerate(self.coordinate_names):
            columns[name] = self.q[:, i]
            columns[f"{name}_dot"] = self.qd[:, i]
            columns[f"{name}_ddot"] = self.qdd[:, i]
        for i, name in enumerate(self.constraint_names):
            columns[f"lambda[{name}]"] = self.multipliers[:, i]
        for i, name in enumerate(self.coordinate_names):
            columns[f"constraint_force[{name}]"] = self.constraint_forces[:, i]
        columns["kinetic_energy"] = self.kinetic_energy
        columns["potential_energy"] = self.potential_energy
        columns["energy"] = self.energy
        for name in ("jacobi_integral", "position_residual", "velocity_residual"):
            columns[name] = getattr(self, name)
        for i, name in enumerate(self.input_names):
            columns[f"input[{name}]"] = self.inputs[:, i]
        return pd.DataFrame(columns, index=pd.Index(self.t, name="t"))


def _coordinate_key(key: object) -> tuple[str, int | None]:
    """A key's name and derivative order (``None``: read it from a name suffix).

    Strings are names (``"x"``, ``"x_dot"``); SymPy keys are the coordinate
    ``x(t)`` or a plain symbol (order 0) or a derivative ``x(t).diff(t, k)``.
    """
    if isinstance(key, str):
        return key, None
    import sympy as sp  # only SymPy keys need it

    if isinstance(key, sp.Derivative):
        order = sum(count for _, count in key.variable_count)
        if order > 2:
            raise KeyError(f"{key} is a derivative of order {order}; only q, qd, qdd are kept")
        return _coordinate_key(key.expr)[0], order
    if isinstance(key, sp.Symbol):
        return key.name, None
    if isinstance(key, sp.Expr) and key.is_Function:
        return key.func.__name__, 0
    raise KeyError(f"{key!r} is not a coordinate name")

