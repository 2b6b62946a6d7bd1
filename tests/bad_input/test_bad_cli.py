"""The command line with bad arguments, unwritable folders and Ctrl-C: one line, right status."""

from __future__ import annotations

import signal
from pathlib import Path

import pytest

from dalembert import System, cli, report


def test_points_are_bounded(capsys):
    assert cli.main(["run", "pendulum", "--points", "100000000"]) == 2
    err = capsys.readouterr().err
    assert "argument --points: at most 100000 points, not 100000000" in err


@pytest.mark.parametrize("command", [["run", "pendulum"], ["demo"], ["gallery", "pendulum"]])
def test_unwritable_output_folder_is_one_line_exit_2(tmp_path, capsys, command):
    blocker = tmp_path / "a-file"
    blocker.write_text("not a folder")
    out = blocker / "sub"
    assert cli.main([*command, "--t-end", "0.1", "--points", "3", "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "Traceback" not in err
    assert f"cannot write to the output folder {str(out)!r}" in err


def test_a_write_that_fails_midway_is_one_line_exit_2(tmp_path, monkeypatch, capsys):
    def full_disk(*args, **kwargs):
        raise OSError(28, "No space left on device", str(tmp_path / "trajectory.npz"))

    monkeypatch.setattr(report, "run_example", full_disk)
    assert cli.main(["run", "pendulum", "--out", str(tmp_path)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "Traceback" not in err
    assert "could not write" in err and "trajectory.npz" in err and "No space left" in err


def test_ctrl_c_outside_a_simulation_exits_130(monkeypatch, tmp_path, capsys):
    def interrupted(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(report, "run_example", interrupted)
    assert cli.main(["run", "pendulum", "--out", str(tmp_path)]) == 130
    assert capsys.readouterr().err == "dalembert: error: interrupted\n"


def test_ctrl_c_during_a_simulation_writes_the_part_and_exits_130(monkeypatch, tmp_path,
                                                                  capsys):
    # A real SIGINT, raised from inside the integration (an event function), which the
    # simulation catches to return the part computed so far.
    simulate = System.simulate

    def pressed_at_half_time(t, q, qd):
        if t > 0.5:
            signal.raise_signal(signal.SIGINT)
        return 1.0

    def with_ctrl_c(self, *args, **kwargs):
        return simulate(self, *args, **{**kwargs, "events": [pressed_at_half_time]})

    monkeypatch.setattr(System, "simulate", with_ctrl_c)
    with pytest.warns(UserWarning, match="interrupted by the user"):
        status = cli.main(["run", "pendulum", "--t-end", "2", "--points", "21",
                           "--no-animation", "--out", str(tmp_path)])
    assert status == 130
    captured = capsys.readouterr()
    assert "status='interrupted'" in captured.out
    assert captured.err.endswith("interrupted; the files hold the part computed before "
                                 "Ctrl-C\n")
    assert (Path(tmp_path) / "trajectory.npz").stat().st_size > 0
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler  # restored
