"""Rigid transforms of the robot's frames, vectorised over a leading batch axis.

A pose is a position ``(N, 3)`` [m] and a rotation matrix ``(N, 3, 3)`` of a child frame in its parent frame
(``x_parent = R x_child + p``); quaternions are (x, y, z, w) as in geometry_msgs, computed on demand. The
rotations themselves are in :mod:`gpr_kinematics.core.rotations`.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..core.floats import FloatPose, Mat3, Vec3
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

    def floats(self, i: int) -> FloatPose:
        """Pose ``i`` as floats (position, rotation rows)."""
        (x, y, z), (r0, r1, r2) = self.position[i].tolist(), self.rotation[i].tolist()
        return (x, y, z), ((r0[0], r0[1], r0[2]), (r1[0], r1[1], r1[2]), (r2[0], r2[1], r2[2]))

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


def pose_batch(p: Vec3, R: Mat3) -> PoseBatch:
    """One pose of floats as a :class:`PoseBatch` of one row."""
    return PoseBatch(np.array([p]), np.array([R]))
