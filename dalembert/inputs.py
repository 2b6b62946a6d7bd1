"""Input signals: the values of a model's inputs during a simulation.

A System declares input symbols (``System(..., inputs=[u])``) that may appear in its
applied forces; ``simulate(inputs=...)`` says what they are worth along the run:

- a number: constant;
- a function of the state, ``u(t, q, qd)`` (a feedback controller), or of the time
  alone, ``u(t)`` (a SciPy interpolator of measured data is one);
- a table ``(times, values)``, interpolated linearly (it must cover ``t_span``);
- for several inputs, a dict by input (symbol or name) of any of these, or one
  function or table giving them all as a vector.

``sample_time=dt`` holds the values between samples: they are computed at
``t0, t0 + dt, ...`` from the state there and held until the next sample (a zero-
order hold, as a digital controller acts); the integration restarts at every sample
instant, so that steps land on them.

:func:`input_signal` turns the user's values into an :class:`InputSignal` once, at
the door; the loops call it, and a value it cannot produce (an exception in the
user's function, a wrong shape, NaN) is an :class:`~dalembert.errors.InputError`
naming the input, which ends the run with the steps made before.
"""

from __future__ import annotations

import dataclasses
import inspect
import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from .errors import InputError

#: One input's (or all inputs') value at ``(t, q, qd)``.
Source = Callable[[float, np.ndarray, np.ndarray], np.ndarray | float]


@dataclass(frozen=True)
class InputSignal:
    """The inputs' values along a run (see :mod:`dalembert.inputs`).

    Attributes
    ----------
    names
        The inputs, in the model's order.
    sources
        One function ``(t, q, qd) -> values`` per group of inputs, with the positions
        of the inputs it gives.
    sample_time
        The zero-order hold's period, or ``None`` (values at every evaluation).
    """

    names: tuple[str, ...]
    sources: tuple[tuple[Source, tuple[int, ...], str], ...]
    sample_time: float | None = None

    def __call__(self, t: float, q: np.ndarray, qd: np.ndarray) -> np.ndarray:
        """The inputs' values at ``(t, q, qd)``; an :class:`InputError` names the input
        whose value is not a finite number (or whose function raised)."""
        out = np.empty(len(self.names))
        for source, where, what in self.sources:
            try:
                value = source(t, q, qd)
            except Exception as exc:  # the user's function: any error ends the run
                raise InputError(f"{what} raised at t={t:.6g}: {type(exc).__name__}: {exc}"
                                 ) from exc
            if len(where) == 1 and isinstance(value, (float, int, np.floating, np.integer)):
                out[where[0]] = value  # the common case, one number: no array made
                if not math.isfinite(out[where[0]]):
                    raise InputError(f"{what} gave [{out[where[0]]}] at t={t:.6g}, "
                                     "not finite")
                continue
            out[list(where)] = self._values(value, where, what, t)
        return out

    def holding(self, values: Mapping[str, float]) -> InputSignal:
        """This signal with the inputs ``values`` names held at those numbers (a case
        of an ensemble that gives them).

        Parameters
        ----------
        values
            ``input name -> number``; each of these inputs must have a source of its
            own here (``inputs=`` a dict by input, or a single input).

        Raises
        ------
        InputError
            A name that is not an input, a value that is not a finite number, or an
            input given together with others by one function or table.

        Examples
        --------
        >>> signal = input_signal({"u": 2.0, "v": lambda t: 3 * t}, ["u", "v"], None, (0, 1))
        >>> signal.holding({"u": -1.0})(0.5, np.zeros(1), np.zeros(1))
        array([-1. ,  1.5])
        """
        held: dict[int, float] = {}
        for name, value in values.items():
            if name not in self.names:
                raise InputError(f"{name!r} is not an input of this model (its inputs: "
                                 f"{', '.join(self.names)})")
            number = float(value)
            if not math.isfinite(number):
                raise InputError(f"the input {name!r} must be a finite number, got {number}")
            held[self.names.index(name)] = number
        sources = []
        for source, where, what in self.sources:
            together = [self.names[k] for k in where if k in held]
            if together and len(where) > 1:
                raise InputError(f"{what} gives {', '.join(together)} together with other "
                                 "inputs; give the inputs as a dict by input to hold some")
            if together:
                source = _constant(held[where[0]])
            sources.append((source, where, what))
        return dataclasses.replace(self, sources=tuple(sources))

    def extended(self, names: Sequence[str], source: Source, what: str) -> InputSignal:
        """This signal with inputs ``names`` after its own, all given by ``source``
        (forces a run computes itself at each state, such as sliding friction).

        Parameters
        ----------
        names
            The new inputs.
        source
            ``(t, q, qd) -> values`` of the new inputs.
        what
            What gives them, for messages.

        Examples
        --------
        >>> signal = input_signal(2.0, ["u"], None, (0, 1))
        >>> both = signal.extended(["f"], lambda t, q, qd: [3 * t], "a test")
        >>> both.names, both(0.5, np.zeros(1), np.zeros(1)).tolist()
        (('u', 'f'), [2.0, 1.5])
        """
        start = len(self.names)
        where = tuple(range(start, start + len(names)))
        return dataclasses.replace(self, names=self.names + tuple(names),
                                   sources=(*self.sources, (source, where, what)))

    def _values(self, value: object, where: tuple[int, ...], what: str,
                t: float) -> np.ndarray:
        """``value`` as an array of ``len(where)`` finite numbers, or an InputError."""
        if value is None:  # NumPy would make it NaN: a function without its return
            raise InputError(f"{what} returned None at t={t:.6g}; it must return "
                             f"{len(where)} number(s) ({', '.join(self.names[k] for k in where)})"
                             " (a missing return statement?)")
        try:
            array = np.asarray(value, dtype=float)
        except (TypeError, ValueError) as exc:
            raise InputError(f"{what} gave {value!r} at t={t:.6g}, not numbers") from exc
        if array.shape == () and len(where) == 1:
            array = array.reshape(1)
        if array.shape != (len(where),):
            raise InputError(f"{what} gave an array of shape {array.shape} at t={t:.6g}; "
                             f"it must give {len(where)} value(s) "
                             f"({', '.join(self.names[k] for k in where)})")
        if not np.all(np.isfinite(array)):
            raise InputError(f"{what} gave {array.tolist()} at t={t:.6g}, not finite")
        return array


def input_signal(inputs: object, names: Sequence[str], sample_time: float | None,
                 t_span: tuple[float, float]) -> InputSignal | None:
    """The :class:`InputSignal` of ``simulate(inputs=..., sample_time=...)``.

    Parameters
    ----------
    inputs
        The user's values (see :mod:`dalembert.inputs`), or ``None``.
    names
        The model's input names.
    sample_time
        The zero-order hold's period (``None``: none).
    t_span
        The run's span (a table must cover it).

    Raises
    ------
    InputError
        An input without a value, a name that is not an input, a value of no known form,
        a table that does not cover ``t_span``.

    Examples
    --------
    >>> signal = input_signal({"u": 2.0, "v": lambda t: 3 * t}, ["u", "v"], None, (0, 1))
    >>> signal(0.5, np.zeros(1), np.zeros(1))
    array([2. , 1.5])
    """
    if not names:
        if inputs is not None:
            raise InputError("inputs= is given, but the model declares no inputs "
                             "(System(..., inputs=[u, ...]))")
        if sample_time is not None:
            raise InputError("sample_time= is given, but the model declares no inputs")
        return None
    if inputs is None:
        raise InputError(f"the model's inputs {', '.join(names)} have no values: pass "
                         f"inputs={{{', '.join(repr(n) + ': ...' for n in names)}}}")
    if isinstance(inputs, Mapping):
        given = {_name(key): value for key, value in inputs.items()}
        unknown = [n for n in given if n not in names]
        if unknown:
            raise InputError(f"{', '.join(map(repr, unknown))} is not an input of this model "
                             f"(its inputs: {', '.join(names)})")
        missing = [n for n in names if n not in given]
        if missing:
            raise InputError(f"the input(s) {', '.join(missing)} have no values in inputs=")
        sources: tuple[tuple[Source, tuple[int, ...], str], ...] = tuple(
            (_source(given[n], 1, f"the input {n!r}", t_span), (k,), f"the input {n!r}")
            for k, n in enumerate(names))
    else:
        what = f"inputs= (all of {', '.join(names)})" if len(names) > 1 else \
            f"the input {names[0]!r}"
        sources = ((_source(inputs, len(names), what, t_span), tuple(range(len(names))),
                    what),)
    return InputSignal(tuple(names), sources, sample_time)


def _name(key: object) -> str:
    return str(getattr(key, "name", key))


def _source(value: object, size: int, what: str, t_span: tuple[float, float]) -> Source:
    """``value`` (a number, a function, a table) as a function of ``(t, q, qd)``."""
    if callable(value):
        return _function(value, what)
    if isinstance(value, tuple) and len(value) == 2:
        return _table(value, size, what, t_span)
    try:
        number = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        number = None
    if number is None or number.shape not in ((), (size,)) or not np.all(np.isfinite(number)):
        raise InputError(f"{what} must be a finite number, a function u(t, q, qd) or u(t), "
                         f"or a table (times, values); got {value!r}")
    return lambda t, q, qd: number


def _constant(number: float) -> Source:
    """A source that always gives ``number``."""
    return lambda t, q, qd: number


def _function(f: Callable[..., Any], what: str) -> Source:
    """``f(t, q, qd)`` or ``f(t)``, by what it accepts; a function that takes neither
    is refused here, naming the input (else its first call would fail the run)."""
    try:
        signature = inspect.signature(f)
    except (TypeError, ValueError):  # a builtin or a C function: assume u(t)
        return lambda t, q, qd: f(t)
    parameters = signature.parameters.values()
    # three required positional parameters: u(t, q, qd); else u(t) (an interpolator's
    # further parameters have defaults: CubicSpline(t, nu=0, extrapolate=None))
    required = [p for p in parameters if p.default is p.empty and p.kind in (
        p.POSITIONAL_ONLY, p.POSITIONAL_OR_KEYWORD)]
    takes_state = len(required) >= 3 or any(p.kind == p.VAR_POSITIONAL for p in parameters)
    try:
        signature.bind(*range(3 if takes_state else 1))
    except TypeError:
        raise InputError(f"{what}: the function given takes {signature}, so it cannot be "
                         "called as u(t, q, qd) (a controller of the state) or u(t) (of "
                         "the time); give it one of these signatures") from None
    if takes_state:
        # copies: the arrays given are the run's state, and a function may well change
        # its arguments for its own use (wrapping an angle, say)
        return lambda t, q, qd: f(t, q.copy(), qd.copy())
    return lambda t, q, qd: f(t)


def _table(value: tuple[Any, Any], size: int, what: str,
           t_span: tuple[float, float]) -> Source:
    try:
        times = np.asarray(value[0], dtype=float)
        values = np.asarray(value[1], dtype=float)
    except (TypeError, ValueError) as exc:
        raise InputError(f"{what}: a table is (times, values) of numbers") from exc
    if values.ndim == 1:
        values = values[:, None]
    if times.ndim != 1 or len(times) < 2 or values.shape != (len(times), size):
        raise InputError(f"{what}: a table is (times, values) with at least two times and "
                         f"values of shape ({len(times)},{' ' + str(size) if size > 1 else ''})"
                         f"; got times {times.shape}, values {np.shape(value[1])}")
    if not (np.all(np.isfinite(times)) and np.all(np.isfinite(values))
            and np.all(np.diff(times) > 0)):
        raise InputError(f"{what}: the table's times must increase and every entry be finite")
    lo, hi = min(t_span), max(t_span)
    if times[0] > lo or times[-1] < hi:
        raise InputError(f"{what}: the table covers t = {times[0]:g} .. {times[-1]:g}, not "
                         f"all of t_span {t_span}; extend it (it is not extrapolated)")
    columns = [values[:, k] for k in range(size)]
    if size == 1:
        return lambda t, q, qd: np.interp(t, times, columns[0])
    return lambda t, q, qd: np.array([np.interp(t, times, c) for c in columns])
