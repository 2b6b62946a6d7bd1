"""Derivatives of a joint's constraints by the chain rule on their expression trees.

A joint's equations are polynomials in its bodies' coordinates (or in the sines
and cosines of a planar body's angle) built from a few shared pieces
(rotation-matrix entries, sums of products). SymPy's ``diff`` goes
through its general ``Derivative`` machinery for every node, and the rates
``c = -(d/dq (A qd)) qd`` differentiate every term of every entry of ``A`` again:
for the revolute joint between two links that was most of a chain's build time.
Here each node is differentiated once (memoized) by the sum, product,
integer-power and sine/cosine rules, so the results stay factored over the same pieces, which
``cse`` then finds once: the same polynomials, fewer operations to derive,
compile and evaluate.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import sympy as sp


class NotPolynomial(ValueError):
    """An expression holds something other than sums, products, positive integer powers,
    sines and cosines.

    Internal control flow, never seen by a user: the part's equations then take the
    general route (:func:`~dalembert.multibody.parts._constraint_equations`)."""


def directional_derivative(expr: sp.Expr, direction: Mapping[sp.Symbol, sp.Expr],
                           memo: dict[sp.Expr, sp.Expr]) -> sp.Expr:
    """``sum_k d expr/d x_k * direction[x_k]`` of ``expr`` (a polynomial, possibly in
    sines and cosines), kept factored.

    Parameters
    ----------
    expr
        The expression.
    direction
        ``{x_k: direction[x_k]}``; symbols not in it are constants.
    memo
        The derivatives of the nodes already seen along this ``direction`` (share it
        between expressions; start with ``{}``).

    Raises :class:`NotPolynomial` for an expression of another kind.

    Examples
    --------
    >>> x, y, u = sp.symbols("x y u")
    >>> directional_derivative((x + y) ** 2 * y, {x: u}, {})
    u*y*(2*x + 2*y)
    >>> directional_derivative(x * sp.sin(y), {y: u}, {})
    u*x*cos(y)
    """
    done = memo.get(expr)
    if done is not None:
        return done
    if expr.is_Symbol:
        out = direction.get(expr, sp.S.Zero)
    elif expr.is_Number:
        out = sp.S.Zero
    elif expr.is_Add:
        out = sp.Add(*(directional_derivative(a, direction, memo) for a in expr.args))
    elif expr.is_Mul:
        args = expr.args
        out = sp.Add(*(sp.Mul(*args[:i], d, *args[i + 1:]) for i, a in enumerate(args)
                       if (d := directional_derivative(a, direction, memo)) != 0))
    elif expr.is_Pow and expr.exp.is_Integer and expr.exp > 0:
        d = directional_derivative(expr.base, direction, memo)
        out = expr.exp * expr.base ** (expr.exp - 1) * d if d != 0 else sp.S.Zero
    elif isinstance(expr, (sp.sin, sp.cos)):
        u = expr.args[0]
        d = directional_derivative(u, direction, memo)
        slope = sp.cos(u) if isinstance(expr, sp.sin) else -sp.sin(u)
        out = slope * d if d != 0 else sp.S.Zero
    elif not expr.free_symbols & direction.keys():  # a constant such as sqrt(2)
        out = sp.S.Zero
    else:
        raise NotPolynomial(f"no polynomial derivative of {expr}")
    memo[expr] = out
    return out


def holonomic_rates(exprs: Sequence[sp.Expr], q: Sequence[sp.Symbol],
                    qd: Sequence[sp.Symbol]) -> tuple[sp.Matrix, sp.Matrix]:
    """``A = d psi/dq`` and ``c = -(d/dq (A qd)) qd`` of ``psi(q)`` (no time): polynomials,
    possibly in sines and cosines.

    The rows are those :func:`dalembert.equations.lagrange.derive_equations` gives a
    scleronomic holonomic constraint (``b = 0``), as equal polynomials. Raises
    :class:`NotPolynomial` for any other expression.

    Parameters
    ----------
    exprs
        The constraint functions ``psi(q)``.
    q, qd
        The coordinate and velocity symbols.

    Examples
    --------
    >>> x, y, xd, yd = sp.symbols("x y x_dot y_dot")
    >>> holonomic_rates([x**2 + y**2 - 1], [x, y], [xd, yd])
    (Matrix([[2*x, 2*y]]), Matrix([[-2*x_dot**2 - 2*y_dot**2]]))
    """
    velocity = dict(zip(q, qd))
    rate_memo: dict[sp.Expr, sp.Expr] = {}
    memos: list[dict[sp.Expr, sp.Expr]] = [{} for _ in q]
    A, c = [], []
    for psi in exprs:
        A += _partials(psi, q, memos)
        rate = directional_derivative(psi, velocity, rate_memo)
        c.append(-directional_derivative(rate, velocity, rate_memo))
    return sp.Matrix(len(c), len(q), A), sp.Matrix(len(c), 1, c)


def _partials(expr: sp.Expr, variables: Sequence[sp.Symbol],
              memos: list[dict[sp.Expr, sp.Expr]]) -> list[sp.Expr]:
    """``d expr / d x`` for each variable ``x`` (one memo per variable)."""
    free = expr.free_symbols
    return [directional_derivative(expr, {x: sp.S.One}, memo) if x in free else sp.S.Zero
            for x, memo in zip(variables, memos)]
