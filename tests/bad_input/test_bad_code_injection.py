"""Names and strings from users never reach ``exec``: a crafted name runs nothing.

Each test plants a shell command in a name (a summation index, a symbol, a
parameter, a constraint, a force) or in a string given as an expression, then
checks that the marker file the command would create does not exist, and that the
model either works (under a generated name, against a closed form) or is refused
with a message naming the input.
"""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest
import sympy as sp
from bad_input_cases import pendulum, x, y

from dalembert import Holonomic, ModelError, PointForce, System, extremum
from dalembert.codegen.numpy_printer import generate_function
from dalembert.multibody import Multibody, RigidBody


def crafted(marker: Path) -> list[str]:
    """Names that ran ``touch marker`` when the generated code printed them verbatim:
    the first closes the expression, runs a module-level statement when the source is
    exec'd and opens a new function; the second is the classic one-line form."""
    command = f"__import__('os').system('touch {marker}')"
    return [f"i in range(0)))\n{command}\ndef _unused():\n    return ((0 for i",
            f"x); {command}; ("]


@pytest.fixture
def marker(tmp_path: Path) -> Path:
    path = tmp_path / "MARKER"
    yield path
    assert not path.exists(), "a crafted name ran code"


def summed(i: sp.Symbol, expr: sp.Expr) -> sp.Sum:
    """``expr`` written as ``sum_{i=1}^{2} expr / 2`` (equal to ``expr``)."""
    return sp.Sum(expr / 2, (i, 1, 2))


@pytest.mark.parametrize("where", ["kinetic", "potential", "constraint", "force"])
@pytest.mark.parametrize("which", [0, 1])
def test_summation_index_with_a_crafted_name(marker, where, which):
    # Each model is x'' = -x (with x = y for the constraint) written with a Sum over a
    # crafted index: x(t) = cos t from x(0) = 1 at rest. The C printer rejects Sum, so
    # the default backend falls back to the NumPy generator, the one that printed names.
    i = sp.Symbol(crafted(marker)[which], integer=True)
    xd, yd = x.diff(), y.diff()
    models = {
        "kinetic": dict(kinetic=summed(i, (xd**2 + yd**2) / 2), potential=(x**2 + y**2) / 2),
        "potential": dict(kinetic=(xd**2 + yd**2) / 2, potential=summed(i, (x**2 + y**2) / 2)),
        "constraint": dict(kinetic=(xd**2 + yd**2) / 2, potential=(x**2 + y**2) / 2,
                           constraints=[Holonomic(x - summed(i, y), name="tie")]),
        "force": dict(kinetic=(xd**2 + yd**2) / 2,
                      generalized_forces={x: -summed(i, x), y: -summed(i, y)}),
    }
    system = System([x, y], **models[where])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)  # "C code generation failed"
        traj = system.simulate((0, 1), q0=[1.0, 1.0], t_eval=[1.0])
    np.testing.assert_allclose([traj["x"][-1], traj["y"][-1]], np.cos(1.0), atol=1e-9)
    assert crafted(marker)[which] not in system.compiled.kkt_values.__source__


@pytest.mark.parametrize("which", [0, 1])
def test_crafted_names_of_symbols_parameters_and_constraints(marker, which):
    # The crafted name is the mass (in T and V), the rod length, the rod's name and a
    # force's name. The pendulum still swings with period 2 pi sqrt(l / g).
    name = crafted(marker)[which]
    length, mass = sp.Symbol(name, positive=True), sp.Symbol(name + "m", positive=True)
    rod = Holonomic(x**2 + y**2 - length**2, name=name)
    drag = PointForce(force=[0, 0, 0], point=[x, y, 0], name=name)
    system = pendulum(kinetic=mass / 2 * (x.diff() ** 2 + y.diff() ** 2),
                      potential=mass * sp.Symbol("g") * y, constraints=[rod], forces=[drag],
                      parameters={mass: 1.0, "g": 9.81, name: 1.0})
    system.equilibrium({"x": 0.1, "y": -0.9})  # the statics code generator too
    period = 2 * np.pi / system.linearize(system.equilibrium({"x": 0.1, "y": -0.9})
                                          ).natural_frequencies[0]
    assert abs(period - 2 * np.pi * np.sqrt(1.0 / 9.81)) < 1e-9
    traj = system.simulate((0, 0.5), q0=[0.0, -1.0], qd0=[0.1, 0.0])
    assert traj.success and traj.position_residual.max() < 1e-12


def test_crafted_name_in_a_summation_of_an_extremum(marker):
    # min of sum_{i=1}^{3} (a - 1)^2 + b^2 on a + b = 0: at a = 1/2, b = -1/2.
    a, b = sp.symbols("a b")
    i = sp.Symbol(crafted(marker)[0], integer=True)
    found = extremum(sp.Sum((a - 1) ** 2, (i, 1, 3)) / 3 + b**2, [a + b], [a, b],
                     {"a": 0.3, "b": 0.1})
    np.testing.assert_allclose(found.x, [0.5, -0.5], atol=1e-12)


def test_crafted_name_of_a_multibody_load_point(marker):
    with pytest.raises(ModelError, match=r"a point of body 'b' is the string"):
        Multibody([RigidBody("b", 1.0, (1, 1, 1))]).bodies[0].position(
            (f"__import__('os').system('touch {marker}')", 0, 0))


@pytest.mark.parametrize("where", ["kinetic", "potential", "constraint", "force",
                                   "generalized_force", "extremum"])
def test_strings_are_refused_not_parsed(marker, where):
    evil = f"__import__('os').system('touch {marker}')"
    with pytest.raises(ModelError, match=r"is the string .*does not parse strings") as info:
        if where == "kinetic":
            System([x], kinetic=evil)
        elif where == "potential":
            pendulum(potential=evil)
        elif where == "constraint":
            pendulum(constraints=[Holonomic(evil, name="rod")])
        elif where == "force":
            pendulum(forces=[PointForce(force=[evil, 0, 0], point=[x, y, 0], name="push")])
        elif where == "generalized_force":
            pendulum(generalized_forces={x: evil})
        else:
            a = sp.Symbol("a")
            extremum(evil, [], [a], {"a": 0.0})
    assert "__import__" in str(info.value)  # the string is shown, not run


def test_a_function_the_generator_cannot_print_is_named():
    q = sp.Symbol("q")
    with pytest.raises(ModelError, match=r"besselj\(0, q\) cannot be evaluated by the NumPy"):
        generate_function("f", [("q", [q])], [("v", sp.Matrix([sp.besselj(0, q)]))])


def test_a_name_the_generator_did_not_make_is_refused():
    # Subs prints as a call of a name the generator never made: refused, not run.
    q = sp.Symbol("q")
    with pytest.raises(ModelError, match=r"cannot be turned into NumPy code: it would print "
                                         r"'Subs'"):
        generate_function("f", [("q", [q])], [("v", sp.Matrix([q * sp.Subs(q**2, q, 1)]))])


def test_a_symbol_that_is_no_argument_is_named():
    q = sp.Symbol("q")
    B = sp.MatrixSymbol("B; import os", 1, 1)
    with pytest.raises(ModelError, match=r"depend on B; import os, which is not a coordinate"):
        generate_function("f", [("q", [q])], [("v", sp.Matrix([q * B[0, 0]]))])


def test_generated_code_has_no_builtins_but_range():
    q = sp.Symbol("q")
    fn = generate_function("f", [("q", [q])], [("v", sp.Matrix([q]))])
    assert fn.__globals__["__builtins__"] == {"range": range}
