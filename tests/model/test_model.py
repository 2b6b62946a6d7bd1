"""Coordinates, constraint assembly, point forces and parameters (the model layer)."""

from __future__ import annotations

import warnings

import numpy as np
import pytest
import sympy as sp
from sympy.physics.vector import ReferenceFrame

from dalembert import Holonomic, Pfaffian, PointForce, System, coordinates, t
from dalembert.errors import DoubleCountingWarning, ModelError
from dalembert.model.constraints import build_constraints
from dalembert.model.coordinates import build_coordinates
from dalembert.model.forces import generalized_forces
from dalembert.model.parameters import resolve_parameters

x, y = coordinates("x y")
X, Y, XD, YD = sp.symbols("x y x_dot y_dot")
m, g, a, w = sp.symbols("m g a omega", positive=True)


# -- coordinates -----------------------------------------------------------------------
def test_dynamicsymbols_become_plain_symbols():
    coords = build_coordinates([x, y])
    assert coords.names == ("x", "y")
    assert coords.q == (X, Y) and coords.qd == (XD, YD)
    assert coords.to_plain(x.diff() * y + y.diff(), "T") == XD * Y + YD


def test_single_coordinate_is_a_tuple():
    (r,) = coordinates("r")
    assert build_coordinates([r]).names == ("r",)


def test_plain_names_get_dot_velocities():
    coords = build_coordinates("u, v")
    assert [s.name for s in coords.qd] == ["u_dot", "v_dot"]
    system = System("u v", kinetic=sp.Symbol("u_dot") ** 2 + sp.Symbol("v_dot") ** 2 / 2)
    M = system.equations().M
    assert sp.diag(2, 1) == M


def test_explicit_velocities():
    r, v = sp.symbols("r v")
    coords = build_coordinates([r], velocities=[v])
    assert coords.qd == (v,)
    system = System([r], velocities=[v], kinetic=m * v**2 / 2, potential=m * g * r,
                    parameters={m: 2.0, g: 1.0})
    eqs = system.equations()
    assert sp.Matrix([[m]]) == eqs.M and eqs.f == sp.Matrix([-m * g])
    traj = system.simulate((0, 1), q0=[0.0], qd0=[1.0])
    # r = t - g t^2 / 2 exactly
    assert abs(traj["r"][-1] - 0.5) < 1e-12
    assert abs(traj["r_dot"][-1] - 0.0) < 1e-12


def test_wrong_number_of_velocities():
    with pytest.raises(ModelError, match="1 velocities given for 2 coordinates"):
        build_coordinates("u v", velocities=[sp.Symbol("p")])


def test_index_by_name_symbol_and_function():
    coords = build_coordinates([x, y])
    assert coords.index("y") == coords.index(y) == coords.index(Y) == coords.index(y.diff()) == 1


def test_second_derivative_of_a_coordinate_rejected_in_a_force():
    with pytest.raises(ModelError, match="acceleration of 'y'"):
        System([x, y], kinetic=x.diff() ** 2 + y.diff() ** 2, generalized_forces={x: y.diff(t, 2)})


# -- constraints -----------------------------------------------------------------------
def test_holonomic_rows_are_gradients():
    coords = build_coordinates([x, y])
    cons = build_constraints([Holonomic(x**2 + y**2 - 1, name="rod")], coords)
    assert sp.Matrix([[2 * X, 2 * Y]]) == cons.A and cons.b == sp.Matrix([0])
    assert cons.holonomic_rows == (0,) and cons.names == ("rod",)


def test_rheonomic_holonomic_b_is_time_derivative():
    coords = build_coordinates([x, y])
    psi = x - a * sp.sin(w * t) + y * t
    cons = build_constraints(Holonomic(psi), coords)
    assert sp.Matrix([[1, t]]) == cons.A
    assert sp.simplify(cons.b[0] - (-a * w * sp.cos(w * t) + Y)) == 0
    assert cons.names == ("holonomic_0",)


def test_pfaffian_split_into_A_and_b():
    th = sp.Function("theta")(t)
    coords = build_coordinates([x, y, th])
    cons = build_constraints([Pfaffian(-sp.sin(th) * x.diff() + sp.cos(th) * y.diff() + t**2,
                                       name="blade")], coords)
    TH = sp.Symbol("theta")
    assert sp.Matrix([[-sp.sin(TH), sp.cos(TH), 0]]) == cons.A
    assert cons.b == sp.Matrix([t**2])
    assert cons.holonomic_rows == () and cons.psi.shape == (0, 1)


def test_rows_keep_the_users_order():
    z = coordinates("z")[0]
    coords = build_coordinates([x, y, z])
    cons = build_constraints([Pfaffian(x.diff() - z.diff(), name="p"), Holonomic(y - 1, name="h")],
                             coords)
    assert cons.names == ("p", "h") and cons.kinds == ("Pfaffian", "holonomic")
    assert cons.holonomic_rows == (1,) and cons.psi == sp.Matrix([Y - 1])


# -- forces ----------------------------------------------------------------------------
def test_point_force_virtual_work_polar():
    r, th = coordinates("r theta")
    R, TH = sp.symbols("r theta")
    Fx, Fy = sp.symbols("F_x F_y")
    coords = build_coordinates([r, th])
    pf = PointForce(force=[Fx, Fy, 0], point=[r * sp.cos(th), r * sp.sin(th), 0])
    Q = generalized_forces(None, [pf], coords)
    # Q_r = F . e_r, Q_theta = r F . e_theta (hand computed)
    expected = sp.Matrix([Fx * sp.cos(TH) + Fy * sp.sin(TH),
                          R * (-Fx * sp.sin(TH) + Fy * sp.cos(TH))])
    assert sp.simplify(Q - expected) == sp.zeros(2, 1)


def test_point_force_with_velocity_dependent_force_and_vectors():
    N = ReferenceFrame("N")
    c = sp.Symbol("c")
    coords = build_coordinates([x, y])
    drag = PointForce(force=-c * (x.diff() * N.x + y.diff() * N.y), point=x * N.x + 2 * y * N.y,
                      frame=N, name="drag")
    Q = generalized_forces({x: 1}, [drag], coords)
    assert sp.Matrix([1 - c * XD, -2 * c * YD]) == Q


def test_point_force_vector_needs_frame():
    N = ReferenceFrame("N")
    with pytest.raises(ModelError, match="pass frame="):
        generalized_forces(None, [PointForce(N.x, x * N.x)], build_coordinates([x]))


def test_point_depending_on_velocity_rejected():
    with pytest.raises(ModelError, match="depends on velocities"):
        generalized_forces(None, [PointForce([1, 0], [x.diff(), 0])], build_coordinates([x]))


def test_generalized_forces_as_sequence_and_wrong_length():
    coords = build_coordinates([x, y])
    assert generalized_forces([x, 2], [], coords) == sp.Matrix([X, 2])
    with pytest.raises(ModelError, match="3 entries for 2 coordinates"):
        generalized_forces([1, 2, 3], [], coords)


# -- gravity counted twice: -dV/dq against Q, both expanded ------------------------------
C = sp.Symbol("c", positive=True)
T_Y = m / 2 * y.diff() ** 2


def double_counting(**model):
    """The DoubleCountingWarning messages of building ``System([y], **model)``, each
    checked to point at this file (the user's line), not into the library."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        System([y], **model)
    found = [w for w in caught if issubclass(w.category, DoubleCountingWarning)]
    assert all(w.filename == __file__ for w in found), [w.filename for w in found]
    return [str(w.message) for w in found]


@pytest.mark.parametrize("model", [
    # a float coefficient: -1.0*g*m is the potential's -g*m
    dict(kinetic=T_Y, potential=m * g * y, generalized_forces={y: -1.0 * g * m}),
    # the weight inside a product with a damper
    dict(kinetic=T_Y, potential=m * g * y, generalized_forces={y: -m * (g + C * y.diff())}),
    # the potential given inside a Lagrangian
    dict(lagrangian=T_Y - m * g * y, generalized_forces={y: -m * g}),
    # both: a Lagrangian and the weight among damper terms
    dict(lagrangian=T_Y - m * g * y, generalized_forces={y: -C * y.diff() - g * m}),
], ids=["float", "product", "lagrangian", "lagrangian-damped"])
def test_gravity_counted_twice_is_reported(model):
    (message,) = double_counting(**model)
    assert "force on 'y' contains -" in message and "g*m" in message
    assert "counted twice" in message


@pytest.mark.parametrize("model", [
    # a damper alone: no force at rest, nothing conservative
    dict(kinetic=T_Y, potential=m * g * y, generalized_forces={y: -C * y.diff()}),
    dict(lagrangian=T_Y - m * g * y, generalized_forces={y: -C * y.diff()}),
    # forces that only partly resemble the weight: shaken in time, buoyancy
    dict(kinetic=T_Y, potential=m * g * y,
         generalized_forces={y: -m * g * sp.sin(w * t) - C * y.diff()}),
    dict(kinetic=T_Y, potential=m * g * y, generalized_forces={y: a * g}),
], ids=["damper", "damper-lagrangian", "shaker", "buoyancy"])
def test_non_conservative_forces_are_not_reported(model):
    assert double_counting(**model) == []


# -- parameters ------------------------------------------------------------------------
def test_parameters_sorted_and_overridden():
    system = System([x], kinetic=m * x.diff() ** 2 / 2, potential=m * g * x,
                    parameters={"m": 1.0, g: 9.0})
    assert [s.name for s in system.parameters] == ["g", "m"]
    p = resolve_parameters(system.parameters, system.parameter_values, {"g": 2.0})
    assert np.array_equal(p, [2.0, 1.0])
    assert system.numeric({"m": 3.0}).p.tolist() == [9.0, 3.0]


def test_one_parameter_set_serves_several_models():
    """A ``ParameterSet(strict=False)`` carries names a model lacks; a plain dict may
    not (a typo would pass silently)."""
    import numpy as np

    from dalembert import ParameterError, ParameterSet
    from dalembert.examples import cartesian_pendulum
    from dalembert.multibody import Ground as G0
    from dalembert.multibody import Multibody, Particle, SpringDamper

    k, m_p = sp.Symbol("k"), sp.Symbol("m")
    bob = Particle("bob", m_p)
    spring = Multibody([bob], springs=[SpringDamper("s", G0(), bob, k)], gravity=(0, 0, 0))
    pendulum = cartesian_pendulum.build()
    shared = ParameterSet({"m": 2.0, "g": 9.81, "l": 1.0, "k": 8.0}, strict=False)
    swing = pendulum.simulate((0, 1), {"x": 1.0, "y": 0.0}, parameters=shared, t_eval=[1.0])
    bounce = spring.simulate((0, np.pi / 2), {"bob_x": 0.1}, parameters=shared,
                             t_eval=[np.pi / 2])
    assert swing.parameters == {"g": 9.81, "l": 1.0, "m": 2.0}
    assert bounce["bob_x"][0] == pytest.approx(0.1 * np.cos(2 * np.pi / 2), abs=1e-10)
    rest = pendulum.equilibrium({"x": 0.1, "y": -0.9}, parameters=shared)
    assert -2 * rest.multiplier("rod") == pytest.approx(2.0 * 9.81, rel=1e-12)
    # a plain dict is strict: the error names the key and the way to pass extra ones
    with pytest.raises(ParameterError, match=r"'k' is not a parameter of this model "
                       r"\(its parameters: g, l, m\).*ParameterSet\(values, strict=False\)"):
        pendulum.simulate((0, 1), {"x": 1.0, "y": 0.0}, parameters=dict(shared))
    with pytest.raises(ParameterError, match="strict must be True or False"):
        ParameterSet({}, strict="no")
