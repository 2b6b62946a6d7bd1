"""Trajectory: access by name, save/load round trip, atomic writing, checked loading, DataFrame."""

from __future__ import annotations

import fcntl
import io
import json
import os
import subprocess
import sys
import time
import warnings
import zipfile
from pathlib import Path

import numpy as np
import pytest
import sympy as sp

from dalembert import (
    Holonomic,
    InitialConditionsAdjusted,
    System,
    Trajectory,
    TrajectoryFileError,
    coordinates,
    t,
)

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
    path = traj.save(tmp_path / "run.npz")
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


def test_to_dataframe_constraint_forces_energies_and_inputs(traj):
    """The rod x^2 + y^2 = l^2 has A = [2x, 2y]: the force columns are A^T lambda, and also
    M qdd - f with m = 1 and f = (0, -g); T, V and T + V from q and qd (m = 1, g = 9.81)."""
    df = traj.to_dataframe()
    x_, y_, lam = df["x"].to_numpy(), df["y"].to_numpy(), df["lambda[rod]"].to_numpy()
    force = df[["constraint_force[x]", "constraint_force[y]"]].to_numpy()
    np.testing.assert_allclose(force, np.column_stack([2 * x_ * lam, 2 * y_ * lam]),
                               rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(force, np.column_stack([df["x_ddot"], df["y_ddot"] + 9.81]),
                               rtol=1e-9, atol=1e-9)
    T = 0.5 * (df["x_dot"] ** 2 + df["y_dot"] ** 2).to_numpy()
    V = 9.81 * y_
    np.testing.assert_allclose(df["kinetic_energy"], T, rtol=1e-13, atol=1e-13)
    np.testing.assert_allclose(df["potential_energy"], V, rtol=1e-13, atol=1e-13)
    np.testing.assert_allclose(df["energy"], T + V, rtol=1e-13, atol=1e-13)
    assert {"position_residual", "velocity_residual"} <= set(df.columns)
    driven = Trajectory(**{**vars(traj), "inputs": np.arange(len(traj.t))[:, None] * 0.5,
                           "input_names": ("u",)})
    np.testing.assert_array_equal(driven.to_dataframe()["input[u]"], 0.5 * np.arange(len(traj)))


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


# -- the file format: save asks for .npz, load trusts nothing ---------------------------------
@pytest.mark.parametrize(("name", "got"), [("run", "no suffix"), ("run.csv", "the suffix '.csv'"),
                                           ("run.npy", "the suffix '.npy'"),
                                           ("run.npz.txt", "the suffix '.txt'")])
def test_save_refuses_other_formats(traj, tmp_path, name, got):
    with pytest.raises(TrajectoryFileError, match=rf"Trajectory.save writes NumPy .npz files "
                                                  rf"only; '.*{name}' has {got}. Give a path "
                                                  r"ending in .npz"):
        traj.save(tmp_path / name)
    assert list(tmp_path.iterdir()) == []


def test_save_takes_the_suffix_in_any_case(traj, tmp_path):
    assert Trajectory.load(traj.save(tmp_path / "RUN.NPZ")).status == traj.status


def members(path: Path) -> dict[str, np.ndarray]:
    with np.load(path, allow_pickle=False) as data:
        return {name: data[name] for name in data.files}


def crafted(traj: Trajectory, folder: Path, meta: dict | None = None, drop: tuple = (),
            **arrays: object) -> Path:
    """A file saved by ``traj``, its metadata fields and arrays then changed."""
    content = members(traj.save(folder / "good.npz"))
    fields = json.loads(str(content["meta"]))
    fields.update(meta or {})
    content["meta"] = np.array(json.dumps({k: v for k, v in fields.items() if k not in drop}))
    content.update(arrays)
    for name in drop:
        content.pop(name, None)
    path = folder / "crafted.npz"
    np.savez(path, **content)
    return path


@pytest.mark.parametrize(("meta", "drop", "message"), [
    ({"status": 123}, (), "the field 'status' is 123, not a JSON str"),
    ({"status": "exploded"}, (), "the field 'status' is 'exploded'; a trajectory's status is one "
                                 "of 'finished', 'event', 'failed', 'interrupted'"),
    ({"coordinate_names": "xy"}, (), "the field 'coordinate_names' is 'xy', not a JSON list"),
    ({"coordinate_names": ["x", "x"]}, (), r"the field 'coordinate_names' is \['x', 'x'\], not "
                                           "a list of distinct names"),
    ({"constraint_names": [1]}, (), r"the field 'constraint_names' is \[1\], not a list"),
    ({"stats": {"nfev": "many"}}, (), "the field 'stats' has 'nfev': 'many', not a number"),
    ({"sol": "anything"}, (), "the field 'sol' is unknown"),
    ({}, ("message",), "the field 'message' is missing"),
])
def test_load_names_the_bad_metadata_field(traj, tmp_path, meta, drop, message):
    path = crafted(traj, tmp_path, meta, drop)
    with pytest.raises(TrajectoryFileError, match=rf"{path} is not a valid trajectory file: "
                                                  f"{message}"):
        Trajectory.load(path)


@pytest.mark.parametrize(("arrays", "drop", "message"), [
    ({"q": np.zeros((3, 2))}, (), r"the array 'q' has shape \(3, 2\); \d+ times, 2 coordinates "
                                  r"and 1 constraints make it \(\d+, 2\)"),
    ({"multipliers": "tension"}, (), "the array 'multipliers' has shape"),
    ({"t": np.zeros((2, 2))}, (), r"the array 't' has shape \(2, 2\), not one value per time"),
    ({"kinetic_energy": np.zeros(1)}, (), r"the array 'kinetic_energy' has shape \(1,\)"),
    ({}, ("qd",), "the array 'qd' is missing"),
    ({}, ("y_events_0",), "the events of event function 0 are missing"),
    ({"y_events_1": np.zeros((0, 4))}, (), "the array 'y_events_1' has no t_events of the same"),
    ({"t_events_0": np.float64(0.5)}, (), r"the array 't_events_0' has shape \(\), not one time "
                                          "per event"),
])
def test_load_names_the_inconsistent_array(traj, tmp_path, arrays, drop, message):
    path = crafted(traj, tmp_path, None, drop, **arrays)
    with pytest.raises(TrajectoryFileError, match=rf"{path} is not a valid trajectory file: "
                                                  f"{message}"):
        Trajectory.load(path)


def test_load_refuses_strings_for_numbers(traj, tmp_path):
    n_t = len(traj)
    path = crafted(traj, tmp_path, None, (), t=np.array(["a"] * n_t))
    with pytest.raises(TrajectoryFileError, match=r"the array 't' holds <U1, not numbers"):
        Trajectory.load(path)


@pytest.mark.parametrize(("content", "message"), [
    (b"time,x\n0,1\n", "is not a trajectory file: it is not an .npz archive"),
    (b"", "is not a trajectory file: it is not an .npz archive"),
])
def test_load_says_what_the_file_is_not(tmp_path, content, message):
    path = tmp_path / "run.npz"
    path.write_bytes(content)
    with pytest.raises(TrajectoryFileError, match=message):
        Trajectory.load(path)


def test_load_of_a_npy_array_or_another_archive(tmp_path):
    np.save(tmp_path / "array.npy", np.zeros(3))
    with pytest.raises(TrajectoryFileError, match=r"it is not an \.npz archive"):
        Trajectory.load(tmp_path / "array.npy")
    np.savez(tmp_path / "other.npz", x=np.zeros(3))
    with pytest.raises(TrajectoryFileError, match=r"is an .npz archive but not a trajectory "
                                                  r"file: it has no 'meta' member"):
        Trajectory.load(tmp_path / "other.npz")


class _Opens:
    """Unpickled, it would create ``marker`` (as any code a pickle names would run)."""

    def __init__(self, marker: Path) -> None:
        self.marker = marker

    def __reduce__(self):
        return (open, (str(self.marker), "w"))


@pytest.mark.parametrize("member", ["meta", "q", "extra"])
def test_load_never_unpickles(traj, tmp_path, member):
    marker = tmp_path / "marker"
    path = tmp_path / "pickled.npz"
    content = members(traj.save(tmp_path / "good.npz"))
    content[member] = np.array([_Opens(marker)], dtype=object)
    np.savez(path, **content)  # NumPy pickles object arrays
    with pytest.raises(TrajectoryFileError, match=rf"its member '{member}' holds Python objects "
                                                  r"\(they are never unpickled\)|unexpected "
                                                  f"member '{member}.npy'"):
        Trajectory.load(path)
    assert not marker.exists()


def npy_header(shape: tuple[int, ...]) -> bytes:
    buffer = io.BytesIO()
    np.lib.format.write_array_header_1_0(buffer, {"descr": "<f8", "fortran_order": False,
                                                  "shape": shape})
    return buffer.getvalue()


def test_load_bounds_what_a_small_file_expands_to(traj, tmp_path):
    """A consistent trajectory of 600 000 zero rows, deflated: 72 MB read from 0.1 MB."""
    k, n, m = 600_000, 2, 1
    meta = json.dumps({"coordinate_names": ["x", "y"], "constraint_names": ["rod"],
                       "status": "finished", "message": "", "stats": {},
                       "initialization": ""})
    path = tmp_path / "bomb.npz"
    with zipfile.ZipFile(path, "w", zipfile.ZIP_DEFLATED) as archive:
        archive.writestr("meta.npy", _npy(np.array(meta)))
        for name in ("t", "q", "qd", "qdd", "multipliers", "constraint_forces",
                     "kinetic_energy", "potential_energy", "jacobi_integral",
                     "position_residual", "velocity_residual"):
            shape = {"q": (k, n), "qd": (k, n), "qdd": (k, n), "constraint_forces": (k, n),
                     "multipliers": (k, m)}.get(name, (k,))
            with archive.open(f"{name}.npy", "w", force_zip64=True) as fh:
                fh.write(npy_header(shape))
                zeros = bytes(8 * 2**16)
                for _ in range(int(np.prod(shape)) * 8 // len(zeros)):
                    fh.write(zeros)
                fh.write(bytes(int(np.prod(shape)) * 8 % len(zeros)))
    size = path.stat().st_size
    declared = sum(i.file_size for i in zipfile.ZipFile(path).infolist())
    assert size < 2**20 and declared > 64 * 2**20
    with pytest.raises(TrajectoryFileError, match=rf"{path} would take {declared} bytes once "
                                                  rf"read, more than the limit of {64 * 2**20} "
                                                  rf"bytes for a file of {size} bytes; if you "
                                                  "trust it, pass max_bytes="):
        Trajectory.load(path)
    back = Trajectory.load(path, max_bytes=declared)  # trusted: read in full
    assert back.q.shape == (k, n) and not back.q.any()


def _npy(array: np.ndarray) -> bytes:
    buffer = io.BytesIO()
    np.save(buffer, array)
    return buffer.getvalue()


def test_load_checks_a_header_against_its_declared_size(traj, tmp_path):
    """A member claiming 10**9 values (8 GB) in 80 bytes is refused before allocation."""
    path = tmp_path / "liar.npz"
    content = members(traj.save(tmp_path / "good.npz"))
    with zipfile.ZipFile(path, "w") as archive:
        for name, value in content.items():
            archive.writestr(f"{name}.npy", _npy(value))
        archive.writestr("t_events_1.npy", npy_header((10**9,)) + bytes(80))
    with pytest.raises(TrajectoryFileError, match=r"its member 't_events_1' declares shape "
                                                  r"\(1000000000,\) of float64 \(8000000000 "
                                                  r"bytes\) but holds 80"):
        Trajectory.load(path)


SLOW_SAVE = """
import sys, time
from pathlib import Path
import numpy as np
from dalembert import Trajectory

traj = Trajectory.load(sys.argv[1])
traj.t[:] = -1.0  # a different trajectory, if it were written

def stalled(fh, **arrays):
    fh.write(b"PK partial")
    fh.flush()
    Path(sys.argv[2]).touch()
    time.sleep(120)

np.savez = stalled
traj.save(sys.argv[1])
"""


def test_a_save_killed_midway_leaves_the_old_file_and_a_later_save_cleans_up(traj, tmp_path):
    path = traj.save(tmp_path / "run.npz")
    before = path.read_bytes()
    started = tmp_path / "started"
    child = subprocess.Popen([sys.executable, "-c", SLOW_SAVE, str(path), str(started)])
    try:
        deadline = time.monotonic() + 60
        while not started.exists():
            assert child.poll() is None and time.monotonic() < deadline, "the save did not start"
            time.sleep(0.02)
    finally:
        child.kill()
        child.wait()
    assert path.read_bytes() == before  # the old file, untouched
    assert np.array_equal(Trajectory.load(path).t, traj.t)
    (left,) = [p for p in tmp_path.iterdir() if p.name.endswith(".tmp")]
    assert left.name.startswith("run.npz.")
    # A later save removes it once it is old enough to be no save in progress; a
    # temporary file still locked (a save running elsewhere) stays, however old.
    busy = tmp_path / "run.npz.busy0000.tmp"
    busy.write_bytes(b"")
    hours_ago = time.time() - 7200
    for p in (left, busy):
        os.utime(p, (hours_ago, hours_ago))
    with open(busy, "rb") as held:
        fcntl.flock(held, fcntl.LOCK_EX)
        traj.save(path)
        assert sorted(p.name for p in tmp_path.iterdir()) == ["run.npz", busy.name, "started"]


def test_a_damaged_file_loads_or_raises_the_one_error(traj, tmp_path):
    """200 files with a few bytes changed (half of them in the zip directory, at the end):
    each loads, or raises TrajectoryFileError, never another exception."""
    good = traj.save(tmp_path / "good.npz").read_bytes()
    rng = np.random.default_rng(0)
    path, outcomes = tmp_path / "damaged.npz", {"loaded": 0, "refused": 0}
    for _ in range(200):
        data = bytearray(good)
        low = len(data) - 400 if rng.random() < 0.5 else 0
        for _ in range(rng.integers(1, 6)):
            data[rng.integers(low, len(data))] = rng.integers(256)
        path.write_bytes(bytes(data))
        try:
            Trajectory.load(path)
            outcomes["loaded"] += 1
        except TrajectoryFileError:
            outcomes["refused"] += 1
    assert outcomes["refused"] > 150  # the damage was mostly seen


def test_a_forced_or_driven_change_of_energy_is_not_called_an_error(traj, tmp_path):
    """Conservative (the pendulum): the change of T + V is an error, measured against the
    energy exchanged. Damped (c x_dot, c y_dot): T + V falls by the damper's work, the
    integral of -c |v|^2 (trapezoid on a fine grid), and the summary says so; the flag
    is kept by save and load, and a file without it reads as not known."""
    assert traj.energy_conserved is True
    text = traj.summary()
    e = traj.energy
    scale = max(np.abs(traj.kinetic_energy).max(), np.abs(traj.potential_energy).max())
    assert f"relative change of T + V {np.abs(e - e[0]).max() / scale:.2e} (an error" in text
    c = sp.Symbol("c")
    damped = System([x, y], kinetic=m / 2 * (x.diff() ** 2 + y.diff() ** 2), potential=m * g * y,
                    constraints=[Holonomic(x**2 + y**2 - l**2, name="rod")],
                    generalized_forces={x: -c * x.diff(), y: -c * y.diff()},
                    parameters={m: 1.0, g: 9.81, l: 1.0, c: 0.3})
    run = damped.simulate((0, 2), q0=[1.0, 0.0], t_eval=np.linspace(0, 2, 4001))
    assert run.energy_conserved is False
    work = np.trapezoid(-0.3 * (run.qd ** 2).sum(axis=1), run.t)
    change = run.energy[-1] - run.energy[0]
    assert change < -0.1 and abs(change - work) < 1e-5 * abs(work)
    summary = run.summary()
    assert f"change of T + V {change:.6g} (relative" in summary
    assert "the work of the applied forces, inputs and drivers, not an error" in summary
    assert "an error where" not in summary
    assert Trajectory.load(run.save(tmp_path / "damped.npz")).energy_conserved is False
    assert Trajectory.load(traj.save(tmp_path / "free.npz")).energy_conserved is True
    old = crafted(traj, tmp_path, drop=("energy_conserved",))  # a file of an earlier version
    assert Trajectory.load(old).energy_conserved is None


def test_which_models_conserve_energy():
    """T + V is constant only without applied forces, inputs or moving constraints, and
    with T quadratic in the velocities (measured on each: the drift of T + V along a run
    is at rounding level exactly where the flag says so)."""
    from dalembert.multibody import Driver, Ground, Multibody, PlanarBody, Revolute, chain

    u, w = sp.Symbol("u"), sp.Symbol("w")
    kinetic = m / 2 * (x.diff() ** 2 + y.diff() ** 2)
    rod = Holonomic(x**2 + y**2 - l**2, name="rod")
    p = {m: 1.0, g: 9.81, l: 1.0}
    cases = {
        "free": (System([x, y], kinetic=kinetic, potential=m * g * y, constraints=[rod],
                        parameters=p), {}, True),
        "input": (System([x, y], kinetic=kinetic, potential=m * g * y, constraints=[rod],
                         generalized_forces={x: u}, inputs=[u], parameters=p),
                  {"inputs": 1.0}, False),
        # the rod's length grows: the constraint moves
        "moving": (System([x, y], kinetic=kinetic, potential=m * g * y,
                          constraints=[Holonomic(x**2 + y**2 - (l + t / 2) ** 2)],
                          parameters=p), {}, False),
        # a frame turning at w: T has a part linear in the velocities
        "turning": (System([x, y], kinetic=m / 2 * ((x.diff() - w * y) ** 2
                                                    + (y.diff() + w * x) ** 2),
                           potential=m * g * y, constraints=[rod], parameters={**p, w: 2.0}),
                    {}, False),
    }
    for name, (system, options, expected) in cases.items():
        assert system.conserves_energy is expected, name
        with warnings.catch_warnings():  # the moving rod's start is projected
            warnings.simplefilter("ignore", InitialConditionsAdjusted)
            run = system.simulate((0, 1), q0=[1.0, 0.0], qd0=[0.0, 0.3], **options)
        drift = np.abs(run.energy - run.energy[0]).max()
        assert bool(drift < 1e-9) is expected, (name, drift)
        assert run.energy_conserved is expected
    disk = PlanarBody("disk", 1.0, 0.5)
    pin = Revolute("pin", Ground(), disk)
    assert chain(2, 1.0, 1.0, 0.1).conserves_energy is True
    assert chain(2, 1.0, 1.0, 0.1).system.conserves_energy is True
    driven = Multibody([disk], [pin, Driver("motor", pin, 2 * t**2)], gravity=(0, 0, 0))
    assert driven.system.conserves_energy is False
    run = driven.simulate((0, 1), {}, t_eval=[0.0, 1.0])
    # the motor brings the disk from rest to 4 rad/s: T = 1/2 0.5 4^2 = 4, its work
    assert run.energy_conserved is False and abs(run.energy[-1] - 4.0) < 1e-9
    assert "change of T + V 4 (relative" in run.summary()


# -- files built to make a reader hang or crash ----------------------------------------------
def many_members(path: Path, count: int) -> Path:
    """An archive of ``count`` tiny members with names a trajectory may have."""
    with zipfile.ZipFile(path, "w") as archive:
        archive.writestr("meta.npy", b"")
        for e in range(count - 1):
            archive.writestr(f"t_events_{e}.npy", b"")
    return path


def test_load_refuses_an_archive_of_too_many_members_at_once(tmp_path):
    """20 001 members: refused from the zip directory's count, before any is read (it
    took 34 s to get an answer, 150 000 none in 300 s)."""
    path = many_members(tmp_path / "many.npz", 20_001)
    start = time.perf_counter()
    with pytest.raises(TrajectoryFileError, match=rf"{path} is not a trajectory file: it has "
                                                  r"20001 members, more than the 10000 a "
                                                  "trajectory file may have"):
        Trajectory.load(path)
    assert time.perf_counter() - start < 2.0  # a guard, not a benchmark: it was 34 s


def test_load_says_a_zip64_count_is_a_lower_bound(tmp_path):
    """An end record counting 0xFFFF members means that many or more."""
    path = many_members(tmp_path / "few.npz", 3)
    data = bytearray(path.read_bytes())
    end = data.rfind(b"PK\x05\x06")
    data[end + 8:end + 12] = (0xFFFF).to_bytes(2, "little") * 2
    path.write_bytes(bytes(data))
    with pytest.raises(TrajectoryFileError, match=r"it has 65535 or more members, more than "):
        Trajectory.load(path)


def test_load_counts_the_members_when_the_directory_understates_them(tmp_path):
    """The count in the zip directory's end record says 3; the directory lists 20 001."""
    path = many_members(tmp_path / "many.npz", 20_001)
    data = bytearray(path.read_bytes())
    end = data.rfind(b"PK\x05\x06")
    data[end + 8:end + 12] = (3).to_bytes(2, "little") * 2
    path.write_bytes(bytes(data))
    start = time.perf_counter()
    with pytest.raises(TrajectoryFileError, match=r"it has 20001 members, more than the 10000"):
        Trajectory.load(path)
    assert time.perf_counter() - start < 5.0


def _load_in_a_child(path: Path) -> subprocess.CompletedProcess:
    """``Trajectory.load(path)`` in a child process that prints the error (a hang fails)."""
    script = ("import sys\nfrom dalembert import Trajectory, TrajectoryFileError\n"
              "try:\n    Trajectory.load(sys.argv[1])\n"
              "except TrajectoryFileError as exc:\n    print(exc)\n")
    try:
        return subprocess.run([sys.executable, "-c", script, str(path)], capture_output=True,
                              text=True, timeout=60, cwd=Path(__file__).parents[1])
    except subprocess.TimeoutExpired:
        pytest.fail(f"Trajectory.load({str(path)!r}) did not return within 60 s")


@pytest.mark.parametrize(("make", "what"), [(os.mkfifo, "a FIFO"), (os.mkdir, "a folder")])
def test_load_refuses_what_is_not_a_regular_file_without_blocking(tmp_path, make, what):
    path = tmp_path / "run.npz"
    make(path)
    run = _load_in_a_child(path)
    assert run.returncode == 0, run.stderr
    assert run.stdout.strip() == (f"{path} is not a trajectory file: it is {what}, not a "
                                  "regular file")


def test_load_of_deeply_nested_metadata_names_the_file(traj, tmp_path):
    content = members(traj.save(tmp_path / "good.npz"))
    content["meta"] = np.array("[" * 100_000 + "]" * 100_000)
    path = tmp_path / "deep.npz"
    np.savez(path, **content)
    with pytest.raises(TrajectoryFileError, match=rf"{path} is not a valid trajectory file: the "
                                                  "member 'meta' is JSON nested too deeply"):
        Trajectory.load(path)
