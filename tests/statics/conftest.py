"""Fixtures of the statics tests."""

from __future__ import annotations

import pytest
from statics_systems import L_ROD, M_BOB, G

from dalembert.examples import cartesian_pendulum


@pytest.fixture(scope="module")
def pendulum():
    return cartesian_pendulum.build(m_value=M_BOB, g_value=G, l_value=L_ROD)
