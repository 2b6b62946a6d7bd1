"""Derivatives of many expressions that share subexpressions, each part taken once.

SymPy's ``diff`` starts afresh on every call: differentiating the rows of a
spring's force by every coordinate differentiates the spring's length, a square
root of a long polynomial in the bodies' poses, once per row and coordinate, and
walks every subexpression again for its symbols on the way.
A :class:`Differentiator` keeps every derivative it has taken, keyed by
subexpression and variable, and the symbols of every subexpression, so a shared
part is differentiated once per variable and one that does not contain the
variable is skipped without a look inside. Sums, products, constant powers and
functions of one or more arguments (``sin``, ``sqrt``, ``atan2``...) follow the
chain rule here, applied as SymPy applies it, so that the results are the very
expressions SymPy's ``diff`` gives (and the code generated from them is the
same); anything else (``Abs``, ``Piecewise``, ``Derivative``...) is left to SymPy.
"""

from __future__ import annotations

import sympy as sp
from sympy.core.function import AppliedUndef, ArgumentIndexError

_CHAIN_RULE = sp.Function._eval_derivative  # a function class that does not override it


class Differentiator:
    """``d expr / d v`` for many ``expr`` and ``v``, every subexpression's derivative kept.

    Examples
    --------
    >>> x, y = sp.symbols("x y")
    >>> L = sp.sqrt(x**2 + y**2)
    >>> d = Differentiator()
    >>> d.diff(L * sp.sin(x), x) - sp.diff(L * sp.sin(x), x)
    0
    >>> d.diff((L - 1) * y, x)
    x*y/sqrt(x**2 + y**2)
    >>> d.diff(L, sp.Symbol("z"))
    0
    """

    def __init__(self) -> None:
        self._derivatives: dict[tuple[sp.Basic, sp.Basic], sp.Expr] = {}
        self._symbols: dict[sp.Basic, frozenset[sp.Basic]] = {}

    def free_symbols(self, expr: sp.Basic) -> frozenset[sp.Basic]:
        """``expr.free_symbols``, kept for ``expr`` and its subexpressions.

        Parameters
        ----------
        expr
            A SymPy expression.

        Examples
        --------
        >>> x, y = sp.symbols("x y")
        >>> sorted(Differentiator().free_symbols(sp.sin(x) * y + 2), key=str)
        [x, y]
        """
        found = self._symbols.get(expr)
        if found is None:
            if expr.is_Atom or not isinstance(expr, (sp.Add, sp.Mul, sp.Pow, sp.Function)):
                # atoms, and objects that bind symbols of their own (Derivative, Subs...)
                found = frozenset(expr.free_symbols)
            else:
                found = frozenset().union(*(self.free_symbols(a) for a in expr.args))
            self._symbols[expr] = found
        return found

    def diff(self, expr: sp.Expr, v: sp.Symbol) -> sp.Expr:
        """``d expr / d v``.

        Parameters
        ----------
        expr
            A SymPy expression.
        v
            The symbol to differentiate by.

        Examples
        --------
        >>> x = sp.Symbol("x")
        >>> Differentiator().diff(sp.cos(x**2) / x, x) == sp.diff(sp.cos(x**2) / x, x)
        True
        """
        if v not in self.free_symbols(expr):
            return sp.S.Zero
        key = (expr, v)
        found = self._derivatives.get(key)
        if found is None:
            found = self._derivative(expr, v)
            self._derivatives[key] = found
        return found

    def _derivative(self, expr: sp.Expr, v: sp.Symbol) -> sp.Expr:
        if expr == v:
            return sp.S.One
        args = expr.args
        if expr.is_Add:
            return sp.Add(*(self.diff(a, v) for a in args))
        if expr.is_Mul:
            # the product rule as SymPy's Mul applies it (one product per factor)
            terms = []
            for i, a in enumerate(args):
                d = self.diff(a, v)
                if d != 0:
                    terms.append(sp.Mul(*args[:i], d, *args[i + 1:]))
            return sp.Add(*terms)
        if expr.is_Pow:
            base, exp = args
            if v not in self.free_symbols(exp):
                # SymPy's arrangement, so that the result is the very expression its
                # diff gives: base**exp * (d base * exp / base)
                return expr * (self.diff(base, v) * exp / base)
        elif (isinstance(expr, sp.Function) and not isinstance(expr, AppliedUndef)
              and type(expr)._eval_derivative is _CHAIN_RULE):
            terms = []
            try:
                for i, a in enumerate(args):
                    d = self.diff(a, v)
                    if not d.is_zero:
                        terms.append(expr.fdiff(i + 1) * d)
            except ArgumentIndexError:  # no closed-form partial: SymPy's own rule
                return expr.diff(v)
            return sp.Add(*terms)
        return expr.diff(v)
