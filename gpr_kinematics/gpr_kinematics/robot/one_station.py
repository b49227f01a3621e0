"""Station inverse kinematics of one station per call, in float arithmetic: the steps of
:func:`gpr_kinematics.robot.inverse.solve_stations` without the batch machinery.

A teach pendant, a planner sampling stations or a service answers one station at a time; there the batch's numpy
operations on arrays of one row cost milliseconds of overhead. :func:`solve_one` takes the same steps (module
docstring of :mod:`gpr_kinematics.robot.inverse`) on floats: the station in ``gpr_base``, the GPR's one-pose inverse
kinematics (:func:`gpr_kinematics.core.inverse.inverse_parts`, Bratovanov & Sotirov §IV-V) and the height through the
wafer point, the arm in closed form (:func:`~gpr_kinematics.robot.planar_arm.solve_arm_one`), the forward kinematics
of the answer, and the naive model's joints with the wafer error they make. It returns ``None`` where a station is
refused or fails a limit (the caller then takes the batch path, which names why), so the messages have one source,
and where a decision lies within :data:`EDGE_MARGIN` of its threshold or an arm within :data:`STRETCH_MARGIN` of its
stretch or fold: there the batch answers, so the two paths never decide differently (an ulp had flipped a joint
limit's refusal at its slack) nor answer joints a turn or 2e-9 rad apart. Results equal the batch's to rounding
(numpy's and the C library's ``sin``, ``cos``, ``atan2`` differ by an ulp at most; the tests compare them to 1e-12
over random stations). SI units.
"""
from __future__ import annotations

import math
from typing import NamedTuple, TypeVar

import numpy as np
from numpy.typing import NDArray

from ..core import STROKE_SLACK, ForwardResult
from ..core.config import GprConfig
from ..core.floats import (
    FloatPose,
    Mat3,
    Vec3,
    mat_mul,
    mat_tvec,
    tilt_matrix,
    tilt_of_normal_one,
)
from ..core.forward import one_result, one_row
from ..core.inverse import inverse_parts, tilt_target_slack
from ..core.platform_pose import FitFloats
from ..core.rotations import wrap_angle
from ..core.single import Centres, OnePose, one_pose
from ..core.virtual_joints import Closure
from ..errors import ConvergenceError, LimitError
from .arm_chain import LIMIT_SLACK, STRETCH_SNAP, ArmFloats, arm_floats, link_vectors
from .description import Arm, RobotDescription
from .forward import RobotForward, base_floats, one_on_platform, platform_to_blade_one
from .nearest import nearest_value
from .planar_arm import OneArm, solve_arm_one
from .stations import Stations
from .transforms import PoseBatch

#: Convergence of the height: plane residual [m] and platform-normal error.
PLANE_TOLERANCE = 1e-13
NORMAL_TOLERANCE = 1e-12
PLANE_ITERATIONS = 8
#: A 2-joint arm's heading must match a requested one to this [rad].
HEADING_TOLERANCE = 1e-9
#: Within this of a decision's threshold [m or rad] (a rod's stroke, the station's tilt, a joint's limit or the wrap
#: of its representative, a 2-joint arm's heading tolerance), the batch decides and answers: the two paths round
#: differently, and an ulp there flipped a refusal, or a joint's representative by a turn.
EDGE_MARGIN = 2e-13
#: Within this of an arm's full stretch or fold [m], the batch answers: the elbow moves as the square root of the
#: distance there, and the paths' ulp apart targets put the joints up to 2e-9 rad apart (6e-13 rad at 1e-7 m).
STRETCH_MARGIN = 1e-6


def parallel_rods(config: GprConfig) -> bool:
    """The rods move along one direction (``rod_directions`` all equal): a common change of them translates the
    platform without turning it. Else every step of the height solves the rods again. Kept with the config."""
    parallel: bool | None = config.derived.get('parallel_rods')
    if parallel is None:
        parallel = config.derived['parallel_rods'] = all(tuple(d) == tuple(config.rod_directions[0])
                                                         for d in config.rod_directions)
    return parallel


class OneStation(NamedTuple):
    """The answer for one station as rows of one (the fields of
    :class:`~gpr_kinematics.robot.inverse.StationSolution` but the stations, arm and branch)."""

    rods: NDArray[np.float64]
    joints: NDArray[np.float64]
    forward: RobotForward
    naive_rods: NDArray[np.float64]
    naive_joints: NDArray[np.float64]
    naive_wafer: PoseBatch
    position_error: NDArray[np.float64]
    angle_error: NDArray[np.float64]


#: :func:`_platform_height`'s answer: the rods ``q``, of their solve the joint centres ``P``, side lengths ``L``,
#: closure and rigid fit ``frame``, and the rigid fit ``first`` of the naive model's rods for the target at the
#: height ``h_first`` of the core's last solve (the naive model's answer is its translation on parallel rods).
_Height = tuple[list[float], Centres, tuple[float, float, float], Closure, FitFloats, FitFloats, float]


def _translated(kernel: OnePose, frame: FitFloats, c: float) -> FitFloats:
    """The rigid fit ``frame`` of parallel rods all changed by ``c`` [m]: the platform moves by ``c`` along them, the
    closure and the rotation unchanged (the side lengths are)."""
    ux, uy, uz = kernel.rod_direction
    r00, r01, r02, r10, r11, r12, r20, r21, r22, t0, t1, t2 = frame
    return r00, r01, r02, r10, r11, r12, r20, r21, r22, t0 + c * ux, t1 + c * uy, t2 + c * uz


def _platform_height(kernel: OnePose, parallel: bool, tilt: float, az: float, p_b: Vec3, n_b: Vec3, zw: float
                     ) -> _Height:
    """Rods putting the platform plane at the wafer height through ``p_b`` with normal ``n_b`` (the batch's
    ``_platform_height`` for one station), and of their solve what :class:`_Height` holds
    (:func:`~gpr_kinematics.core.forward.one_row` completes the pose): each step solves the closure and the rigid fit
    only; on parallel rods the common change translates the fit along them (:func:`_translated`; the batch solves the
    new rods again, to rounding the same). The iterates are not judged against the stroke (the answer is, by
    :func:`_batch_decides`); a height the core does not solve is left to the batch. ``parallel``:
    :func:`parallel_rods` of the kernel's config."""
    cfg = kernel.config
    zero = (0.0, 0.0, 0.0)
    h = 0.5 * (cfg.stroke_min + cfg.stroke_max)
    q, P, L, closure, frame, _, first = inverse_parts(kernel, h, tilt, az, zero, stroke=False)
    for _ in range(PLANE_ITERATIONS):
        n0, n1, n2, t0, t1, t2 = frame[2], frame[5], frame[8], frame[9], frame[10], frame[11]
        e = n0 * (p_b[0] - t0) + n1 * (p_b[1] - t1) + n2 * (p_b[2] - t2) - zw
        normal_error = max(max(abs(n0 - n_b[0]), abs(n1 - n_b[1])), abs(n2 - n_b[2]))
        if abs(e) <= PLANE_TOLERANCE and normal_error <= NORMAL_TOLERANCE:
            return q, P, L, closure, frame, first, h
        if normal_error > NORMAL_TOLERANCE or not parallel:  # rods that move together would turn the platform
            h = t2 + e / n2
            q, P, L, closure, frame, _, first = inverse_parts(kernel, h, tilt, az, zero, stroke=False)
        else:
            c = e / n2
            q = [q[0] + c, q[1] + c, q[2] + c]
            P, frame = kernel.centres(q[0], q[1], q[2]), _translated(kernel, frame, c)
    raise ConvergenceError('station height did not converge')  # the batch path says by how much


def _target(mount: tuple[float, float, float, float, float], w: Vec3, R_platform: Mat3, R_b: Mat3
            ) -> tuple[float, float, float]:
    """The arm's target for the wafer at ``w`` in the platform frame and the station's orientation ``R_b``
    (gpr_base) on a platform turned by ``R_platform``: the wafer point and heading in the mount frame [m, rad];
    ``mount``: :attr:`~.arm_chain.ArmFloats.mount` of the arm."""
    (a00, a01, _), (a10, a11, _), (a20, a21, _) = R_platform   # of M = R_platform^T R_b, the first column only
    b00, b10, b20 = R_b[0][0], R_b[1][0], R_b[2][0]
    c, s, mx, my, yaw = mount   # cos and sin of -mount_yaw, the mount's x, y, mount_yaw
    x, y = w[0] - mx, w[1] - my
    return (c * x - s * y, s * x + c * y,
            math.atan2(a01 * b00 + a11 * b10 + a21 * b20, a00 * b00 + a10 * b10 + a20 * b20) - yaw)


def _held_values(arm: Arm, targets: list[tuple[float, float, float]], sign: float, value: float | None
                 ) -> list[float | None]:
    """The held joint's value for each mount-frame target ``(x, y, phi)``: ``value`` (the caller's or ``None``,
    the rule's own), except under the ``nearest`` rule, which is solved for all targets in one call (the real
    and the naive target of a station: numpy's cost on rows of one is per call, not per row)."""
    red = arm.redundancy
    if red is None or red.rule != 'nearest':
        return [value] * len(targets)
    d, beta = link_vectors(arm)
    held = nearest_value(arm, d, beta, np.array([t[:2] for t in targets]),
                         np.array([t[2] for t in targets]), np.full(len(targets), sign))
    return [float(v) for v in held.tolist()]


def _near_stretch(sol: OneArm) -> bool:
    """The (sub-)chain within :data:`STRETCH_MARGIN` of its full stretch or fold, but not within half the snap
    (:data:`~.arm_chain.STRETCH_SNAP`), where both paths snap to it (a ``nearest`` answer at its run's edge)."""
    d = min(abs(sol.reach - sol.reach_max), abs(sol.reach - sol.reach_min))
    return 0.5 * STRETCH_SNAP < d < STRETCH_MARGIN


def _batch_decides(cfg: GprConfig, floats: ArmFloats, joints: int, q: list[float], sol: OneArm, phi: float,
                   free: bool) -> bool:
    """The batch's fault mask for one station (a rod outside the stroke, out of reach, a joint beyond its limits, a
    2-joint arm's heading that misses the station's), each threshold moved :data:`EDGE_MARGIN` towards the inside,
    and a joint at the wrap of its representative or the arm near its stretch or fold (:func:`_near_stretch`): a
    station the batch answers (module docstring). ``floats``: :func:`~.arm_chain.arm_floats` of the arm of ``joints``
    joints."""
    lo, hi = cfg.stroke_min - STROKE_SLACK + EDGE_MARGIN, cfg.stroke_max + STROKE_SLACK - EDGE_MARGIN
    if not (lo < q[0] < hi and lo < q[1] < hi and lo < q[2] < hi) or not sol.reachable or _near_stretch(sol):
        return True
    for t, (lower, upper, mid) in zip(sol.theta, floats.limits, strict=True):
        if not lower - LIMIT_SLACK + EDGE_MARGIN < t < upper + LIMIT_SLACK - EDGE_MARGIN or \
                abs(abs(t - mid) - math.pi) < EDGE_MARGIN:
            return True
    if joints != 2 or free:
        return False
    return abs(wrap_angle(sol.heading - phi)) > HEADING_TOLERANCE - EDGE_MARGIN


class StationFloats(NamedTuple):
    """The answer for one station in floats (world frame unless named): the ``rods`` [m] and ``joints`` [rad], the
    platform's forward kinematics ``gpr`` (in ``gpr_base``), the ``platform``, ``blade`` and ``wafer`` poses and the
    wafer's on the platform (``on_platform``, in ``gpr_platform``); the naive model's ``naive_rods`` and
    ``naive_joints`` and where they really put the wafer (``naive_wafer``); how closely the wafer reaches the station
    (``position_error`` [m], ``angle_error`` [rad]) and how far the naive answer misses it (``naive_wafer_error``,
    its vector [m], and ``naive_wafer_angle_error`` [rad])."""

    rods: list[float]
    joints: list[float]
    gpr: ForwardResult
    platform: FloatPose
    blade: FloatPose
    wafer: FloatPose
    on_platform: FloatPose
    naive_rods: list[float]
    naive_joints: list[float]
    naive_wafer: FloatPose
    position_error: float
    angle_error: float
    naive_wafer_error: Vec3
    naive_wafer_angle_error: float


#: What :func:`station_floats` and :func:`solve_one` share of one station (:func:`_solve`'s plain tuple): the rods and
#: joints, the solve of the rods (:func:`_platform_height`; the caller completes the platform's pose), the platform,
#: blade, wafer and on-platform poses, the naive model's rods, joints and wafer, the position and angle errors, and the
#: station's orientation ``R_st``.
_Solved = tuple[list[float], list[float],
                tuple[OnePose, list[float], Centres, tuple[float, float, float], Closure, FitFloats],
                FloatPose, FloatPose, FloatPose, FloatPose, list[float], list[float], FloatPose, float, float, Mat3]


def _solve(robot: RobotDescription, arm: Arm, P: Vec3, tilt_st: float, azimuth: float, heading: float, free: bool,
           sign: float, value: float | None) -> _Solved | None:
    """:func:`station_floats` but the platform's completed pose and the naive model's wafer errors, as a plain tuple in
    :class:`_Solved`'s order (no class built per call)."""
    kernel = one_pose(robot.config)
    cfg = kernel.config
    floats = arm_floats(arm)
    base = p_wb, R_wb = base_floats(robot)
    R_st, R_b, p_b = _station_frame(base, P, tilt_st, azimuth, 0.0 if free else heading)
    n_b = (R_b[0][2], R_b[1][2], R_b[2][2])
    tilt, az = tilt_of_normal_one(*n_b)
    if tilt - cfg.tilt_limit > tilt_target_slack(cfg) - EDGE_MARGIN:
        return None
    zw = floats.wafer_height
    parallel = parallel_rods(cfg)
    try:
        q, P_, L, closure, frame, first, h_first = _platform_height(kernel, parallel, tilt, az, p_b, n_b, zw)
    except (LimitError, ConvergenceError):
        return None
    r00, r01, r02, r10, r11, r12, r20, r21, r22, t0, t1, t2 = frame
    R = (r00, r01, r02), (r10, r11, r12), (r20, r21, r22)
    mount = floats.mount
    target = _target(mount, mat_tvec(R, (p_b[0] - t0, p_b[1] - t1, p_b[2] - t2)), R, R_b)
    # The naive model's answer: platform at (0, 0, h) tilted about its centre.
    h = (n_b[0] * p_b[0] + n_b[1] * p_b[1] + n_b[2] * p_b[2] - zw) / n_b[2]
    R_n = tilt_matrix(tilt, az)
    naive_target = _target(mount, mat_tvec(R_n, (p_b[0], p_b[1], p_b[2] - h)), R_n, R_b)
    held, naive_held = _held_values(arm, [target, naive_target], sign, value)
    sol = solve_arm_one(arm, *target, sign, held, floats)
    if _batch_decides(cfg, floats, len(arm.joints), q, sol, target[2], free):
        return None
    naive_sol = solve_arm_one(arm, *naive_target, sign, naive_held, floats)
    if _near_stretch(naive_sol):
        return None
    platform, blade, wafer, on_platform = one_on_platform(robot, arm, sol.theta, (t0, t1, t2), R, floats)
    # the real platform under the naive rods (tilt_matrix's third column is the naive normal): its pose only
    q_n = kernel.naive_rods(h, (R_n[0][2], R_n[1][2], R_n[2][2]), (0.0, 0.0, 0.0))
    if parallel:  # the naive rods change the core's first rods by a common amount: its fit translated
        fit = _translated(kernel, first, (h - h_first) / kernel.rod_direction[2])
    else:
        P_n = kernel.centres(q_n[0], q_n[1], q_n[2])
        fit = kernel.fit(P_n, kernel.closure(*kernel.lengths(P_n)).components)
    f00, f01, f02, f10, f11, f12, f20, f21, f22, tx, ty, tz = fit
    _, naive_blade_R, (x, y, z) = platform_to_blade_one(arm, naive_sol.theta, floats)
    # the naive platform (compose_one of the fit in gpr_base), and the wafer on it (compose_one again), inline: the
    # operations of mat_vec and mat_mul in their order
    (w00, w01, w02), (w10, w11, w12), (w20, w21, w22) = R_wb
    a0, a1, a2 = w00 * tx + w01 * ty + w02 * tz, w10 * tx + w11 * ty + w12 * tz, w20 * tx + w21 * ty + w22 * tz
    R_p = ((w00 * f00 + w01 * f10 + w02 * f20, w00 * f01 + w01 * f11 + w02 * f21, w00 * f02 + w01 * f12 + w02 * f22),
           (w10 * f00 + w11 * f10 + w12 * f20, w10 * f01 + w11 * f11 + w12 * f21, w10 * f02 + w11 * f12 + w12 * f22),
           (w20 * f00 + w21 * f10 + w22 * f20, w20 * f01 + w21 * f11 + w22 * f21, w20 * f02 + w21 * f12 + w22 * f22))
    (m00, m01, m02), (m10, m11, m12), (m20, m21, m22) = R_p
    naive_wafer = ((p_wb[0] + a0 + (m00 * x + m01 * y + m02 * z), p_wb[1] + a1 + (m10 * x + m11 * y + m12 * z),
                    p_wb[2] + a2 + (m20 * x + m21 * y + m22 * z)), mat_mul(R_p, naive_blade_R))
    d0, d1, d2 = wafer[0][0] - P[0], wafer[0][1] - P[1], wafer[0][2] - P[2]
    return (q, sol.theta, (kernel, q, P_, L, closure, frame), platform, blade, wafer, on_platform, q_n,
            naive_sol.theta, naive_wafer, math.sqrt(d0 * d0 + d1 * d1 + d2 * d2), _angle(R_st, wafer[1], free), R_st)


def _station_frame(base: tuple[Vec3, Mat3], P: Vec3, tilt: float, azimuth: float, heading: float
                   ) -> tuple[Mat3, Mat3, Vec3]:
    """The station's orientation ``R_st = tilt_matrix(tilt, azimuth) rot_z(heading)`` (world), and the station in
    ``gpr_base`` (``base``: its pose in the world): ``R_b = R_wb^T R_st``, ``p_b = R_wb^T (P - p_wb)``; the operations
    of :func:`~gpr_kinematics.core.floats.tilt_matrix`, ``rot_z``, ``mat_mul``, ``mat_tmul`` and ``mat_tvec`` in
    their order, inline (the same numbers)."""
    (b0, b1, b2), ((w00, w01, w02), (w10, w11, w12), (w20, w21, w22)) = base
    s, c = math.sin(tilt), math.cos(tilt)
    ax, ay = math.cos(azimuth), math.sin(azimuth)
    v = 1.0 - c
    a00, a01, a02, a10, a11 = c + v * ax * ax, v * ax * ay, s * ay, v * ax * ay, c + v * ay * ay
    a12, a20, a21, a22 = -s * ax, -s * ay, s * ax, c
    zc, zs = math.cos(heading), math.sin(heading)
    nzs = -zs
    R_st = ((a00 * zc + a01 * zs + a02 * 0.0, a00 * nzs + a01 * zc + a02 * 0.0, a00 * 0.0 + a01 * 0.0 + a02 * 1.0),
            (a10 * zc + a11 * zs + a12 * 0.0, a10 * nzs + a11 * zc + a12 * 0.0, a10 * 0.0 + a11 * 0.0 + a12 * 1.0),
            (a20 * zc + a21 * zs + a22 * 0.0, a20 * nzs + a21 * zc + a22 * 0.0, a20 * 0.0 + a21 * 0.0 + a22 * 1.0))
    (s00, s01, s02), (s10, s11, s12), (s20, s21, s22) = R_st
    R_b = ((w00 * s00 + w10 * s10 + w20 * s20, w00 * s01 + w10 * s11 + w20 * s21, w00 * s02 + w10 * s12 + w20 * s22),
           (w01 * s00 + w11 * s10 + w21 * s20, w01 * s01 + w11 * s11 + w21 * s21, w01 * s02 + w11 * s12 + w21 * s22),
           (w02 * s00 + w12 * s10 + w22 * s20, w02 * s01 + w12 * s11 + w22 * s21, w02 * s02 + w12 * s12 + w22 * s22))
    x, y, z = P[0] - b0, P[1] - b1, P[2] - b2
    return R_st, R_b, (w00 * x + w10 * y + w20 * z, w01 * x + w11 * y + w21 * z, w02 * x + w12 * y + w22 * z)


def station_floats(robot: RobotDescription, arm: Arm, P: Vec3, tilt_st: float, azimuth: float, heading: float,
                   free: bool, sign: float, value: float | None) -> StationFloats | None:
    """Rods and joints for the station at ``P`` [m, world] with the station plane's ``tilt_st`` and ``azimuth`` and the
    blade ``heading`` [rad] (``free``: the heading is left to a 2-joint arm), the branch ``sign`` and the held value
    of a 4-joint arm (module docstring); ``None`` where the batch path must answer (a limit, a fault, no
    convergence: it raises or marks the station with its message). The inputs are checked by the caller."""
    one = _solve(robot, arm, P, tilt_st, azimuth, heading, free, sign, value)
    if one is None:
        return None
    rods, joints, parts, platform, blade, wafer, on_platform, naive_rods, naive_joints, naive_wafer, position_error, \
        angle_error, R_st = one
    e = (naive_wafer[0][0] - P[0], naive_wafer[0][1] - P[1], naive_wafer[0][2] - P[2])
    return StationFloats(rods, joints, one_result(*parts), platform, blade, wafer, on_platform, naive_rods,
                         naive_joints, naive_wafer, position_error, angle_error, e, _angle(R_st, naive_wafer[1], free))


def solve_one(robot: RobotDescription, stations: Stations, arm: Arm, sign: float, value: float | None
              ) -> OneStation | None:
    """:func:`station_floats` of the one station of ``stations`` as rows of one (``None`` likewise): every array a
    view of one, made at once from the floats."""
    (x, y, z), = stations.position.tolist()
    one = _solve(robot, arm, (x, y, z), stations.tilt.item(), stations.azimuth.item(), stations.heading.item(),
                 bool(stations.heading_free[0]), sign, value)
    if one is None:
        return None
    rods, joints, parts, (p0, R0), (p1, R1), (p2, R2), (p3, R3), naive_rods, naive_joints, (p4, R4), position_error, \
        angle_error, _ = one
    n = len(joints)
    flat = [*rods, *joints, *naive_rods, *naive_joints, position_error, angle_error,
            *p0, *p1, *p2, *p3, *p4, *R0[0], *R0[1], *R0[2], *R1[0], *R1[1], *R1[2], *R2[0], *R2[1], *R2[2],
            *R3[0], *R3[1], *R3[2], *R4[0], *R4[1], *R4[2]]   # one list: the poses' positions, then their rotations
    gpr, a = one_row(*parts, head=flat)  # the station's values and the platform's pose in one array
    o = 8 + 2 * n  # the poses: 5 positions, then 5 rotations
    at, turned = a[0, o:o + 15].reshape(5, 1, 3), a[0, o + 15:o + 60].reshape(5, 1, 3, 3)
    platform, blade, wafer = _pose(at[0], turned[0]), _pose(at[1], turned[1]), _pose(at[2], turned[2])
    rods_, joints_ = a[:, 0:3], a[:, 3:3 + n]
    fk = frozen(RobotForward, arm=arm.name, rods=rods_, joints=joints_, gpr=gpr, platform=platform, blade=blade,
                wafer=wafer, robot=robot, wafer_on_platform=_pose(at[3], turned[3]))
    return OneStation(rods_, joints_, fk, a[:, 3 + n:6 + n], a[:, 6 + n:6 + 2 * n], _pose(at[4], turned[4]),
                      a[0, o - 2:o - 1], a[0, o - 1:o])


def _pose(position: NDArray[np.float64], rotation: NDArray[np.float64]) -> PoseBatch:
    """``PoseBatch(position, rotation)`` without its ``__init__``'s per-field ``object.__setattr__``."""
    out = PoseBatch.__new__(PoseBatch)
    out.__dict__.update(position=position, rotation=rotation)
    return out


Frozen = TypeVar('Frozen')


def frozen(cls: type[Frozen], **fields: object) -> Frozen:
    """An instance of the frozen dataclass ``cls`` with every field in ``fields`` (the caller's), without its
    ``__init__``'s per-field ``object.__setattr__``; the instance stays frozen."""
    out = cls.__new__(cls)
    out.__dict__.update(fields)
    return out


def _angle(R_station: Mat3, R: Mat3, free: bool) -> float:
    """The angle between ``R`` and the station's orientation [rad] (between the normals where the heading is free):
    the batch's ``_angle_to`` in floats."""
    if free:
        n, m = (R[0][2], R[1][2], R[2][2]), (R_station[0][2], R_station[1][2], R_station[2][2])
        cx, cy, cz = n[1] * m[2] - n[2] * m[1], n[2] * m[0] - n[0] * m[2], n[0] * m[1] - n[1] * m[0]
        return math.atan2(math.sqrt(cx * cx + cy * cy + cz * cz), n[0] * m[0] + n[1] * m[1] + n[2] * m[2])
    (a00, a01, a02), (a10, a11, a12), (a20, a21, a22) = R_station   # angle_between, inline: M = R_station^T R
    (b00, b01, b02), (b10, b11, b12), (b20, b21, b22) = R
    m00, m01 = a00 * b00 + a10 * b10 + a20 * b20, a00 * b01 + a10 * b11 + a20 * b21
    m02 = a00 * b02 + a10 * b12 + a20 * b22
    m10, m11 = a01 * b00 + a11 * b10 + a21 * b20, a01 * b01 + a11 * b11 + a21 * b21
    m12 = a01 * b02 + a11 * b12 + a21 * b22
    m20, m21 = a02 * b00 + a12 * b10 + a22 * b20, a02 * b01 + a12 * b11 + a22 * b21
    m22 = a02 * b02 + a12 * b12 + a22 * b22
    s = 0.5 * math.sqrt((m21 - m12) ** 2 + (m02 - m20) ** 2 + (m10 - m01) ** 2)
    return math.atan2(s, 0.5 * (m00 + m11 + m22 - 1.0))
