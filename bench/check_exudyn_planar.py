"""Check Exudyn's planar (2D-body) chain against independent references.

- n = 1, a compound pendulum: the link's angle and angular velocity at ``T_CHECK``
  against ``solve_ivp`` of ``theta'' = -(M G L/2) sin(theta) / (I + M (L/2)^2)`` at
  tight tolerances, for each step of the peer's ladder (generalized-alpha is second
  order: the error must fall about 4x per halving);
- n = 4: the tip (bottom of the last link) at ``T_END`` and the energy error against
  Exudyn's chain of 3D bodies (Euler parameters) with hinge joints about ``y``, the
  same physics in other coordinates (its x-z plane mirrored onto the 2D chain's x-y
  plane: x -> -x, z -> y), at each step of the ladder.

Exits non-zero when a check fails. ``--time N ...`` also runs the peer's ladder
(as the suite does) on both body kinds and prints the seconds.

Usage: ``python bench/check_exudyn_planar.py [--time 4 16 64]``.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np
from scipy.integrate import solve_ivp

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from bench.peers import exudyn as ex
from bench.peers.common import ANGLE, I_T, T_END, G, L, M, energy_error, initial_energy

T_CHECK = 1.0
#: Largest tip mismatch between 2D and 3D bodies at the ladder's coarsest step
#: (measured: 2.4e-5 at 1e-2, falling 4x per halving).
TIP_TOL = 1e-4
#: Largest pendulum angle error at the ladder's finest step (rad; measured: 2.7e-6).
ANGLE_TOL = 1e-5


def pendulum_reference(t: float) -> np.ndarray:
    """``(theta, theta')`` of the compound pendulum at ``t``, from rest at ``ANGLE``."""
    k = M * G * L / 2 / (I_T + M * (L / 2) ** 2)
    sol = solve_ivp(lambda _t, y: [y[1], -k * np.sin(y[0])], (0.0, t), [ANGLE, 0.0],
                    method="DOP853", rtol=1e-13, atol=1e-14)
    return sol.y[:, -1]


def pendulum_state(mbs, body) -> np.ndarray:
    """``(theta, theta')`` of a 2D body: its rotation coordinate and angular velocity."""
    import exudyn as exu

    node = mbs.GetObject(body)["nodeNumber"]
    q = mbs.GetNodeOutput(node, exu.OutputVariableType.Coordinates)
    qd = mbs.GetNodeOutput(node, exu.OutputVariableType.Coordinates_t)
    return np.array([q[2] + mbs.GetNode(node)["referenceCoordinates"][2], qd[2]])


def tip(mbs, bodies) -> np.ndarray:
    """The chain's free end in the 2D chain's plane coordinates (x, up)."""
    p = ex._outputs(mbs, bodies[-1], "Position", ex.axis_end(mbs, bodies, -1.0))
    return p[:2] if ex.planar(mbs, bodies) else np.array([-p[0], p[2]])


def check_pendulum() -> bool:
    reference = pendulum_reference(T_CHECK)
    print(f"n = 1 at t = {T_CHECK} s: reference theta {reference[0]:.12f}, "
          f"theta' {reference[1]:.12f}")
    errors = []
    for h in ex.STEPS:
        mbs, bodies, ok, _, _ = ex.simulate("revolute", 1, h, t_end=T_CHECK)
        error = np.abs(pendulum_state(mbs, bodies[0]) - reference)
        errors.append(error[0])
        print(f"  step {h:.5f}: |d theta| {error[0]:.2e}, |d theta'| {error[1]:.2e}, "
              f"finished {ok}")
    rates = np.array(errors[:-1]) / np.array(errors[1:])
    print(f"  error ratio per halving: {np.round(rates, 2).tolist()}")
    return bool(errors[-1] <= ANGLE_TOL and np.all((rates > 3.5) & (rates < 4.5)))


def check_chain(n: int = 4) -> bool:
    e0 = initial_energy(n, "revolute")
    print(f"n = {n} at t = {T_END} s: 2D bodies against 3D bodies (hinges about y)")
    good = True
    for h in ex.STEPS:
        ends = []
        for builder in (ex.build_2d, ex.build_3d):  # from the same energy as the closed form
            _, mbs, bodies = builder("revolute", n)[0]
            good &= bool(np.isclose(ex.energy(mbs, bodies), e0, rtol=1e-14, atol=0.0))
            mbs, bodies, ok, seconds, _ = ex.simulate("revolute", n, h, builder)
            ends.append((tip(mbs, bodies), energy_error(e0, ex.energy(mbs, bodies), n),
                         ex.residual(mbs, bodies, "revolute"), seconds, ok))
        (tip2, err2, res2, s2, ok2), (tip3, err3, res3, s3, ok3) = ends
        gap = float(np.abs(tip2 - tip3).max())
        print(f"  step {h:.5f}: tip 2D {np.round(tip2, 8).tolist()} 3D "
              f"{np.round(tip3, 8).tolist()} |d| {gap:.1e}; energy error {err2:.3e} / "
              f"{err3:.3e}; residual {res2:.0e} / {res3:.0e}; {s2:.3f} / {s3:.3f} s")
        good &= ok2 and ok3 and gap <= TIP_TOL
    return good


def timings(sizes: list[int]) -> None:
    print("step as in the suite (bisected to 5%; simulate_s: the kept step's run):")
    for n in sizes:
        for name, builder in (("2D", ex.build_2d), ("3D", ex.build_3d)):
            r = ex.run("revolute", n, builder)
            print(f"  n = {n:3} {name}: simulate {r['simulate_s']:.3f} s "
                  f"({len(r['attempts'])} attempts), "
                  f"step {r['setting']['step']:g}, energy error {r['energy_error']:.2e}, "
                  f"residual {r['residual']:.0e}, build {r['build_s']:.4f} s")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--time", type=int, nargs="*", metavar="N",
                        help="also time the ladder on both body kinds at these n")
    args = parser.parse_args()
    good = check_pendulum() & check_chain()
    if args.time:
        timings(args.time)
    print("all checks passed" if good else "CHECK FAILED")
    sys.exit(0 if good else 1)


if __name__ == "__main__":
    main()
