"""Loading the C runtime, the ctypes mirrors of its structs, and their check.

The runtime is ``runtime.h`` and the sources listed in :data:`SOURCES`, compiled
together as one translation unit (the header in place of each ``#include``), so
the functions one source calls in another inline as before, and the cache key is
the whole text. Right after loading, :func:`check_layout` compares every mirror
with the sizes and offsets the library reports (``dl_layout``): a field added,
moved or retyped on one side only is named, instead of corrupting memory.
"""

from __future__ import annotations

import contextlib
import ctypes
import threading
from functools import lru_cache
from pathlib import Path

from ...codegen import c_backend
from ...codegen.registry import REGISTRY

_i64, _ptr, _f64 = ctypes.c_int64, ctypes.c_void_p, ctypes.c_double
#: ``int inputs(double t)``, the state in ``input_state`` (see ``runtime.h``).
INPUTS_CALLBACK = ctypes.CFUNCTYPE(ctypes.c_int, _f64)

#: Return codes of the runtime (OUTPUTS: a step has more outputs than the buffer holds;
#: RANK_CHANGED: a dropped dependent row no longer follows from the kept ones;
#: NOT_FINITE: a step would start from a time, step size, state or derivative that is
#: not finite; INPUT: the inputs' callback failed; NEAR_SINGULAR: a stretch ended after
#: a step that ended near a singular configuration; STIFF: a stretch ended after the step
#: that made the stiffness detector say stiff; EVENT: a stretch ended before a step
#: whose end a screen of its events flags).
(OK, SINGULAR_MASS, SINGULAR_CONSTRAINTS, STEP_TOO_SMALL, PROJECTION, OUTPUTS, RANK_CHANGED,
 NOT_FINITE, INPUT, NEAR_SINGULAR, STIFF, EVENT) = range(12)
CODES = {"DL_OK": OK, "DL_SINGULAR_MASS": SINGULAR_MASS,
         "DL_SINGULAR_CONSTRAINTS": SINGULAR_CONSTRAINTS, "DL_STEP_TOO_SMALL": STEP_TOO_SMALL,
         "DL_PROJECTION": PROJECTION, "DL_OUTPUTS": OUTPUTS, "DL_RANK_CHANGED": RANK_CHANGED,
         "DL_NOT_FINITE": NOT_FINITE, "DL_INPUT": INPUT, "DL_NEAR_SINGULAR": NEAR_SINGULAR,
         "DL_STIFF": STIFF, "DL_EVENT": EVENT}
#: The places of the generated functions in ``dl_model.fn`` (``DL_FN_<NAME>``): the
#: registry's ``native`` numbers; ``DL_FN_COUNT`` places in all, functions of at most
#: ``DL_MAX_ARGS`` arguments for ``dl_call``.
FUNCTIONS = {d.name: d.native for d in REGISTRY.values() if d.native is not None}
FN_COUNT, MAX_ARGS = 5, 8
FUNCTION_CODES = {**{f"DL_FN_{name.upper()}": k for name, k in FUNCTIONS.items()},
                  "DL_FN_COUNT": FN_COUNT, "DL_MAX_ARGS": MAX_ARGS}
#: The runtime's sources, after ``runtime.h``, in the order they are compiled.
SOURCES = ("kkt.c", "outputs.c", "projection.c", "screens.c", "friction.c", "runge_kutta.c",
           "radau.c", "functions.c", "layout.c")
HEADER = "runtime.h"


class Function(ctypes.Structure):
    _fields_ = [("fn", _ptr), ("K", _ptr), ("index", _ptr), ("target", _ptr), ("size", _i64),
                ("n_args", _i64)]


class Model(ctypes.Structure):
    """``dl_model``: what is constant for a model (C only reads it; shared by its runs)."""

    _fields_ = [
        *((name, _i64) for name in ("n", "m", "nM", "nA", "n_hol")),
        ("fn", Function * FN_COUNT), ("holonomic", _ptr), ("baumgarte", _f64),
        ("n_blocks", _i64),
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
        ("kkt_in_layout", _i64), ("n_dropped_pairs", _i64), ("n_dropped", _i64),
        ("dropped_rows", _ptr), ("dropped_rtol", _f64),
    ]


class Factor(ctypes.Structure):
    """``dl_factor``: what the held KKT factors were made from (inside :class:`Data`)."""

    _fields_ = [("active", _ptr), ("mask", _ptr), ("fold", _ptr), ("rows", _ptr),
                ("factored", _i64)]


class Data(ctypes.Structure):
    """``dl_data``: everything one run writes (its parameter vector, work arrays,
    factorization and inputs); one per run, over a shared :class:`Model`."""

    _fields_ = [
        ("p", _ptr),
        *((name, _ptr) for name in ("values", "vel_values", "psi", "blocks", "a", "y", "u", "S",
                                    "r", "lambda", "qdd", "q_trial", "elim", "error_work", "c")),
        ("factor", Factor), ("inputs", _ptr), ("input_state", _ptr), ("conditioning", _f64),
        ("gram_diagonal", _ptr), ("unit_mass", _ptr), ("unit_root", _ptr), ("friction", _ptr),
        ("looking", _i64),
    ]


class Friction(ctypes.Structure):
    """``dl_friction``: the friction forces of a segment's sliding contacts, computed
    before each evaluation (:mod:`.friction`)."""

    _fields_ = [("n_sliding", _i64),
                *((name, _ptr) for name in ("normal", "start", "slot", "term_start",
                                            "term_value", "term_col", "mu",
                                            "start_direction")),
                ("velocity", Function), ("p", _ptr), ("vel", _ptr),
                ("onset", _ptr), ("tangent_row", _ptr), ("last_direction", _ptr),
                ("kkt", Function), ("kkt_values", _ptr), ("c_at", _i64), ("iterations", _i64),
                ("free_steps", _i64),
                ("difference", _f64), ("rounding", _f64), ("smallest_step", _f64),
                ("stalled", _f64),
                ("n_copy", _i64),
                ("copy_from", _ptr), ("copy_to", _ptr), ("run_velocity", Function),
                ("run_vel", _ptr), ("n_group", _i64), ("n_group_kept", _i64),
                *((name, _ptr) for name in ("group_row", "group_start", "group_entry",
                                            "group_col")),
                ("dependent_rtol", _f64), ("work", _ptr)]


class Tableau(ctypes.Structure):
    _fields_ = [("n_stages", _i64), *((name, _ptr) for name in ("A", "B", "C", "E", "E3")),
                ("n_P", _i64), ("P", _ptr), ("n_extra", _i64),
                ("A_extra", _ptr), ("C_extra", _ptr), ("n_D", _i64), ("D", _ptr)]


class Stepper(ctypes.Structure):
    _fields_ = [*((name, _f64) for name in ("t", "h_abs", "h_previous", "t_bound", "direction",
                                            "rtol", "max_step")),
                ("atol", _ptr), ("nfev", _i64), ("alpha", _f64), ("beta", _f64),
                ("err_old", _f64), ("safety", _f64), ("min_factor", _f64),
                ("max_factor", _f64), ("error_floor", _f64), ("h_lambda", _f64),
                ("stiff_limit", _f64), *((name, _i64) for name in (
                    "stiff_after", "calm_after", "stiff_count", "calm_count"))]


class Screens(ctypes.Structure):
    """``dl_screens``: the screens of a stretch's events (:mod:`.screens`)."""

    _fields_ = [("position", Function), ("velocity", Function),
                *((name, _ptr) for name in ("p", "psi", "vel")),
                ("n_position", _i64), ("pos_at", _ptr), ("pos_floor", _ptr),
                ("n_rate", _i64),
                *((name, _ptr) for name in ("rate_start", "rate_value", "rate_col",
                                            "rate_weight", "rate_floor")),
                ("n_force", _i64), ("force_row", _ptr), ("n_cone", _i64),
                *((name, _ptr) for name in ("cone_normal", "cone_start", "cone_tangent",
                                            "cone_mu")),
                ("margin", _f64), ("force_rtol", _f64), ("lambda", _ptr), ("ydot", _ptr),
                ("run_velocity", Function), ("run_vel", _ptr), ("n_group", _i64),
                ("n_group_kept", _i64),
                *((name, _ptr) for name in ("group_row", "group_start", "group_entry",
                                            "group_col")),
                ("n_held", _i64), ("n_held_kept", _i64),
                *((name, _ptr) for name in ("held_row", "held_normal", "held_start",
                                            "held_entry", "held_col")),
                ("dependent_rtol", _f64), ("spread", _ptr), ("work", _ptr)]


class Run(ctypes.Structure):
    _fields_ = [("t_eval", _ptr), ("n_eval", _i64), ("next_eval", _i64), ("holonomic", _ptr),
                ("max_newton", _i64), ("max_full", _i64), ("position_tol", _f64),
                ("accept_tol", _f64), ("max_steps", _i64), ("max_seconds", _f64),
                ("capacity", _i64), ("t_out", _ptr), ("y_out", _ptr), ("n_steps", _i64),
                ("n_out", _i64), ("t_old", _f64),
                *((name, _ptr) for name in ("y_new", "y_end", "rows")), ("near2", _f64),
                ("screens", _ptr)]


class Newton(ctypes.Structure):
    """``dl_newton``: where the values of an implicit step's reduced Newton matrix go
    (constant for a model and its kept rows)."""

    _fields_ = [*((name, _i64) for name in ("N", "kl", "ku", "ldab")), ("perm", _ptr),
                ("kkt_size", _i64), ("jac_size", _i64), ("n_fixed", _i64),
                *((name, _ptr) for name in ("fixed_src", "fixed_dst", "fixed_sign")),
                ("n_v", _i64), *((name, _ptr) for name in ("v_src", "v_dst", "v_row", "v_col")),
                ("n_q", _i64), *((name, _ptr) for name in ("q_src", "q_dst", "q_row", "q_col"))]


class RadauState(ctypes.Structure):
    """``dl_radau``: one Radau solver's state between steps and its work arrays."""

    _fields_ = [*((name, _f64) for name in ("t", "t_old", "t_bound", "direction", "rtol",
                                            "max_step", "newton_tol")),
                ("atol", _ptr), *((name, _f64) for name in ("h_abs", "h_abs_old",
                                                            "error_norm_old")),
                *((name, _i64) for name in ("current_jac", "jac_ready", "lu_ready", "nfev",
                                            "njev", "nlu")),
                ("kkt", _ptr), ("jac", _ptr),
                *((name, _f64) for name in ("c_real", "c_complex_re", "c_complex_im")),
                *((name, _ptr) for name in ("lu_real", "lu_complex", "piv_real",
                                            "piv_complex")),
                ("has_sol", _i64), ("sol_t_old", _f64), ("sol_h", _f64),
                *((name, _ptr) for name in ("sol_Q", "sol_y_old", "work", "cwork",
                                            "stage_work"))]


#: The C struct each mirror stands for.
MIRRORS: dict[str, type[ctypes.Structure]] = {
    "dl_function": Function, "dl_model": Model, "dl_factor": Factor, "dl_data": Data,
    "dl_friction": Friction, "dl_tableau": Tableau,
    "dl_stepper": Stepper, "dl_run": Run, "dl_screens": Screens, "dl_newton": Newton,
    "dl_radau": RadauState}


class LayoutError(c_backend.CompileError):
    """A ctypes mirror does not match its C struct (treated as a failed compile: the C
    loop does not apply).

    Internal control flow, never seen by a user: :func:`~dalembert.solvers.native.native_solver`
    turns it into :class:`~dalembert.solvers.native.structure.NotApplicable`."""


class _Entry(ctypes.Structure):
    _fields_ = [("name", ctypes.c_char_p), ("value", _i64)]


def layout(lib: ctypes.CDLL) -> dict[str, int]:
    """What ``dl_layout`` reports: ``{"dl_model": sizeof, "dl_model.n": offsetof,
    ..., "DL_OK": 0, ...}``.

    Parameters
    ----------
    lib
        The loaded runtime.
    """
    table = ctypes.POINTER(_Entry)()
    count = lib.dl_layout(ctypes.byref(table))
    return {table[k].name.decode(): int(table[k].value) for k in range(count)}


def check_layout(reported: dict[str, int],
                 mirrors: dict[str, type[ctypes.Structure]] | None = None,
                 codes: dict[str, int] | None = None) -> None:
    """Raise :class:`LayoutError` naming the first struct and field (or return code)
    where the mirrors differ from the C library's layout.

    Parameters
    ----------
    reported
        The library's layout (:func:`layout`).
    mirrors
        C struct name -> its ctypes mirror (default :data:`MIRRORS`).
    codes
        C return code name -> its value here (default :data:`CODES` and
        :data:`FUNCTION_CODES`).
    """
    mirrors = MIRRORS if mirrors is None else mirrors
    codes = {**CODES, **FUNCTION_CODES} if codes is None else codes
    for struct, mirror in mirrors.items():
        names = [f[0] for f in mirror._fields_]
        in_c = [key.split(".", 1)[1] for key in reported if key.startswith(struct + ".")]
        for name in in_c:
            if name not in names:
                raise LayoutError(f"{struct}.{name} is in the C runtime but not in its "
                                  f"mirror {mirror.__name__}")
        for name in names:
            if name not in in_c:
                raise LayoutError(f"{struct}.{name}: the mirror {mirror.__name__} has a "
                                  "field the C runtime does not")
            at, offset = reported[f"{struct}.{name}"], getattr(mirror, name).offset
            if at != offset:
                raise LayoutError(f"{struct}.{name} is at byte {at} in C, {offset} in the "
                                  f"mirror {mirror.__name__}")
        if reported.get(struct) != ctypes.sizeof(mirror):
            raise LayoutError(f"{struct} has {reported.get(struct)} bytes in C, "
                              f"{ctypes.sizeof(mirror)} in the mirror {mirror.__name__}")
    for name, value in codes.items():
        if reported.get(name) != value:
            raise LayoutError(f"return code {name} is {reported.get(name)} in C, {value} here")


_LOCK = threading.Lock()


def runtime() -> ctypes.CDLL:
    """The compiled runtime (built once per machine and cached like generated code).

    Raises :class:`~dalembert.codegen.c_backend.CompileError` without a C compiler
    or when the runtime cannot be built, stored or loaded, and :class:`LayoutError`
    (one) when a mirror does not match the library; either is also said once per
    reason as a :class:`~dalembert.errors.NativeUnavailableWarning` (the simulation
    then takes the slower Python loop).
    """
    with _LOCK:  # one compilation, even when prepare_runtime's thread is at it
        try:
            return _runtime()
        except c_backend.CompileError as exc:
            c_backend.warn_unavailable(c_backend.RUNTIME, exc)
            raise


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
    # A failure is reported (and warned about) by the first simulation that needs the
    # runtime, in the caller's thread.
    with _LOCK, contextlib.suppress(c_backend.CompileError):
        _runtime()


@lru_cache(maxsize=1)
def _runtime() -> ctypes.CDLL:
    lib = c_backend.source_library(runtime_source())
    signatures = {
        # (model, data, ...) each
        "dl_rhs": [_ptr, _ptr, _f64, _ptr, _ptr, _ptr],
        "dl_project": [_ptr, _ptr, _f64, _ptr, _ptr, _i64, _i64, _f64, _f64],
        "dl_kkt_factor": [_ptr] * 4,
        "dl_kkt_solve": [_ptr, _ptr, _i64, _ptr, _i64, _ptr],
        "dl_rk_step": [_ptr] * 8,
        "dl_rk_run": [_ptr] * 8,
        "dl_outputs": [_ptr, _ptr, _i64, *[_ptr] * 8],
        "dl_inputs": [_ptr, _ptr, _i64, _ptr, _ptr, _i64, _i64, _ptr],
        "dl_stages": [_ptr, _ptr, _ptr, _i64, _ptr, _i64, _i64, _i64, _f64, _f64, _ptr, _ptr,
                      _ptr, _ptr],
        "dl_call": [_ptr, _ptr, _i64, _ptr, _ptr],
        "dl_radau_step": [_ptr] * 9,
        "dl_radau_run": [_ptr] * 8,
    }
    for name, argtypes in signatures.items():
        fn = getattr(lib, name)
        fn.restype = ctypes.c_int
        fn.argtypes = argtypes
    lib.dl_layout.restype, lib.dl_layout.argtypes = _i64, [ctypes.POINTER(ctypes.POINTER(_Entry))]
    check_layout(layout(lib))
    return lib


def runtime_source() -> str:
    """The runtime as one translation unit: ``runtime.h``, then each source without its
    ``#include "runtime.h"`` (the text is the cache key, so every file is in it)."""
    here = Path(__file__).parent
    include = f'#include "{HEADER}"'
    parts = [(here / HEADER).read_text()]
    for name in SOURCES:
        text = (here / name).read_text().replace(include, "", 1)
        parts.append(f"/* ---- {name} ---- */\n" + text)
    return "\n".join(parts)
