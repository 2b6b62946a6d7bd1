"""The cases of an ensemble: a table whose columns name what changes from run to run.

A case is one row: values of parameters, of initial coordinates (``x``) and
velocities (``x_dot``), of inputs (each held constant along the case's run), and
of any other variables an ``initial_state`` function turns into an initial state
(an angle from which a mechanism's ``q0`` follows). :func:`grid` makes the rows of a
full factorial sweep, :func:`sample` draws them for Monte Carlo from one seeded
generator, so the same seed gives the same cases. :func:`read_cases` checks a table
against a model once, before anything runs, and says which column is which.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from ..errors import EnsembleError

if TYPE_CHECKING:
    import pandas as pd

#: The most cases :func:`grid` makes (two float columns of them take 160 MB, and an
#: ensemble's results hundreds of times more).
MAX_GRID_CASES = 10_000_000
#: What a case table may be given as.
CaseTable = Any  # a pandas DataFrame, a sequence of dicts, or a dict of columns


def grid(**axes: Sequence[float]) -> pd.DataFrame:
    """Every combination of the given values (a full factorial sweep), one case a row.

    The first axis varies slowest, as in nested loops written in the same order.

    Parameters
    ----------
    axes
        ``name=values``: a parameter, a coordinate (``x``), a velocity (``x_dot``), an
        input or a variable of ``initial_state`` or ``case_inputs``, each with a sequence
        of numbers.

    Returns
    -------
    pandas.DataFrame
        One row per combination, one column per axis.

    Examples
    --------
    >>> grid(l=[1.0, 2.0], x=[0.1, 0.2, 0.3]).shape
    (6, 2)
    >>> grid(l=[1.0, 2.0], x=[0.1, 0.2]).values.tolist()
    [[1.0, 0.1], [1.0, 0.2], [2.0, 0.1], [2.0, 0.2]]
    """
    pd = _pandas()
    if not axes:
        raise EnsembleError("grid needs at least one axis, e.g. grid(l=[1.0, 2.0])")
    columns: dict[str, list[float]] = {}
    for name, values in axes.items():
        column = np.atleast_1d(np.asarray(values, dtype=object))
        if column.ndim != 1 or len(column) == 0:
            raise EnsembleError(f"grid axis {name!r} must be a non-empty 1-D sequence of "
                                f"numbers, got {values!r}")
        columns[name] = [_number(v, f"grid axis {name!r}") for v in column]
    count = math.prod(len(values) for values in columns.values())  # exact, before any is made
    if count > MAX_GRID_CASES:
        sizes = ", ".join(f"{name}={len(values)} values" for name, values in columns.items())
        raise EnsembleError(f"grid({sizes}) makes {count} cases, more than the "
                            f"{MAX_GRID_CASES} a grid may have; sweep fewer values, or draw "
                            "cases at random with sample()")
    axes_values = [np.asarray(values, dtype=float) for values in columns.values()]
    mesh = np.meshgrid(*axes_values, indexing="ij")  # the first axis varies slowest
    return pd.DataFrame(np.stack([m.ravel() for m in mesh], axis=1), columns=list(columns))


def sample(dist: Mapping[Any, Any], n: int, seed: int | np.random.SeedSequence) -> pd.DataFrame:
    """``n`` cases drawn at random (Monte Carlo), reproducibly from ``seed``.

    One generator (``numpy.random.default_rng(seed)``) draws the columns in the
    order of ``dist``: the same ``dist``, ``n`` and ``seed`` give the same cases,
    on any machine and whatever runs them afterwards.

    Parameters
    ----------
    dist
        ``name -> distribution``: a frozen ``scipy.stats`` distribution (anything
        with ``rvs(size=, random_state=)``), a function ``f(rng, n)`` returning
        ``n`` numbers, or a number (the same in every case). A tuple of names takes
        a joint distribution whose ``rvs`` gives ``n`` rows of that many numbers
        (``scipy.stats.multivariate_normal``).
    n
        The number of cases.
    seed
        The seed (an integer or a ``numpy.random.SeedSequence``).

    Returns
    -------
    pandas.DataFrame
        ``n`` rows, one column per name.

    Examples
    --------
    >>> from scipy import stats
    >>> cases = sample({"m": stats.uniform(0.9, 0.2), "theta": 0.3}, 4, seed=1)
    >>> cases.shape, bool(cases["m"].between(0.9, 1.1).all()), cases["theta"].tolist()
    ((4, 2), True, [0.3, 0.3, 0.3, 0.3])
    >>> sample({"m": stats.norm()}, 3, seed=7).equals(sample({"m": stats.norm()}, 3, seed=7))
    True
    """
    pd = _pandas()
    if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 1:
        raise EnsembleError(f"sample needs a positive whole number of cases n, got {n!r}")
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer, np.random.SeedSequence)):
        raise EnsembleError(f"sample needs an integer seed (the same seed gives the same "
                            f"cases), got {seed!r}")
    if not isinstance(dist, Mapping) or not dist:
        raise EnsembleError("sample needs a dict {name: distribution}, e.g. "
                            "{'m': scipy.stats.uniform(0.9, 0.2)}")
    rng = np.random.default_rng(seed)
    columns: dict[str, np.ndarray] = {}
    for key, law in dist.items():
        names = tuple(key) if isinstance(key, tuple) else (key,)
        values = _draw(law, rng, int(n), names)
        for k, name in enumerate(names):
            if not isinstance(name, str):
                raise EnsembleError(f"sample's names must be strings, got {name!r}")
            columns[name] = values[:, k]
    return pd.DataFrame(columns)


def _draw(law: Any, rng: np.random.Generator, n: int, names: tuple) -> np.ndarray:
    """``(n, len(names))`` values of one entry of :func:`sample`'s ``dist``."""
    what = f"the distribution of {', '.join(map(str, names))}"
    if hasattr(law, "rvs"):
        values = law.rvs(size=n, random_state=rng)
    elif callable(law):
        values = law(rng, n)
    else:
        values = np.full(n, _number(law, what))
    values = np.asarray(values, dtype=float).reshape(n, -1)
    if values.shape[1] != len(names):
        raise EnsembleError(f"{what} gave {values.shape[1]} value(s) per case for "
                            f"{len(names)} name(s)")
    return values


@dataclass(frozen=True)
class CaseColumns:
    """Which column of a case table is what, for one model.

    ``parameters``, ``positions`` and ``velocities`` hold column names (a velocity
    column ``x_dot`` sets coordinate ``x``'s velocity); ``other`` are the columns
    only ``initial_state`` or ``case_inputs`` read; ``inputs`` name inputs of the
    model, each held at the case's value along its run.
    """

    parameters: tuple[str, ...]
    positions: tuple[str, ...]
    velocities: tuple[str, ...]
    other: tuple[str, ...]
    inputs: tuple[str, ...] = ()


@dataclass(frozen=True)
class Cases:
    """A checked case table: the values (one row per case) and what each column is."""

    table: pd.DataFrame
    columns: CaseColumns

    def __len__(self) -> int:
        return len(self.table)

    def row(self, i: int) -> dict[str, float]:
        """Case ``i`` as ``{column: value}``."""
        return {name: float(v) for name, v in zip(self.table.columns, self.values[i])}

    @property
    def values(self) -> np.ndarray:
        return self.table.to_numpy(dtype=float)


def read_cases(cases: CaseTable, parameters: Sequence[str], coordinates: Sequence[str],
               reader: Callable | None, inputs: Sequence[str] = ()) -> Cases:
    """Check a case table against a model: every column must name something.

    Parameters
    ----------
    cases
        A pandas DataFrame, a list of dicts (one per case) or a dict of columns.
    parameters, coordinates
        The model's parameter and coordinate names.
    reader
        A function that reads cases (``initial_state``, ``case_inputs``), if any:
        only then may a column name something else (it reads those columns).
    inputs
        The model's input names (a column may hold an input's constant value).

    Raises
    ------
    EnsembleError
        No cases, rows with different columns, non-numeric values, or a column that
        names nothing (and no function reads it); the message names it.

    Examples
    --------
    >>> cases = read_cases([{"l": 1.0, "x": 0.1}, {"l": 2.0, "x": 0.2}], ["g", "l", "m"],
    ...                    ["x", "y"], None)
    >>> len(cases), cases.columns.parameters, cases.columns.positions
    (2, ('l',), ('x',))
    """
    table = _table(cases)
    params, coords = set(parameters), set(coordinates)
    velocities = {f"{c}_dot" for c in coordinates}
    kinds: dict[str, list[str]] = {"p": [], "q": [], "qd": [], "other": [], "u": []}
    for name in table.columns:
        if not isinstance(name, str):
            raise EnsembleError(f"case column names must be strings, got {name!r}")
        if name in params:
            kinds["p"].append(name)
        elif name in coords:
            kinds["q"].append(name)
        elif name in velocities:
            kinds["qd"].append(name)
        elif name in inputs:
            kinds["u"].append(name)
        elif reader is not None:
            kinds["other"].append(name)
        else:
            among = f", an input ({_listing(inputs)})" if inputs else ""
            raise EnsembleError(
                f"the case column {name!r} is not a parameter ({_listing(parameters)}), a "
                f"coordinate ({_listing(coordinates)}){among} or a velocity (a coordinate "
                "name + '_dot'); check the spelling, or pass initial_state=f(case) -> (q0, "
                "qd0) to make an initial state from it")
    return Cases(table, CaseColumns(*(tuple(kinds[k]) for k in ("p", "q", "qd", "other", "u"))))


def _table(cases: CaseTable) -> pd.DataFrame:
    pd = _pandas()
    if isinstance(cases, pd.DataFrame):
        table = cases.reset_index(drop=True)
    elif isinstance(cases, Mapping):
        table = _columns_table(pd, dict(cases))
    elif isinstance(cases, Sequence) and not isinstance(cases, (str, bytes)):
        rows = list(cases)
        if not all(isinstance(r, Mapping) for r in rows):
            raise EnsembleError("cases given as a list must be dicts {name: value}, one per "
                                "case")
        keys = [tuple(r) for r in rows]
        for i, k in enumerate(keys):
            if set(k) != set(keys[0]):
                raise EnsembleError(f"case {i} names {sorted(map(str, k))}, case 0 names "
                                    f"{sorted(map(str, keys[0]))}: every case must give the "
                                    "same names")
        table = pd.DataFrame(rows)
    else:
        raise EnsembleError(f"cases must be a pandas DataFrame, a list of dicts or a dict "
                            f"of columns, got {type(cases).__name__}")
    if len(table) == 0:
        raise EnsembleError("there are no cases to run")
    table.columns = [c.strip() if isinstance(c, str) else c for c in table.columns]
    seen: set[Any] = set()
    for name in table.columns:
        if name in seen:
            raise EnsembleError(f"the case column {name!r} is given twice; give each column "
                                "once")
        seen.add(name)
    for name in table.columns:
        try:
            table[name] = table[name].astype(float)
        except (TypeError, ValueError) as exc:
            raise EnsembleError(f"the case column {name!r} holds a value that is not a "
                                f"number: {exc}") from exc
    return table


def _columns_table(pd: Any, columns: dict[Any, Any]) -> pd.DataFrame:
    """A dict of columns as a table: every column a sequence of one value per case (a
    single number is the same in every case, as pandas has it)."""
    lengths = {}
    for name, values in columns.items():
        array = np.asarray(values, dtype=object)
        if array.ndim == 0:
            continue
        if array.ndim != 1:
            raise EnsembleError(f"the case column {name!r} must be a 1-D sequence of numbers, "
                                f"one per case, got {type(values).__name__} of shape "
                                f"{array.shape}")
        lengths[name] = len(array)
    if len(set(lengths.values())) > 1:
        listed = ", ".join(f"{name}: {n}" for name, n in lengths.items())
        raise EnsembleError(f"the case columns have different lengths ({listed}); every "
                            "column must give one value per case")
    if not lengths:
        raise EnsembleError("the case columns are single numbers; give each a list of one "
                            "value per case, e.g. {'l': [1.0, 2.0]}")
    return pd.DataFrame(columns)


def _number(value: Any, what: str) -> float:
    try:
        return float(value)
    except (TypeError, ValueError) as exc:
        raise EnsembleError(f"{what} holds {value!r}, which is not a number") from exc


def _listing(names: Sequence[str]) -> str:
    return ", ".join(names) if names else "none"


def _pandas():
    try:
        import pandas as pd
    except ImportError as exc:  # pragma: no cover - pandas comes with the extra
        raise ImportError("dalembert.ensemble needs pandas: pip install 'dalembert[ensemble]'"
                          ) from exc
    return pd
