"""``import dalembert`` stays light: statics, plotting and SciPy's integrators and
optimizers are imported on first use."""

from __future__ import annotations

import subprocess
import sys


def fresh(code: str) -> str:
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          check=True)
    return done.stdout.strip()


def test_import_leaves_statics_and_plotting_out():
    loaded = fresh("import sys, dalembert; print(sorted(m for m in sys.modules if m in "
                   "('dalembert.statics', 'dalembert.plotting', 'matplotlib')))")
    assert loaded == "[]"


def test_import_leaves_scipy_integrate_and_optimize_out_until_a_run():
    """They are large imports (about a third of a second together): a System is built
    and its equations seen without them; a simulation brings them in."""
    out = fresh("import sys, dalembert\n"
                "heavy = ('scipy.integrate', 'scipy.optimize')\n"
                "print(sorted(m for m in heavy if m in sys.modules))\n"
                "from dalembert.examples import load\n"
                "pendulum = load('pendulum').build()\n"
                "pendulum.equations()\n"
                "print(sorted(m for m in heavy if m in sys.modules))\n"
                "pendulum.simulate((0, 0.1), {'x': 1.0, 'y': 0.0})\n"
                "print('scipy.integrate' in sys.modules)")
    assert out.splitlines() == ["[]", "[]", "True"]


def test_multibody_leaves_plotting_and_statics_out():
    # building mechanisms needs neither drawings nor statics; the stick figure's
    # drawing and Euler angles (scipy.spatial) import what they need when called
    heavy = ("dalembert.statics", "dalembert.plotting", "matplotlib", "mpl_toolkits", "PIL",
             "pandas", "tqdm")
    loaded = fresh(f"import sys, dalembert.multibody; print(sorted(m for m in sys.modules "
                   f"if m.split('.')[0] in {heavy!r} or m in {heavy!r}))")
    assert loaded == "[]"


def test_lazy_names_work_and_are_listed():
    out = fresh("import dalembert; print(callable(dalembert.extremum), "
                "'extremum' in dir(dalembert), 'extremum' in dalembert.__all__)")
    assert out == "True True True"


def test_python_dash_m_dalembert_lists_the_gallery():
    done = subprocess.run([sys.executable, "-m", "dalembert", "list"], capture_output=True,
                          text=True)
    assert done.returncode == 0 and "four-bar" in done.stdout


def test_every_error_and_warning_is_exported():
    import dalembert
    from dalembert import errors

    for name in errors.__all__:
        assert name in dalembert.__all__ and getattr(dalembert, name) is getattr(errors, name)
    classes = [v for v in vars(errors).values() if isinstance(v, type)
               and issubclass(v, (errors.DalembertError, errors.DalembertWarning))]
    assert {c.__name__ for c in classes} == set(errors.__all__)
