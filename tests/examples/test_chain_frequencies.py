"""The chain-frequency study: one build, every length a parameter value; frequencies
against the hand linearization in absolute angles (the example's ``hand_modes``, a
derivation independent of dalembert's), the first mode's motion against its linear
closed form, no code generated per length."""

from __future__ import annotations

import numpy as np
import pytest

from dalembert import report
from dalembert.codegen import c_backend
from dalembert.examples import chain_frequencies as example


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    return report.run_example("chain-frequencies", tmp_path_factory.mktemp("chain"),
                              t_end=3.0, points=301, animation=False)


def test_frequencies_and_first_mode(run):
    assert run.checks["natural frequency relative error (hand linearization)"] < 1e-9
    assert run.checks["first-mode motion error relative to the amplitude"] < 1e-6
    assert "frequencies.png" in [p.name for p in run.files]


def test_the_study_compiles_nothing_per_length(run, monkeypatch):
    runs = []
    original = c_backend._compile
    monkeypatch.setattr(c_backend, "_compile", lambda *a, **k: runs.append(a) or original(*a, **k))
    found = example.study(run.system, np.array([0.7, 1.9]))
    assert runs == []
    for length, omega in zip((0.7, 1.9), found):
        np.testing.assert_allclose(omega, example.hand_modes(length)[0], rtol=1e-9)
