"""Rotations of the package, one module: quaternions, tilts, URDF ``rpy``, Euler angles, rotation vectors.

Vectorised over leading batch axes (``(..., 3, 3)`` matrices); plain-float forms where a kernel needs them
(:func:`rodrigues`); scipy's ``Rotation`` where speed does not matter (:func:`euler_from_rotation`).

Conventions (``docs/core.md``): quaternions are (x, y, z, w) as in geometry_msgs, normalised, w >= 0;
a *tilt* is the rotation ``exp(alpha [a]x)`` about the horizontal axis ``a = (cos gamma, sin gamma, 0)``
(no heading change). For a rotation ``R`` with platform normal ``n = R e3``, the tilt is the angle
between ``n`` and ``e3`` (>= 0), the tilt azimuth is the direction of the tilt axis ``e3 x n`` in
(-pi, pi] (0 when the tilt is zero) and the *twist* is the remaining rotation about the platform
normal: ``R = tilt_rotation(tilt, azimuth) @ Rz(twist)``. The robot description gives fixed orientations in the
URDF ``rpy`` convention (fixed axes x, y, z: ``R = Rz(yaw) Ry(pitch) Rx(roll)``, :func:`rpy_matrix`). An Euler
sequence of the mechanisms (:mod:`gpr_kinematics.mechanisms.base`) is three axes from ``xyz``, lower case
extrinsic, upper case intrinsic, as ``scipy.spatial.transform.Rotation.from_euler``; angular velocities are in
the base frame.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import cast, overload

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..errors import InputError, brief
from .ops import ARRAY, Ops, Value

Array = NDArray[np.float64]

#: Below this tilt [rad] the azimuth is undefined and reported as 0.
AZIMUTH_UNDEFINED_BELOW = 1e-15


@overload
def wrap_angle(angle: float) -> float: ...
@overload
def wrap_angle(angle: Array) -> Array: ...
def wrap_angle(angle: float | Array) -> float | Array:
    """``angle`` [rad] taken to ``[-pi, pi)``: ``(angle + pi) mod 2 pi - pi`` (floored, as Python's ``%`` and
    ``numpy.remainder`` both compute it), a float for a float, an array for an array."""
    return (angle + np.pi) % (2 * np.pi) - np.pi


def tilt_rotation(tilt: ArrayLike, azimuth: ArrayLike) -> Array:
    """Rotation matrices ``exp(tilt [a]x)``, ``a = (cos azimuth, sin azimuth, 0)`` (Rodrigues' formula).

    ``tilt`` may be negative (a tilt about the opposite axis). Shapes broadcast; result ``(..., 3, 3)``.
    """
    t, g = np.broadcast_arrays(np.asarray(tilt, dtype=float), np.asarray(azimuth, dtype=float))
    s, c = np.sin(t), np.cos(t)
    ax, ay = np.cos(g), np.sin(g)
    v = 1.0 - c
    R = np.empty(t.shape + (3, 3))
    R[..., 0, 0] = c + v * ax * ax
    R[..., 0, 1] = v * ax * ay
    R[..., 0, 2] = s * ay
    R[..., 1, 0] = v * ax * ay
    R[..., 1, 1] = c + v * ay * ay
    R[..., 1, 2] = -s * ax
    R[..., 2, 0] = -s * ay
    R[..., 2, 1] = s * ax
    R[..., 2, 2] = c
    return R


def tilt_normal(tilt: ArrayLike, azimuth: ArrayLike) -> Array:
    """Platform normal ``R e3 = (sin t sin g, -sin t cos g, cos t)`` of :func:`tilt_rotation`, (..., 3)."""
    t, g = np.broadcast_arrays(np.asarray(tilt, dtype=float), np.asarray(azimuth, dtype=float))
    s = np.sin(t)
    return np.stack([s * np.sin(g), -s * np.cos(g), np.cos(t)], axis=-1)


def rotation_z(angle: ArrayLike) -> Array:
    """Rotations about the z axis by ``angle`` [rad], ``(..., 3, 3)``."""
    a = np.asarray(angle, dtype=float)
    c, s = np.cos(a), np.sin(a)
    R = np.zeros(a.shape + (3, 3))
    R[..., 0, 0] = c
    R[..., 0, 1] = -s
    R[..., 1, 0] = s
    R[..., 1, 1] = c
    R[..., 2, 2] = 1.0
    return R


def quaternion_from_matrix(R: ArrayLike) -> Array:
    """Unit quaternions (x, y, z, w), w >= 0, of rotation matrices ``(..., 3, 3)`` (Shepperd's method)."""
    M = np.asarray(R, dtype=float)
    m00, m11, m22 = M[..., 0, 0], M[..., 1, 1], M[..., 2, 2]
    tr = m00 + m11 + m22
    # Pick, per matrix, the largest of 4w^2, 4x^2, 4y^2, 4z^2 as the pivot: no cancellation.
    cand = np.stack([1.0 + tr, 1.0 + m00 - m11 - m22, 1.0 - m00 + m11 - m22, 1.0 - m00 - m11 + m22], -1)
    k = np.argmax(cand, axis=-1)
    piv = np.sqrt(np.take_along_axis(cand, k[..., None], -1)[..., 0])  # = 2 |component|
    d21, d12 = M[..., 2, 1] - M[..., 1, 2], M[..., 2, 1] + M[..., 1, 2]
    d02, d20 = M[..., 0, 2] - M[..., 2, 0], M[..., 0, 2] + M[..., 2, 0]
    d10, d01 = M[..., 1, 0] - M[..., 0, 1], M[..., 1, 0] + M[..., 0, 1]
    q = np.empty(M.shape[:-2] + (4,))
    with np.errstate(divide='ignore', invalid='ignore'):
        inv = 1.0 / piv
        q[..., 0] = np.select([k == 0, k == 1, k == 2], [d21 * inv, piv, d01 * inv], d20 * inv)
        q[..., 1] = np.select([k == 0, k == 1, k == 2], [d02 * inv, d01 * inv, piv], d12 * inv)
        q[..., 2] = np.select([k == 0, k == 1, k == 2], [d10 * inv, d20 * inv, d12 * inv], piv)
        q[..., 3] = np.select([k == 0, k == 1, k == 2], [piv, d21 * inv, d02 * inv], d10 * inv)
    q *= 0.5
    q /= np.linalg.norm(q, axis=-1, keepdims=True)
    return np.where(q[..., 3:4] < 0.0, -q, q)


def matrix_from_quaternion(quat: ArrayLike) -> Array:
    """Rotation matrices of quaternions (x, y, z, w) ``(..., 4)``; the quaternion is normalised first."""
    q = np.asarray(quat, dtype=float)
    q = q / np.linalg.norm(q, axis=-1, keepdims=True)
    x, y, z, w = q[..., 0], q[..., 1], q[..., 2], q[..., 3]
    R = np.empty(q.shape[:-1] + (3, 3))
    R[..., 0, 0] = 1 - 2 * (y * y + z * z)
    R[..., 0, 1] = 2 * (x * y - z * w)
    R[..., 0, 2] = 2 * (x * z + y * w)
    R[..., 1, 0] = 2 * (x * y + z * w)
    R[..., 1, 1] = 1 - 2 * (x * x + z * z)
    R[..., 1, 2] = 2 * (y * z - x * w)
    R[..., 2, 0] = 2 * (x * z - y * w)
    R[..., 2, 1] = 2 * (y * z + x * w)
    R[..., 2, 2] = 1 - 2 * (x * x + y * y)
    return R


def tilt_of_normal(ops: Ops, nx: Value, ny: Value, nz: Value) -> tuple[Value, Value]:
    """Tilt (>= 0) and tilt azimuth in (-pi, pi] of a unit normal given by components (floats with
    ``ops = SCALAR`` or arrays with ``ops = ARRAY``).

    The azimuth is the direction of ``e3 x n = (-n_y, n_x, 0)``; it is 0 where the tilt is below
    :data:`AZIMUTH_UNDEFINED_BELOW`.
    """
    tilt = ops.atan2(ops.hypot(nx, ny), nz)
    az = ops.atan2(nx, -ny)
    az = ops.where(az <= -math.pi, math.pi, az)
    return tilt, ops.where(tilt < AZIMUTH_UNDEFINED_BELOW, 0.0, az)


def tilt_from_normal(n: ArrayLike) -> tuple[Array, Array]:
    """:func:`tilt_of_normal` of unit platform normals ``(..., 3)``."""
    n = np.asarray(n, dtype=float)
    return cast('tuple[Array, Array]', tilt_of_normal(ARRAY, n[..., 0], n[..., 1], n[..., 2]))


def tilt_from_matrix(R: ArrayLike) -> tuple[Array, Array, Array]:
    """Decompose ``R = tilt_rotation(tilt, azimuth) @ rotation_z(twist)``; returns (tilt, azimuth, twist)."""
    R = np.asarray(R, dtype=float)
    tilt, az = tilt_from_normal(R[..., :, 2])
    T = tilt_rotation(tilt, az)
    M = np.einsum('...ji,...jk->...ik', T, R)
    twist = np.arctan2(M[..., 1, 0], M[..., 0, 0])
    return tilt, az, twist


def quaternion_multiply(a: ArrayLike, b: ArrayLike) -> Array:
    """Hamilton product ``a * b`` of quaternions (x, y, z, w)."""
    a = np.asarray(a, dtype=float)
    b = np.asarray(b, dtype=float)
    ax, ay, az, aw = np.moveaxis(a, -1, 0)
    bx, by, bz, bw = np.moveaxis(b, -1, 0)
    return np.stack([aw * bx + ax * bw + ay * bz - az * by,
                     aw * by - ax * bz + ay * bw + az * bx,
                     aw * bz + ax * by - ay * bx + az * bw,
                     aw * bw - ax * bx - ay * by - az * bz], axis=-1)


@dataclass(frozen=True)
class RigidTransform:
    """A rigid transform ``x -> Rot x + translation``: ``translation`` [m] and the unit ``quaternion``
    (x, y, z, w) of ``Rot``."""

    translation: Array
    quaternion: Array

    @property
    def rotation(self) -> Array:
        """The rotation matrix ``Rot`` (3 x 3)."""
        return matrix_from_quaternion(self.quaternion)

    def apply(self, points: ArrayLike) -> Array:
        """``Rot x + translation`` for points ``(..., 3)``."""
        return np.asarray(points, dtype=float) @ self.rotation.T + self.translation


def rpy_matrix(roll: float, pitch: float, yaw: float) -> Array:
    """``Rz(yaw) Ry(pitch) Rx(roll)`` (URDF ``rpy``: roll, pitch, yaw about the fixed x, y, z axes).

    >>> np.round(rpy_matrix(0.0, 0.0, np.pi / 2) @ [1.0, 0.0, 0.0], 12).tolist()
    [0.0, 1.0, 0.0]
    """
    cr, sr, cp, sp, cy, sy = np.cos(roll), np.sin(roll), np.cos(pitch), np.sin(pitch), np.cos(yaw), np.sin(yaw)
    return np.array([[cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
                     [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
                     [-sp, cp * sr, cp * cr]])


def kabsch(a: ArrayLike, b: ArrayLike) -> Array:
    """The rotations ``R (..., 3, 3)`` minimising ``sum_k |b_k - R a_k|^2`` of centred vectors ``a, b (..., K, 3)``
    (Kabsch: ``H = sum_k a_k b_k^T = U S V^T``, ``R = V diag(1, 1, d) U^T``, ``d = sign det(V U^T) = +-1``)."""
    H = np.swapaxes(np.asarray(a, dtype=float), -1, -2) @ np.asarray(b, dtype=float)
    U, _, Vt = np.linalg.svd(H)
    V, Ut = np.swapaxes(Vt, -1, -2), np.swapaxes(U, -1, -2)
    d = np.sign(np.linalg.det(V @ Ut))
    D = np.zeros(H.shape)
    D[..., 0, 0] = D[..., 1, 1] = 1.0
    D[..., 2, 2] = np.where(d == 0.0, 1.0, d)   # +-1 (orthogonal factors); 1 should rounding ever give 0
    return np.asarray(V @ D @ Ut, dtype=np.float64)


def rotate_z(angle: ArrayLike, xy: Array) -> Array:
    """Rotate planar vectors ``xy (..., 2)`` by ``angle`` [rad] (broadcast)."""
    c, s = np.cos(angle), np.sin(angle)
    return np.stack([c * xy[..., 0] - s * xy[..., 1], s * xy[..., 0] + c * xy[..., 1]], axis=-1)


def rotation_angle(Ra: Array, Rb: Array) -> Array:
    """Angle [rad] of the rotation ``Ra^T Rb`` for ``(N, 3, 3)`` stacks, accurate for small angles (from the
    norm of the skew part and the trace, ``atan2``)."""
    M = np.swapaxes(Ra, -1, -2) @ Rb
    s = 0.5 * np.sqrt((M[:, 2, 1] - M[:, 1, 2]) ** 2 + (M[:, 0, 2] - M[:, 2, 0]) ** 2
                      + (M[:, 1, 0] - M[:, 0, 1]) ** 2)
    c = 0.5 * (M[:, 0, 0] + M[:, 1, 1] + M[:, 2, 2] - 1.0)
    return np.arctan2(s, c)


def rotation_vector(R: ArrayLike) -> Array:
    """Rotation vectors ``(..., 3)`` [rad] of rotation matrices ``(..., 3, 3)``, through the quaternion
    (:func:`~gpr_kinematics.core.rotations.quaternion_from_matrix`, Shepperd's method, ``w >= 0``):
    ``phi = 2 atan2(|v|, w) v / |v|`` (``2 v / w`` as ``|v| -> 0``), accurate to rounding at every angle below pi.

    >>> from gpr_kinematics.core.rotations import rotation_z
    >>> rotation_vector(rotation_z(0.25)).round(15).tolist()
    [0.0, 0.0, 0.25]
    """
    q = quaternion_from_matrix(R)
    v, w = q[..., :3], q[..., 3]
    n = np.linalg.norm(v, axis=-1)
    with np.errstate(divide='ignore', invalid='ignore'):
        f = np.where(n > 0.0, 2.0 * np.arctan2(n, w) / n, 2.0 / w)
    return v * f[..., None]


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
    from scipy.spatial.transform import Rotation  # imported here: scipy.spatial is slow to import
    return np.asarray(Rotation.from_matrix(np.array(R, dtype=float)).as_euler(convention))


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
