"""The implicit solvers' linear systems ``(I - c J) x = b`` on the KKT structure.

For the first-order system ``y = [q, v]``, ``y' = F = [v, qdd(q, v)]`` with ``qdd``
and the multipliers ``lambda`` from the KKT residuals

    r1 = M(q) qdd - f(q, v) - A(q)^T lambda = 0,      r2 = A(q) qdd - c(q, v) = 0,

an implicit step solves with ``I - c J`` (``J = dF/dy``, ``c`` the step size times a
method's constant). Written out for ``x = [x_q, x_v]`` and ``b = [b_q, b_v]``,

    x_q - c x_v = b_q,      x_v - c (qdd_q x_q + qdd_v x_v) = b_v,

and ``w = qdd_q x_q + qdd_v x_v`` is the change of ``qdd`` along ``x``, which
differentiating the residuals gives with a change ``l`` of the multipliers:
``M w - A^T l + r1_q x_q + r1_v x_v = 0`` and ``A w + r2_q x_q + r2_v x_v = 0``.
With ``x_v = b_v + c w`` and ``x_q = s + c^2 w`` (``s = b_q + c b_v``) this is one
system of the KKT matrix's size and sparsity,

    [ M + c r1_v + c^2 r1_q    -A^T ] [ w ]     [ -r1_q s - r1_v b_v ]
    [ A + c r2_v + c^2 r2_q      0  ] [ l ]  =  [ -r2_q s - r2_v b_v ],

whose blocks are the generated KKT values and the residuals' exact Jacobians
(the registry's ``residual_jacobians``). ``J`` itself, dense (``2 n x 2 n``) and a
KKT solve per column, is never formed; as ``c -> 0`` the matrix is the KKT matrix.
With dependent constraints the kept rows are solved for, as in the dynamics. ``c`` may
be complex (Radau IIA's complex pair of eigenvalues): the matrix is then complex.

:class:`DenseLinearization` is the same contract on a dense Jacobian (forward
differences where the exact one does not apply: Baumgarte's terms, inputs computed
from the state).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Protocol

import numpy as np
import scipy.linalg
import scipy.sparse
import scipy.sparse.linalg

from ..codegen.compiled import NumericModel
from .jacobian import residual_jacobians_at


class Linearization(Protocol):
    """The first-order system linearized at one state: solves with ``I - c J``."""

    def factor(self, c: complex) -> Callable[[np.ndarray], np.ndarray]:
        """A solve ``b -> x`` of ``(I - c J) x = b``; raises
        ``numpy.linalg.LinAlgError`` if the matrix is singular."""
        ...


#: ``linearize(t, y, f)``: the linearization at ``(t, y)`` (``f``: the right-hand side
#: there, for a linearization that differentiates it).
Linearize = Callable[[float, np.ndarray, np.ndarray], Linearization]


class DenseLinearization:
    """A dense Jacobian ``J`` as a :class:`Linearization` (an LU of ``I - c J``).

    Parameters
    ----------
    J
        ``dF/dy``, ``n x n``.

    Examples
    --------
    >>> DenseLinearization(np.array([[-2.0]])).factor(0.5)(np.array([4.0]))  # (1 + 1) x = 4
    array([2.])
    """

    def __init__(self, J: np.ndarray) -> None:
        self.J = np.asarray(J, dtype=float)

    def factor(self, c: complex) -> Callable[[np.ndarray], np.ndarray]:
        """A solve ``b -> x`` of ``(I - c J) x = b``.

        Parameters
        ----------
        c
            The step size times the method's constant (real or complex).
        """
        lu = scipy.linalg.lu_factor(np.eye(len(self.J)) - c * self.J, check_finite=False)
        if not np.all(np.isfinite(lu[0])) or np.any(np.diag(lu[0]) == 0):
            raise np.linalg.LinAlgError("I - c J is singular")
        return lambda b: scipy.linalg.lu_solve(lu, b, check_finite=False)


class _DenseLinearize:
    """``linearize(t, y, f)`` from a dense Jacobian (see :func:`dense_linearization`)."""

    def __init__(self, jac: Callable[[float, np.ndarray], np.ndarray]) -> None:
        self.jac = jac

    def __call__(self, t: float, y: np.ndarray, f: np.ndarray) -> DenseLinearization:
        return DenseLinearization(self.jac(t, y))

    @property
    def evaluations(self) -> int:
        """The right-hand side's calls in the Jacobians (forward differences: counted
        in ``nfev`` by :func:`~dalembert.solvers.running.integrate.integrate`)."""
        return getattr(self.jac, "evaluations", 0)


def dense_linearization(jac: Callable[[float, np.ndarray], np.ndarray]) -> Linearize:
    """``linearize(t, y, f)`` from a dense Jacobian ``jac(t, y)``.

    Parameters
    ----------
    jac
        ``dF/dy`` at ``(t, y)``.

    Examples
    --------
    >>> lin = dense_linearization(lambda t, y: -np.eye(2))(0.0, np.ones(2), -np.ones(2))
    >>> lin.factor(1.0)(np.array([2.0, 4.0]))
    array([1., 2.])
    """
    return _DenseLinearize(jac)


def kept_places(m: int, rows: np.ndarray) -> np.ndarray:
    """Each constraint row's place among the kept ``rows`` (-1: not kept).

    Parameters
    ----------
    m
        The number of constraint rows.
    rows
        The kept rows.

    Examples
    --------
    >>> kept_places(4, np.array([0, 2, 3]))
    array([ 0, -1,  1,  2])
    """
    place = np.full(m, -1)
    place[rows] = np.arange(len(rows))
    return place


def stacked_entries(r1: tuple[np.ndarray, np.ndarray], r2: tuple[np.ndarray, np.ndarray],
                    place: np.ndarray, n: int
                    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The entries ``(rows, cols)`` of an ``r1`` block (``n`` rows), then those of an
    ``r2`` block on kept constraint rows, placed after ``n``: the reduced matrix's rows,
    columns, and which of ``r2``'s entries were kept.

    Parameters
    ----------
    r1, r2
        The blocks' row and column indices (``r2``'s rows: constraint rows).
    place
        Each constraint row's place among the kept (:func:`kept_places`).
    n
        The number of coordinates.

    Examples
    --------
    >>> rows, cols, keep = stacked_entries((np.array([0]), np.array([1])),
    ...                                    (np.array([0, 1]), np.array([0, 0])),
    ...                                    kept_places(2, np.array([1])), 2)
    >>> rows, cols, keep
    (array([0, 2]), array([1, 0]), array([False,  True]))
    """
    r2_place = place[r2[0]]
    keep = r2_place >= 0
    return (np.concatenate([r1[0], r2_place[keep] + n]),
            np.concatenate([r1[1], r2[1][keep]]), keep)


class _Assembly:
    """Where each value of the reduced matrix goes (see the module), fixed by the
    model's patterns: the matrix ``[[M + c r1_v + c^2 r1_q, -A^T], [A + c r2_v + c^2
    r2_q, 0]]`` in compressed columns, made from the values by one ``bincount``."""

    def __init__(self, num: NumericModel, rows: np.ndarray, jac) -> None:
        n, m = num.n, num.m
        place = kept_places(m, rows)
        self.n, self.size = n, n + len(rows)
        pattern = num.pattern
        a_place = place[pattern.A_rows]
        self.a_keep = a_place >= 0
        a_rows, a_cols = a_place[self.a_keep] + n, pattern.A_cols[self.a_keep]

        self.q_rows, self.q_cols, self.q_keep = stacked_entries(
            (jac.r1_q.rows, jac.r1_q.cols), (jac.r2_q.rows, jac.r2_q.cols), place, n)
        self.v_rows, self.v_cols, self.v_keep = stacked_entries(
            (jac.r1_qd.rows, jac.r1_qd.cols), (jac.r2_qd.rows, jac.r2_qd.cols), place, n)
        i = np.concatenate([pattern.M_rows, a_rows, a_cols, self.v_rows, self.q_rows])
        j = np.concatenate([pattern.M_cols, a_cols, a_rows, self.v_cols, self.q_cols])
        order = np.lexsort((i, j))  # by column, then row
        key = j[order] * self.size + i[order]
        first = np.r_[True, key[1:] != key[:-1]]
        self.slot = np.empty(len(i), dtype=np.intp)
        self.slot[order] = np.cumsum(first) - 1  # each value's place among the unique
        self.indices = i[order][first]
        self.indptr = np.searchsorted(j[order][first], np.arange(self.size + 1))
        self.n_unique = int(first.sum())
        self.lengths = np.cumsum([len(pattern.M_rows), len(a_rows), len(a_rows),
                                  len(self.v_rows)])

    def matrix(self, Mv: np.ndarray, Av: np.ndarray, v_values: np.ndarray,
               q_values: np.ndarray, c: complex) -> scipy.sparse.csc_matrix:
        values = np.concatenate([Mv, Av, -Av, c * v_values, (c * c) * q_values])
        data = np.bincount(self.slot, weights=values.real, minlength=self.n_unique)
        if np.iscomplexobj(values):
            data = data + 1j * np.bincount(self.slot, weights=values.imag,
                                           minlength=self.n_unique)
        return scipy.sparse.csc_matrix((data, self.indices, self.indptr),
                                       shape=(self.size, self.size))


class KKTLinearization:
    """The first-order system linearized at one state (see the module); ``factor(c)``
    solves with ``I - c J``.

    Parameters
    ----------
    num
        The compiled equations bound to parameter values (the inputs as they stand in
        its parameter vector).
    kept
        The constraint rows solved for (``None``: all).
    t, y
        The state ``[q, v]`` and its time.
    assembly
        Where the values go, from an earlier linearization of the same model and rows
        (``None``: worked out here).

    Examples
    --------
    The Cartesian pendulum: the solve agrees with ``I - c J`` of the dense Jacobian.

    >>> from dalembert.examples import cartesian_pendulum
    >>> from dalembert.solvers.jacobian import first_order_jacobian
    >>> num = cartesian_pendulum.build().numeric()
    >>> y = np.array([0.6, -0.8, 0.8, 0.6])
    >>> b = np.array([0.1, 0.2, -0.3, 0.4])
    >>> x = KKTLinearization(num, None, 0.0, y).factor(0.01)(b)
    >>> J = first_order_jacobian(num)(0.0, y)
    >>> bool(np.allclose((np.eye(4) - 0.01 * J) @ x, b, atol=1e-14))
    True
    """

    def __init__(self, num: NumericModel, kept: np.ndarray | None, t: float,
                 y: np.ndarray, assembly: _Assembly | None = None) -> None:
        q, v = num.layout.split(y)
        jac, _, Mv, Av = residual_jacobians_at(num, kept, t, q, v)
        rows = np.arange(num.m) if kept is None else np.asarray(kept, dtype=np.intp)
        self.assembly = _Assembly(num, rows, jac) if assembly is None else assembly
        a = self.assembly
        self._Mv, self._Av = Mv, Av[a.a_keep]
        self._q = np.concatenate([jac.r1_q.values, jac.r2_q.values[a.q_keep]])
        self._v = np.concatenate([jac.r1_qd.values, jac.r2_qd.values[a.v_keep]])

    def factor(self, c: complex) -> Callable[[np.ndarray], np.ndarray]:
        """A solve ``b -> x`` of ``(I - c J) x = b``.

        Parameters
        ----------
        c
            The step size times the method's constant (real or complex).

        Raises
        ------
        numpy.linalg.LinAlgError
            The matrix is singular (a singular configuration, or ``1 / c`` an
            eigenvalue of ``J``).
        """
        a = self.assembly
        n, size = a.n, a.size
        try:
            lu = scipy.sparse.linalg.splu(a.matrix(self._Mv, self._Av, self._v, self._q, c))
        except RuntimeError as e:  # SuperLU: "Factor is exactly singular"
            raise np.linalg.LinAlgError(str(e)) from None
        q_values, v_values = self._q, self._v

        def solve(b: np.ndarray) -> np.ndarray:
            b_q, b_v = b[:n], b[n:]
            s = b_q + c * b_v
            rhs = -(_product(a.q_rows, a.q_cols, q_values, s, size)
                    + _product(a.v_rows, a.v_cols, v_values, b_v, size))
            w = lu.solve(rhs)[:n]
            return np.concatenate([s + (c * c) * w, b_v + c * w])

        return solve


def _product(rows: np.ndarray, cols: np.ndarray, values: np.ndarray, x: np.ndarray,
             size: int) -> np.ndarray:
    """``B @ x`` for ``B`` given by entries (complex ``x`` too)."""
    terms = values * x[cols]
    out = np.bincount(rows, weights=terms.real, minlength=size)
    if np.iscomplexobj(terms):
        out = out + 1j * np.bincount(rows, weights=terms.imag, minlength=size)
    return out


def kkt_linearization(num: NumericModel, kept: np.ndarray | None) -> Linearize:
    """``linearize(t, y, f)``: the :class:`KKTLinearization` at ``(t, y)``.

    Parameters
    ----------
    num
        The compiled equations bound to parameter values.
    kept
        The constraint rows solved for (``None``: all).

    Examples
    --------
    >>> from dalembert.examples import cartesian_pendulum
    >>> num = cartesian_pendulum.build().numeric()
    >>> lin = kkt_linearization(num, None)(0.0, np.array([0.6, -0.8, 0.0, 0.0]), np.zeros(4))
    >>> lin.factor(0.0)(np.ones(4))   # c = 0: the identity
    array([1., 1., 1., 1.])
    """
    assembly: list[_Assembly] = []  # worked out at the first state, kept for the others

    def linearize(t: float, y: np.ndarray, f: np.ndarray) -> KKTLinearization:
        lin = KKTLinearization(num, kept, t, y, assembly[0] if assembly else None)
        assembly[:1] = [lin.assembly]
        return lin

    return linearize
