"""SciPy's Radau IIA with each step taken in C, on the KKT structure.

:class:`NativeRadau` is :class:`scipy.integrate.Radau` whose step (``_step_impl``) runs in
``radau.c``: the same simplified Newton iteration, error estimate, step-size control
and reuse of the Jacobian and factors, so its steps are SciPy's to rounding (tested
against :class:`~dalembert.solvers.steppers.scipy_ivp.LinearizedRadau`). Its Newton
systems are the reduced KKT-sized ones of :mod:`dalembert.solvers.newton`, made from
the generated KKT values and the residuals' exact Jacobians and factored by a band LU
in reverse Cuthill-McKee order (:func:`newton_tables`): a step costs time linear in the
mechanism, with no Python inside it. Start-up, dense output and restarts stay SciPy's.

It applies where the exact Jacobian does: no Baumgarte terms, and no inputs computed
from the state at every evaluation (held samples are parameters).
"""

from __future__ import annotations

import ctypes

import numpy as np
import scipy.sparse
from scipy.sparse.csgraph import reverse_cuthill_mckee

from ...codegen.compiled import NumericModel
from ..newton import kept_places, stacked_entries
from ..steppers.scipy_ivp import RadauEnd, SteppedRadau, step_size
from . import library
from .solver import NativeSolver


class NewtonTables:
    """Where the values of the reduced Newton matrix go (``dl_newton``), for one model
    and set of kept rows; C only reads it, so every run of the model shares it.

    Parameters
    ----------
    num
        The compiled equations, their residual Jacobians generated.
    kept
        The constraint rows solved for (``None``: all).
    kkt_place
        Where each of the kkt function's values ``[M, f, A, c]`` is in the C buffer.
    kkt_size
        The size of that buffer.

    Examples
    --------
    The Cartesian pendulum: two coordinates and one rod, three unknowns.

    >>> from dalembert.examples import cartesian_pendulum
    >>> num = cartesian_pendulum.build().numeric()
    >>> _ = num.compiled.functions["residual_jacobians"]
    >>> size = len(num.pattern.M_rows) + 2 + len(num.pattern.A_rows) + 1
    >>> tables = NewtonTables(num, None, np.arange(size), size)
    >>> tables.struct.N, tables.struct.kl + tables.struct.ku <= 4
    (3, True)
    """

    def __init__(self, num: NumericModel, kept: np.ndarray | None, kkt_place: np.ndarray,
                 kkt_size: int) -> None:
        n, m, pattern = num.n, num.m, num.pattern
        rows = np.arange(m) if kept is None else np.asarray(kept, dtype=np.intp)
        place = kept_places(m, rows)
        N = n + len(rows)
        found = num.compiled.functions["residual_jacobians"]
        blocks = dict(zip(("r1_q", "r1_qd", "r2_q", "r2_qd"), found.layout.blocks))
        offsets = dict(zip(blocks, np.cumsum([0, *(b.size for b in blocks.values())])))

        def stacked(r1: str, r2: str) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
            """The Jacobian entries of r1, then r2's kept rows: row, col, source."""
            b1, b2 = blocks[r1], blocks[r2]
            row, col, keep = stacked_entries((b1.index[0], b1.index[1]),
                                             (b2.index[0], b2.index[1]), place, n)
            return row, col, np.concatenate([offsets[r1] + np.arange(b1.size),
                                             offsets[r2] + np.flatnonzero(keep)])

        v_row, v_col, v_src = stacked("r1_qd", "r2_qd")
        q_row, q_col, q_src = stacked("r1_q", "r2_q")
        nM = len(pattern.M_rows)
        a_place = place[pattern.A_rows]
        a_keep = a_place >= 0
        a_rows, a_cols = a_place[a_keep] + n, pattern.A_cols[a_keep]
        a_src = kkt_place[nM + n + np.flatnonzero(a_keep)]
        fixed_row = np.concatenate([pattern.M_rows, a_rows, a_cols])
        fixed_col = np.concatenate([pattern.M_cols, a_cols, a_rows])
        fixed_src = np.concatenate([kkt_place[:nM], a_src, a_src])
        fixed_sign = np.concatenate([np.ones(nM), np.ones(len(a_src)), -np.ones(len(a_src))])
        # the band: reverse Cuthill-McKee on the symmetric pattern of every entry
        i = np.concatenate([fixed_row, v_row, q_row, np.arange(N)])
        j = np.concatenate([fixed_col, v_col, q_col, np.arange(N)])
        graph = scipy.sparse.csr_matrix((np.ones(len(i)), (i, j)), shape=(N, N))
        order = reverse_cuthill_mckee((graph + graph.T).tocsr(), symmetric_mode=True)
        perm = np.empty(N, dtype=np.int64)
        perm[order] = np.arange(N)
        below = perm[i] - perm[j]
        kl, ku = int(max(below.max(), 0)), int(max((-below).max(), 0))
        ldab = 2 * kl + ku + 1

        def dst(r: np.ndarray, c: np.ndarray) -> np.ndarray:
            return perm[c] * ldab + kl + ku + perm[r] - perm[c]

        self._keep = {  # the arrays the struct points to
            "perm": perm, "fixed_src": fixed_src, "fixed_dst": dst(fixed_row, fixed_col),
            "fixed_sign": fixed_sign, "v_src": v_src, "v_dst": dst(v_row, v_col),
            "v_row": v_row, "v_col": v_col, "q_src": q_src, "q_dst": dst(q_row, q_col),
            "q_row": q_row, "q_col": q_col}
        for name, a in self._keep.items():
            dtype = np.float64 if name == "fixed_sign" else np.int64
            self._keep[name] = np.ascontiguousarray(a, dtype=dtype)
        address = {name: a.ctypes.data for name, a in self._keep.items()}
        self.struct = library.Newton(N=N, kl=kl, ku=ku, ldab=ldab, kkt_size=kkt_size,
                                     jac_size=found.layout.size, n_fixed=len(fixed_src),
                                     n_v=len(v_src), n_q=len(q_src), **address)
        #: the sizes of a run's work arrays: m multipliers, N unknowns
        self.m, self.N = m, N


def newton_tables(native: NativeSolver) -> NewtonTables:
    """The :class:`NewtonTables` of ``native``'s model and kept rows (made once, shared).

    Parameters
    ----------
    native
        The run's C solver, made after the residual Jacobians were generated.
    """
    shared, num = native.shared, native.num
    kept_key = None if native.kept is None else native.kept.tobytes()
    size = native.model.fn[library.FUNCTIONS["kkt"]].size
    return num.pattern.remember(
        ("newton tables", kept_key),
        lambda: NewtonTables(num, native.kept, shared.kkt_place, size))


class NativeRadau(SteppedRadau):
    """:class:`scipy.integrate.Radau` stepping in C on the KKT structure (see the module).

    Parameters
    ----------
    fun, t0, y0, t_bound
        As SciPy's solvers take them (``fun``: the run's right-hand side, used for the
        start-up and restarts; the steps evaluate it in C).
    native
        The run's C solver (:class:`~dalembert.solvers.native.solver.NativeSolver`),
        its residual Jacobians generated.
    options
        Radau's other keywords (``rtol``, ``atol``, ``max_step``, ``first_step``).
    """

    def __init__(self, fun, t0, y0, t_bound, *, native: NativeSolver, **options) -> None:
        super().__init__(fun, t0, y0, t_bound, **options)
        n = len(y0)
        self._native = native
        tables = newton_tables(native)
        N, m, nw = tables.N, tables.m, tables.struct
        tolerances = self.tolerances
        self._atol = tolerances.atol
        buffers = {
            "kkt": np.zeros(nw.kkt_size), "jac": np.zeros(max(nw.jac_size, 1)),
            "lu_real": np.zeros(nw.ldab * N), "lu_complex": np.zeros(nw.ldab * N, complex),
            "piv_real": np.zeros(N, np.int64), "piv_complex": np.zeros(N, np.int64),
            "sol_Q": np.zeros(3 * n), "sol_y_old": np.zeros(n),
            "work": np.zeros(max(n + m, n // 2 + 2 * N)),
            "cwork": np.zeros(n + 2 * N, complex), "stage_work": np.zeros(17 * n)}
        self._buffers = buffers  # kept alive: the struct points into them
        # SciPy's Radau makes its first Jacobian at the start; C makes it at the first step
        self._state = library.RadauState(
            t=t0, t_bound=t_bound, direction=self.direction, rtol=tolerances.rtol,
            max_step=tolerances.max_step, newton_tol=self.newton_tolerance,
            atol=self._atol.ctypes.data, h_abs=step_size(self), h_abs_old=-1.0,
            error_norm_old=-1.0, current_jac=1,
            **{name: a.ctypes.data for name, a in buffers.items()})
        self._fixed = (ctypes.addressof(nw), ctypes.addressof(self._state))

    def take_step(self, t: float, y: np.ndarray, f: np.ndarray, h_abs: float
                  ) -> RadauEnd | str:
        st, n = self._state, len(y)
        st.t, st.h_abs = t, h_abs  # the loop may have restarted the solver
        y = np.ascontiguousarray(y, dtype=np.float64)
        f = np.ascontiguousarray(f, dtype=np.float64)
        y_new, f_new, Z = np.empty(n), np.empty(n), np.empty((3, n))
        counts = st.nfev, st.njev, st.nlu
        status = self._native.lib.dl_radau_step(
            *self._native._at, *self._fixed, y.ctypes.data, f.ctypes.data,
            y_new.ctypes.data, f_new.ctypes.data, Z.ctypes.data)
        self.nfev += st.nfev - counts[0]
        self.njev += st.njev - counts[1]
        self.nlu += st.nlu - counts[2]
        if status == library.STEP_TOO_SMALL:
            return self.TOO_SMALL_STEP
        if status == library.NOT_FINITE:  # the loop checks first; said here for other callers
            return "the step would start from values that are not finite"
        self._native._check(status)
        return RadauEnd(st.t_old, y, st.t, y_new, f_new, Z, st.h_abs,
                        None if st.h_abs_old < 0 else st.h_abs_old,
                        None if st.error_norm_old < 0 else st.error_norm_old)
