"""The tools compared by ``bench/suite.py``: one module per tool.

Each module has ``TOOL`` (its name in the JSON), ``versions() -> dict`` and
``run(workload, n) -> dict``; ``workload`` is ``"spherical"`` (3D chain) or
``"revolute"`` (planar chain). ``run`` builds the chain twice (cold, then warm),
meets the accuracy target of :mod:`bench.peers.common` by tightening tolerances or
steps, and returns the measured record. An optional tool that is not installed
raises ``ImportError`` from ``versions``/``run``; the suite records that as the status.
"""

TOOLS = ("dalembert", "sympy", "mujoco", "exudyn")
