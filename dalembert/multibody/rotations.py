"""Euler parameters (unit quaternions) ``b = (b0, b1, b2, b3)``, scalar first.

Convention (Nikravesh / Haug, with the body-frame matrix called ``E`` here)::

    E(b) = [[-b1,  b0,  b3, -b2],        G(b) = [[-b1,  b0, -b3,  b2],
            [-b2, -b3,  b0,  b1],                [-b2,  b3,  b0, -b1],
            [-b3,  b2, -b1,  b0]]                [-b3, -b2,  b1,  b0]]

    w_body  = 2 E(b) bdot        w_world = 2 G(b) bdot        R(b) = G(b) E(b)^T

``R`` maps body-frame components to world components (``r_world = R r_body``) and
equals ``(2 b0^2 - 1) I + 2 (v v^T + b0 [v]x)`` with ``v = (b1, b2, b3)``. For a
unit ``b``: ``E E^T = G G^T = I3``, ``E b = G b = 0`` and ``E^T E = I4 - b b^T``,
so ``bdot = 1/2 E^T w_body = 1/2 G^T w_world`` and a body torque ``tau`` does the
virtual work of the generalized force ``2 E^T tau_body = 2 G^T tau_world`` on ``b``.

Every function takes SymPy input (returning ``sympy.Matrix``) or NumPy input of
shape ``(..., 4)`` (returning arrays of shape ``(..., 3, 4)`` or ``(..., 3, 3)``).

>>> b = quaternion_from_matrix(rotation_matrix(np.array([0.5, 0.5, 0.5, 0.5])))
>>> np.allclose(b, 0.5)
True
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any, TypeAlias

import numpy as np
import sympy as sp
from numpy.typing import ArrayLike

from .types import FloatArray

_AXES = {"x": 0, "y": 1, "z": 2}
#: Euler parameters: SymPy (a matrix or 4 expressions) or numbers of shape ``(..., 4)``.
Quaternions: TypeAlias = sp.MatrixBase | Sequence[sp.Expr] | ArrayLike
#: A ``sympy.Matrix`` for SymPy input, else an array.
MatrixOrArray: TypeAlias = sp.Matrix | FloatArray


def _is_symbolic(b: Any) -> bool:
    if isinstance(b, np.ndarray) and b.dtype != object:
        return False  # numbers: no need to look at each element
    return isinstance(b, sp.MatrixBase) or any(isinstance(v, sp.Basic) for v in b)


def _assemble(rows: list[list[Any]], symbolic: bool) -> MatrixOrArray:
    if symbolic:
        return sp.Matrix(rows)
    out = np.array(rows, dtype=float)  # (rows, columns, *batch)
    return out.transpose(*range(2, out.ndim), 0, 1)  # (*batch, rows, columns)


def _split(b: Any) -> tuple[Any, Any, Any, Any]:
    if _is_symbolic(b):
        return tuple(b)
    b = np.asarray(b, dtype=float)
    if b.shape[-1] != 4:
        raise ValueError(f"Euler parameters need 4 components, got shape {b.shape}")
    if b.ndim == 1:  # one quaternion: Python floats are cheaper than 0-d arrays
        return float(b[0]), float(b[1]), float(b[2]), float(b[3])
    return b[..., 0], b[..., 1], b[..., 2], b[..., 3]


def E_matrix(b: Quaternions) -> MatrixOrArray:
    """Body-frame matrix: ``w_body = 2 E(b) bdot``.

    Parameters
    ----------
    b
        Euler parameters: SymPy (a matrix or 4 expressions) or numbers ``(..., 4)``.

    Examples
    --------
    >>> bool(np.array_equal(E_matrix(np.array([1.0, 0.0, 0.0, 0.0]))[:, 1:], np.eye(3)))
    True
    """
    symbolic = _is_symbolic(b)
    b0, b1, b2, b3 = _split(b)
    rows = [[-b1, b0, b3, -b2], [-b2, -b3, b0, b1], [-b3, b2, -b1, b0]]
    return _assemble(rows, symbolic)


def G_matrix(b: Quaternions) -> MatrixOrArray:
    """World-frame matrix: ``w_world = 2 G(b) bdot``.

    Parameters
    ----------
    b
        Euler parameters: SymPy (a matrix or 4 expressions) or numbers ``(..., 4)``.

    Examples
    --------
    >>> b = sp.symbols("b0:4")
    >>> G_matrix(b) * sp.Matrix(b) == sp.zeros(3, 1)   # G b = 0
    True
    """
    symbolic = _is_symbolic(b)
    b0, b1, b2, b3 = _split(b)
    rows = [[-b1, b0, -b3, b2], [-b2, b3, b0, -b1], [-b3, -b2, b1, b0]]
    return _assemble(rows, symbolic)


def rotation_matrix(b: Quaternions) -> MatrixOrArray:
    """``R(b) = G(b) E(b)^T`` (body to world), written out as quadratic polynomials.

    Parameters
    ----------
    b
        Euler parameters: SymPy (a matrix or 4 expressions) or numbers ``(..., 4)``.

    Examples
    --------
    A half turn about ``z``, ``b = (cos 90deg, 0, 0, sin 90deg)``:

    >>> rotation_matrix(np.array([0.0, 0.0, 0.0, 1.0])).tolist()
    [[-1.0, 0.0, 0.0], [0.0, -1.0, 0.0], [0.0, 0.0, 1.0]]
    """
    symbolic = _is_symbolic(b)
    b0, b1, b2, b3 = _split(b)
    rows = [
        [b0**2 + b1**2 - b2**2 - b3**2, 2 * (b1 * b2 - b0 * b3), 2 * (b1 * b3 + b0 * b2)],
        [2 * (b1 * b2 + b0 * b3), b0**2 - b1**2 + b2**2 - b3**2, 2 * (b2 * b3 - b0 * b1)],
        [2 * (b1 * b3 - b0 * b2), 2 * (b2 * b3 + b0 * b1), b0**2 - b1**2 - b2**2 + b3**2],
    ]
    return _assemble(rows, symbolic)


def quaternion_from_matrix(R: ArrayLike) -> FloatArray:
    """Unit Euler parameters with ``b0 >= 0`` of a rotation matrix (Shepperd's method).

    The largest of ``b0^2..b3^2`` is taken from the trace and diagonal, the others
    from off-diagonal sums, so no division by a small number occurs.

    Parameters
    ----------
    R
        Rotation matrices ``(..., 3, 3)``.

    Examples
    --------
    >>> quaternion_from_matrix(np.diag([-1.0, -1.0, 1.0])).tolist()
    [0.0, 0.0, 0.0, 1.0]
    """
    R = np.asarray(R, dtype=float)
    if R.shape[-2:] != (3, 3):
        raise ValueError(f"a rotation matrix is 3x3, got shape {R.shape}")
    flat = R.reshape(-1, 3, 3)
    # one 3x3 at a time in Python floats: a dozen operations on 0-d arrays cost more
    out = np.array([_shepperd(m) for m in flat.tolist()]).reshape(-1, 4)
    out /= np.sqrt(np.einsum("ki,ki->k", out, out))[:, None]
    out[out[:, 0] < 0] *= -1.0  # b and -b are the same rotation: b0 >= 0
    return out.reshape((*R.shape[:-2], 4))


def _shepperd(R: list[list[float]]) -> list[float]:
    """The Euler parameters of one rotation matrix, not yet normalized."""
    tr = R[0][0] + R[1][1] + R[2][2]
    d = (tr, R[0][0], R[1][1], R[2][2])
    k = max(range(4), key=d.__getitem__)
    if k == 0:
        b0 = 0.5 * math.sqrt(1.0 + tr)
        return [b0, (R[2][1] - R[1][2]) / (4 * b0), (R[0][2] - R[2][0]) / (4 * b0),
                (R[1][0] - R[0][1]) / (4 * b0)]
    i = k - 1
    j, l = (i + 1) % 3, (i + 2) % 3
    bi = 0.5 * math.sqrt(1.0 + 2 * R[i][i] - tr)
    b = [(R[l][j] - R[j][l]) / (4 * bi), 0.0, 0.0, 0.0]
    b[1 + i] = bi
    b[1 + j] = (R[j][i] + R[i][j]) / (4 * bi)
    b[1 + l] = (R[l][i] + R[i][l]) / (4 * bi)
    return b


def elementary_rotation(axis: str, angle: float) -> FloatArray:
    """Rotation by ``angle`` about the coordinate axis ``"x"``, ``"y"`` or ``"z"``.

    Parameters
    ----------
    axis
        ``"x"``, ``"y"`` or ``"z"`` (either case).
    angle
        In radians, counterclockwise seen from the axis' tip.

    Examples
    --------
    >>> (elementary_rotation("z", np.pi / 2) @ [1.0, 0.0, 0.0]).round(12).tolist()
    [0.0, 1.0, 0.0]
    """
    c, s = np.cos(angle), np.sin(angle)
    i = _AXES[axis.lower()]
    j, k = (i + 1) % 3, (i + 2) % 3
    R = np.eye(3)
    R[j, j], R[j, k], R[k, j], R[k, k] = c, -s, s, c
    return R


def matrix_from_euler(angles: Sequence[float], sequence: str = "ZYX") -> FloatArray:
    """Rotation matrix of Euler angles, SciPy's naming of ``sequence``.

    Upper case (``"ZYX"``) is intrinsic (rotations about the moving axes, so
    ``R = R1 R2 R3``), lower case (``"xyz"``) extrinsic (fixed axes, ``R = R3 R2 R1``).

    Parameters
    ----------
    angles
        The three angles (radians), in the order of ``sequence``.
    sequence
        Three axes, no two neighbours equal, all upper or all lower case.

    Examples
    --------
    >>> np.allclose(matrix_from_euler([np.pi / 2, 0, 0], "ZYX") @ [1, 0, 0], [0, 1, 0])
    True
    """
    _check_sequence(sequence)
    mats = [elementary_rotation(a, x) for a, x in zip(sequence, angles)]
    if sequence.isupper():
        return mats[0] @ mats[1] @ mats[2]
    return mats[2] @ mats[1] @ mats[0]


def euler_from_matrix(R: ArrayLike, sequence: str = "ZYX") -> FloatArray:
    """Euler angles (radians) of rotation matrices ``(..., 3, 3)``; inverse of
    :func:`matrix_from_euler` (SciPy's conventions and gimbal-lock handling).

    Parameters
    ----------
    R
        Rotation matrices ``(..., 3, 3)``.
    sequence
        As in :func:`matrix_from_euler`.

    Examples
    --------
    >>> euler_from_matrix(matrix_from_euler([0.3, -0.2, 0.1])).round(12).tolist()
    [0.3, -0.2, 0.1]
    """
    from scipy.spatial.transform import Rotation

    _check_sequence(sequence)
    R = np.asarray(R, dtype=float)
    flat = R.reshape(-1, 3, 3)
    angles = Rotation.from_matrix(flat).as_euler(sequence)
    return angles.reshape((*R.shape[:-2], 3))


def _check_sequence(sequence: str) -> None:
    if (len(sequence) != 3 or not (sequence.isupper() or sequence.islower())
            or any(a.lower() not in _AXES for a in sequence)
            or sequence[0].lower() == sequence[1].lower()
            or sequence[1].lower() == sequence[2].lower()):
        raise ValueError(
            f"Euler sequence {sequence!r}: give three axes from x, y, z, no two neighbours "
            "equal, all upper case (intrinsic) or all lower case (extrinsic)"
        )


def times_vector(R: sp.MatrixBase, v: sp.MatrixBase) -> sp.Matrix:
    """``R v`` for SymPy ``R`` and a column ``v``, the products with a zero factor left out.

    The same entries as ``R * v``, which multiplies by the zeros too (to keep
    ``0 * oo = nan``) and asks each such product whether it is finite: for a joint's
    frames and points that query was much of the time taken to write the equations.

    Parameters
    ----------
    R
        A SymPy matrix.
    v
        A SymPy column with as many entries as ``R`` has columns.

    Examples
    --------
    >>> b = sp.symbols("b0:4")
    >>> times_vector(rotation_matrix(b), sp.Matrix([0, 0, 1])) == rotation_matrix(b)[:, 2]
    True
    """
    return sp.Matrix(R.rows, 1, [dot(R[i, :], v) for i in range(R.rows)])


def dot(a: sp.MatrixBase, b: sp.MatrixBase) -> sp.Expr:
    """``a . b`` of two SymPy vectors without the products that have a zero factor.

    Parameters
    ----------
    a, b
        SymPy vectors of equal length.

    Examples
    --------
    >>> x, y = sp.symbols("x y")
    >>> dot(sp.Matrix([x, 0, 2]), sp.Matrix([y, x, 1]))
    x*y + 2
    """
    return sp.Add(*(u * v for u, v in zip(a, b) if u != 0 and v != 0))


def skew(v: Sequence[float | sp.Expr] | sp.MatrixBase | FloatArray) -> MatrixOrArray:
    """The cross-product matrix ``[v]x`` with ``[v]x u = v x u``.

    Parameters
    ----------
    v
        3 numbers (an array comes back) or SymPy expressions (a ``sympy.Matrix``).

    Examples
    --------
    >>> (skew([1.0, 2.0, 3.0]) @ [4.0, 5.0, 6.0]).tolist(), np.cross([1, 2, 3], [4, 5, 6]).tolist()
    ([-3.0, 6.0, -3.0], [-3, 6, -3])
    """
    x, y, z = v
    rows = [[0, -z, y], [z, 0, -x], [-y, x, 0]]
    return sp.Matrix(rows) if _is_symbolic(v) else np.array(rows, dtype=float)


def check_rotation(R: ArrayLike, what: str, tol: float = 1e-9) -> FloatArray:
    """``R`` as a float array after checking it is a proper rotation; errors name ``what``.

    Parameters
    ----------
    R
        The matrix.
    what
        What it is, for the ``ValueError`` messages.
    tol
        Largest ``|R^T R - I|`` accepted.

    Examples
    --------
    >>> check_rotation(np.diag([1.0, 1.0, -1.0]), "the mirror")
    Traceback (most recent call last):
    ...
    ValueError: the mirror: det R = -1, a reflection, not a rotation
    """
    R = np.asarray(R, dtype=float)
    if R.shape != (3, 3):
        raise ValueError(f"{what}: a rotation matrix is 3x3, got shape {R.shape}")
    return check_rotations(R[None], [what], tol)[0]


def check_rotations(R: ArrayLike, what: Sequence[str], tol: float = 1e-9) -> FloatArray:
    """Rotation matrices ``(k, 3, 3)`` checked at once, as :func:`check_rotation` checks
    one; the error is about the first one that is not a proper rotation.

    Parameters
    ----------
    R
        The matrices, ``(k, 3, 3)``.
    what
        What each one is, for the ``ValueError`` messages.
    tol
        Largest ``|R^T R - I|`` accepted.

    Examples
    --------
    >>> check_rotations(np.stack([np.eye(3), 2 * np.eye(3)]), ["the first", "the second"])
    Traceback (most recent call last):
    ...
    ValueError: the second: the matrix is not orthonormal (|R^T R - I| = 3.00e+00)
    """
    R = np.asarray(R, dtype=float)
    if R.ndim != 3 or R.shape[1:] != (3, 3) or len(R) != len(what):
        raise ValueError(f"check_rotations takes {len(what)} 3x3 matrices, got shape {R.shape}")
    err = np.abs(np.einsum("kji,kjl->kil", R, R) - np.eye(3)).max(axis=(1, 2), initial=0.0)
    reflected = np.linalg.det(R) < 0
    bad = np.flatnonzero((err > tol) | reflected)
    if len(bad):
        i = int(bad[0])
        if err[i] > tol:
            raise ValueError(f"{what[i]}: the matrix is not orthonormal (|R^T R - I| = "
                             f"{err[i]:.2e})")
        raise ValueError(f"{what[i]}: det R = -1, a reflection, not a rotation")
    return R
