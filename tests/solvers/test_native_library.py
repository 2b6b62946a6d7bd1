"""The C runtime's ctypes mirrors against the library's own report of its layout.

The reference is the C compiler: ``dl_layout`` reports ``sizeof`` and ``offsetof``
of every mirrored struct and the value of every return code, as compiled. A mirror
that differs (a field added on one side only, moved or retyped) must be named.
"""

from __future__ import annotations

import ctypes

import pytest

from dalembert.codegen.c_backend import CompileError
from dalembert.solvers.native import library


@pytest.fixture(scope="module")
def reported():
    return library.layout(library.runtime())


def test_every_mirror_matches_the_compiled_structs(reported):
    library.check_layout(reported)  # raises on any difference
    for struct, mirror in library.MIRRORS.items():
        assert reported[struct] == ctypes.sizeof(mirror)
        for name, *_ in mirror._fields_:
            assert reported[f"{struct}.{name}"] == getattr(mirror, name).offset
    for name, value in library.CODES.items():
        assert reported[name] == value


def mirror_with(fields):
    return type("Mirror", (ctypes.Structure,), {"_fields_": fields})


def test_a_field_missing_from_a_mirror_is_named(reported):
    fields = [f for f in library.Function._fields_ if f[0] != "size"]
    with pytest.raises(library.LayoutError, match=r"dl_function\.size is in the C runtime "
                                                  "but not in its mirror"):
        library.check_layout(reported, {"dl_function": mirror_with(fields)}, {})


def test_a_field_the_c_side_lacks_is_named(reported):
    fields = [*library.Function._fields_, ("extra", ctypes.c_int64)]
    with pytest.raises(library.LayoutError, match=r"dl_function\.extra: the mirror .* has "
                                                  "a field the C runtime does not"):
        library.check_layout(reported, {"dl_function": mirror_with(fields)}, {})


def test_a_moved_or_retyped_field_is_named(reported):
    fields = list(library.Function._fields_)
    fields[1], fields[2] = fields[2], fields[1]  # K and index swapped
    with pytest.raises(library.LayoutError, match=r"dl_function\.index is at byte 16 in C, 8 "):
        library.check_layout(reported, {"dl_function": mirror_with(fields)}, {})
    last = library.Function._fields_[-1][0]  # retyped wider: only the size tells
    retyped = [(n, ctypes.c_int64 * 2 if n == last else t)
               for n, t in library.Function._fields_]
    size = ctypes.sizeof(library.Function)
    with pytest.raises(library.LayoutError, match=rf"dl_function has {size} bytes in C, "
                                                  rf"{size + 8}"):
        library.check_layout(reported, {"dl_function": mirror_with(retyped)}, {})


def test_a_return_code_that_differs_is_named(reported):
    with pytest.raises(library.LayoutError, match="return code DL_PROJECTION is 4 in C, 5"):
        library.check_layout(reported, {}, {"DL_PROJECTION": 5})


def test_a_layout_error_counts_as_a_failed_compile():
    """The C loop then does not apply, with the reason (see test_native)."""
    assert issubclass(library.LayoutError, CompileError)


def test_the_runtime_is_one_translation_unit_of_every_source():
    source = library.runtime_source()
    assert source.count('#include "runtime.h"') == 0
    for name in library.SOURCES:
        assert f"/* ---- {name} ---- */" in source
