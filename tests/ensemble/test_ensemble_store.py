"""Where an ensemble's arrays are held: in memory, without the huge-page advice under
which the kernel may stall a first write to compact memory (Linux's
``/proc/self/smaps`` lists a mapping's advice among its ``VmFlags``: ``hg``)."""

from __future__ import annotations

import sys

import numpy as np
import pytest
from ensemble_models import pendulum, released

linux_only = pytest.mark.skipif(not sys.platform.startswith("linux"),
                                reason="reads the memory map in /proc (Linux)")


def vm_flags(array: np.ndarray) -> set[str]:
    """The ``VmFlags`` of the mapping that holds the middle of ``array``."""
    address = array.__array_interface__["data"][0] + array.nbytes // 2
    inside = False
    with open("/proc/self/smaps") as smaps:
        for line in smaps:
            head = line.split(maxsplit=1)[0]
            if "-" in head and not head.endswith(":"):
                start, end = (int(x, 16) for x in head.split("-"))
                inside = start <= address < end
            elif inside and head == "VmFlags:":
                return set(line.split()[1:])
    raise AssertionError(f"no mapping holds address {address:#x}")


@linux_only
def test_numpy_advises_huge_pages_for_large_arrays():
    """The premise of the test below: NumPy's own large arrays carry the advice (if
    NumPy stops giving it, the results' own allocation is no longer needed)."""
    large = np.empty((1024, 1024))  # 8 MB: NumPy advises from 4 MB
    assert "hg" in vm_flags(large)


@linux_only
def test_results_held_in_memory_carry_no_huge_page_advice():
    system = pendulum()
    cases = [{"l": 1.0 + 0.001 * k} for k in range(300)]
    t_eval = np.linspace(0.0, 0.2, 2001)  # q of 300 cases: 300 x 2001 x 2 = 9.6 MB
    result = system.simulate_many((0.0, 0.2), cases, initial_state=released, t_eval=t_eval,
                                  keep=("q",), scheduler="serial", progress=False)
    q = result.dataset["q"].values
    assert q.nbytes > 4 * 2**20 and q.flags.writeable
    assert "hg" not in vm_flags(q)
    # the values are those of the cases (the rod's length kept by the projection)
    lengths = np.hypot(q[..., 0], q[..., 1])
    expected = np.broadcast_to(np.array([c["l"] for c in cases])[:, None], lengths.shape)
    np.testing.assert_allclose(lengths, expected, rtol=1e-9)
