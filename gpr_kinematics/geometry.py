"""Rotations, quaternions and tilt angles, vectorised over leading batch axes.

Conventions (``docs/core.md``): quaternions are (x, y, z, w) as in geometry_msgs, normalised, w >= 0;
a *tilt* is the rotation ``exp(alpha [a]x)`` about the horizontal axis ``a = (cos gamma, sin gamma, 0)``
(no heading change). For a rotation ``R`` with platform normal ``n = R e3``, the tilt is the angle
between ``n`` and ``e3`` (>= 0), the tilt azimuth is the direction of the tilt axis ``e3 x n`` in
(-pi, pi] (0 when the tilt is zero) and the *twist* is the remaining rotation about the platform
normal: ``R = tilt_rotation(tilt, azimuth) @ Rz(twist)``.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ._ops import ARRAY, Ops

Array = NDArray[np.float64]

#: Below this tilt [rad] the azimuth is undefined and reported as 0.
AZIMUTH_UNDEFINED_BELOW = 1e-15


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


def tilt_of_normal(ops: Ops, nx: Any, ny: Any, nz: Any) -> tuple[Any, Any]:
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
    return tilt_of_normal(ARRAY, n[..., 0], n[..., 1], n[..., 2])


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
