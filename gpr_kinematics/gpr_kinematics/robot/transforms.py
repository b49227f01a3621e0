"""Rigid transforms of the robot's frames, vectorised over a leading batch axis.

A pose is a position ``(N, 3)`` [m] and a rotation matrix ``(N, 3, 3)`` of a child frame in its parent frame
(``x_parent = R x_child + p``); quaternions are (x, y, z, w) as in geometry_msgs, computed on demand. The
rotations themselves are in :mod:`gpr_kinematics.core.rotations`.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..core.rotations import quaternion_from_matrix

Array = NDArray[np.float64]


@dataclass(frozen=True)
class Pose:
    """One frame's pose in its parent: ``position`` (3,) [m], ``rotation`` (3, 3)."""

    position: Array
    rotation: Array

    @property
    def quaternion(self) -> Array:
        """Orientation as a unit quaternion (x, y, z, w), w >= 0."""
        return quaternion_from_matrix(self.rotation)


@dataclass(frozen=True)
class PoseRecord:
    """One frame's pose as the command line and the messages give it: ``position`` (3,) [m] and ``quaternion``
    (x, y, z, w), w >= 0."""

    position: Array
    quaternion: Array


@dataclass(frozen=True)
class PoseBatch:
    """Poses of one frame for ``N`` configurations: ``position (N, 3)`` [m], ``rotation (N, 3, 3)``."""

    position: Array
    rotation: Array

    def __len__(self) -> int:
        return int(self.position.shape[0])

    def __getitem__(self, i: int) -> Pose:
        return Pose(self.position[i], self.rotation[i])

    def record(self, i: int) -> PoseRecord:
        """Pose ``i`` as a :class:`PoseRecord` (its own copy: a record never holds on to the batch)."""
        return PoseRecord(np.array(self.position[i]), quaternion_from_matrix(self.rotation[i]))

    @property
    def quaternion(self) -> Array:
        """Orientations as unit quaternions (x, y, z, w), ``(N, 4)``."""
        return quaternion_from_matrix(self.rotation)

    def apply(self, points: ArrayLike) -> Array:
        """Points given in the child frame, ``(N, 3)`` or ``(3,)``, in the parent frame."""
        p = np.asarray(points, dtype=float)
        return np.asarray(self.position + np.einsum('nij,...nj->...ni', self.rotation,
                                                     np.broadcast_to(p, self.position.shape)), dtype=np.float64)

    def compose(self, child: PoseBatch) -> PoseBatch:
        """``self * child``: the pose of ``child``'s frame in ``self``'s parent."""
        return PoseBatch(self.apply(child.position), self.rotation @ child.rotation)

    def inverse_apply(self, points: Array) -> Array:
        """Points ``(N, 3)`` given in the parent frame, in the child frame: ``R^T (x - p)``."""
        return np.asarray(np.einsum('nji,nj->ni', self.rotation, points - self.position), dtype=np.float64)

    @staticmethod
    def fixed(position: ArrayLike, rotation: ArrayLike, n: int) -> PoseBatch:
        """One fixed pose repeated ``n`` times (broadcast views, not copies)."""
        p = np.asarray(position, dtype=float)
        R = np.asarray(rotation, dtype=float)
        return PoseBatch(np.broadcast_to(p, (n, 3)), np.broadcast_to(R, (n, 3, 3)))


#: One rotation matrix as rows of floats, and one vector: the float forms of the one-station path.
Mat3 = tuple[tuple[float, float, float], tuple[float, float, float], tuple[float, float, float]]
Vec3 = tuple[float, float, float]


def mat_mul(A: Mat3, B: Mat3) -> Mat3:
    """``A B`` in float arithmetic."""
    (a00, a01, a02), (a10, a11, a12), (a20, a21, a22) = A
    (b00, b01, b02), (b10, b11, b12), (b20, b21, b22) = B
    return ((a00 * b00 + a01 * b10 + a02 * b20, a00 * b01 + a01 * b11 + a02 * b21, a00 * b02 + a01 * b12 + a02 * b22),
            (a10 * b00 + a11 * b10 + a12 * b20, a10 * b01 + a11 * b11 + a12 * b21, a10 * b02 + a11 * b12 + a12 * b22),
            (a20 * b00 + a21 * b10 + a22 * b20, a20 * b01 + a21 * b11 + a22 * b21, a20 * b02 + a21 * b12 + a22 * b22))


def mat_tmul(A: Mat3, B: Mat3) -> Mat3:
    """``A^T B`` in float arithmetic."""
    (a00, a01, a02), (a10, a11, a12), (a20, a21, a22) = A
    return mat_mul(((a00, a10, a20), (a01, a11, a21), (a02, a12, a22)), B)


def mat_vec(A: Mat3, v: Vec3) -> Vec3:
    """``A v`` in float arithmetic."""
    (a00, a01, a02), (a10, a11, a12), (a20, a21, a22) = A
    return (a00 * v[0] + a01 * v[1] + a02 * v[2], a10 * v[0] + a11 * v[1] + a12 * v[2],
            a20 * v[0] + a21 * v[1] + a22 * v[2])


def mat_tvec(A: Mat3, v: Vec3) -> Vec3:
    """``A^T v`` in float arithmetic."""
    (a00, a01, a02), (a10, a11, a12), (a20, a21, a22) = A
    return (a00 * v[0] + a10 * v[1] + a20 * v[2], a01 * v[0] + a11 * v[1] + a21 * v[2],
            a02 * v[0] + a12 * v[1] + a22 * v[2])


def rot_z(angle: float) -> Mat3:
    """The rotation about z by ``angle`` [rad] (:func:`~gpr_kinematics.core.rotations.rotation_z`) in floats."""
    c, s = math.cos(angle), math.sin(angle)
    return (c, -s, 0.0), (s, c, 0.0), (0.0, 0.0, 1.0)


def compose_one(p: Vec3, R: Mat3, child_p: Vec3, child_R: Mat3) -> tuple[Vec3, Mat3]:
    """:meth:`PoseBatch.compose` of one pose in floats: ``(p + R child_p, R child_R)``."""
    a = mat_vec(R, child_p)
    return (p[0] + a[0], p[1] + a[1], p[2] + a[2]), mat_mul(R, child_R)


def pose_batch(p: Vec3, R: Mat3) -> PoseBatch:
    """One pose of floats as a :class:`PoseBatch` of one row."""
    return PoseBatch(np.array([p]), np.array([R]))
