"""Text and LaTeX rendering of the equations, with and without constraints."""

from __future__ import annotations

import sympy as sp

from dalembert import Holonomic, System, coordinates

x, y = coordinates("x y")
m, g, l = sp.symbols("m g l", positive=True)
T = m / 2 * (x.diff() ** 2 + y.diff() ** 2)


def test_text_with_constraint():
    eqs = System([x, y], kinetic=T, potential=m * g * y, name="pend",
                 constraints=[Holonomic(x**2 + y**2 - l**2, name="rod")]).equations()
    text = str(eqs)
    assert "'pend'" in text and "m*x_ddot = 2*lambda_1*x" in text
    assert "[lambda_1 <- rod]  2*x*x_dot + 2*y*y_dot = 0" in text
    assert "Derivative" not in text


def test_text_without_constraints():
    text = str(System([x, y], kinetic=T, potential=m * g * y).equations())
    assert "m*y_ddot = -g*m" in text
    assert "lambda" not in text.split("\n", 1)[1] and "Constraints" not in text


def test_latex_uses_dots():
    eqs = System([x, y], kinetic=T, potential=m * g * y,
                 constraints=[Holonomic(x**2 + y**2 - l**2)]).equations()
    tex = eqs.latex()
    assert tex.startswith(r"\begin{aligned}") and tex.endswith(r"\end{aligned}")
    assert r"\ddot{x}" in tex and r"\dot{y}" in tex and r"\lambda_{1}" in tex
    assert "Derivative" not in tex and "x_dot" not in tex
    assert eqs._repr_latex_().startswith("$\\displaystyle")


def test_latex_without_constraints():
    tex = System([x], kinetic=m / 2 * x.diff() ** 2, potential=m * g * x).equations().latex()
    assert tex == r"\begin{aligned}m \ddot{x} &= - g m\end{aligned}"
