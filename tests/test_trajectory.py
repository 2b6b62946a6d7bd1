"""Trajectory: access by name, save/load round trip, atomic writing, DataFrame."""

from __future__ import annotations

import numpy as np
import pytest
import sympy as sp

from dalembert import Holonomic, System, Trajectory, coordinates, t

x, y = coordinates("x y")
m, g, l = sp.symbols("m g l", positive=True)


@pytest.fixture(scope="module")
def traj() -> Trajectory:
    system = System([x, y], kinetic=m / 2 * (x.diff() ** 2 + y.diff() ** 2), potential=m * g * y,
                    constraints=[Holonomic(x**2 + y**2 - l**2, name="rod")],
                    parameters={m: 1.0, g: 9.81, l: 1.0})

    def bottom(t_, q, qd):
        return q[0]

    return system.simulate((0, 2), q0=[1.0, 0.0], events=[bottom])


def test_access_by_name_and_symbol(traj):
    assert np.array_equal(traj["x"], traj.q[:, 0]) and np.array_equal(traj[x], traj.q[:, 0])
    assert np.array_equal(traj["y_dot"], traj.qd[:, 1])
    assert np.array_equal(traj[y.diff()], traj.qd[:, 1])
    assert np.array_equal(traj["x_ddot"], traj.qdd[:, 0])
    assert np.array_equal(traj[x.diff(t, 2)], traj.qdd[:, 0])
    assert np.array_equal(traj[sp.Symbol("y")], traj.q[:, 1])
    assert np.array_equal(traj.multiplier("rod"), traj.multipliers[:, 0])


@pytest.mark.parametrize("key", ["z", "x_dott", "_dot", "", "xdot", "rod"])
def test_unknown_names(traj, key):
    with pytest.raises(KeyError, match="is not a coordinate; the coordinates are x, y"):
        traj[key]


def test_unknown_multiplier(traj):
    with pytest.raises(KeyError, match="'x' is not a constraint; the constraints are rod"):
        traj.multiplier("x")


def plain(names: tuple[str, ...], n_t: int = 3) -> Trajectory:
    n = len(names)
    rng = np.random.default_rng(0)
    arrays = {k: rng.normal(size=(n_t, n)) for k in ("q", "qd", "qdd", "constraint_forces")}
    scalars = {k: rng.normal(size=n_t) for k in (
        "kinetic_energy", "potential_energy", "jacobi_integral", "position_residual",
        "velocity_residual")}
    return Trajectory(t=np.arange(n_t, dtype=float), multipliers=np.empty((n_t, 0)), **arrays,
                      **scalars, coordinate_names=names, constraint_names=())


def test_exact_coordinate_name_wins_over_a_suffix():
    tr = plain(("u", "u_dot"))
    assert np.array_equal(tr["u_dot"], tr.q[:, 1])  # the coordinate called u_dot
    assert np.array_equal(tr["u_dot_dot"], tr.qd[:, 1])
    assert np.array_equal(tr["u_ddot"], tr.qdd[:, 0])


def test_names_with_underscores():
    tr = plain(("theta_1", "d"))
    assert np.array_equal(tr["theta_1_dot"], tr.qd[:, 0])
    assert np.array_equal(tr["d_ddot"], tr.qdd[:, 1])
    assert tr.multipliers.shape == (3, 0)
    with pytest.raises(KeyError, match="the constraints are none"):
        tr.multiplier("c")


def test_save_load_lossless(traj, tmp_path):
    path = traj.save(tmp_path / "run")
    assert path.name == "run.npz"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["run.npz"]  # no temp file left
    back = Trajectory.load(path)
    for name in ("t", "q", "qd", "qdd", "multipliers", "constraint_forces", "kinetic_energy",
                 "potential_energy", "jacobi_integral", "position_residual",
                 "velocity_residual"):
        a, b = getattr(traj, name), getattr(back, name)
        assert a.dtype == b.dtype and a.shape == b.shape and a.tobytes() == b.tobytes(), name
    assert back.coordinate_names == traj.coordinate_names == ("x", "y")
    assert back.constraint_names == ("rod",)
    assert back.stats == traj.stats and back.message == traj.message
    assert back.status == traj.status and back.initialization == traj.initialization
    assert len(back.t_events) == 1 and back.t_events[0].tobytes() == traj.t_events[0].tobytes()
    assert back.y_events[0].tobytes() == traj.y_events[0].tobytes()
    assert back.success and len(traj.t_events[0]) >= 1


def test_save_overwrites_atomically(traj, tmp_path):
    path = tmp_path / "run.npz"
    path.write_bytes(b"old")
    traj.save(path)
    assert len(Trajectory.load(path)) == len(traj)
    assert [p.name for p in tmp_path.iterdir()] == ["run.npz"]


def test_failed_save_leaves_no_temp_file(traj, tmp_path, monkeypatch):
    def broken(*args, **kwargs):
        raise OSError("disk full")

    monkeypatch.setattr(np, "savez", broken)
    with pytest.raises(OSError, match="disk full"):
        traj.save(tmp_path / "run.npz")
    assert list(tmp_path.iterdir()) == []


def test_to_dataframe(traj):
    pytest.importorskip("pandas")
    df = traj.to_dataframe()
    assert df.index.name == "t" and np.array_equal(df.index.to_numpy(), traj.t)
    assert np.array_equal(df["x_dot"].to_numpy(), traj["x_dot"])
    assert np.array_equal(df["lambda[rod]"].to_numpy(), traj.multiplier("rod"))
    assert {"x", "y", "x_ddot", "jacobi_integral", "position_residual"} <= set(df.columns)


def test_summary_and_repr(traj):
    assert repr(traj).startswith(f"Trajectory({len(traj)} points, t=0..2, status='finished'")
    text = traj.summary()
    assert "max position residual" in text and "relative change of T + V" in text


@pytest.mark.parametrize(("umask", "mode"), [(0o022, 0o644), (0o077, 0o600), (0o002, 0o664)])
def test_saved_file_honours_the_umask(traj, tmp_path, umask, mode):
    import os
    import stat

    previous = os.umask(umask)
    try:
        path = traj.save(tmp_path / "run.npz")
        plain = tmp_path / "plain.txt"
        plain.write_text("x")  # what open() gives under this umask
    finally:
        os.umask(previous)
    assert stat.S_IMODE(path.stat().st_mode) == mode == stat.S_IMODE(plain.stat().st_mode)
