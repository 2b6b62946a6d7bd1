"""SUNDIALS IDA (through scikit-sundae) on the stabilized index-2 (GGL) form.

``method="IDA"`` integrates :class:`~.ggl.GGLForm` with IDA's variable-order BDF
and the exact Newton matrix (dense; :mod:`.ggl`), so the reference DAE solver is one
keyword away and compares with the other methods in the same process. Choices:

- the multipliers ``lambda`` and ``mu`` are declared algebraic and left out of the
  error test: scikit-sundae does not call ``IDASetSuppressAlg``, so their absolute
  tolerance is made so large that their weights vanish (:data:`ALGEBRAIC_ATOL`), the
  usual way to the same effect; in an index-2 DAE their error estimate does not
  shrink with the step and would otherwise stall it;
- the Newton matrix is exact (:mod:`.ggl`), factored dense up to :data:`DENSE_MAX`
  unknowns and by SuperLU above (compressed columns on the matrix's fixed pattern);
- the start is dalembert's consistent initial state, with the multipliers and
  accelerations of the KKT solve there (no IDA initial-condition calculation);
- with ``t_eval`` the steps are taken one by one and each output time is
  interpolated by IDA once a step passes it (IDA's own dense output); without it
  every step is recorded;
- the result is the state ``[q, v]`` at those times; the trajectory's multipliers and
  accelerations come from the KKT solve there, as for every method.

scikit-sundae is optional (``pip install 'dalembert[stiff]'``); a run asking for IDA
without it is refused with an :class:`ImportError` saying so.
"""

from __future__ import annotations

import time
import warnings

import numpy as np

from ..options import StepControl
from .ggl import CompressedColumns, GGLForm
from .running.loop import IntegrationResult

#: The absolute tolerance given to the algebraic entries (``lambda``, ``mu``): their
#: error weights ``1 / (rtol |y| + atol)`` are then 1e-100, out of the error test.
ALGEBRAIC_ATOL = 1e100
#: IDA's limit on steps per call (one step per call here): effectively none.
MAX_STEPS_PER_CALL = 1_000_000
#: Up to this many unknowns (``2 n + rows + holonomic rows``) IDA factors the Newton
#: matrix dense (SUNDIALS' dense LU), above it sparse (SuperLU_MT, the matrix in
#: compressed columns). Measured on planar chains hanging at 0.5 rad, 1 s, at the
#: default tolerances: 16 links (160 unknowns) dense 0.46 s, sparse 0.71 s; 64 links
#: (640) dense 2.0 s, sparse 1.0 s.
DENSE_MAX = 256


def ida_solver_class() -> type:
    """scikit-sundae's ``IDA`` class, or an ``ImportError`` naming the extra to install.

    >>> ida_solver_class().__name__
    'IDA'
    """
    try:
        from sksundae.ida import IDA
    except ImportError as exc:
        raise ImportError("method='IDA' needs scikit-sundae (SUNDIALS IDA): "
                          "pip install 'dalembert[stiff]' or pip install scikit-sundae"
                          ) from exc
    return IDA


def integrate_ida(form: GGLForm, t_span: tuple[float, float], y0: np.ndarray,
                  t_eval: np.ndarray | None, step: StepControl,
                  deadline: float | None = None) -> IntegrationResult:
    """Integrate the GGL form with IDA from the consistent state ``y0 = [q0, qd0]``.

    Parameters
    ----------
    form
        The model's GGL form (the constraint rows kept).
    t_span
        ``(t0, tf)``.
    y0
        The consistent state ``[q, qd]`` at ``t0``.
    t_eval
        The times to record (``None``: every step).
    step
        The tolerances (``rtol`` a number; ``atol`` a number or one per state entry)
        and the step limits (``first_step``, ``max_step``).
    deadline
        A ``time.monotonic()`` past which the run stops with status ``"timeout"``.

    Returns
    -------
    IntegrationResult
        ``y`` holds the states ``[q, qd]``; ``stats`` IDA's residual evaluations
        (``nfev``), Newton matrices (``njev``) and the steps (``n_steps``).

    Examples
    --------
    The pendulum released from the horizontal reaches the bottom after a quarter of
    the period of a pendulum of amplitude 90 degrees, ``K(1/2) / sqrt(g / l)`` (``K``
    the complete elliptic integral of parameter ``1/2``), 0.59196 s for ``l = 1``,
    ``g = 9.81``:

    >>> from dalembert.examples import cartesian_pendulum
    >>> form = GGLForm(cartesian_pendulum.build().numeric())
    >>> out = integrate_ida(form, (0.0, 0.59196), np.array([1.0, 0.0, 0.0, 0.0]), None,
    ...                     StepControl(rtol=1e-8, atol=1e-10))
    >>> out.status, [round(float(v), 4) + 0.0 for v in out.y[-1, :2]]
    ('finished', [0.0, -1.0])
    """
    IDA = ida_solver_class()
    num = form.num
    n = num.n
    t0, tf = t_span
    q0, qd0 = num.layout.split(y0)
    start, start_rate = form.start(t0, q0, qd0)
    atol = np.full(form.size, ALGEBRAIC_ATOL)
    atol[:2 * n] = step.atol
    options: dict[str, object] = {
        "rtol": float(step.rtol), "atol": atol, "algebraic_idx": form.algebraic,
        "max_num_steps": MAX_STEPS_PER_CALL}
    options.update(_linear_solver(form, t0, start, start_rate))
    if step.first_step is not None:
        options["first_step"] = step.first_step
    if np.isfinite(step.max_step):
        options["max_step"] = step.max_step
    with warnings.catch_warnings():  # "custom sparse Jacobian ... ignored": ours is given
        warnings.filterwarnings("ignore", message="Custom sparse Jacobian")
        solver = IDA(_residual(form), **options)
    solver.init_step(t0, start, start_rate)
    times: list[float] = []
    states: list[np.ndarray] = []
    pending = list(t_eval) if t_eval is not None else []
    forward = tf > t0

    def passed(t_out: float, t_now: float) -> bool:
        return t_out <= t_now if forward else t_out >= t_now

    def record(t: float, y: np.ndarray) -> None:
        times.append(float(t))
        states.append(np.array(y[:2 * n]))

    while pending and pending[0] == t0:
        record(t0, start)
        pending.pop(0)
    if t_eval is None:
        record(t0, start)
    status, message, steps, t_now = "finished", "The solver successfully reached the " \
        "end of the integration interval.", 0, t0
    while t_now != tf:
        out = solver.step(tf, method="onestep", tstop=tf)
        if not out.success:
            status, message = "failed", f"IDA stopped at t={t_now:.6g}: {out.message}"
            break
        steps += 1
        t_now = float(out.t)
        if t_eval is None:
            record(t_now, out.y)
        while pending and passed(pending[0], t_now):
            t_out = pending.pop(0)
            record(t_out, out.y if t_out == t_now else solver.step(t_out).y)
        if deadline is not None and time.monotonic() > deadline and t_now != tf:
            status, message = "timeout", f"the timeout passed at t={t_now:.6g}"
            break
    nfev, njev = _counts(out) if steps else (0, 0)
    y = np.array(states) if states else np.zeros((0, 2 * n))
    return IntegrationResult(t=np.array(times), y=y, status=status, message=message,
                             stats={"nfev": nfev, "njev": njev, "n_steps": steps})


def _counts(out: object) -> tuple[int, int]:
    return int(getattr(out, "nfev", 0)), int(getattr(out, "njev", 0))


def _residual(form: GGLForm):
    def residual(t: float, y: np.ndarray, yp: np.ndarray, res: np.ndarray) -> None:
        res[:] = form.residual(t, y, yp)

    return residual


def _linear_solver(form: GGLForm, t0: float, y0: np.ndarray, yp0: np.ndarray
                   ) -> dict[str, object]:
    """IDA's linear solver and Jacobian function: dense up to :data:`DENSE_MAX`
    unknowns, else sparse on the Newton matrix's pattern."""
    if form.size <= DENSE_MAX:
        def dense(t: float, y: np.ndarray, yp: np.ndarray, res: np.ndarray, cj: float,
                  JJ: np.ndarray) -> None:
            JJ[:, :] = form.newton_matrix(t, y, yp, cj)

        return {"linsolver": "dense", "jacfn": dense}
    from scipy.sparse import csc_matrix

    columns = CompressedColumns.of(form, t0, y0, yp0)

    def sparse(t: float, y: np.ndarray, yp: np.ndarray, res: np.ndarray, cj: float,
               JJ: np.ndarray) -> None:
        JJ[:] = columns.values(form, t, y, yp, cj)

    pattern = csc_matrix((np.ones(len(columns.rows)), (columns.rows, columns.cols)),
                         shape=(form.size, form.size))
    return {"linsolver": "sparse", "sparsity": pattern, "jacfn": sparse}
