"""Loading ``runtime.c`` and the ctypes mirrors of its structs."""

from __future__ import annotations

import contextlib
import ctypes
import threading
from functools import lru_cache
from pathlib import Path

from ...codegen import c_backend

_i64, _ptr, _f64 = ctypes.c_int64, ctypes.c_void_p, ctypes.c_double

#: Return codes of the runtime (OUTPUTS: a step has more outputs than the buffer holds).
OK, SINGULAR_MASS, SINGULAR_CONSTRAINTS, STEP_TOO_SMALL, PROJECTION, OUTPUTS = range(6)


class Function(ctypes.Structure):
    _fields_ = [("fn", _ptr), ("K", _ptr), ("index", _ptr), ("target", _ptr), ("size", _i64)]


class Model(ctypes.Structure):
    _fields_ = [
        *((name, _i64) for name in ("n", "m", "nM", "nA", "n_hol")),
        ("p", _ptr), ("kkt", Function), ("velocity", Function), ("position", Function),
        ("energy", Function),
        ("holonomic", _ptr), ("baumgarte", _f64), ("n_blocks", _i64),
        *((name, _ptr) for name in ("block_start", "slot_coord", "block_mat", "M_at")),
        ("n_pairs", _i64),
        *((name, _ptr) for name in ("pair_row", "pair_block", "pair_vec", "A_at", "block_pairs",
                                    "block_external", "elim_at")),
        ("n_elim_blocks", _i64), ("elim_blocks", _ptr), ("m_band", _i64), ("kd", _i64),
        ("band_row", _ptr), ("gram_start", _ptr), ("gram_target", _ptr),
        ("unit", _ptr), *((name, _i64) for name in ("n_unit", "n_unit_pairs", "n_unit_gram")),
        *((name, _ptr) for name in ("unit_slot", "unit_mat", "unit_pair_vec", "unit_pair_row",
                                    "unit_pair_slot", "unit_pair_mat", "unit_gram_target",
                                    "unit_gram_i", "unit_gram_j")),
        *((name, _ptr) for name in ("values", "vel_values", "psi", "blocks", "a", "y", "u", "S",
                                    "r", "lambda", "qdd", "q_trial", "elim", "error_work",
                                    "active")),
        ("kkt_in_layout", _i64), ("c", _ptr),
    ]


class Tableau(ctypes.Structure):
    _fields_ = [("n_stages", _i64), *((name, _ptr) for name in ("A", "B", "C", "E", "E3")),
                ("n_P", _i64), ("P", _ptr), ("n_extra", _i64),
                ("A_extra", _ptr), ("C_extra", _ptr), ("n_D", _i64), ("D", _ptr)]


class Stepper(ctypes.Structure):
    _fields_ = [*((name, _f64) for name in ("t", "h_abs", "h_previous", "t_bound", "direction",
                                            "rtol", "max_step")),
                ("atol", _ptr), ("nfev", _i64), ("alpha", _f64), ("beta", _f64),
                ("err_old", _f64)]


class Run(ctypes.Structure):
    _fields_ = [("t_eval", _ptr), ("n_eval", _i64), ("next_eval", _i64), ("holonomic", _ptr),
                ("max_newton", _i64), ("max_full", _i64), ("position_tol", _f64),
                ("accept_tol", _f64), ("max_steps", _i64), ("max_seconds", _f64),
                ("capacity", _i64), ("t_out", _ptr), ("y_out", _ptr), ("n_steps", _i64),
                ("n_out", _i64), ("t_old", _f64),
                *((name, _ptr) for name in ("y_new", "y_end", "rows"))]


_LOCK = threading.Lock()


def runtime() -> ctypes.CDLL:
    """The compiled runtime (built once per machine and cached like generated code).

    Raises :class:`~dalembert.codegen.c_backend.CompileError` without a C compiler.
    """
    with _LOCK:  # one compilation, even when prepare_runtime's thread is at it
        return _runtime()


def prepare_runtime() -> None:
    """Start compiling the runtime in the background, if C is the backend.

    Called when a model's code is generated: gcc then runs beside the derivation
    (a cold build on a new machine does not wait for it), and the first simulation
    finds it ready.
    """
    if _runtime.cache_info().currsize or c_backend.backend() != "c":
        return
    threading.Thread(target=_runtime_if_possible, daemon=True).start()


def _runtime_if_possible() -> None:
    # A failure is reported by the first simulation that needs the runtime.
    with contextlib.suppress(c_backend.CompileError):
        runtime()


@lru_cache(maxsize=1)
def _runtime() -> ctypes.CDLL:
    source = (Path(__file__).with_name("runtime.c")).read_text()
    lib = c_backend.source_library(source)
    signatures = {
        "dl_rhs": [_ptr, _f64, _ptr, _ptr, _ptr],
        "dl_project": [_ptr, _f64, _ptr, _ptr, _i64, _i64, _f64, _f64],
        "dl_rk_step": [_ptr] * 7,
        "dl_rk_run": [_ptr] * 7,
        "dl_outputs": [_ptr, _i64, *[_ptr] * 8],
        "dl_stages": [_ptr, _ptr, _i64, _ptr, _i64, _i64, _i64, _f64, _f64, _ptr, _ptr, _ptr,
                      _ptr],
    }
    for name, argtypes in signatures.items():
        fn = getattr(lib, name)
        fn.restype = ctypes.c_int
        fn.argtypes = argtypes
    return lib
