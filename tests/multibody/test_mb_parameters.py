"""Parameters in every number of a multibody model.

References: the same mechanisms built from numbers (their own derivation and
compilation, the route every test before this one covers), compared at random
states and along trajectories; the compiler, whose runs are counted.
"""

from __future__ import annotations

import numpy as np
import pytest
import sympy as sp

from dalembert import ModelError, ParameterError
from dalembert import t as time
from dalembert.codegen import c_backend
from dalembert.multibody import (
    Distance,
    Force,
    Ground,
    Multibody,
    Particle,
    PlanarBody,
    Revolute,
    RigidBody,
    Rolling,
    Spherical,
    SpringDamper,
    Torque,
    chain,
    energy,
    joint_reactions,
)

m, l, r = sp.symbols("m l r", positive=True)
N = 16


def hanging(mb, length, n):
    """Links hanging straight, swinging and turning (consistent: a rigid rotation
    about the pivot)."""
    omega = np.array([0.4, 0.7, 0.0])
    positions = {f"link{k + 1}": (0.0, 0.0, -(k + 0.5) * length) for k in range(n)}
    velocities = {name: np.cross(omega, x) for name, x in positions.items()}
    return mb.initial_state(positions=positions, velocities=velocities,
                            angular_velocities=dict.fromkeys(positions, omega))


@pytest.fixture(scope="module")
def symbolic_chain():
    mb = chain(N, l, m, r)
    mb.defaults = {m: 1.0, l: 1.0, r: 0.05}
    return mb


def test_the_chain_lists_its_parameters(symbolic_chain):
    assert symbolic_chain.system.parameters == (l, m, r)
    assert symbolic_chain.system.parameter_values == {"m": 1.0, "l": 1.0, "r": 0.05}


@pytest.mark.parametrize("values", [{m: 0.7, l: 1.3, r: 0.04}, {m: 2.5, l: 0.6, r: 0.08}])
def test_one_build_runs_every_parameter_set_as_a_chain_of_numbers(symbolic_chain, values,
                                                                  monkeypatch):
    symbolic_chain.system.compiled  # noqa: B018  (built once, before counting)
    runs = []
    original = c_backend._compile
    monkeypatch.setattr(c_backend, "_compile", lambda *a, **k: runs.append(a) or original(*a, **k))
    q0, qd0 = hanging(symbolic_chain, values[l], N)
    times = np.linspace(0.0, 3.0, 31)
    ours = symbolic_chain.simulate((0.0, 3.0), q0, qd0, t_eval=times, parameters=values)
    assert runs == []  # nothing generated or compiled for new values
    reference = chain(N, values[l], values[m], values[r])
    theirs = reference.simulate((0.0, 3.0), q0, qd0, t_eval=times)
    assert ours.stats["nfev"] == theirs.stats["nfev"]
    # to rounding: a derived value (the links' inertia) is computed by another route
    assert np.abs(ours.q - theirs.q).max() < 1e-12 * np.abs(theirs.q).max()
    assert np.abs(ours.multipliers - theirs.multipliers).max() < 1e-12 * np.abs(
        theirs.multipliers).max()
    assert ours.parameters == {"l": values[l], "m": values[m], "r": values[r]}
    # the outputs read the values the run used
    np.testing.assert_allclose(energy(symbolic_chain, ours), energy(reference, theirs),
                               rtol=1e-12)
    ours_j = joint_reactions(symbolic_chain, ours)["joint1"]["link1"].force_world
    theirs_j = joint_reactions(reference, theirs)["joint1"]["link1"].force_world
    np.testing.assert_allclose(ours_j, theirs_j, rtol=1e-10, atol=1e-10)


def every_kind(numbers: dict):
    """A mechanism with a parameter in every kind of number, or (``numbers``) the
    same built from floats."""
    def v(symbol, default):
        return numbers.get(symbol, default) if numbers else symbol

    mass, moment, length, radius, k, c, rest, F, tau, g, I2, x = sp.symbols(
        "mass moment length radius k c rest F tau g I2 x")
    a = RigidBody("a", v(mass, 1.2), (0.1, v(I2, 0.2), 0.25))
    p = Particle("p", v(mass, 1.2) / 2)
    wheel = RigidBody("wheel", 2.0, (0.25, 0.5, 0.25))
    disk = PlanarBody("disk", 1.0, v(moment, 0.3))
    joints = [Revolute("hinge", Ground(), a, (0, 0, 1), (0, 0, v(x, 0.4)), axis_a=(0, 1, 0)),
              Distance("rod", a, p, v(length, 0.7), point_a=(0, 0, -v(x, 0.4))),
              Rolling("roll", wheel, v(radius, 0.5), axis=(0, 1, 0))]
    mb = Multibody(
        [a, p, wheel, disk], joints, gravity=(0.0, -v(g, 9.81), 0.0),
        forces=[Force(p, (v(F, 0.3) * sp.sin(time), 0, 0))],
        torques=[Torque(disk, (0, 0, v(tau, 0.1)))],
        springs=[SpringDamper("s", a, p, v(k, 3.0), v(rest, 0.2), v(c, 0.1),
                              point_a=(0, v(x, 0.4) / 4, 0))])
    values = {mass: 1.2, moment: 0.3, length: 0.7, radius: 0.5, k: 3.0, c: 0.1, rest: 0.2,
              F: 0.3, tau: 0.1, g: 9.81, I2: 0.2, x: 0.4}
    return mb, values


def test_every_kind_of_number_may_be_a_parameter():
    symbolic, values = every_kind({})
    assert {s.name for s in symbolic.parameters} == {s.name for s in values}
    rng = np.random.default_rng(0)
    for scale in (1.0, 1.3):
        chosen = {s: v * scale for s, v in values.items()}
        numbers, _ = every_kind(chosen)
        fast = symbolic.system.numeric(chosen)
        reference = numbers.system.numeric()
        for _ in range(3):
            t, q, qd = rng.normal(), rng.normal(size=fast.n), rng.normal(size=fast.n)
            q[3:7] /= np.linalg.norm(q[3:7])
            q[13:17] /= np.linalg.norm(q[13:17])
            for got, want in [*zip(fast.kkt_blocks(t, q, qd), reference.kkt_blocks(t, q, qd)),
                              *zip(fast.velocity_constraint(t, q),
                                   reference.velocity_constraint(t, q)),
                              (fast.position_constraint(t, q),
                               reference.position_constraint(t, q)),
                              (fast.energies(t, q, qd), reference.energies(t, q, qd))]:
                np.testing.assert_allclose(got, want, rtol=1e-12, atol=1e-12)


def test_pieces_with_different_parameters_share_one_kernel():
    """Sixteen links with sixteen masses: one body kernel, placed sixteen times."""
    from dalembert.multibody.parts import multibody_parts

    masses = sp.symbols(f"m1:{N + 1}")
    links = [RigidBody(f"link{k + 1}", masses[k], (0.1, 0.1, 0.02)) for k in range(N)]
    joints = [Spherical(f"j{k + 1}", Ground() if k == 0 else links[k - 1], links[k],
                        (0, 0, 0) if k == 0 else (0, 0, -0.5), (0, 0, 0.5)) for k in range(N)]
    parts = multibody_parts(Multibody(links, joints))
    assert sorted(p.instances for p in parts) == [1, N - 1, N]


def test_a_force_with_a_free_symbol_is_a_parameter():
    F = sp.Symbol("F")
    p = Particle("p", 2.0)
    mb = Multibody([p], forces=[Force(p, (F, 0, 0))], gravity=(0, 0, 0))
    assert mb.system.parameters == (F,)
    q0, qd0 = mb.initial_state()
    traj = mb.simulate((0.0, 1.0), q0, qd0, parameters={"F": 4.0}, t_eval=[1.0])
    assert traj["p_x"][0] == pytest.approx(1.0, abs=1e-12)  # F t^2 / (2 m)
    with pytest.raises(ParameterError, match=r"no numeric value for parameter.*F"):
        mb.simulate((0.0, 1.0), q0, qd0)


def test_values_that_break_a_piece_are_refused_naming_it():
    mb = chain(2, l, m, 0.05)
    q0, qd0 = hanging(chain(2, 1.0, 1.0, 0.05), 1.0, 2)
    with pytest.raises(ModelError, match="the mass of 'link1' must be positive"):
        mb.simulate((0.0, 1.0), q0, qd0, parameters={m: -1.0, l: 1.0})
    I = sp.Symbol("I")
    lopsided = Multibody([RigidBody("b", 1.0, (1.0, 1.0, I))])
    with pytest.raises(ModelError, match="'b' violates the triangle inequality"):
        lopsided.simulate((0.0, 1.0), *lopsided.initial_state(), parameters={I: 3.0})


def test_body_values_checked_together_still_name_the_first_body_at_fault():
    """Where only rigid bodies' masses and inertias are parameters, a run checks them
    all at once (no bound copy of the mechanism): the error is still about the first
    body at fault, in order, as checking them one by one gives it."""
    m1, m2, I = sp.symbols("m1 m2 I")
    a = RigidBody("a", m1, (1.0, 1.0, I))
    b = RigidBody("b", m2, (1.0, 1.0, 1.0))
    mb = Multibody([a, b], [Spherical("j", a, b, (0, 0, -0.5), (0, 0, 0.5))])
    q0, qd0 = mb.initial_state(positions={"b": (0, 0, -1.0)})
    values = {m1: 1.0, m2: 1.0, I: 1.0}
    assert mb.simulate((0.0, 0.1), q0, qd0, parameters=values).status == "finished"
    with pytest.raises(ModelError, match="the mass of 'b' must be positive and finite, got -1"):
        mb.simulate((0.0, 0.1), q0, qd0, parameters={**values, m2: -1.0})
    with pytest.raises(ModelError, match="'a' violates the triangle inequality"):
        mb.simulate((0.0, 0.1), q0, qd0, parameters={**values, I: 3.0, m2: -1.0})
    with pytest.raises(ModelError, match=r"the mass of 'a' must be positive and finite, got 0\.0"):
        mb.simulate((0.0, 0.1), q0, qd0, parameters={**values, m1: 0.0})


def test_geometry_may_not_depend_on_the_motion():
    x = sp.Function("x")(time)
    with pytest.raises(ModelError, match="depends on the motion or the time"):
        Particle("p", 1.0 + x)
    with pytest.raises(ModelError, match="depends on the motion or the time"):
        Distance("rod", Ground(), Particle("q", 1.0), 1.0 + time)


def test_statics_of_a_parametric_chain():
    """Hanging at rest, the pivot carries the whole weight ``n m g``."""
    mb = chain(4, l, m, 0.05, joint="revolute", planar=True)
    values = {m: 1.7, l: 0.8}
    guess = {}
    for k in range(4):
        guess |= {f"link{k + 1}_y": -(k + 0.5) * 0.8 + 0.01, f"link{k + 1}_theta": 0.02}
    rest = mb.system.equilibrium(guess, parameters=values)
    lifted = sum(rest.constraint_force(f"link{k + 1}_y") for k in range(4))
    assert lifted == pytest.approx(4 * 1.7 * 9.81, rel=1e-12)
    assert rest["link4_y"] == pytest.approx(-3.5 * 0.8, abs=1e-12)


def test_joint_axes_may_be_parameters():
    """A door on a hinge tilted by a parameter angle: the same equations as the hinge
    built from the numbers, for two angles, with one build."""
    a = sp.Symbol("a")

    def door(axis):
        body = RigidBody("door", 10.0, (1.0, 1.2, 0.3))
        hinge = Revolute("hinge", Ground(), body, (0, 0, 0), (-0.5, 0, 0), axis_a=axis,
                         ref_a=(1, 0, 0), ref_b=(1, 0, 0))
        return Multibody([body], [hinge])

    symbolic = door((0, sp.sin(a), sp.cos(a)))
    assert symbolic.parameters == (a,)
    rng = np.random.default_rng(6)
    for angle in (0.3, -0.7):
        fast = symbolic.system.numeric({a: angle})
        reference = door((0.0, np.sin(angle), np.cos(angle))).system.numeric()
        for _ in range(3):
            t, q, qd = rng.normal(), rng.normal(size=7), rng.normal(size=7)
            q[3:] /= np.linalg.norm(q[3:])
            for got, want in zip(fast.kkt_blocks(t, q, qd), reference.kkt_blocks(t, q, qd)):
                np.testing.assert_allclose(got, want, rtol=1e-12, atol=1e-12)
    with pytest.raises(ModelError, match="axis written with parameters needs its reference"):
        Revolute("h", Ground(), RigidBody("b", 1.0, (1, 1, 1)), axis_a=(0, sp.sin(a), 1))
