"""A box resting on its four bottom corners, each with Coulomb friction, in the
event-driven contact mode: four coplanar contacts whose normal rows are dependent (rank
3), so their normal forces are the minimum-norm ones, which on a rigid body are the
loads of four equal springs (linear in the corners' positions).

References (closed forms, from force and moment balance about the mass center, the
corners at ``(x_k, y_k, -c/2)``):

- pushed by ``F`` along the unit ``d`` at its mass center, beyond the cone
  (``F > mu m g``), every corner slides along ``d``: the box translates at
  ``(F - mu m g) / m``; the loads ``lambda_k = m g / 4 + beta x_k + delta y_k`` with
  ``sum x_k lambda_k = (c / 2) mu m g d_x`` (pitch) and ``sum y_k lambda_k =
  (c / 2) mu m g d_y`` (roll), the friction ``-mu lambda_k d``; their moment about the
  vertical, ``-mu (d_y sum x_k lambda_k - d_x sum y_k lambda_k)``, is 0: it does not
  yaw, along an axis of the box or not;
- pushed below the cone it stays at rest, the loads as above with ``F`` for
  ``mu m g``, each corner holding ``F lambda_k / (m g)``: the same fraction of its cone;
- a block on two contacts with the same row: half its weight on each.
"""

from __future__ import annotations

import numpy as np
import pytest
import sympy as sp

from dalembert import System, Unilateral, coordinates
from dalembert.model.constraints import ClosedGaps
from dalembert.multibody import Force, Ground, Multibody, RigidBody, plane_contact
from dalembert.solvers.contact.friction import solve_sliding
from dalembert.solvers.contact.gaps import Gaps

g, mu = 9.81, 0.5
A, B, C, M = 0.2, 0.15, 0.1, 2.0
CORNERS = np.array([(sx * A / 2, sy * B / 2) for sx, sy in [(-1, -1), (1, -1), (1, 1), (-1, 1)]])
FX, FY = sp.symbols("Fx Fy")
TIMES = np.linspace(0.0, 0.3, 7)


def box_pushed_by(scale: sp.Expr | float) -> Multibody:
    """The box on its corners, pushed at its mass center by ``scale (Fx, Fy, 0)``."""
    inertia = M / 12 * np.diag([B**2 + C**2, A**2 + C**2, A**2 + B**2])
    body = RigidBody("box", M, inertia)
    corners = [plane_contact(f"c{k}", Ground(), body, point=(x, y, -C / 2), friction=mu)
               for k, (x, y) in enumerate(CORNERS)]
    return Multibody([body], gravity=(0, 0, -g), contacts=corners,
                     forces=[Force(body, (scale * FX, scale * FY, 0))])


@pytest.fixture(scope="module")
def box() -> Multibody:
    """Pushed by ``(Fx, Fy, 0)``."""
    return box_pushed_by(1)


def pushed(box: Multibody, force: float, angle: float):
    q0, qd0 = box.initial_state(positions={"box": (0, 0, C / 2)})
    traj = box.simulate((0.0, 0.3), q0, qd0, t_eval=TIMES, parameters={
        "Fx": force * np.cos(angle), "Fy": force * np.sin(angle)})
    assert traj.success, traj.message
    return traj


def loads(friction: float, d: np.ndarray) -> np.ndarray:
    """The four equal springs' loads with a floor friction ``friction`` against ``d``."""
    beta = C * friction * d[0] / (2 * A**2)   # sum x_k^2 = A^2
    delta = C * friction * d[1] / (2 * B**2)  # sum y_k^2 = B^2
    return M * g / 4 + beta * CORNERS[:, 0] + delta * CORNERS[:, 1]


def test_loads_share_the_weight_and_balance_the_friction_moments():
    d = np.array([np.cos(0.3), np.sin(0.3)])
    lam = loads(mu * M * g, d)
    assert abs(lam.sum() - M * g) < 1e-12
    assert abs(CORNERS[:, 0] @ lam - C / 2 * mu * M * g * d[0]) < 1e-12
    assert abs(CORNERS[:, 1] @ lam - C / 2 * mu * M * g * d[1]) < 1e-12


@pytest.mark.parametrize("angle", [0.0, 0.5])
def test_a_box_pushed_beyond_the_cone_slides_on_all_four_corners(box, angle):
    force = 15.0
    traj = pushed(box, force, angle)
    d = np.array([np.cos(angle), np.sin(angle)])
    s = (force - mu * M * g) / M * traj.t**2 / 2
    assert np.abs(traj["box_x"] - d[0] * s).max() < 1e-10
    assert np.abs(traj["box_y"] - d[1] * s).max() < 1e-10
    assert np.abs(traj["box_z"] - C / 2).max() < 1e-12
    for part in ("b1", "b2", "b3"):  # no roll, pitch or yaw
        assert np.abs(traj[f"box_{part}"]).max() < 1e-10
    lam = loads(mu * M * g, d)
    for k in range(4):  # from the start, at rest, on
        normal = traj.multiplier(f"c{k}_1")
        assert np.abs(normal - lam[k]).max() < 1e-10
        for j in (0, 1):  # sliding along d
            assert np.abs(traj.multiplier(f"c{k}_friction_{j + 1}")
                          + mu * normal * d[j]).max() < 1e-10


@pytest.fixture(scope="module")
def ramped() -> Multibody:
    """Pushed by ``(Fx t, Fy t, 0)``."""
    from dalembert import t as time

    return box_pushed_by(time)


@pytest.mark.parametrize("angle", [0.0, 0.5])
def test_a_box_pushed_by_a_growing_force_slips_on_all_four_corners_at_once(ramped, angle):
    """Pushed by ``k t``: at rest until ``k t = mu m g``, every corner on its cone at
    once, then sliding along the push with ``x'' = (k t - mu m g) / m`` (the corners'
    sliding velocities start from 0: their direction is their accelerations')."""
    rate = 40.0
    d = np.array([np.cos(angle), np.sin(angle)])
    q0, qd0 = ramped.initial_state(positions={"box": (0, 0, C / 2)})
    t = np.array([0.27, 0.3])
    traj = ramped.simulate((0.0, 0.3), q0, qd0, t_eval=t, timeout=120,
                           parameters={"Fx": rate * d[0], "Fy": rate * d[1]})
    assert traj.success, traj.message
    slip = mu * M * g / rate
    assert [s.t for s in traj.contacts.switches][1:] == pytest.approx([slip], abs=1e-12)
    s = rate / M * ((t**3 - slip**3) / 6 - slip**2 * (t - slip) / 2) - mu * g * (t - slip)**2 / 2
    assert np.abs(traj["box_x"] - d[0] * s).max() < 1e-10
    assert np.abs(traj["box_y"] - d[1] * s).max() < 1e-10
    for part in ("b1", "b2", "b3"):
        assert np.abs(traj[f"box_{part}"]).max() < 1e-10


@pytest.mark.parametrize("angle", [0.0, 0.5])
def test_a_box_pushed_below_the_cone_stays_each_corner_at_the_same_fraction(box, angle):
    force = 8.0
    traj = pushed(box, force, angle)
    assert [s.t for s in traj.contacts.switches] == [0.0]
    for part in ("x", "y", "b1", "b2", "b3"):
        assert np.abs(traj[f"box_{part}"]).max() < 1e-14
    d = np.array([np.cos(angle), np.sin(angle)])
    lam = loads(force, d)
    for k in range(4):
        normal = traj.multiplier(f"c{k}_1")
        assert np.abs(normal - lam[k]).max() < 1e-10
        for j in (0, 1):  # each holds F / (m g) of its load against the push
            assert np.abs(traj.multiplier(f"c{k}_friction_{j + 1}")
                          + force / (M * g) * lam[k] * d[j]).max() < 1e-10


def test_a_block_on_two_equal_contacts_loads_each_with_half_its_weight_sliding():
    """Two contacts with the same row (rank 1): the minimum-norm normal forces are
    ``g / 2`` each, whichever row the factorization keeps, and each sliding contact's
    friction is ``mu g / 2`` of them (the block decelerates at ``mu g``)."""
    x, y = coordinates("x y")
    both = System([x, y], kinetic=(x.diff()**2 + y.diff()**2) / 2, potential=g * y,
                  constraints=[Unilateral(y, name, friction=mu, tangents=[x.diff()])
                               for name in ("a", "b")])
    full = both._closed(ClosedGaps((0, 1), held=(0, 1))).numeric()
    gaps = Gaps.of(both.definition.unilateral, 0, [0.0, 0.0])
    qdd, lam = solve_sliding(full, gaps, 0.0, np.zeros(2), np.array([1.0, 0.0]),
                             ClosedGaps((0, 1), sliding=(0, 1)),
                             {0: np.ones(1), 1: np.ones(1)})
    assert np.abs(qdd - [-mu * g, 0.0]).max() < 1e-14
    assert np.abs(lam - [g / 2, g / 2, -mu * g / 2, -mu * g / 2]).max() < 1e-14
