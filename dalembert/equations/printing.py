"""Readable text and LaTeX for constrained equations of motion.

Velocities print as dotted coordinates (``\\dot{x}``), accelerations as double
dots, with no ``Derivative(x(t), t)`` clutter.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import sympy as sp

if TYPE_CHECKING:
    from .lagrange import Equations


def symbol_names(eqs: Equations) -> dict[sp.Symbol, str]:
    """LaTeX names: ``x_dot`` -> ``\\dot{x}``, ``x_ddot`` -> ``\\ddot{x}``."""
    names: dict[sp.Symbol, str] = {}
    for q, qd, qdd in zip(eqs.q, eqs.qd, eqs.qdd):
        base = sp.latex(q)
        names[qd] = rf"\dot{{{base}}}"
        names[qdd] = rf"\ddot{{{base}}}"
    for lam in eqs.multipliers:
        names[lam] = rf"\lambda_{{{lam.name.split('_')[1]}}}"
    return names


def equation_rows(eqs: Equations) -> tuple[list[tuple[sp.Expr, sp.Expr]], list[sp.Expr]]:
    """Dynamic rows ``(lhs, rhs)`` of ``M qdd = f + A^T lambda`` and constraint rows."""
    qdd = sp.Matrix(eqs.qdd)
    lam = sp.Matrix(eqs.multipliers)
    lhs = eqs.M * qdd
    rhs = eqs.f + (eqs.A.T * lam if eqs.multipliers else sp.zeros(len(eqs.q), 1))
    dynamic = list(zip(lhs, rhs))
    constraints = list(eqs.A * sp.Matrix(eqs.qd) + eqs.b) if eqs.multipliers else []
    return dynamic, constraints


def equations_latex(eqs: Equations) -> str:
    names = symbol_names(eqs)

    def tex(e: sp.Expr) -> str:
        return sp.latex(e, symbol_names=names)

    dynamic, constraints = equation_rows(eqs)
    lines = [f"{tex(lhs)} &= {tex(rhs)}" for lhs, rhs in dynamic]
    lines += [f"{tex(expr)} &= 0" for expr in constraints]
    return r"\begin{aligned}" + r" \\ ".join(lines) + r"\end{aligned}"


def equations_text(eqs: Equations) -> str:
    dynamic, constraints = equation_rows(eqs)
    model = eqs.model
    out = [f"Equations of motion of {model.name!r}: M qdd = f + A^T lambda"]
    out += [f"  {lhs} = {rhs}" for lhs, rhs in dynamic]
    if constraints:
        out.append("Constraints (velocity level, A qd + b = 0):")
        for lam, name, expr in zip(eqs.multipliers, model.constraints.names, constraints):
            out.append(f"  [{lam} <- {name}]  {expr} = 0")
    return "\n".join(out)
