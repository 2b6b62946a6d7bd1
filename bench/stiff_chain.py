"""The stiff planar chain of ``bench/stiff.py``: its data, its damping, its reference.

The suite's planar chain (``bench/peers/common.py``: ``N`` uniform solid cylinders,
1 kg, 1 m, r = 5 cm, hung from a fixed pin, every link tilted 30 degrees, at rest) with
a torsional spring of stiffness ``k`` and a damper ``c`` on each of joints 2..N (joint
1, the pin to the ground, is free). The springs' rest angle is the relative angle 0:
the chain straight, which is also the relative angle at the start (all links share
the tilt), so the two readings of "rest angle" coincide.

**Reference.** The same chain in minimal coordinates, the absolute angles ``phi_i``
of the links from the downward vertical (link ``i``'s center at
``sum_{j<i} L e(phi_j) + L/2 e(phi_i)``, ``e(phi) = (sin phi, -cos phi)``), written
out here from the Lagrangian and not from any tool's equations: with
``W[k, j] = L`` for ``j < k``, ``L/2`` for ``j = k`` (0 above), ``A = m W^T W``,
``b = m W^T 1``,

    sum_j (A_ij cos(phi_i - phi_j) + I delta_ij) phi_j'' + sum_j A_ij sin(phi_i - phi_j) phi_j'^2
        = -g b_i sin(phi_i) - k (S phi)_i - c (S phi')_i,

``S = D^T D``, ``D`` the (N-1) x N difference matrix of the relative angles
``phi_i - phi_{i-1}`` (i >= 2). It is integrated with SciPy's DOP853 at rtol 1e-12 and checked
at 1e-10 (:data:`REFERENCE_RUNS`; the difference is recorded).

**Damping.** ``c`` is chosen so that the fastest mode of the chain linearized about
hanging straight down (the springs' rest configuration and the chain's equilibrium)
has damping ratio ``ZETA = 0.05``: the linearized equations are
``M0 x'' + c S x' + (k S + G0) x = 0``, ``M0 = A + I 1`` (the cosines 1),
``G0 = g diag(b)``; the eigenvalues ``lambda`` of the first-order form
``[[0, 1], [-M0^-1 K, -M0^-1 c S]]`` are computed and ``c`` is found (Brent's method)
so that the one of largest modulus has ``-Re lambda / |lambda| = ZETA``
(:func:`damping_for`), starting from the modal estimate
``c = 2 ZETA w v^T M0 v / v^T S v`` of the undamped fastest mode ``(w, v)``.
"""

from __future__ import annotations

import numpy as np
from scipy.integrate import solve_ivp
from scipy.linalg import eig, eigh
from scipy.optimize import brentq

N = 16
M, L, R, G = 1.0, 1.0, 0.05, 9.81
I_C = M * (3 * R**2 + L**2) / 12
ANGLE = np.radians(30.0)
T_END = 10.0
ZETA = 0.05
STIFFNESSES = (1e2, 1e4, 1e6, 1e8)


def chain_matrices(n: int = N) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(A, b, S)`` of the module docstring."""
    W = np.tril(np.full((n, n), L), -1) + np.diag(np.full(n, L / 2))
    A = M * W.T @ W
    b = M * W.sum(axis=0)
    D = np.zeros((n - 1, n))
    D[np.arange(n - 1), np.arange(1, n)] = 1.0
    D[np.arange(n - 1), np.arange(n - 1)] = -1.0
    return A, b, D.T @ D


def linearized(k: float, n: int = N) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(M0, K, S)`` about hanging straight down: ``M0 x'' + c S x' + K x = 0``."""
    A, b, S = chain_matrices(n)
    return A + I_C * np.eye(n), k * S + G * np.diag(b), S


def fastest_mode(k: float, n: int = N) -> tuple[float, np.ndarray]:
    """The undamped linearized chain's highest angular frequency and its mode."""
    M0, K, _ = linearized(k, n)
    w2, V = eigh(K, M0)
    return float(np.sqrt(w2[-1])), V[:, -1]


def fastest_damping_ratio(k: float, c: float, n: int = N) -> float:
    """``-Re lambda / |lambda|`` of the damped linearized chain's eigenvalue of largest modulus."""
    M0, K, S = linearized(k, n)
    Minv = np.linalg.inv(M0)
    top = np.hstack([np.zeros((n, n)), np.eye(n)])
    bottom = np.hstack([-Minv @ K, -c * Minv @ S])
    lam = eig(np.vstack([top, bottom]), right=False)
    fast = lam[np.argmax(np.abs(lam))]
    return float(-fast.real / abs(fast))


def damping_for(k: float, zeta: float = ZETA, n: int = N) -> dict:
    """The damper ``c`` giving the fastest mode the damping ratio ``zeta``, with the
    undamped fastest frequency and the modal estimate it started from."""
    M0, _, S = linearized(k, n)
    w, v = fastest_mode(k, n)
    estimate = 2 * zeta * w * (v @ M0 @ v) / (v @ S @ v)
    c = brentq(lambda c: fastest_damping_ratio(k, c, n) - zeta, estimate / 4, estimate * 4,
               xtol=1e-14 * estimate, rtol=1e-12)
    return {"k": k, "c": float(c), "c_modal_estimate": float(estimate),
            "fastest_omega": w, "fastest_damping_ratio": fastest_damping_ratio(k, c, n)}


def rhs_factory(k: float, c: float, n: int = N):
    """``f(t, y)``, ``y = [phi, phi']``, and its count of calls."""
    A, b, S = chain_matrices(n)
    calls = [0]

    def f(t: float, y: np.ndarray) -> np.ndarray:
        calls[0] += 1
        phi, w = y[:n], y[n:]
        d = phi[:, None] - phi[None, :]
        mass = A * np.cos(d) + I_C * np.eye(n)
        force = (-(A * np.sin(d)) @ (w * w) - G * b * np.sin(phi) - k * (S @ phi)
                 - c * (S @ w))
        return np.concatenate([w, np.linalg.solve(mass, force)])

    return f, calls


def initial(n: int = N) -> np.ndarray:
    """Every link tilted ``ANGLE``, at rest."""
    return np.concatenate([np.full(n, ANGLE), np.zeros(n)])


def energy(y: np.ndarray, k: float, n: int = N) -> float:
    """``T + V`` (gravity and springs) of a state ``[phi, phi']``."""
    A, b, S = chain_matrices(n)
    phi, w = y[:n], y[n:]
    mass = A * np.cos(phi[:, None] - phi[None, :]) + I_C * np.eye(n)
    return float(0.5 * w @ mass @ w - G * b @ np.cos(phi) + 0.5 * k * phi @ S @ phi)


def reference_key(k: float, n: int = N) -> str:
    """A reference's key in ``stiff_reference.json``: ``"1e+06"``, ``"1e+06 n=64"``."""
    return f"{k:g}" if n == N else f"{k:g} n={n}"


def reference(k: float, method: str = "Radau", rtol: float = 1e-12, atol: float = 1e-13,
              n: int = N) -> dict:
    """The absolute angles at ``T_END`` (and the run's statistics), minimal coordinates."""
    c = damping_for(k, n=n)["c"]
    f, calls = rhs_factory(k, c, n)
    sol = solve_ivp(f, (0.0, T_END), initial(n), method=method, rtol=rtol, atol=atol)
    if not sol.success:
        raise RuntimeError(f"reference k={k:g} {method}: {sol.message}")
    return {"k": k, "c": c, "method": method, "rtol": rtol, "atol": atol,
            "phi": sol.y[:n, -1].tolist(), "phidot": sol.y[n:, -1].tolist(),
            "nfev": calls[0], "steps": int(sol.t.size - 1)}


#: The reference's two runs: the kept one and the check at a 100x looser tolerance.
#: DOP853, not Radau: SciPy's Radau (a Newton iteration in Python, a difference Jacobian)
#: took 40-250 s of CPU at 1e-11 to 1e-12 for k <= 1e6, DOP853 seconds; Radau at rtol
#: 1e-11 and DOP853 at 1e-11 agree to 3e-12 rad at k = 1e2 and 1e-12 at k = 1e4.
REFERENCE_RUNS = (("DOP853", 1e-12, 1e-13), ("DOP853", 1e-10, 1e-11))
#: At k >= 1e8 DOP853's steps are held to its stability limit (w_max h about 5.5) and
#: rtol 1e-12 took over 15 min of CPU: rtol 1e-10, checked at 1e-9 (2.8 min each).
STIFFEST_RUNS = (("DOP853", 1e-10, 1e-11), ("DOP853", 1e-9, 1e-10))


def main() -> None:
    """Compute the reference at every stiffness (both runs) into ``stiff_reference.json``."""
    import argparse
    import json
    import time
    from pathlib import Path

    parser = argparse.ArgumentParser(description=main.__doc__)
    parser.add_argument("--k", type=float, nargs="+", default=list(STIFFNESSES))
    parser.add_argument("--n", type=int, default=N, help="links of the chain")
    parser.add_argument("--out", type=Path,
                        default=Path(__file__).parent / "results" / "stiff_reference.json")
    args = parser.parse_args()
    out = json.loads(args.out.read_text()) if args.out.exists() else {}
    for k in args.k:
        runs = []
        for method, rtol, atol in (STIFFEST_RUNS if k >= 1e8 else REFERENCE_RUNS):
            start = time.process_time()
            run = reference(k, method, rtol, atol, n=args.n)
            run["cpu_s"] = time.process_time() - start
            runs.append(run)
            print(f"k={k:g} {method} rtol={rtol:g}: {run['cpu_s']:.1f} s CPU, "
                  f"{run['nfev']} evaluations", flush=True)
        spread = float(np.max(np.abs(np.subtract(runs[0]["phi"], runs[1]["phi"]))))
        out[reference_key(k, args.n)] = {"k": k, "links": args.n, **damping_for(k, n=args.n),
                                         "phi": runs[0]["phi"],
                         "check_max_angle_difference": spread, "runs": runs}
        args.out.parent.mkdir(parents=True, exist_ok=True)
        args.out.write_text(json.dumps(out, indent=1) + "\n")
        print(f"k={k:g}: the two runs differ by {spread:.2e} rad at most", flush=True)


if __name__ == "__main__":
    main()
