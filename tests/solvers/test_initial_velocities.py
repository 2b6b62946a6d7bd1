"""Initial velocities made consistent as a perfectly plastic impact onto the constraints.

Reference: a uniform sphere (``I = 2/5 m r^2``) set on a table sliding at ``v0``
without spin, with rolling imposed at once, keeps its angular momentum about the
contact point (the impulse acts there): ``m v0 r = m v r + I w`` with ``w = v / r``,
so ``v = 5/7 v0`` whatever ``m`` and ``r``, the friction impulse is ``-2/7 m v0`` and
the impact dissipates ``m v0^2 / 2 - 7/10 m v^2 = m v0^2 / 7``.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest
import sympy as sp

from dalembert import Holonomic, InitialConditionsAdjusted, System, coordinates, t
from dalembert.multibody import Multibody, RigidBody, Rolling, angular_velocities, chain
from dalembert.solvers.kkt.dense import solve_kkt

MASS, V0 = 2.0, 1.0


def sphere_on_table(radius: float):
    ball = RigidBody("ball", MASS, np.full(3, 0.4 * MASS * radius**2))
    mb = Multibody([ball], [Rolling("roll", ball, radius)], gravity=(0.0, 0.0, -9.81))
    q0, qd0 = mb.initial_state(positions={ball: (0.0, 0.0, radius)},
                               velocities={ball: (V0, 0.0, 0.0)})
    return mb, q0, qd0


@pytest.mark.parametrize("radius", [1.0, 0.1, 0.01])
def test_sliding_sphere_starts_rolling_at_five_sevenths(radius):
    mb, q0, qd0 = sphere_on_table(radius)
    with pytest.warns(InitialConditionsAdjusted, match=r"perfectly plastic impact.*impulse"):
        traj = mb.simulate((0.0, 0.1), q0, qd0, t_eval=[0.0, 0.1])
    v = np.array([traj["ball_x_dot"][0], traj["ball_y_dot"][0], traj["ball_z_dot"][0]])
    assert abs(v[0] - 5 / 7 * V0) < 1e-12 and np.abs(v[1:]).max() < 1e-12
    omega = angular_velocities(mb, traj, "ball")[0]
    np.testing.assert_allclose(omega, [0.0, 5 / 7 * V0 / radius, 0.0], atol=1e-12 / radius)
    # no force along the table afterwards: it keeps rolling at 5/7 v0
    assert abs(traj["ball_x_dot"][-1] - 5 / 7 * V0) < 1e-10


@pytest.mark.parametrize("radius", [1.0, 0.01])
def test_impact_impulse_and_energy_are_reported(radius):
    mb, q0, qd0 = sphere_on_table(radius)
    report = mb.system.consistent_initial_state(q0, qd0)
    names = mb.system.coordinate_names
    impulse = dict(zip(names, report.impulse))
    assert abs(impulse["ball_x"] - (-2 / 7 * MASS * V0)) < 1e-12
    assert abs(report.kinetic_energy_lost - MASS * V0**2 / 7) < 1e-12
    assert "kinetic energy lost" in report.describe_changes()


def test_least_change_is_kept_as_an_option_and_depends_on_units():
    starts = []
    for radius in (1.0, 0.1):
        mb, q0, qd0 = sphere_on_table(radius)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", InitialConditionsAdjusted)
            report = mb.system.consistent_initial_state(q0, qd0,
                                                        velocity_projection="least-change")
        assert "least change" in report.describe_changes()
        starts.append(dict(zip(mb.system.coordinate_names, report.qd))["ball_x"])
    # the Euclidean projection mixes metres and quaternion rates: not 5/7, and not the same
    assert abs(starts[0] - starts[1]) > 0.1 and abs(starts[1] - 5 / 7) > 0.1


def test_fixed_coordinates_keep_their_velocity():
    """A particle on the circle ``x^2 + y^2 = 1`` at (1, 0), with ``x_dot`` held: the
    constraint ``x x_dot + y y_dot = 0`` then allows only ``x_dot = 0``... so hold
    ``y_dot`` instead: ``x_dot`` must become 0 and ``y_dot`` keeps its value."""
    x, y = coordinates("x y")
    m = sp.Symbol("m")
    circle = System([x, y], kinetic=m / 2 * (x.diff() ** 2 + y.diff() ** 2),
                    constraints=[Holonomic(x**2 + y**2 - 1)], parameters={m: 3.0})
    report = circle.consistent_initial_state([1.0, 0.0], [0.4, 2.0], fixed=["y"])
    np.testing.assert_allclose(report.qd, [0.0, 2.0], atol=1e-15)
    assert abs(report.impulse[0] - 3.0 * -0.4) < 1e-14


def test_large_chain_uses_the_same_metric():
    """The sparse route of a 20-link chain agrees with a dense KKT solve of the impact."""
    mb = chain(20, 1.0, 1.0, 0.05)
    system = mb.system
    q0, _ = mb.initial_state(positions={f"link{k + 1}": (0.0, 0.0, -k - 0.5)
                                        for k in range(20)})
    names = system.coordinate_names
    rng = np.random.default_rng(3)
    q = np.array([q0[k] for k in names])
    qd = 0.1 * rng.normal(size=len(names))
    report = system.consistent_initial_state(q, qd)
    num = system.numeric()
    Mv, _, Av, _ = num.kkt_sparse(0.0, report.q, qd)
    _, b = num.velocity_sparse(0.0, report.q)
    M, A = num.pattern.dense_M(Mv), num.pattern.dense_A(Av)
    ref, _ = solve_kkt(M, M @ qd, A, -b)
    assert np.abs(report.qd - ref).max() < 1e-12
    assert np.abs(A @ report.qd + b).max() < 1e-12


@pytest.mark.parametrize(("vx0", "word"), [(0.0, "gained"), (5.0, "lost")])
def test_a_moving_constraint_reports_the_energy_gained_or_lost(vx0, word):
    """A particle (mass 3) whose constraint x = 2 t drives it at 2 along x: started at
    ``vx0`` (and 1 along y, kept), its kinetic energy changes by 3/2 (2^2 - vx0^2): gained
    from rest, lost from 5 (the energy of the velocity change alone, 3/2 (2 - vx0)^2, has
    no sign and is not the change where the constraint moves)."""
    x, y = coordinates("x y")
    driven = System([x, y], kinetic=sp.Rational(3, 2) * (x.diff() ** 2 + y.diff() ** 2),
                    constraints=[Holonomic(x - 2 * t, name="drive")])
    report = driven.consistent_initial_state({x: 0.0, y: 0.0}, {x: vx0, y: 1.0})
    expected = 1.5 * (2.0**2 - vx0**2)
    assert abs(report.kinetic_energy_change - expected) < 1e-12
    assert f"kinetic energy {word} {abs(expected):.6g}" in report.describe_changes()
    with pytest.warns(InitialConditionsAdjusted, match=f"kinetic energy {word} "):
        driven.simulate((0.0, 0.1), {x: 0.0, y: 0.0}, {x: vx0, y: 1.0})
