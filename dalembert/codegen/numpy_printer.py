"""Turn SymPy matrices into one NumPy function, with common subexpressions shared.

All outputs of a function go through a single ``sympy.cse`` call, so a
subexpression shared by ``M``, ``f`` and ``c`` is computed once. Only nonzero
entries are assigned into preallocated arrays. The source is kept on the
function (``__source__``) for inspection.
"""

from __future__ import annotations

import linecache
from collections.abc import Callable, Collection, Sequence
from typing import Any

import numpy as np
import sympy as sp
from sympy.printing.numpy import NumPyPrinter

from ..equations.sparse import nonzero_entries

Arguments = Sequence[tuple[str, Sequence[sp.Symbol]]]
Outputs = Sequence[tuple[str, sp.Matrix]]


def generate_function(
    name: str, arguments: Arguments, outputs: Outputs, *, vectors: Collection[str] | None = None
) -> Callable:
    """Compile ``outputs`` (named matrices) into ``name(*arrays)`` returning arrays.

    ``arguments`` lists ``(argument name, symbols)``: each argument is a 1-D array
    (or a scalar for a single symbol) unpacked into its symbols. The function
    returns a tuple of arrays shaped like the matrices; column vectors are
    returned as 1-D arrays. ``vectors`` names the outputs that
    are vectors; the others stay 2-D even with one column (a 1 x 1 mass matrix, or
    a 0 x 1 constraint matrix). By default every one-column matrix is a vector.

    >>> x, k = sp.symbols("x k")
    >>> fn = generate_function("spring", [("q", [x]), ("p", [k])],
    ...                        [("F", sp.Matrix([-k * x, sp.sin(x)]))])
    >>> fn(np.array([0.5]), np.array([2.0]))[0]
    array([-1.        ,  0.47942554])
    """
    names = _argument_names(arguments)
    matrices = [sp.Matrix(m) for _, m in outputs]
    flat = [m.cols == 1 and (vectors is None or out in vectors)
            for (out, _), m in zip(outputs, matrices)]
    entries = [(k, i, j, e) for k, m in enumerate(matrices)
               for (i, j), e in nonzero_entries(m).items()]
    # Dummy temporaries cannot clash with a user symbol called x0; symbols are
    # renamed only when printed (an xreplace would rebuild every expression).
    replacements, reduced = sp.cse([e for *_, e in entries], symbols=_temporaries(names))
    printer = _NamedPrinter(names)
    lines = [f"def {name}({', '.join(arg for arg, _ in arguments)}):"]
    lines += _unpack_lines(arguments, names)
    lines += [f"    {names[tmp]} = {printer.doprint(expr)}" for tmp, expr in replacements]
    lines += [f"    {_array_name(k)} = zeros({_shape(m, flat[k])})" for k, m in enumerate(matrices)]
    for (k, i, j, _), expr in zip(entries, reduced):
        index = f"{i}" if flat[k] else f"{i}, {j}"
        lines.append(f"    {_array_name(k)}[{index}] = {printer.doprint(expr)}")
    lines.append(f"    return ({''.join(_array_name(k) + ', ' for k in range(len(matrices)))})")
    return _compile("\n".join(lines) + "\n", name)


def _argument_names(arguments: Arguments) -> dict[sp.Symbol, str]:
    return {s: f"{arg}_{i}" for arg, symbols in arguments for i, s in enumerate(symbols)}


class _NamedPrinter(NumPyPrinter):
    """Prints each symbol under its generated name (``q_0``, ``x3``)."""

    def __init__(self, names: dict[sp.Symbol, str]) -> None:
        super().__init__({"fully_qualified_modules": False, "inline": True})
        self._names = names

    def _print_Symbol(self, expr: sp.Symbol) -> str:
        return self._names.get(expr) or super()._print_Symbol(expr)

    _print_Dummy = _print_Symbol


def _unpack_lines(arguments: Arguments, renames: dict[sp.Symbol, str]) -> list[str]:
    lines = []
    for arg, symbols in arguments:
        if len(symbols) == 1:
            # A scalar (time) or a one-element array (a model with one parameter
            # called "p", or one coordinate called "q") both unpack through ravel.
            lines.append(f"    {renames[symbols[0]]}, = ravel({arg})")
        elif symbols:
            names = ", ".join(str(renames[s]) for s in symbols)
            lines.append(f"    {names}, = {arg}")
    return lines


def _shape(m: sp.Matrix, flat: bool) -> str:
    return f"{m.rows}" if flat else f"({m.rows}, {m.cols})"


def _array_name(k: int) -> str:
    return f"out{k}"


def _temporaries(names: dict[sp.Symbol, str]):
    """Fresh symbols for ``cse``, each recorded in ``names`` as ``x<k>``."""
    k = 0
    while True:
        tmp = sp.Dummy(f"x{k}")
        names[tmp] = f"x{k}"
        yield tmp
        k += 1


def _compile(source: str, name: str) -> Callable:
    filename = f"<dalembert-generated {name} {abs(hash(source))}>"
    # Registering the source lets tracebacks and inspect show generated lines.
    linecache.cache[filename] = (len(source), None, source.splitlines(True), filename)
    namespace: dict[str, Any] = {"zeros": np.zeros, "ravel": np.ravel, **_numpy_namespace()}
    exec(compile(source, filename, "exec"), namespace)
    fn = namespace[name]
    fn.__source__ = source  # the generated code, for inspection and tracebacks
    return fn


def _numpy_namespace() -> dict[str, object]:
    names = ("sin", "cos", "tan", "arcsin", "arccos", "arctan", "arctan2", "sinh", "cosh",
             "tanh", "exp", "log", "sqrt", "abs", "sign", "pi", "e", "floor", "ceil",
             "hypot", "select", "where", "heaviside", "amax", "amin", "logical_and",
             "logical_or", "logical_not", "isnan", "inf", "nan", "power", "cbrt", "expm1",
             "log1p", "arcsinh", "arccosh", "arctanh", "maximum", "minimum", "less",
             "greater", "less_equal", "greater_equal", "equal", "not_equal", "array",
             "float64", "exp2", "log2", "log10")
    ns = {n: getattr(np, n) for n in names if hasattr(np, n)}
    ns["numpy"] = np
    return ns
