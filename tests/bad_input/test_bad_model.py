"""Bad model input: each case asserts the error class and that the message names the culprit.

The cases cover what ``System(...)`` is given (coordinates, energies, constraints,
forces, parameters, names) and the multibody bodies' masses and inertias, both
the checks that existed before this suite and those added with it.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import pytest
import sympy as sp
from bad_input_cases import PARAMETERS, T2, g, l, m, pendulum, x, y

from dalembert import (
    ConstraintError,
    Holonomic,
    ModelError,
    ParameterError,
    Pfaffian,
    PointForce,
    System,
    coordinates,
    t,
)
from dalembert.multibody import Particle, PlanarBody, RigidBody

k = sp.Symbol("k")

#: (situation, what raises, error class, text the message must contain)
MODEL_CASES: list[tuple[str, Callable[[], object], type[Exception], str]] = [
    # -- coordinates
    ("coordinates a number", lambda: System(42, kinetic=T2), ModelError,
     "coordinates must be a sequence of coordinates"),
    ("coordinates empty", lambda: System([], kinetic=T2), ModelError, "at least one coordinate"),
    ("coordinate not a name", lambda: System([42], kinetic=T2), ModelError,
     "42 is not a coordinate or parameter name"),
    ("coordinate listed twice", lambda: System([x, x], kinetic=T2), ModelError,
     "coordinate 'x' is listed twice"),
    ("coordinate named t", lambda: System(coordinates("t"), kinetic=k), ModelError,
     "a coordinate cannot be named 't'"),
    ("coordinate named like a velocity", lambda: System(["x", "x_dot"], kinetic=k), ModelError,
     "'x_dot' is both a coordinate and a velocity"),
    ("velocities a number", lambda: System(["x"], kinetic=sp.Symbol("x_dot") ** 2,
                                           velocities=42), ModelError,
     "velocities must be a sequence"),
    ("velocities of the wrong length", lambda: System(["x"], kinetic=k, velocities=["a", "b"]),
     ModelError, "2 velocities given for 1 coordinates"),
    # -- energies
    ("no kinetic energy", lambda: System([x], potential=x**2), ModelError, "kinetic=T"),
    ("kinetic energy a matrix", lambda: System([x], kinetic=sp.Matrix([x.diff() ** 2])),
     ModelError, "the kinetic energy must be a scalar SymPy expression, got a 1 x 1 matrix"),
    ("potential energy a list", lambda: pendulum(potential=[y]), ModelError,
     "the potential energy is not a SymPy expression or a number: [y(t)]"),
    ("kinetic energy None-like object", lambda: System([x], kinetic=object()), ModelError,
     "the kinetic energy is not a SymPy expression"),
    ("kinetic energy without velocity", lambda: System([x], kinetic=x**2), ModelError,
     "the kinetic energy contains no velocity"),
    ("acceleration in T", lambda: System([x], kinetic=x.diff(t, 2) ** 2), ModelError,
     "the acceleration of 'x'"),
    ("function of time that is no coordinate",
     lambda: System([x], kinetic=x.diff() ** 2 + sp.Function("f")(t)), ModelError, "f(t)"),
    ("lagrangian and kinetic", lambda: System([x], kinetic=x.diff() ** 2,
                                              lagrangian=x.diff() ** 2), ModelError,
     "give either lagrangian=L or kinetic=T"),
    ("potential with a velocity", lambda: pendulum(potential=x.diff()), ModelError,
     "the potential energy depends on the velocity of 'x'"),
    # -- symbols that look like time or a coordinate
    ("plain symbol named like the coordinate",
     lambda: System([x], kinetic=x.diff() ** 2 / 2, potential=k * sp.Symbol("x")), ModelError,
     "the potential energy contains a plain symbol named 'x', the name of the coordinate 'x'"),
    ("plain symbol named like the velocity",
     lambda: System([x], kinetic=sp.Symbol("x_dot") ** 2 / 2), ModelError,
     "a plain symbol named 'x_dot', the name of the velocity of 'x'"),
    ("parameter t with assumptions",
     lambda: pendulum(potential=m * g * y * sp.Symbol("t", positive=True)), ModelError,
     "a symbol with assumptions (positive=True) named 't', the name of time"),
    ("parameter named like a coordinate given as a name",
     lambda: System(["x"], kinetic=sp.Symbol("x_dot") ** 2,
                    potential=sp.Symbol("x", positive=True)), ModelError,
     "named 'x', the name of the coordinate 'x'"),
    # -- constraints
    ("constraints a number", lambda: pendulum(constraints=42), ConstraintError,
     "constraints must be a sequence of dalembert.Holonomic"),
    ("constraint not wrapped", lambda: pendulum(constraints=[x**2 + y**2 - l**2]),
     ConstraintError, "constraint 0 is -l**2 + x(t)**2 + y(t)**2; wrap it"),
    ("constraint named by a number", lambda: pendulum(constraints=[Holonomic(x - y, name=7)]),
     ConstraintError, "the name of constraint 0 must be a string, got 7"),
    ("two constraints with one name",
     lambda: pendulum(constraints=[Holonomic(x, name="c"), Holonomic(y, name="c")]),
     ConstraintError, "two constraints are named 'c'"),
    ("holonomic constraint with a velocity",
     lambda: pendulum(constraints=[Holonomic(x.diff() + y, name="h")]), ConstraintError,
     "holonomic constraint 'h' contains velocities"),
    ("holonomic constraint without coordinate",
     lambda: pendulum(constraints=[Holonomic(l - 1, name="h")]), ConstraintError,
     "holonomic constraint 'h' does not involve any coordinate"),
    ("Pfaffian constraint without velocity",
     lambda: pendulum(constraints=[Pfaffian(x - y, name="p")]), ConstraintError,
     "Pfaffian constraint 'p' contains no velocity"),
    ("Pfaffian constraint not linear",
     lambda: pendulum(constraints=[Pfaffian(x.diff() ** 2, name="skid")]), ConstraintError,
     "Pfaffian constraint 'skid' is not linear in the velocities"),
    # -- forces
    ("forces a number", lambda: pendulum(forces=42), ModelError,
     "forces must be a sequence of dalembert.PointForce"),
    ("force not a PointForce", lambda: pendulum(forces=[(1, 0, 0)]), ModelError,
     "forces[0] is (1, 0, 0); give dalembert.PointForce"),
    ("force vector a string", lambda: pendulum(forces=[PointForce("abc", [x, y, 0], name="f")]),
     ModelError, "the force of f must be a vector of components, got the string 'abc'"),
    ("force with 4 components",
     lambda: pendulum(forces=[PointForce([1, 0, 0, 0], [x, y, 0], name="f")]), ModelError,
     "the force of f has 4 components"),
    ("point depending on velocities",
     lambda: pendulum(forces=[PointForce([1, 0, 0], [x.diff(), y, 0], name="f")]), ModelError,
     "the point of f depends on velocities"),
    ("generalized forces a number", lambda: pendulum(generalized_forces=42), ModelError,
     "generalized_forces must be a sequence of forces, one per coordinate"),
    ("generalized forces of the wrong length", lambda: pendulum(generalized_forces=[0]),
     ModelError, "generalized_forces has 1 entries for 2 coordinates"),
    ("generalized force on an unknown coordinate",
     lambda: pendulum(generalized_forces={"w": 1}), ModelError, "unknown coordinate 'w'"),
    # -- parameters and names
    ("parameters a list", lambda: pendulum(parameters=[1.0, 9.81, 1.0]), ParameterError,
     "parameters must be a dict {symbol or name: number}, got [1.0, 9.81, 1.0] (list)"),
    ("parameter t", lambda: pendulum(parameters={**PARAMETERS, "t": 2.0}), ParameterError,
     "'t' is not a parameter of this model (its parameters: g, l, m) ('t' is time"),
    ("unknown parameter", lambda: pendulum(parameters={**PARAMETERS, "k": 2.0}),
     ParameterError, "'k' is not a parameter of this model"),
    ("parameter not a number", lambda: pendulum(parameters={**PARAMETERS, m: "heavy"}),
     ParameterError, "parameter 'm' = 'heavy' is not a number"),
    ("parameter NaN", lambda: pendulum(parameters={**PARAMETERS, g: np.nan}), ParameterError,
     "parameter 'g' = nan is not finite"),
    ("parameter infinite", lambda: pendulum(parameters={**PARAMETERS, l: -np.inf}),
     ParameterError, "parameter 'l' = -inf is not finite"),
    ("name a number", lambda: pendulum(name=42), ModelError, "name must be a string, got 42"),
    ("redundant_constraints unknown", lambda: pendulum(redundant_constraints="ignore"),
     ValueError, "The 'redundant_constraints' parameter of System must be one of"),
    # -- bodies
    ("negative particle mass", lambda: Particle("bob", -1.0), ModelError,
     "the mass of 'bob' must be positive and finite, got -1.0"),
    ("body name not an identifier", lambda: Particle("my bob", 1.0), ModelError,
     "a body name must be an identifier-like string, got 'my bob'"),
    ("inertia not numbers", lambda: RigidBody("b", 1.0, ("a", 1, 1)), ModelError,
     "the inertia of 'b' is the string 'a'"),
    ("inertia of the wrong shape", lambda: RigidBody("b", 1.0, (1, 1)), ModelError,
     "the inertia of 'b' must be a 3x3 tensor or 3 principal values, got shape (2,)"),
    ("inertia not finite", lambda: RigidBody("b", 1.0, (1, np.nan, 1)), ModelError,
     "the inertia of 'b' must be finite, got nan"),
    ("inertia not symmetric", lambda: RigidBody("b", 1.0, [[1, 0.5, 0], [0, 1, 0], [0, 0, 1]]),
     ModelError, "the inertia tensor of 'b' must be symmetric: I[0, 1] = 0.5 but I[1, 0] = 0"),
    ("inertia with a zero moment", lambda: RigidBody("b", 1.0, (1, 1, 0)), ModelError,
     "the inertia tensor of 'b' is not positive definite (principal values 0, 1, 1)"),
    ("inertia with a negative moment", lambda: RigidBody("b", 1.0, (-1, 1, 1)), ModelError,
     "the inertia tensor of 'b' is not positive definite (principal values -1, 1, 1)"),
    ("inertia violating the triangle inequality", lambda: RigidBody("b", 1.0, (1, 1, 3)),
     ModelError, "the inertia tensor of 'b' violates the triangle inequality: principal "
     "moments 1, 1, 3, and 1 + 1 = 2 < 3"),
    ("inertia of a too thin rod", lambda: RigidBody("rod", 1.0, (5e-15, 0.02, 0.02)),
     ModelError, "the inertia tensor of 'rod' is nearly singular"),
    ("planar inertia not positive", lambda: PlanarBody("p", 1.0, 0.0), ModelError,
     "the moment of inertia of planar body 'p' must be positive and finite, got 0.0"),
]


@pytest.mark.parametrize(("situation", "make", "error", "culprit"), MODEL_CASES,
                         ids=[case[0] for case in MODEL_CASES])
def test_bad_model_input_is_named(situation, make, error, culprit):
    with pytest.raises(error) as info:
        make()
    assert culprit in str(info.value), f"{situation}: {info.value}"


@pytest.mark.parametrize("moments", [(1.0, 1.0, 2.0), (0.3, 0.4, 0.7 * (1 + 1e-12)),
                                     (0.1, 0.2, 0.25)])
def test_inertias_on_or_inside_the_triangle_are_accepted(moments):
    # a flat plate has I3 = I1 + I2 exactly; rounding of that sum must not be refused
    body = RigidBody("plate", 1.0, moments)
    assert np.allclose(np.diag(body.inertia), moments)


def test_coordinates_given_as_symbols_with_assumptions_are_the_coordinates():
    # x positive given as the coordinate: the same symbol in T and V is the coordinate
    # (it once became a parameter named like it). x'' = -x from x = 1: cos t.
    X, Xd = sp.symbols("x x_dot", positive=True)
    system = System([X], kinetic=Xd**2 / 2, potential=X**2 / 2, velocities=[Xd])
    assert system.parameters == ()
    traj = system.simulate((0, 1), q0=[1.0], t_eval=[1.0])
    assert abs(traj["x"][-1] - np.cos(1.0)) < 1e-9
