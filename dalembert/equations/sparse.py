"""Sparse differentiation: only the derivatives that can be nonzero are taken.

SymPy spends as long on a derivative that is zero as on one that is not, and a
mechanism's Lagrangian is a long sum whose terms each involve a few coordinates
(one body's pose, one joint's two bodies). Differentiating the whole sum by every
coordinate is quadratic in the size of the mechanism; differentiating each term
only by the symbols it contains is linear. The results are the same expressions
``Matrix.jacobian`` would give (``Add`` differentiates term by term too), minus
the zero entries.
"""

from __future__ import annotations

from collections import defaultdict
from collections.abc import Sequence

import sympy as sp

from .chain_rule import Differentiator

#: Nonzero entries of a matrix, keyed by ``(row, column)``.
SparseEntries = dict[tuple[int, int], sp.Expr]


def gradient(expr: sp.Expr, variables: Sequence[sp.Symbol],
             differentiator: Differentiator | None = None) -> dict[int, sp.Expr]:
    """Nonzero partial derivatives of ``expr``, keyed by the variable's position.

    Each term of a sum is differentiated only by the variables it contains.

    Parameters
    ----------
    expr
        The expression.
    variables
        The symbols to differentiate by.
    differentiator
        Where the terms that are not monomials are differentiated: one shared by
        many expressions differentiates their common subexpressions once
        (:mod:`.chain_rule`). Without it, SymPy's ``diff``.

    Examples
    --------
    >>> x, y, z = sp.symbols("x y z")
    >>> gradient(x**2 * y + sp.sin(z) + 3, [x, y, z])
    {0: 2*x*y, 1: x**2, 2: cos(z)}
    >>> gradient(y, [x])
    {}
    >>> gradient(sp.sqrt(x**2 + y**2) * z, [x, z], Differentiator())
    {0: x*z/sqrt(x**2 + y**2), 1: sqrt(x**2 + y**2)}
    """
    index = {v: k for k, v in enumerate(variables)}
    parts: dict[int, list[sp.Expr]] = defaultdict(list)
    for term in sp.Add.make_args(expr):
        symbols = term.free_symbols if differentiator is None \
            else differentiator.free_symbols(term)
        for v in symbols:
            k = index.get(v)
            if k is not None:
                parts[k].append(_monomial_derivative(term, v, differentiator))
    out = {k: sp.Add(*parts[k]) for k in sorted(parts)}
    return {k: d for k, d in out.items() if d != 0}


def jacobian_entries(rows: Sequence[sp.Expr], variables: Sequence[sp.Symbol],
                     differentiator: Differentiator | None = None) -> SparseEntries:
    """The nonzero entries of ``d rows / d variables``, row-major (:func:`gradient` of
    each row).

    Parameters
    ----------
    rows
        The expressions.
    variables
        The symbols to differentiate by.
    differentiator
        As for :func:`gradient`.

    Examples
    --------
    >>> x, y = sp.symbols("x y")
    >>> jacobian_entries([x * y, y**2], [x, y])
    {(0, 0): y, (0, 1): x, (1, 1): 2*y}
    """
    return {(i, j): d for i, row in enumerate(rows)
            for j, d in gradient(row, variables, differentiator).items()}


def _monomial_derivative(term: sp.Expr, v: sp.Symbol,
                         differentiator: Differentiator | None = None) -> sp.Expr:
    """``term.diff(v)``, built directly when ``term`` is ``number * symbol powers``.

    Multibody energies are sums of such monomials; building the result skips
    SymPy's general ``Derivative`` machinery, the bulk of the cost. Other terms go
    to ``differentiator`` when given.
    """
    def general() -> sp.Expr:
        return term.diff(v) if differentiator is None else differentiator.diff(term, v)

    if not term.is_Mul:
        return general()
    coeff, monomial = term.as_coeff_Mul()
    rest, power = [], None
    for f in sp.Mul.make_args(monomial):
        base, exp = (f.base, f.exp) if f.is_Pow else (f, sp.S.One)
        if not (base.is_Symbol and exp.is_Integer and exp > 0):
            return general()
        if base == v:
            power = exp
        else:
            rest.append(f)
    if power is None:  # v does not occur in the monomial
        return sp.S.Zero
    return sp.Mul(coeff * power, v ** (power - 1), *rest)


def derivative(expr: sp.Expr, v: sp.Symbol) -> sp.Expr:
    """``expr.diff(v)``, skipped (zero) when ``v`` does not occur in ``expr``.

    >>> x, t = sp.symbols("x t")
    >>> derivative(x**2, t), derivative(x * t, t)
    (0, x)
    """
    return expr.diff(v) if v in expr.free_symbols else sp.S.Zero


def rate(
    expr: sp.Expr, q: Sequence[sp.Symbol], qd: Sequence[sp.Symbol], time: sp.Symbol,
    differentiator: Differentiator | None = None,
) -> tuple[sp.Expr, sp.Expr]:
    """``(sum_k d expr/d q_k qd_k, d expr/d time)``: the parts of ``d expr/dt``.

    The first is what ``expr.jacobian(q) * qd`` gives for a one-row ``expr``.

    Parameters
    ----------
    expr
        The expression.
    q, qd
        The coordinates and their rates.
    time
        The time symbol.
    differentiator
        As for :func:`gradient`.

    Examples
    --------
    >>> x, xd, t = sp.symbols("x x_dot t")
    >>> rate(x**2 * t, [x], [xd], t)
    (2*t*x*x_dot, x**2)
    """
    grad = gradient(expr, q, differentiator)
    convective = sp.Add(*(d * qd[k] for k, d in grad.items()))
    explicit = derivative(expr, time) if differentiator is None \
        else differentiator.diff(expr, time)
    return convective, explicit


def dense(entries: SparseEntries, rows: int, cols: int) -> sp.Matrix:
    """A dense ``Matrix`` of shape ``(rows, cols)`` holding the given entries.

    >>> dense({(0, 1): sp.Symbol("a")}, 2, 2)
    Matrix([
    [0, a],
    [0, 0]])
    """
    flat = [sp.S.Zero] * (rows * cols)
    for (i, j), e in entries.items():
        flat[i * cols + j] = e
    return sp.Matrix(rows, cols, flat)


def nonzero_entries(m: sp.MatrixBase) -> SparseEntries:
    """The nonzero entries of a SymPy matrix, in row-major order.

    >>> nonzero_entries(sp.Matrix([[0, 2], [3, 0]]))
    {(0, 1): 2, (1, 0): 3}
    """
    return dict(sorted(((ij, e) for ij, e in m.todok().items() if e != 0), key=lambda kv: kv[0]))
