"""Paths that are not paths, folders that are not there, a time span given as a string:
each named at the door (they gave pathlib's TypeError, an error about a temporary file
the user never named, and a run over the digits of the string)."""

from __future__ import annotations

from pathlib import Path

import pytest

from dalembert import Trajectory
from dalembert.examples import load

Q0 = {"x": 1.0, "y": 0.0}


@pytest.fixture(scope="module")
def traj():
    return load("pendulum").build().simulate((0.0, 1.0), Q0, t_eval=[0.0, 1.0])


@pytest.mark.parametrize("path", [None, 3, ["run.npz"]])
def test_load_of_what_is_not_a_path_names_it(path):
    with pytest.raises(TypeError, match=r"^Trajectory.load takes a path \(a str or "
                                        r"os.PathLike ending in .npz\), got "):
        Trajectory.load(path)


def test_save_to_what_is_not_a_path_names_it(traj):
    with pytest.raises(TypeError, match=r"^Trajectory.save takes a path .*got 3 \(int\)$"):
        traj.save(3)


def test_save_into_a_missing_folder_names_the_file_and_the_folder(traj, tmp_path):
    target = tmp_path / "not-made" / "run.npz"
    with pytest.raises(FileNotFoundError) as info:
        traj.save(target)
    assert str(info.value) == (f"[Errno 2] cannot save {target}: the folder does not exist "
                               f"(create it first): '{target.parent}'")
    assert not list(tmp_path.iterdir())


@pytest.mark.parametrize("span", ["10", b"01"])
def test_a_time_span_given_as_a_string_is_refused(span):
    pendulum = load("pendulum").build()
    with pytest.raises(ValueError, match=r"^t_span must be two numbers \(t0, tf\), got the "
                                         r"string "):
        pendulum.simulate(span, Q0)


def test_paths_of_every_kind_still_save_and_load(traj, tmp_path):
    for path in (str(tmp_path / "a.npz"), tmp_path / "b.npz"):
        assert Trajectory.load(traj.save(path)).status == traj.status
    assert isinstance(traj.save(str(tmp_path / "c.npz")), Path)
