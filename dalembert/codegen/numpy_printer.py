"""Turn SymPy matrices into one NumPy function, with common subexpressions shared.

All outputs of a function go through a single ``sympy.cse`` call, so a
subexpression shared by ``M``, ``f`` and ``c`` is computed once. Only nonzero
entries are assigned into preallocated arrays. The source is kept on the
function (``__source__``) for inspection.

The source is ``exec``'d, so no text derived from a user's string may reach it: a
symbol's name is data (``Symbol("x); __import__('os')...")`` is a valid SymPy
symbol). Every symbol is therefore printed under a name generated from indices
(``q_0``, ``p_2``, a temporary ``x5``, a summation index ``i0``), never its own,
and before anything runs each printed expression is read back token by token:
only names this module generated, the NumPy functions of the namespace and a few
keywords may appear, no strings and no comments. What does not pass (an unknown
function, a ``MatrixSymbol``) is refused with a :class:`~dalembert.errors.ModelError`
naming it. The code runs with no Python builtins but ``range``.
"""

from __future__ import annotations

import functools
import io
import itertools
import keyword
import linecache
import tokenize
import types
from collections.abc import Callable, Collection, Iterator, Sequence
from typing import Any

import numpy as np
import sympy as sp
from sympy.printing.codeprinter import PrintMethodNotImplementedError
from sympy.printing.numpy import NumPyPrinter

from ..equations.sparse import nonzero_entries
from ..errors import ModelError

Arguments = Sequence[tuple[str, Sequence[sp.Symbol]]]
Outputs = Sequence[tuple[str, sp.Matrix]]

#: NumPy names the generated code may call (the printer writes them unqualified).
NUMPY_NAMES = (
    "sin", "cos", "tan", "arcsin", "arccos", "arctan", "arctan2", "sinh", "cosh", "tanh",
    "exp", "log", "sqrt", "abs", "sign", "pi", "e", "floor", "ceil", "hypot", "select",
    "where", "heaviside", "amax", "amin", "logical_and", "logical_or", "logical_not", "isnan",
    "inf", "nan", "power", "cbrt", "expm1", "log1p", "arcsinh", "arccosh", "arctanh",
    "maximum", "minimum", "less", "greater", "less_equal", "greater_equal", "equal",
    "not_equal", "array", "float64", "exp2", "log2", "log10", "mod", "real", "imag", "sinc",
)
#: Python keywords and keyword-argument names the printer writes.
KEYWORDS = frozenset({"def", "return", "for", "in", "if", "else", "and", "or", "not", "True",
                      "False", "None", "default", "axis", "range"})
#: Attributes the printer writes after a dot (``builtins.sum``, ``logical_and.reduce``,
#: ``numpy.sin``).
ATTRIBUTES = frozenset({"sum", "reduce", *NUMPY_NAMES})


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

    Parameters
    ----------
    name
        The function's name (an identifier).
    arguments
        ``(argument name, symbols)`` pairs, in call order.
    outputs
        ``(output name, matrix)`` pairs, returned in that order.
    vectors
        The outputs returned as 1-D arrays (default: every one-column matrix).

    Raises :class:`~dalembert.errors.ModelError` for an expression that cannot be
    printed as NumPy code (an unsupported function, a symbol that is no argument).

    >>> x, k = sp.symbols("x k")
    >>> fn = generate_function("spring", [("q", [x]), ("p", [k])],
    ...                        [("F", sp.Matrix([-k * x, sp.sin(x)]))])
    >>> fn(np.array([0.5]), np.array([2.0]))[0]
    array([-1.        ,  0.47942554])

    A symbol's own name never reaches the code, whatever it holds:

    >>> i = sp.Symbol("i); __import__('os').system('echo hi'); (", integer=True)
    >>> fn = generate_function("f", [("q", [x])], [("v", sp.Matrix([sp.Sum(x**i, (i, 1, 3))]))])
    >>> fn(np.array([2.0]))[0]
    array([14.])
    """
    _require_identifiers(name, *(arg for arg, _ in arguments))
    names = _argument_names(arguments)
    matrices = [sp.Matrix(m) for _, m in outputs]
    _require_arguments(matrices, names, name)
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
    lines += [f"    {names[tmp]} = {printer.code(expr)}" for tmp, expr in replacements]
    lines += [f"    {_array_name(k)} = zeros({_shape(m, flat[k])})" for k, m in enumerate(matrices)]
    for (k, i, j, _), expr in zip(entries, reduced):
        index = f"{i}" if flat[k] else f"{i}, {j}"
        lines.append(f"    {_array_name(k)}[{index}] = {printer.code(expr)}")
    lines.append(f"    return ({''.join(_array_name(k) + ', ' for k in range(len(matrices)))})")
    source = "\n".join(lines) + "\n"
    # Every line was built from generated names; read back, it must still be so.
    own = {name, *(arg for arg, _ in arguments), *(_array_name(k) for k in range(len(matrices)))}
    printer.check(source, f"the generated function {name}", own)
    return _compile(source, name)


def expression_values(symbols: Sequence[sp.Symbol], exprs: Sequence[sp.Expr],
                      values: np.ndarray) -> np.ndarray:
    """``exprs`` evaluated at ``symbols = values``, through one generated function per
    pair of sequences (made on first use and kept): binding new parameter values to a
    model evaluates its derived numbers (a link's inertia from its mass) without SymPy.

    Parameters
    ----------
    symbols
        The symbols the expressions are written in.
    exprs
        The expressions (no other free symbol).
    values
        A value per symbol.

    Examples
    --------
    >>> m, l = sp.symbols("m l")
    >>> expression_values((m, l), (m * l**2 / 12, 2 * m), np.array([3.0, 2.0]))
    array([1., 6.])
    """
    if not exprs:
        return np.zeros(0)
    return _values_function(tuple(symbols), tuple(exprs))(np.asarray(values, dtype=float))[0]


@functools.lru_cache(maxsize=128)
def _values_function(symbols: tuple[sp.Symbol, ...], exprs: tuple[sp.Expr, ...]) -> Callable:
    return generate_function("values", [("p", symbols)], [("v", sp.Matrix(exprs))],
                             vectors={"v"})


def _require_identifiers(*names: str) -> None:
    for n in names:
        if not n.isidentifier() or keyword.iskeyword(n):
            raise ValueError(f"{n!r} is not a Python identifier")


def _require_arguments(matrices: list[sp.Matrix], names: dict[sp.Symbol, str],
                       function: str) -> None:
    """Every free symbol must be an argument (a bound one, a summation index, is not free)."""
    free = set().union(*(m.free_symbols for m in matrices)) - set(names)
    if free:
        listed = ", ".join(sorted(str(s) for s in free))
        raise ModelError(f"the expressions of {function} depend on {listed}, which is not "
                         "a coordinate, velocity, parameter or time")


def _argument_names(arguments: Arguments) -> dict[sp.Symbol, str]:
    return {s: f"{arg}_{i}" for arg, symbols in arguments for i, s in enumerate(symbols)}


class _NamedPrinter(NumPyPrinter):
    """Prints each symbol under a generated name (``q_0``, ``x3``, ``i0``), never its own."""

    def __init__(self, names: dict[sp.Symbol, str]) -> None:
        super().__init__({"fully_qualified_modules": False, "inline": True})
        self._names = names
        self._generated = set(names.values())

    def _print_Symbol(self, expr: sp.Symbol) -> str:
        if expr not in self._names:  # a bound symbol (a summation index)
            fresh = next(f"i{k}" for k in itertools.count() if f"i{k}" not in self._generated)
            self._names[expr] = fresh
            self._generated.add(fresh)
        return self._names[expr]

    _print_Dummy = _print_Symbol

    def _print_DiracDelta(self, expr: sp.Expr) -> str:
        # The derivative of a step: zero wherever it is defined (as the C code has it).
        return "0.0"

    def code(self, expr: sp.Expr) -> str:
        """``expr`` printed and checked (see :meth:`check`)."""
        try:
            text = self.doprint(expr)
        except (PrintMethodNotImplementedError, KeyError, TypeError) as exc:
            raise ModelError(f"{_short(expr)} cannot be evaluated by the NumPy code "
                             f"generator: {_first_line(exc)}") from exc
        self.check(text, _short(expr))
        return text

    def check(self, text: str, what: str, own: Collection[str] = ()) -> None:
        """Refuse any name that is not generated (or in ``own``), a keyword or a namespace
        function; any string, comment or attribute other than those the printer writes."""
        allowed = self._generated | KEYWORDS | set(NAMESPACE) | set(own)
        previous = None
        try:
            tokens = list(tokenize.generate_tokens(io.StringIO(text).readline))
        except (tokenize.TokenError, SyntaxError) as exc:
            raise ModelError(f"{what} does not print as NumPy code: {exc}") from exc
        for tok in tokens:
            bad = tok.type in (tokenize.STRING, tokenize.COMMENT, tokenize.ERRORTOKEN) or (
                tok.type == tokenize.NAME and tok.string not in (
                    ATTRIBUTES if previous is not None and previous.string == "." else allowed))
            if bad:
                raise ModelError(
                    f"{what} cannot be turned into NumPy code: it would print "
                    f"{tok.string[:40]!r}, which is not a name the code generator made "
                    "(use SymPy functions of the coordinates, parameters and time)")
            if tok.type not in (tokenize.NL, tokenize.NEWLINE, tokenize.INDENT,
                                tokenize.DEDENT):
                previous = tok


def _short(expr: sp.Basic) -> str:
    text = str(expr)
    return text if len(text) <= 80 else text[:77] + "..."


def _first_line(exc: Exception) -> str:
    return str(exc).splitlines()[0] if str(exc) else type(exc).__name__


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


def _temporaries(names: dict[sp.Symbol, str]) -> Iterator[sp.Dummy]:
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
    namespace: dict[str, Any] = {"__builtins__": {"range": range}, **NAMESPACE}
    exec(compile(source, filename, "exec"), namespace)
    fn = namespace[name]
    fn.__source__ = source  # the generated code, for inspection and tracebacks
    return fn


def _numpy_namespace() -> dict[str, object]:
    ns: dict[str, object] = {n: getattr(np, n) for n in NUMPY_NAMES if hasattr(np, n)}
    ns.update(zeros=np.zeros, ravel=np.ravel, numpy=np, reduce=functools.reduce,
              builtins=types.SimpleNamespace(sum=sum))
    return ns


#: What the generated code sees: NumPy's functions, ``reduce`` and ``builtins.sum``
#: (summations), no other builtins.
NAMESPACE = _numpy_namespace()
