"""The platform pose from the solved virtual joints: the rigid fit of the joints onto the rods, and the naive pose.

Once the virtual joints ``X`` close the mechanism, the displaced platform joints ``r_k(X)`` (``gpr_platform``,
z = 0) and the joint centres ``P_k`` on the rods (``gpr_base``) are congruent triangles, so there is a rigid
transform ``(Rot, t)`` with ``P_k = Rot r_k(X) + t``. It is ``Rot = F_P F_r^T`` with ``F`` the orthonormal
frame (edge 1-2 direction, in-plane normal, triangle normal) of each triangle; ``t`` maps the centroid of the
``r_k`` onto that of the ``P_k``; its fit residual ``max_k |Rot r_k + t - P_k|`` is reported (~1e-16 m).
The kernel is written with scalar locals: it runs on floats (one pose) or on arrays (a batch).
"""
from __future__ import annotations

from collections.abc import Sequence
from typing import NamedTuple, cast

from .machine import MachineGeometry
from .naive import NaiveState, naive_state, tilt_matrix_of_normal
from .ops import Ops, Value
from .rotations import tilt_of_normal
from .virtual_joints import Components


class PlatformPose(NamedTuple):
    """Pose components of one pose (floats) or of a batch (arrays ``(N,)``), SI units.

    ``position`` (3), ``rotation`` (3 rows of 3), ``quaternion`` (x, y, z, w), ``tilt``, ``tilt_azimuth``,
    ``twist`` [rad] (``docs/core.md``); the naive pose of the same rods: height ``nominal_z``,
    ``nominal_rotation``, ``nominal_quaternion``; ``joint_displacement`` ``|r_k(X) - p_k|`` [m] (3);
    ``fit_residual`` [m].
    """

    position: list[Value]
    rotation: list[list[Value]]
    quaternion: list[Value]
    tilt: Value
    tilt_azimuth: Value
    twist: Value
    nominal_z: Value
    nominal_rotation: list[list[Value]]
    nominal_quaternion: list[Value]
    joint_displacement: list[Value]
    fit_residual: Value


#: The rigid transform of :func:`rigid_fit`: the rows of ``Rot`` (9 entries, row by row) and ``t`` (3) [m].
RigidFit = tuple[Value, Value, Value, Value, Value, Value, Value, Value, Value, Value, Value, Value]
#: A rigid fit of one pose (:meth:`~gpr_kinematics.core.single.OnePose.fit`): floats.
FitFloats = tuple[float, float, float, float, float, float, float, float, float, float, float, float]


def rigid_fit(ops: Ops, P: tuple[Sequence[Value], Sequence[Value], Sequence[Value]], comps: Components) -> RigidFit:
    """The rigid transform ``(Rot, t)`` with ``P_k = Rot r_k + t`` (module docstring): ``Rot = F_P F_r^T`` from the
    frames of the two triangles, ``t`` maps the centroid of the ``r_k`` onto that of the ``P_k``. Returns
    ``(r00, r01, r02, r10, .., r22, tx, ty, tz)``: what inverse kinematics needs of each of its forward solves (the
    first part of :func:`platform_pose`)."""
    return cast('RigidFit', _pose(ops, None, (), P, comps, None, True))


def platform_pose(ops: Ops, geo: MachineGeometry, q: Sequence[Value],
                  P: tuple[Sequence[Value], Sequence[Value], Sequence[Value]], comps: Components,
                  naive: NaiveState | None = None) -> PlatformPose:
    """The pose of the platform whose joints ``r_k`` (the :func:`~gpr_kinematics.core.virtual_joints.joint_components`
    of the solved ``X``) sit on the joint centres ``P = (x, y, z)`` of the rods set to ``q`` (module docstring).

    The quaternion uses the trace formula (rotations of the platform are far below 90 deg, so ``w >= 0.7``).
    ``naive``: :func:`~gpr_kinematics.core.naive.naive_state` of ``q`` when the caller has it already.
    """
    return cast('PlatformPose', _pose(ops, geo, q, P, comps, naive, False))


def _pose(ops: Ops, geo: MachineGeometry | None, q: Sequence[Value],
          P: tuple[Sequence[Value], Sequence[Value], Sequence[Value]], comps: Components, naive: NaiveState | None,
          fit_only: bool) -> PlatformPose | RigidFit:
    """:func:`platform_pose`, or its rigid fit alone (``fit_only``): one body, so that a batch's intermediate arrays
    live as long as they did in one function (splitting it cost the batch 15-25 % in allocations)."""
    sqrt = ops.sqrt
    (rx0, rx1, rx2), (ry0, ry1, ry2) = comps[0], comps[1]
    (bx0, bx1, bx2), (by0, by1, by2), (bz0, bz1, bz2) = P
    # Base triangle P_k: frame (e1, e2, e3).
    ux, uy, uz = bx1 - bx0, by1 - by0, bz1 - bz0
    vx, vy, vz = bx2 - bx0, by2 - by0, bz2 - bz0
    inv = 1.0 / sqrt(ux * ux + uy * uy + uz * uz)
    e1x, e1y, e1z = ux * inv, uy * inv, uz * inv
    cx, cy, cz = uy * vz - uz * vy, uz * vx - ux * vz, ux * vy - uy * vx
    inv = 1.0 / sqrt(cx * cx + cy * cy + cz * cz)
    e3x, e3y, e3z = cx * inv, cy * inv, cz * inv
    e2x, e2y, e2z = e3y * e1z - e3z * e1y, e3z * e1x - e3x * e1z, e3x * e1y - e3y * e1x
    # Platform triangle r_k (z = 0): frame (f, sigma (-f_y, f_x, 0), (0, 0, sigma)).
    wx, wy = rx1 - rx0, ry1 - ry0
    inv = 1.0 / sqrt(wx * wx + wy * wy)
    fx, fy = wx * inv, wy * inv
    sg = ops.where(wx * (ry2 - ry0) - wy * (rx2 - rx0) >= 0.0, 1.0, -1.0)
    sfx, sfy = sg * fx, sg * fy
    r00, r01, r02 = e1x * fx - e2x * sfy, e1x * fy + e2x * sfx, sg * e3x
    r10, r11, r12 = e1y * fx - e2y * sfy, e1y * fy + e2y * sfx, sg * e3y
    r20, r21, r22 = e1z * fx - e2z * sfy, e1z * fy + e2z * sfx, sg * e3z
    rcx, rcy = (rx0 + rx1 + rx2) / 3.0, (ry0 + ry1 + ry2) / 3.0
    tx = (bx0 + bx1 + bx2) / 3.0 - (r00 * rcx + r01 * rcy)
    ty = (by0 + by1 + by2) / 3.0 - (r10 * rcx + r11 * rcy)
    tz = (bz0 + bz1 + bz2) / 3.0 - (r20 * rcx + r21 * rcy)
    if fit_only:
        return r00, r01, r02, r10, r11, r12, r20, r21, r22, tx, ty, tz
    assert geo is not None
    fit: Value = 0.0
    for k, (rxk, ryk, bxk, byk, bzk) in enumerate(((rx0, ry0, bx0, by0, bz0), (rx1, ry1, bx1, by1, bz1),
                                                   (rx2, ry2, bx2, by2, bz2))):
        dx = r00 * rxk + r01 * ryk + tx - bxk
        dy = r10 * rxk + r11 * ryk + ty - byk
        dz = r20 * rxk + r21 * ryk + tz - bzk
        dk = sqrt(dx * dx + dy * dy + dz * dz)
        fit = dk if k == 0 else ops.maximum(fit, dk)
    tilt, az = tilt_of_normal(ops, r02, r12, r22)
    T = tilt_matrix_of_normal(ops, r02, r12, r22)
    m00 = T[0][0] * r00 + T[1][0] * r10 + T[2][0] * r20
    m10 = T[0][1] * r00 + T[1][1] * r10 + T[2][1] * r20
    twist = ops.atan2(m10, m00)
    w4 = 2.0 * sqrt(1.0 + r00 + r11 + r22)
    qx, qy, qz, qw = (r21 - r12) / w4, (r02 - r20) / w4, (r10 - r01) / w4, 0.25 * w4
    inv = 1.0 / sqrt(qx * qx + qy * qy + qz * qz + qw * qw)
    # Naive model and centre shift.
    z0, _, nnx, nny, nnz = naive_state(ops, geo, q) if naive is None else naive
    NR = tilt_matrix_of_normal(ops, nnx, nny, nnz)
    # quaternion of a pure tilt: (a sin(t/2), 0, cos(t/2)); cos(t/2) = sqrt((1 + n_z) / 2)
    cw = sqrt(0.5 * (1.0 + nnz))
    half = 0.5 / cw
    nquat = [-(NR[1][2]) * half, NR[0][2] * half, 0.0 * cw, cw]
    px, py = geo.px, geo.py
    d0x, d0y, d1x, d1y, d2x, d2y = rx0 - px[0], ry0 - py[0], rx1 - px[1], ry1 - py[1], rx2 - px[2], ry2 - py[2]
    return PlatformPose(
        position=[tx, ty, tz], rotation=[[r00, r01, r02], [r10, r11, r12], [r20, r21, r22]],
        quaternion=[qx * inv, qy * inv, qz * inv, qw * inv], tilt=tilt, tilt_azimuth=az, twist=twist,
        nominal_z=z0, nominal_rotation=NR, nominal_quaternion=nquat,
        joint_displacement=[sqrt(d0x * d0x + d0y * d0y), sqrt(d1x * d1x + d1y * d1y), sqrt(d2x * d2x + d2y * d2y)],
        fit_residual=fit)
