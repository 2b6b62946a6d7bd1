"""The ``dalembert`` command line, run in-process through ``main(argv)``."""

from __future__ import annotations

import re
import types

import numpy as np
import pytest
from PIL import Image

from dalembert import cli, examples
from dalembert.errors import ModelError
from dalembert.examples import cartesian_pendulum
from dalembert.trajectory import Trajectory

SHORT = ["--t-end", "0.5", "--points", "26"]


def check_value(text: str, name: str) -> float:
    """The number in the ``| name | value |`` row of a printed checks table."""
    match = re.search(rf"\| {re.escape(name)} \| ([-+0-9.e]+) \|", text)
    assert match, f"{name!r} not in:\n{text}"
    return float(match.group(1))


def test_list_names_every_importable_example(capsys):
    assert cli.main(["list"]) == 0
    out = capsys.readouterr().out
    assert re.search(r"^pendulum\s+" + re.escape(cartesian_pendulum.TITLE) + "$", out, re.M)


def test_list_skips_an_example_that_does_not_import(monkeypatch, capsys):
    monkeypatch.setitem(examples.EXAMPLES, "broken", "no_such_module")
    assert cli.main(["list"]) == 0
    captured = capsys.readouterr()
    assert "skipping example 'broken'" in captured.err
    assert "pendulum" in captured.out
    assert "broken" not in captured.out


def test_equations_text_and_latex(capsys):
    assert cli.main(["equations", "pendulum"]) == 0
    text = capsys.readouterr().out
    assert "M qdd = f + A^T lambda" in text
    assert "rod" in text
    assert cli.main(["equations", "pendulum", "--latex"]) == 0
    assert capsys.readouterr().out.startswith(r"\begin{aligned}")


def test_run_pendulum_writes_files_and_prints_checks(tmp_path, capsys):
    out = tmp_path / "run"
    assert cli.main(["run", "pendulum", *SHORT, "--out", str(out)]) == 0
    printed = capsys.readouterr().out
    assert "relative energy error" in printed
    # the rod tension from the multiplier against m v^2/l + m g cos(theta)
    assert check_value(printed, "tension relative error") < 1e-12
    for name in ("coordinates", "energy", "residuals", "multipliers", "path"):
        assert (out / f"{name}.png").stat().st_size > 0
    traj = Trajectory.load(out / "trajectory.npz")
    assert len(traj) == 26 and traj.t[-1] == pytest.approx(0.5)
    # independent check of the saved data: the bob stays on the circle of radius l = 1
    assert np.abs(np.hypot(traj["x"], traj["y"]) - 1.0).max() < 1e-12
    with Image.open(out / "animation.gif") as gif:   # one frame per output point (26 < 60)
        assert gif.n_frames == 26
    assert "animation: the example's draw(system, q)" in printed
    assert not (out / "animation.html").exists()


def test_run_html_and_no_animation(tmp_path, capsys):
    assert cli.main(["run", "heavy-top", *SHORT, "--out", str(tmp_path / "a"),
                     "--html"]) == 0
    page = (tmp_path / "a" / "viewer.html").read_text()  # the 3D viewer (tests/viewer)
    assert page.startswith("<!DOCTYPE html>") and "dalembert-scene" in page
    assert (tmp_path / "a" / "animation.gif").exists()
    assert cli.main(["run", "pendulum", *SHORT, "--out", str(tmp_path / "b"),
                     "--no-animation"]) == 0
    printed = capsys.readouterr().out.split("pendulum:")[-1]
    assert "animation:" not in printed and "animation.gif" not in printed
    assert not list((tmp_path / "b").glob("animation.*"))
    assert (tmp_path / "b" / "path.png").exists()


def test_gallery_lists_a_failing_example_and_writes_the_others(monkeypatch, tmp_path, capsys):
    monkeypatch.setitem(examples.EXAMPLES, "broken", "no_such_module")
    assert cli.main(["gallery", "pendulum", "broken", "--out", str(tmp_path), *SHORT]) == 1
    captured = capsys.readouterr()
    assert "1 example(s) failed: broken" in captured.err
    assert "pendulum: " + cartesian_pendulum.TITLE in captured.out
    index = (tmp_path / "index.md").read_text()
    assert "## broken: failed" in index and "ModuleNotFoundError" in index
    assert (tmp_path / "pendulum" / "animation.gif").exists()
    assert 'src="pendulum/animation.gif"' in (tmp_path / "index.html").read_text()


def test_gallery_unknown_example_exits_2(tmp_path, capsys):
    assert cli.main(["gallery", "no-such-example", "--out", str(tmp_path)]) == 2
    assert "no-such-example" in capsys.readouterr().err
    assert not (tmp_path / "index.md").exists()


def test_demo_writes_plots_and_summary(tmp_path, capsys):
    out = tmp_path / "demo"
    assert cli.main(["demo", "--out", str(out), *SHORT]) == 0
    printed = capsys.readouterr().out
    summary = (out / "summary.md").read_text()
    assert summary in printed
    assert check_value(summary, "tension relative error") < 1e-12
    assert (out / "pendulum" / "multipliers.png").stat().st_size > 0
    try:
        examples.load("knife-edge")
    except ImportError:
        assert "`knife-edge` skipped" in summary
    else:
        assert "## knife-edge" in summary
        assert (out / "knife-edge" / "path.png").stat().st_size > 0
    assert "## heavy-top" in summary   # the multibody example, with its animation
    assert (out / "heavy-top" / "animation.gif").stat().st_size > 0


def test_demo_falls_back_to_the_pendulum(monkeypatch, tmp_path, capsys):
    monkeypatch.setitem(examples.EXAMPLES, "knife-edge", "no_such_module")
    assert cli.main(["demo", "--out", str(tmp_path), *SHORT]) == 0
    summary = (tmp_path / "summary.md").read_text()
    assert "## pendulum" in summary
    assert "`knife-edge` skipped" in summary
    assert not (tmp_path / "knife-edge").exists()


@pytest.mark.parametrize("command", ["run", "equations", "equilibrium", "modes"])
def test_unknown_example_exits_2_and_names_it(command, capsys):
    assert cli.main([command, "no-such-example"]) == 2
    err = capsys.readouterr().err
    assert "no-such-example" in err and "pendulum" in err
    assert "Traceback" not in err


def test_dalembert_error_is_one_line_exit_2(monkeypatch, capsys):
    def build():
        raise ModelError("kinetic energy is not quadratic\nin the velocities")

    fake = types.SimpleNamespace(build=build, TITLE="broken")
    monkeypatch.setattr(examples, "load", lambda name: fake)
    assert cli.main(["equations", "pendulum"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1
    assert "ModelError" in err and "not quadratic in the velocities" in err


@pytest.mark.parametrize("argv", [[], ["run", "pendulum", "--t-end", "-1"],
                                  ["run", "pendulum", "--points", "1"],
                                  ["modes", "pendulum", "--count", "0"]])
def test_usage_errors_return_2(argv, capsys):
    assert cli.main(argv) == 2
    assert "usage" in capsys.readouterr().err


def test_help_returns_0(capsys):
    assert cli.main(["--help"]) == 0
    assert "demo" in capsys.readouterr().out


def test_energy_plot_quantity_follows_the_kinetic_energy():
    import sympy as sp

    from dalembert import System, coordinates
    from dalembert.report import conserved, energy_quantity

    assert energy_quantity(cartesian_pendulum.build()) == "energy"
    assert conserved(cartesian_pendulum.build())
    # a rotating frame puts terms linear in th_dot into T: T + V differs from the
    # Jacobi integral, and only the latter is conserved
    r, th = coordinates("r th")
    w = sp.Symbol("w")
    rotating = System([r, th], kinetic=(r.diff() ** 2 + r**2 * (th.diff() + w) ** 2) / 2,
                      potential=0 * r, parameters={w: 1.0})
    assert energy_quantity(rotating) == "jacobi"
    assert conserved(rotating)


def test_moving_constraint_is_not_conservative():
    import sympy as sp

    from dalembert import Holonomic, System, coordinates, t
    from dalembert.report import conserved

    x, y = coordinates("x y")
    w = sp.Symbol("w")
    # a bead on a rod turning at the rate w: the rod does work on the bead
    bead = System([x, y], kinetic=(x.diff() ** 2 + y.diff() ** 2) / 2, potential=0 * x,
                  constraints=[Holonomic(y * sp.cos(w * t) - x * sp.sin(w * t), name="rod")],
                  parameters={w: 1.0})
    assert not conserved(bead)


# -- statics: equilibrium and modes ------------------------------------------------------
def printed_numbers(text: str, pattern: str) -> list[float]:
    """Every number captured by ``pattern`` (one group) in ``text``."""
    return [float(v) for v in re.findall(pattern, text)]


def test_equilibrium_pendulum_prints_and_draws(tmp_path, capsys):
    assert cli.main(["equilibrium", "pendulum", "--out", str(tmp_path)]) == 0
    printed = capsys.readouterr().out
    assert "stable equilibrium" in printed
    # hanging straight down, and the rod holds the weight: -2 lambda l = m g
    (y,) = printed_numbers(printed, r"at x = \S+ y = ([-+0-9.e]+)")
    assert y == pytest.approx(-1.0, abs=1e-12)
    (lam,) = printed_numbers(printed, r"rod = ([-+0-9.e]+)")
    assert -2 * lam * 1.0 == pytest.approx(1.0 * 9.81, rel=1e-12)
    assert (tmp_path / "equilibrium.png").stat().st_size > 0


def test_modes_pendulum_frequency_is_sqrt_g_over_l(tmp_path, capsys):
    assert cli.main(["modes", "pendulum", "--out", str(tmp_path)]) == 0
    printed = capsys.readouterr().out
    (omega,) = printed_numbers(printed, r"omega = ([-+0-9.e]+) rad/s")
    (hz,) = printed_numbers(printed, r"f = ([-+0-9.e]+) Hz")
    assert omega == pytest.approx(np.sqrt(9.81 / 1.0), rel=1e-9)
    assert hz == pytest.approx(np.sqrt(9.81) / (2 * np.pi), rel=1e-9)
    assert (tmp_path / "mode_1.png").stat().st_size > 0
    assert not (tmp_path / "mode_2.png").exists()  # one degree of freedom


def test_modes_double_pendulum_two_closed_form_frequencies(tmp_path, capsys):
    assert cli.main(["modes", "double-pendulum", "--out", str(tmp_path)]) == 0
    printed = capsys.readouterr().out
    omegas = printed_numbers(printed, r"omega = ([-+0-9.e]+) rad/s")
    expected = np.sqrt(np.array([2 - np.sqrt(2), 2 + np.sqrt(2)]) * 9.81 / 1.0)
    np.testing.assert_allclose(omegas, expected, rtol=1e-9)
    assert printed.count("shape:") == 2
    for k in (1, 2):
        assert (tmp_path / f"mode_{k}.png").stat().st_size > 0


def test_modes_count_limits_the_output(tmp_path, capsys):
    assert cli.main(["modes", "double-pendulum", "--out", str(tmp_path), "--count", "1"]) == 0
    printed = capsys.readouterr().out
    assert len(printed_numbers(printed, r"omega = ([-+0-9.e]+) rad/s")) == 1
    assert not (tmp_path / "mode_2.png").exists()


@pytest.mark.parametrize("command", ["equilibrium", "modes"])
def test_example_without_guess_is_one_line_exit_2(command, tmp_path, capsys):
    assert cli.main([command, "knife-edge", "--out", str(tmp_path)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "Traceback" not in err
    assert "'knife-edge' has no EQUILIBRIUM_GUESS" in err
    assert "pendulum" in err  # names the examples that have one
    assert not any(tmp_path.iterdir())


def test_modes_of_a_nonholonomic_example_with_a_guess_is_one_line(monkeypatch, capsys):
    from dalembert.examples import knife_edge

    monkeypatch.setattr(knife_edge, "EQUILIBRIUM_GUESS", {}, raising=False)
    assert cli.main(["modes", "knife-edge"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1
    assert "NonholonomicLinearizationError" in err


def test_equilibrium_without_draw_prints_but_writes_nothing(monkeypatch, tmp_path, capsys):
    from dalembert.examples import spherical_pendulum

    monkeypatch.setattr(spherical_pendulum, "EQUILIBRIUM_GUESS", {"x": 0.1, "z": -0.9},
                        raising=False)
    assert not hasattr(spherical_pendulum, "draw")
    assert cli.main(["equilibrium", "spherical-pendulum", "--out", str(tmp_path)]) == 0
    assert "stable equilibrium" in capsys.readouterr().out
    assert not any(tmp_path.iterdir())


def test_run_a_model_file_given_by_path(tmp_path, capsys):
    """A user's file defining what a gallery example defines runs like one."""
    import inspect

    model = tmp_path / "my_pendulum.py"
    # as a user writes it: absolute imports
    source = inspect.getsource(cartesian_pendulum).replace("from ..", "from dalembert.")
    model.write_text(source.replace("from .", "from dalembert.examples."))
    out = tmp_path / "out"
    assert cli.main(["run", str(model), *SHORT, "--out", str(out), "--no-animation"]) == 0
    printed = capsys.readouterr().out
    assert check_value(printed, "tension relative error") < 1e-12
    traj = Trajectory.load(out / "trajectory.npz")
    assert np.abs(np.hypot(traj["x"], traj["y"]) - 1.0).max() < 1e-12


def test_model_file_missing_or_incomplete_is_named(tmp_path, capsys):
    assert cli.main(["run", str(tmp_path / "absent.py")]) == 2
    assert "no model file" in capsys.readouterr().err
    partial = tmp_path / "partial.py"
    partial.write_text("TITLE = 'half a model'\n")
    assert cli.main(["run", str(partial)]) == 2
    err = capsys.readouterr().err
    assert "does not define build, INITIAL, T_END, checks" in err
    assert "Traceback" not in err
    broken = tmp_path / "broken.py"
    broken.write_text("import not_a_module_anywhere\n")
    assert cli.main(["run", str(broken)]) == 1
    assert "does not import: ModuleNotFoundError" in capsys.readouterr().err
