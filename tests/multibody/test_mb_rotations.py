"""The Euler-parameter convention against independent definitions.

``R(b)`` is checked against SciPy's quaternion rotation (scalar-last ``[v, b0]``)
and against orthonormality; ``w_body = 2 E bdot`` and ``w_world = 2 G bdot``
against the angular velocity read off finite differences of ``R(t)``:
``R^T Rdot = [w_body]x`` and ``Rdot R^T = [w_world]x``.
"""

from __future__ import annotations

import numpy as np
import pytest
import sympy as sp
from scipy.spatial.transform import Rotation

from dalembert.multibody.rotations import (
    E_matrix,
    G_matrix,
    euler_from_matrix,
    matrix_from_euler,
    quaternion_from_matrix,
    rotation_matrix,
    skew,
)

RNG = np.random.default_rng(7)


def random_quaternions(k: int) -> np.ndarray:
    b = RNG.normal(size=(k, 4))
    return b / np.linalg.norm(b, axis=1, keepdims=True)


def vee(S: np.ndarray) -> np.ndarray:
    return 0.5 * np.array([S[2, 1] - S[1, 2], S[0, 2] - S[2, 0], S[1, 0] - S[0, 1]])


def test_rotation_matrix_is_a_proper_rotation_and_matches_scipy():
    b = random_quaternions(50)
    R = rotation_matrix(b)
    assert np.abs(np.transpose(R, (0, 2, 1)) @ R - np.eye(3)).max() < 1e-14
    assert np.abs(np.linalg.det(R) - 1).max() < 1e-14
    ref = Rotation.from_quat(np.column_stack([b[:, 1:], b[:, 0]])).as_matrix()
    assert np.abs(R - ref).max() < 1e-14


def test_R_equals_G_E_transpose_and_E_G_identities():
    for b in random_quaternions(10):
        E, G = E_matrix(b), G_matrix(b)
        assert np.abs(G @ E.T - rotation_matrix(b)).max() < 1e-15
        assert np.abs(E @ E.T - np.eye(3)).max() < 1e-15
        assert np.abs(G @ G.T - np.eye(3)).max() < 1e-15
        assert np.abs(E @ b).max() < 1e-15 and np.abs(G @ b).max() < 1e-15
        assert np.abs(E.T @ E - (np.eye(4) - np.outer(b, b))).max() < 1e-15


def test_symbolic_and_numeric_forms_agree():
    syms = sp.symbols("b0:4")
    b = random_quaternions(1)[0]
    subs = dict(zip(syms, b))
    for fn in (E_matrix, G_matrix, rotation_matrix):
        sym = np.array(fn(sp.Matrix(syms)).subs(subs), dtype=float)
        assert np.abs(sym - fn(b)).max() < 1e-15


def test_angular_velocity_from_finite_differences_of_R():
    # b(t) = normalized smooth curve; central differences of R give R^T Rdot = [w_body]x
    def b_of(t):
        b = np.array([np.cos(t), 0.3 * np.sin(2 * t), 0.5 + 0.2 * t, -0.4 * np.cos(3 * t)])
        return b / np.linalg.norm(b)

    h = 1e-5
    for t in (0.1, 0.7, 1.9):
        bdot = (b_of(t + h) - b_of(t - h)) / (2 * h)
        Rdot = (rotation_matrix(b_of(t + h)) - rotation_matrix(b_of(t - h))) / (2 * h)
        R = rotation_matrix(b_of(t))
        w_body = vee(R.T @ Rdot)
        w_world = vee(Rdot @ R.T)
        assert np.abs(2 * E_matrix(b_of(t)) @ bdot - w_body).max() < 1e-8
        assert np.abs(2 * G_matrix(b_of(t)) @ bdot - w_world).max() < 1e-8
        assert np.abs(R @ w_body - w_world).max() < 1e-8
        # the inverse map used by initial_state
        assert np.abs(0.5 * E_matrix(b_of(t)).T @ w_body - bdot).max() < 1e-8


@pytest.mark.parametrize("angle", [0.0, 1e-9, 0.5, np.pi - 1e-9, np.pi])
def test_quaternion_from_matrix_round_trip_including_half_turns(angle):
    for axis in (np.array([1.0, 2.0, 3.0]), np.array([0.0, 0.0, 1.0]), np.array([1, -1, 0.0])):
        axis = axis / np.linalg.norm(axis)
        R = Rotation.from_rotvec(angle * axis).as_matrix()
        b = quaternion_from_matrix(R)
        assert abs(np.linalg.norm(b) - 1) < 1e-15 and b[0] >= 0
        assert np.abs(rotation_matrix(b) - R).max() < 2e-15


def test_quaternion_from_matrix_vectorized():
    b = random_quaternions(20)
    b *= np.sign(b[:, :1])
    assert np.abs(quaternion_from_matrix(rotation_matrix(b)) - b).max() < 1e-14


@pytest.mark.parametrize("sequence", ["ZYX", "XYZ", "ZXZ", "xyz", "zyz"])
def test_euler_angles_match_scipy_and_round_trip(sequence):
    angles = np.array([0.3, 0.7, 1.2])  # middle angle in (0, pi): valid for every kind
    R = matrix_from_euler(angles, sequence)
    assert np.abs(R - Rotation.from_euler(sequence, angles).as_matrix()).max() < 1e-15
    assert np.abs(euler_from_matrix(R, sequence) - angles).max() < 1e-13


def test_bad_euler_sequence_is_rejected():
    with pytest.raises(ValueError, match="Euler sequence"):
        matrix_from_euler([0, 0, 0], "XXY")


def test_skew_is_the_cross_product():
    a, c = RNG.normal(size=3), RNG.normal(size=3)
    assert np.abs(skew(a) @ c - np.cross(a, c)).max() < 1e-15
