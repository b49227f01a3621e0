"""One pose in float arithmetic: vectors, rotation matrices as rows of floats and quaternions, with the products,
conversions and angles the one-pose and one-station paths need (the batch forms, on arrays, are in
:mod:`gpr_kinematics.core.rotations`; each function here names its batch form and takes the same steps, so the two
agree to rounding). Quaternions are (x, y, z, w) as in geometry_msgs; SI units (metres, radians).
"""
from __future__ import annotations

import math

from .rotations import AZIMUTH_UNDEFINED_BELOW

#: One vector [m], one rotation matrix (its rows) and one quaternion (x, y, z, w) as floats.
Vec3 = tuple[float, float, float]
Mat3 = tuple[Vec3, Vec3, Vec3]
Quat = tuple[float, float, float, float]
#: One frame's pose in its parent: position and rotation.
FloatPose = tuple[Vec3, Mat3]


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


def tilt_matrix(tilt: float, azimuth: float) -> Mat3:
    """:func:`~gpr_kinematics.core.rotations.tilt_rotation` of one tilt and azimuth [rad] in floats."""
    s, c = math.sin(tilt), math.cos(tilt)
    ax, ay = math.cos(azimuth), math.sin(azimuth)
    v = 1.0 - c
    return (c + v * ax * ax, v * ax * ay, s * ay), (v * ax * ay, c + v * ay * ay, -s * ax), (-s * ay, s * ax, c)


def compose_one(p: Vec3, R: Mat3, child_p: Vec3, child_R: Mat3) -> FloatPose:
    """The pose of a child frame ``(child_p, child_R)`` given in the frame ``(p, R)``: ``(p + R child_p, R child_R)``
    (:meth:`~gpr_kinematics.robot.transforms.PoseBatch.compose` of one pose)."""
    a = mat_vec(R, child_p)
    return (p[0] + a[0], p[1] + a[1], p[2] + a[2]), mat_mul(R, child_R)


def quaternion_of(R: Mat3) -> Quat:
    """:func:`~gpr_kinematics.core.rotations.quaternion_from_matrix` of one rotation in floats (Shepperd's method:
    the largest of ``4w^2, 4x^2, 4y^2, 4z^2`` as the pivot, normalised, ``w >= 0``)."""
    (m00, m01, m02), (m10, m11, m12), (m20, m21, m22) = R
    tr = m00 + m11 + m22
    cand = (1.0 + tr, 1.0 + m00 - m11 - m22, 1.0 - m00 + m11 - m22, 1.0 - m00 - m11 + m22)
    k = 0
    for i in (1, 2, 3):
        if cand[i] > cand[k]:
            k = i
    piv = math.sqrt(cand[k])
    inv = 1.0 / piv
    if k == 0:
        x, y, z, w = (m21 - m12) * inv, (m02 - m20) * inv, (m10 - m01) * inv, piv
    elif k == 1:
        x, y, z, w = piv, (m10 + m01) * inv, (m02 + m20) * inv, (m21 - m12) * inv
    elif k == 2:
        x, y, z, w = (m10 + m01) * inv, piv, (m21 + m12) * inv, (m02 - m20) * inv
    else:
        x, y, z, w = (m02 + m20) * inv, (m21 + m12) * inv, piv, (m10 - m01) * inv
    x, y, z, w = 0.5 * x, 0.5 * y, 0.5 * z, 0.5 * w
    n = math.sqrt(x * x + y * y + z * z + w * w)
    x, y, z, w = x / n, y / n, z / n, w / n
    return (-x, -y, -z, -w) if w < 0.0 else (x, y, z, w)


def matrix_of(q: Quat) -> Mat3:
    """:func:`~gpr_kinematics.core.rotations.matrix_from_quaternion` of one quaternion (x, y, z, w) in floats; the
    quaternion is normalised first."""
    n = math.sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3])
    x, y, z, w = q[0] / n, q[1] / n, q[2] / n, q[3] / n
    return ((1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)),
            (2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)),
            (2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)))


def angle_between(A: Mat3, B: Mat3) -> float:
    """:func:`~gpr_kinematics.core.rotations.rotation_angle` of one pair in floats: the angle [rad] of ``A^T B``,
    from the norm of its skew part and its trace (``atan2``, accurate for small angles)."""
    M = mat_tmul(A, B)
    s = 0.5 * math.sqrt((M[2][1] - M[1][2]) ** 2 + (M[0][2] - M[2][0]) ** 2 + (M[1][0] - M[0][1]) ** 2)
    return math.atan2(s, 0.5 * (M[0][0] + M[1][1] + M[2][2] - 1.0))


def tilt_of_normal_one(nx: float, ny: float, nz: float) -> tuple[float, float]:
    """:func:`~gpr_kinematics.core.rotations.tilt_of_normal` of one unit normal in floats (its operations: the same
    numbers): the tilt (>= 0) and the tilt azimuth in (-pi, pi] [rad]."""
    tilt = math.atan2(math.hypot(nx, ny), nz)
    az = math.atan2(nx, -ny)
    return tilt, 0.0 if tilt < AZIMUTH_UNDEFINED_BELOW else (math.pi if az <= -math.pi else az)


def tilt_matrix_of_normal_one(nx: float, ny: float, nz: float) -> Mat3:
    """:func:`~gpr_kinematics.core.naive.tilt_matrix_of_normal` of one unit normal in floats (its operations: the
    same numbers): the pure tilt taking ``e3`` to ``n``."""
    s = math.hypot(nx, ny)
    flat = s < AZIMUTH_UNDEFINED_BELOW
    inv = 1.0 / (1.0 if flat else s)
    ax, ay = 1.0 if flat else -ny * inv, 0.0 if flat else nx * inv
    v = 1.0 - nz
    vxy = v * ax * ay
    return (nz + v * ax * ax, vxy, s * ay), (vxy, nz + v * ay * ay, -s * ax), (-s * ay, s * ax, nz)
