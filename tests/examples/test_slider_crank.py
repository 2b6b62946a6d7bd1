"""The planar slider-crank (9 coordinates, 8 independent rows) against independent answers.

- Position: the piston's closed-form position ``x_B(th)`` at the simulated crank angle.
- Motion: the same mechanism in its one minimal coordinate, the crank angle ``th``:
  ``T = 1/2 J(th) th'^2`` with the link kinematics from the closed-form position
  analysis, Euler-Lagrange ``J th'' + 1/2 J' th'^2 + V' = 0``, derived here with
  SymPy and integrated with ``solve_ivp``.
- Joint reactions: every joint's force from ``joint_reactions`` against Newton's law
  for each body, with the accelerations from the closed form (SymPy) at the simulated
  crank motion: crank, rod and piston linear momentum and the crank's moment about
  ``O`` (5 equations, 5 unknowns: the pin forces at ``A`` and ``B`` and the guide's
  normal force ``N``). The example's own ``guide_force`` uses the rod's moment
  balance instead, so the two are different routes.
"""

from __future__ import annotations

import numpy as np
import pytest
import sympy as sp
from one_coordinate_reference import angle_history

from dalembert import cli
from dalembert.examples import slider_crank as example
from dalembert.multibody import energy, joint_reactions

pytestmark = pytest.mark.filterwarnings("error::dalembert.errors.InitialConditionsAdjusted")

T_END = 5.0  # about six crank turns
TIMES = np.linspace(0.0, T_END, 501)
G = example.G


@pytest.fixture(scope="module")
def mb():
    return example.build_multibody()


@pytest.fixture(scope="module")
def traj(mb):
    return mb.system.simulate((0.0, T_END), **example.INITIAL, t_eval=TIMES)


def test_one_degree_of_freedom_and_a_consistent_start(mb):
    report = mb.system.consistent_initial_state(**example.INITIAL)
    assert not report.changed  # the closed-form initial state is consistent
    assert report.dependent_constraints == []
    assert report.rank.rank == 8 and report.degrees_of_freedom == 1
    assert len(mb.system.coordinate_names) == 9


def test_piston_follows_the_closed_form(traj):
    assert traj.success
    assert example.piston_error(traj) < 1e-9  # measured 8.9e-15
    assert np.abs(traj["piston_y"] - example.GEOMETRY[2]).max() < 1e-12
    assert np.abs(traj["piston_theta"]).max() < 1e-12
    turns = (traj["crank_theta"][-1] - example.THETA_0) / (2 * np.pi)
    assert turns > 6  # the crank goes round, through both dead centers


def test_constraints_and_energy(mb, traj):
    assert traj.position_residual.max() <= 1e-12  # measured 4.9e-15
    assert traj.velocity_residual.max() <= 1e-12  # measured 2.7e-15
    e = energy(mb, traj)  # evaluated from the bodies, not the model
    assert np.abs(e - e[0]).max() / abs(e[0]) < 1e-9  # measured 2.9e-11


def closed_form():
    """SymPy: the crank angle, the link centers, the rod angle and ``B`` as functions of it."""
    a, b, e = example.GEOMETRY
    th = sp.Symbol("th")
    phi = sp.asin((e - a * sp.sin(th)) / b)
    pin_a = a * sp.Matrix([sp.cos(th), sp.sin(th)])
    rod = b * sp.Matrix([sp.cos(phi), sp.sin(phi)])
    return th, phi, {"crank": pin_a / 2, "rod": pin_a + rod / 2, "piston": pin_a + rod}


def minimal_reference(times: np.ndarray) -> np.ndarray:
    """Crank angle from the one-coordinate Lagrangian (see the module docstring)."""
    a, b, _ = example.GEOMETRY
    th, phi, centers = closed_form()
    masses = {"crank": example.DENSITY * a, "rod": example.DENSITY * b,
              "piston": example.PISTON_MASS}
    moments = {"crank": example.DENSITY * a**3 / 12, "rod": example.DENSITY * b**3 / 12}
    angles = {"crank": th, "rod": phi}
    J, V = sp.S.Zero, sp.S.Zero
    for name, center in centers.items():
        v = center.diff(th)
        J += masses[name] * v.dot(v)
        if name in angles:
            J += moments[name] * angles[name].diff(th) ** 2
        V += masses[name] * G * center[1]
    return angle_history(J, V, th, example.THETA_0, example.OMEGA_0, times)


@pytest.mark.validation
def test_crank_motion_matches_minimal_coordinates(traj):
    gap = np.abs(traj["crank_theta"] - minimal_reference(TIMES)).max()
    assert gap < 1e-7  # measured 1.8e-10


def newton_euler_forces(traj) -> dict[str, np.ndarray]:
    """Each joint's force on its moving body from Newton's law, per output time.

    Unknowns: ``F_A`` (crank on rod), ``F_B`` (piston on rod), ``N`` (guide on piston);
    equations: the crank's moment about ``O``, the rod's and the piston's momentum.
    """
    a, b, _ = example.GEOMETRY
    th, _, centers = closed_form()
    w, al = sp.symbols("w al")
    # a center's acceleration: c'' = c_th th'' + c_thth th'^2
    acc = {k: sp.lambdify((th, w, al), c.diff(th) * al + c.diff(th, 2) * w**2, cse=True)
           for k, c in centers.items()}
    m_c, m_r, m_p = example.DENSITY * a, example.DENSITY * b, example.PISTON_MASS
    inertia_o = m_c * a**2 / 3
    gravity = np.array([0.0, -G])
    out = {k: np.zeros((len(traj), 2)) for k in ("J1", "J2", "J3", "guide")}
    for i, (t, wt, at) in enumerate(zip(traj["crank_theta"], traj["crank_theta_dot"],
                                        traj["crank_theta_ddot"])):
        a_c, a_r, a_p = (np.ravel(acc[k](t, wt, at)) for k in ("crank", "rod", "piston"))
        pin = a * np.array([np.cos(t), np.sin(t)])
        # unknowns x = (F_Ax, F_Ay, F_Bx, F_By, N)
        lhs = np.array([
            [pin[1], -pin[0], 0, 0, 0],  # crank about O: A x (-F_A) + moment of weight
            [1, 0, 1, 0, 0], [0, 1, 0, 1, 0],  # rod: F_A + F_B + m_r g = m_r a_r
            [0, 0, -1, 0, 0], [0, 0, 0, -1, 1],  # piston: -F_B + N y + m_p g = m_p a_p
        ])
        rhs = np.array([
            inertia_o * at + m_c * G * pin[0] / 2,  # (A / 2) x m_c g = -m_c g A_x / 2
            *(m_r * (a_r - gravity)), *(m_p * (a_p - gravity)),
        ])
        fa_x, fa_y, fb_x, fb_y, normal = np.linalg.solve(lhs, rhs)
        f_a = np.array([fa_x, fa_y])
        out["J1"][i] = m_c * (a_c - gravity) + f_a  # ground on crank: F + (-F_A) + m_c g
        out["J2"][i] = f_a
        out["J3"][i] = -np.array([fb_x, fb_y])
        out["guide"][i] = [0.0, normal]
    return out


@pytest.mark.validation
def test_joint_reactions_follow_newtons_law(mb, traj):
    reactions = joint_reactions(mb, traj)
    expected = newton_euler_forces(traj)
    scale = np.abs(expected["guide"]).max()
    body = {"J1": "crank", "J2": "rod", "J3": "piston", "guide": "piston"}
    for joint, force in expected.items():
        got = reactions[joint][body[joint]].force_world
        assert np.abs(got[:, :2] - force).max() < 1e-9 * scale, joint  # measured 2.3e-13
        assert np.abs(got[:, 2]).max() == 0.0
    # the example's check (the rod's moment balance) agrees with this route
    assert np.abs(example.guide_force(mb, traj) - expected["guide"][:, 1]).max() < 1e-9 * scale


def test_guide_force_check_can_fail(traj):
    # the same motion read with a heavier piston: the guide force must disagree
    heavier = example.build_multibody(piston_mass=2 * example.PISTON_MASS)
    reference = example.guide_force(example.build_multibody(), traj)
    assert np.abs(example.guide_force(heavier, traj) - reference).max() > 1.0


def test_checks_contract(mb, traj):
    errors = example.checks(mb.system, traj)
    assert max(errors.values()) < 1e-9


def test_cli_runs_and_draws_it(tmp_path, capsys):
    out = tmp_path / "run"
    assert cli.main(["run", "slider-crank", "--t-end", "0.5", "--points", "11",
                     "--out", str(out)]) == 0
    printed = capsys.readouterr().out
    assert "animation: the example's draw(system, q)" in printed
    assert "guide force relative error (Newton-Euler)" in printed
    assert (out / "animation.gif").stat().st_size > 0
