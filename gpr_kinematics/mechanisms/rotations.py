"""Rotations of the mechanisms: Euler angles in scipy's notation, rotation vectors, elementary rotations.

Conventions (shared by every mechanism, :mod:`gpr_kinematics.mechanisms.base`): an Euler sequence is three axes
from ``xyz``, lower case extrinsic, upper case intrinsic, as ``scipy.spatial.transform.Rotation.from_euler``;
angular velocities are in the base frame.
"""
from __future__ import annotations

import math

import numpy as np

from ..errors import InputError, brief


def _axis_rotation(axis: str, angle: np.ndarray) -> np.ndarray:
    """Elementary rotation matrices ``(N, 3, 3)`` about base axis ``x``, ``y`` or ``z`` by ``angle`` (rad)."""
    c, s = np.cos(angle), np.sin(angle)
    k = 'xyz'.find(axis.lower())
    if k < 0 or len(axis) != 1:
        raise InputError(f'unknown rotation axis {brief(axis)}; allowed: x, y, z')
    i, j = (k + 1) % 3, (k + 2) % 3
    R = np.zeros(np.shape(angle) + (3, 3))
    R[..., k, k] = 1.0
    R[..., i, i] = c
    R[..., j, j] = c
    R[..., i, j] = -s
    R[..., j, i] = s
    return R


def check_euler_convention(convention: str) -> str:
    """Validate a scipy-style Euler sequence: three of ``xyz`` all lower case or all upper case."""
    if (not isinstance(convention, str) or len(convention) != 3
            or not (convention.islower() or convention.isupper())
            or any(ch not in 'xyz' for ch in convention.lower())
            or convention[0].lower() == convention[1].lower()
            or convention[1].lower() == convention[2].lower()):
        raise InputError('Euler convention must be three axes from xyz (lower case = extrinsic, upper case '
                         f'= intrinsic, no axis twice in a row), e.g. xyz or ZXZ; got {brief(convention)}')
    return convention


def euler_rotation(angles: np.ndarray, convention: str) -> np.ndarray:
    """Rotation matrices ``(N, 3, 3)`` of Euler angles ``(N, 3)`` (rad), scipy convention ``convention``.

    Upper case (intrinsic) ``'ZXZ'``: ``R = Rz(A) Rx(B) Rz(C)``; lower case (extrinsic) ``'xyz'``:
    ``R = Rz(C) Ry(B) Rx(A)``. Equal to ``scipy.spatial.transform.Rotation.from_euler(convention, angles)``.
    """
    ang = np.asarray(angles, dtype=float)
    r1, r2, r3 = (_axis_rotation(convention[k], ang[..., k]) for k in range(3))
    if convention.isupper():
        return np.asarray(r1 @ r2 @ r3)
    return np.asarray(r3 @ r2 @ r1)


def euler_rate_matrix(angles: np.ndarray, convention: str) -> np.ndarray:
    """Matrices ``E (N, 3, 3)`` with ``omega = E @ (A', B', C')``, angular velocity in the base frame.

    Intrinsic ``R = R1(A) R2(B) R3(C)``: ``omega = e1 A' + R1 e2 B' + R1 R2 e3 C'``; extrinsic
    ``R = R3(C) R2(B) R1(A)``: ``omega = R3 R2 e1 A' + R3 e2 B' + e3 C'``.
    """
    ang = np.asarray(angles, dtype=float)
    unit = {'x': np.array([1.0, 0, 0]), 'y': np.array([0, 1.0, 0]), 'z': np.array([0, 0, 1.0])}
    ax = [convention[k].lower() for k in range(3)]
    r1, r2 = (_axis_rotation(ax[k], ang[..., k]) for k in range(2))
    r3 = _axis_rotation(ax[2], ang[..., 2])
    e1, e2, e3 = (unit[a] for a in ax)
    n = ang.shape[:-1]
    if convention.isupper():
        cols = [np.broadcast_to(e1, n + (3,)), r1 @ e2, r1 @ r2 @ e3]
    else:
        cols = [r3 @ r2 @ e1, r3 @ e2, np.broadcast_to(e3, n + (3,))]
    return np.stack(cols, axis=-1)


def euler_from_rotation(R: np.ndarray, convention: str) -> np.ndarray:
    """Euler angles ``(N, 3)`` (rad) of rotation matrices in the scipy convention ``convention``."""
    from scipy.spatial.transform import Rotation
    return np.asarray(Rotation.from_matrix(np.asarray(R, dtype=float)).as_euler(convention))


def rotation_from_vector(w: np.ndarray) -> np.ndarray:
    """Rodrigues: rotation matrices ``(N, 3, 3)`` ``exp([w]x)`` of rotation vectors ``(N, 3)`` (rad)."""
    w = np.asarray(w, dtype=float)
    th = np.linalg.norm(w, axis=-1)[..., None, None]
    K = np.zeros(w.shape[:-1] + (3, 3))
    K[..., 0, 1], K[..., 0, 2], K[..., 1, 2] = -w[..., 2], w[..., 1], -w[..., 0]
    K = K - np.swapaxes(K, -1, -2)
    small = th < 1e-8
    safe = np.where(small, 1.0, th)
    a = np.where(small, 1.0 - th ** 2 / 6, np.sin(safe) / safe)
    b = np.where(small, 0.5 - th ** 2 / 24, (1 - np.cos(safe)) / safe ** 2)
    return np.asarray(np.eye(3) + a * K + b * (K @ K))


def rodrigues(wx: float, wy: float, wz: float) -> np.ndarray:
    """``exp([w]x)`` ``(3, 3)`` of one rotation vector in float arithmetic."""
    th = math.sqrt(wx * wx + wy * wy + wz * wz)
    if th < 1e-8:
        a, b = 1.0 - th * th / 6.0, 0.5 - th * th / 24.0
    else:
        a, b = math.sin(th) / th, (1.0 - math.cos(th)) / (th * th)
    return np.array([[1.0 - b * (wy * wy + wz * wz), -a * wz + b * wx * wy, a * wy + b * wx * wz],
                     [a * wz + b * wx * wy, 1.0 - b * (wx * wx + wz * wz), -a * wx + b * wy * wz],
                     [-a * wy + b * wx * wz, a * wx + b * wy * wz, 1.0 - b * (wx * wx + wy * wy)]])


def rotation_vector(R: np.ndarray) -> np.ndarray:
    """Rotation vectors ``(N, 3)`` (rad) of rotation matrices ``(N, 3, 3)`` (scipy ``as_rotvec``)."""
    from scipy.spatial.transform import Rotation
    return np.asarray(Rotation.from_matrix(np.asarray(R, dtype=float)).as_rotvec())
