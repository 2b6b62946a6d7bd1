"""Clarabel (through qpsolvers) against dalembert's exact LCP solver on contact LCPs.

The complementarity problems the contact laws solve, ``0 <= P  _|_  w = W P + q >= 0``
with ``W`` symmetric positive definite, are the optimality conditions of the QP
``min 1/2 P^T W P + q^T P`` over ``P >= 0``, so an interior-point QP solver (Clarabel)
solves them too. Measured on:

- Newton's cradle of 3 and 5 unit balls, the first at speed 1, every contact in one
  LCP (the simultaneous law, ``e = 1``): ``W`` the contacts' Delassus matrix
  ``A M^-1 A^T`` (tridiagonal ``[-1, 2, -1]``), ``q = U- + e min(U-, 0)`` with ``U-``
  the gaps' rates before. Closed form for 3 balls: the velocities after are
  ``[-1/3, 2/3, 2/3]``.
- A uniform bar landing flat on two contacts at its ends at speed 1 (``e = 0.5``):
  ``W = [[4, -2], [-2, 4]] / m``; closed form: each impulse ``m (1 + e) / 2``.
- Random well-conditioned SPD LCPs of sizes 2 to 64 (``W = B B^T / n + I``, ``q`` normal).
- The Delassus LCPs of the falling 16-link chain's Moreau-Jean steps (captured from
  the run by wrapping :func:`~dalembert.solvers.contact.impulses.solve_lcp`).

For each: the natural residual ``max |min(P, W P + q)|`` (0 at a solution), the
difference to the exact solution (``solve_lcp``, principal pivoting, checked against the
closed forms and by its own residual), and the time of one solve (the best of a few
repeats; CPU). Usage: ``python bench/lcp.py`` prints the record; ``bench/contact.py``
stores it in its JSON under ``lcp``.
"""

from __future__ import annotations

import json
import time

import numpy as np

#: Clarabel's settings tried: its defaults, and tolerances tightened to 1e-12.
CLARABEL_SETTINGS = {"default": {},
                     "tight": {"tol_gap_abs": 1e-12, "tol_gap_rel": 1e-12,
                               "tol_feas": 1e-12, "tol_ktratio": 1e-10}}
REPEATS = 5


def residual(W: np.ndarray, q: np.ndarray, P: np.ndarray) -> float:
    """The natural residual ``max |min(P, W P + q)|`` (relative to ``1 + max |q|``)."""
    return float(np.abs(np.minimum(P, W @ P + q)).max() / (1.0 + np.abs(q).max()))


def cradle(balls: int, e: float = 1.0) -> tuple[np.ndarray, np.ndarray]:
    """Newton's cradle's simultaneous-law LCP: unit masses, ball 0 at speed 1."""
    k = balls - 1
    A = np.zeros((k, balls))  # each contact's gap rate: v[i + 1] - v[i]
    A[np.arange(k), np.arange(k)], A[np.arange(k), np.arange(k) + 1] = -1.0, 1.0
    v = np.zeros(balls)
    v[0] = 1.0
    U = A @ v
    return A @ A.T, U + e * np.minimum(U, 0.0)


def bar(m: float = 2.0, e: float = 0.5) -> tuple[np.ndarray, np.ndarray]:
    """A uniform bar landing flat on two end contacts at speed 1."""
    W = np.array([[4.0, -2.0], [-2.0, 4.0]]) / m
    return W, (1 + e) * np.full(2, -1.0)


def random_lcp(n: int, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    B = rng.standard_normal((n, n))
    return B @ B.T / n + np.eye(n), rng.standard_normal(n)


def chain_lcps(step: float = 2e-3, keep: int = 40) -> list[tuple[np.ndarray, np.ndarray]]:
    """The Delassus LCPs of the falling chain's time steps (``keep`` of them, spread
    over the run, the largest first)."""
    import contact  # the chain as the contact benchmark builds it

    from dalembert.solvers.contact import impulses

    captured: list[tuple[np.ndarray, np.ndarray]] = []
    original = impulses.solve_lcp

    def capture(W: np.ndarray, q: np.ndarray) -> np.ndarray:
        captured.append((W.copy(), q.copy()))
        return original(W, q)

    _, simulate = contact.dalembert_chain()
    impulses.solve_lcp = capture
    try:
        simulate(step)
    finally:
        impulses.solve_lcp = original
    sizes = np.array([len(q) for _, q in captured])
    order = np.argsort(-sizes, kind="stable")
    chosen = sorted(order[:: max(1, len(order) // keep)][:keep])
    return [captured[i] for i in chosen]


def best_time(solve, W: np.ndarray, q: np.ndarray) -> tuple[np.ndarray, float]:
    times = []
    for _ in range(REPEATS):
        start = time.process_time()
        P = solve(W, q)
        times.append(time.process_time() - start)
    return P, min(times)


def compare(W: np.ndarray, q: np.ndarray) -> dict:
    """Both solvers on one LCP: residuals, difference, CPU seconds."""
    import qpsolvers

    from dalembert.solvers.contact.impulses import solve_lcp

    exact, exact_s = best_time(solve_lcp, W, q)
    out = {"size": len(q), "exact_residual": residual(W, q, exact), "exact_s": exact_s}
    for name, settings in CLARABEL_SETTINGS.items():
        def clarabel(W: np.ndarray, q: np.ndarray, settings: dict = settings) -> np.ndarray:
            x = qpsolvers.solve_qp(W, q, lb=np.zeros(len(q)), solver="clarabel",
                                   verbose=False, **settings)
            return np.full(len(q), np.nan) if x is None else x

        P, seconds = best_time(clarabel, W, q)
        out[f"clarabel_{name}_residual"] = residual(W, q, P)
        out[f"clarabel_{name}_difference"] = float(
            np.abs(P - exact).max() / (1.0 + np.abs(exact).max()))
        out[f"clarabel_{name}_s"] = seconds
    return out


def summary(rows: list[dict]) -> dict:
    """The worst accuracy and the median time over a family of LCPs."""
    keys = [k for k in rows[0] if k != "size"]
    return {"count": len(rows), "sizes": [min(r["size"] for r in rows),
                                          max(r["size"] for r in rows)],
            **{k: (float(np.median([r[k] for r in rows])) if k.endswith("_s")
                   else float(max(r[k] for r in rows))) for k in keys}}


def run(chain_step: float = 2e-3) -> dict:
    """Every family: its cases' records and a summary (worst accuracy, median time)."""
    from dalembert.solvers.contact.impulses import solve_lcp

    record: dict = {"clarabel_settings": CLARABEL_SETTINGS}
    checks = {}
    W, q = cradle(3)
    P = solve_lcp(W, q)
    A = np.array([[-1.0, 1.0, 0.0], [0.0, -1.0, 1.0]])
    checks["cradle3_velocities_error"] = float(
        np.abs(np.array([1.0, 0.0, 0.0]) + A.T @ P - [-1 / 3, 2 / 3, 2 / 3]).max())
    W, q = bar()
    checks["bar_impulse_error"] = float(np.abs(solve_lcp(W, q) - 2.0 * 1.5 / 2).max())
    record["closed_form_checks"] = checks
    rng = np.random.default_rng(1)
    families = {"cradle_3": [cradle(3)], "cradle_5": [cradle(5)], "bar_two_contacts": [bar()],
                "random_spd": [random_lcp(n, rng) for n in (2, 4, 8, 16, 32, 64)],
                "chain_delassus": chain_lcps(chain_step)}
    for name, problems in families.items():
        rows = [compare(W, q) for W, q in problems]
        record[name] = rows if len(rows) <= 6 else summary(rows)
        if name == "random_spd":
            record[name] = {"cases": rows, "summary": summary(rows)}
    return record


if __name__ == "__main__":
    print(json.dumps(run(), indent=1, default=float))
