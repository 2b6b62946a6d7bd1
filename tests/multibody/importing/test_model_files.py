"""Every model file shipped in pybullet_data, example-robot-data and gymnasium: it
imports (warning only of what it leaves out) or gives a ModelFileError that names the
file; nothing else (no raw traceback, no other warning). The counts are in
docs/importing.md; the floors below keep them from sliding back unnoticed."""

from __future__ import annotations

import warnings
from collections import Counter
from pathlib import Path

import gymnasium
import mujoco
import pybullet_data
import pytest

from dalembert.errors import ModelFileError, UnsupportedModelFeatureWarning
from dalembert.multibody import from_mjcf, from_urdf

ROOTS = {
    "pybullet_data": Path(pybullet_data.getDataPath()),
    "gymnasium": Path(gymnasium.__file__).parent,
    # example-robot-data installs its robots in cmeel's prefix beside the packages
    "example-robot-data": Path(mujoco.__file__).parents[1] / "cmeel.prefix" / "share"
    / "example-robot-data",
}
#: How many files of each package import, at least (measured: 39, 5, 39).
IMPORTED_AT_LEAST = {"pybullet_data": 39, "gymnasium": 5, "example-robot-data": 39}


def _files(package: str) -> list[Path]:
    root = ROOTS[package]
    assert root.is_dir(), f"{package}'s models are not installed (pip install '.[dev]')"
    return sorted([*root.rglob("*.urdf"), *root.rglob("*.xml")])


def _outcome(path: Path) -> str:
    """``"imported"``, ``"refused by MuJoCo"`` or ``"refused by dalembert"``; anything
    else fails the test."""
    read = from_urdf if path.suffix == ".urdf" else from_mjcf
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        warnings.simplefilter("ignore", UnsupportedModelFeatureWarning)
        try:
            mb = read(path)
        except ModelFileError as exc:
            assert str(path) in str(exc)
            return "refused by MuJoCo" if "MuJoCo says" in str(exc) else "refused by dalembert"
    assert mb.bodies and mb.imported is not None
    return "imported"


@pytest.mark.parametrize("package", sorted(ROOTS))
def test_a_sample_of_the_shipped_models(package):
    """Every 25th file (sorted by path), and every gymnasium model."""
    files = _files(package)
    sample = files if package == "gymnasium" else files[::25]
    outcomes = Counter(_outcome(path) for path in sample)
    assert outcomes["imported"] >= 1, outcomes


@pytest.mark.validation
@pytest.mark.parametrize("package", sorted(ROOTS))
def test_every_shipped_model(package):
    outcomes = Counter(_outcome(path) for path in _files(package))
    print(package, dict(outcomes))
    assert outcomes["imported"] >= IMPORTED_AT_LEAST[package], outcomes

