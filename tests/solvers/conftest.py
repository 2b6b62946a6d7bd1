"""Session fixtures of the solver tests: the pendulum and its minimal-coordinate reference."""

from __future__ import annotations

import pytest
from pendulum_case import build_pendulum, reference_solution

from dalembert import System


@pytest.fixture(scope="session")
def pendulum() -> System:
    return build_pendulum()


@pytest.fixture(scope="session")
def reference():
    return reference_solution()
