"""The README's Monte Carlo: where the tip of a 16-link chain goes when its link masses
are uncertain (1,000 cases, 10 s), as quantile bands over time.

Usage: ``python bench/ensemble_example.py [--cases N]`` writes
``bench/results/ensemble_tip_band.png``; ``--client ADDRESS`` runs the cases on the
Dask scheduler at that address instead of a local cluster.
"""

import argparse
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
import sympy as sp
from scipy import stats

from dalembert.ensemble import sample
from dalembert.multibody import Ground, Multibody, RigidBody, Spherical, point_positions

L, R, N = 1.0, 0.05, 16
masses = sp.symbols(f"m1:{N + 1}", positive=True)  # one mass parameter per link
links = [RigidBody(f"link{k + 1}", m, (m * (3 * R**2 + L**2) / 12,) * 2 + (m * R**2 / 2,))
         for k, m in enumerate(masses)]
joints = [Spherical(f"joint{k + 1}", a, b, (0, 0, 0) if k == 0 else (0, 0, -L / 2), (0, 0, L / 2))
          for k, (a, b) in enumerate(zip([Ground(), *links[:-1]], links))]
chain = Multibody(links, joints, parameters=dict.fromkeys(masses, 1.0))

# every link tilted 30 degrees about y, the chain turning at 0.2 rad/s about x
c, s = np.cos(np.radians(30)), np.sin(np.radians(30))
tilt, w = np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]]), np.array([0.2, 0, 0])
centers = {b.name: (k + 0.5) * tilt @ [0, 0, -L] for k, b in enumerate(links)}
q0, qd0 = chain.initial_state(
    positions=centers, orientations=dict.fromkeys(centers, tilt),
    velocities={k: np.cross(w, x) for k, x in centers.items()},
    angular_velocities=dict.fromkeys(centers, w))


def tip(axis):
    """An output: the world coordinate ``axis`` of the last link's free end."""
    def output(system, traj):
        return point_positions(chain, traj, "link16", (0, 0, -L / 2))[:, axis]
    return output


if __name__ == "__main__":  # Dask's worker processes import this script
    parser = argparse.ArgumentParser()
    parser.add_argument("--cases", type=int, default=1000)
    parser.add_argument("--client", help="a Dask scheduler's address (default: local)")
    args = parser.parse_args()
    client = None
    if args.client:
        from distributed import Client

        client = Client(args.client)
    cases = sample({f"m{k + 1}": stats.uniform(0.8, 0.4) for k in range(N)}, args.cases,
                   seed=1)  # each link 0.8 .. 1.2 kg
    result = chain.system.simulate_many(
        (0, 10), cases, q0=q0, qd0=qd0, rtol=3e-4, atol=3e-6, client=client,
        outputs={"tip_x": tip(0), "tip_z": tip(2)}, keep=("energy",))
    print(result)
    print(result.summary[["status", "energy_error", "seconds"]].describe())

    q = [0.05, 0.25, 0.5, 0.75, 0.95]
    for name in ("tip_x", "tip_z"):  # the spread where the run ends
        end = result.quantile(name, q)[:, -1].values
        print(f"{name} at t = 10 s: " + ", ".join(f"{int(100 * k)}% {v:.3f} m"
                                                  for k, v in zip(q, end)))
    fig, axes = plt.subplots(2, 1, figsize=(8, 5.5), sharex=True)
    for ax, name in zip(axes, ("tip_x", "tip_z")):
        band = result.quantile(name, q)
        t = band["time"].values
        ax.fill_between(t, band[0], band[4], alpha=0.25, color="C0", label="5-95%")
        ax.fill_between(t, band[1], band[3], alpha=0.45, color="C0", label="25-75%")
        ax.plot(t, band[2], color="C0", lw=1.2, label="median")
        ax.plot(t, result.dataset[name][0], color="k", lw=0.6, alpha=0.6, label="case 0")
        ax.set_ylabel(f"{name.replace('_', ' ')} (m)")
    axes[0].legend(loc="lower left", ncols=4, fontsize=8)
    axes[0].set_title(f"16-link chain, link masses uniform in 0.8..1.2 kg: "
                      f"{len(cases)} cases")
    axes[1].set_xlabel("t (s)")
    fig.tight_layout()
    out = Path(__file__).resolve().parent / "results" / "ensemble_tip_band.png"
    fig.savefig(out, dpi=110)
    print(f"wrote {out}")
