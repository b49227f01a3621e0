"""Forward kinematics of the whole robot: rod lengths and arm joints -> platform, blade and wafer in the world.

The frame chain (docs/robot.md) is ``world -> gpr_base`` (fixed, the description's ``base``) ``-> gpr_platform``
(the GPR's exact pose under the virtual-joint model, :func:`gpr_kinematics.core.forward_batch`; Bratovanov
& Sotirov, *Virtualization for the purposes of modeling and computer simulation of a class of overconstrained
robots*, §IV-V) ``-> <arm>_link1 -> ... -> <arm>_link<n> -> <arm>_blade -> <arm>_wafer``, each link frame turned
by its joint about the platform normal:

* ``<arm>_link1`` in ``gpr_platform``: ``(mount position, Rz(mount_yaw + theta_1 + o_1))``;
* ``<arm>_link<k>`` in ``<arm>_link<k-1>``: ``((length_{k-1}, 0, height_{k-1}), Rz(theta_k + o_k))`` (``o_k``
  the joint's ``zero_offset``, 0 unless calibrated);
* ``<arm>_blade`` in ``<arm>_link<n>``: ``((length_n, 0, height_n) + blade position, Rz(blade yaw))``;
* ``<arm>_wafer`` in ``<arm>_blade``: ``(wafer centre, I)``.

The same chain on the *naive* platform pose (:func:`gpr_kinematics.core.naive_forward`: the platform
rotated about its centre, the paper's Fig. 2, what the old offline tool computed) gives where the old tool
believes the wafer is; ``naive_wafer_error = wafer - naive_wafer`` is the error it makes there.
"""
from __future__ import annotations

import functools
import math
from dataclasses import dataclass
from functools import cached_property
from typing import NamedTuple, cast

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..core import ForwardBatch, ForwardResult, forward, forward_batch, naive_forward
from ..core.floats import FloatPose, Mat3, Vec3, angle_between, compose_one, mat_mul, mat_vec, rot_z, tilt_matrix
from ..core.ops import ARRAY, SCALAR
from ..core.rotations import rotation_angle, rotation_z, rpy_matrix, tilt_of_normal
from ..core.single import one_pose
from ..core.stroke import check_stroke
from ..errors import InputError, LimitError, apart, brief
from ..inputs.validation import bounded, rows_of
from .arm_chain import LIMIT_SLACK, ArmFloats, arm_floats
from .description import Arm, RobotDescription
from .stations import StationRecord, batch_index, stations_from_poses
from .transforms import PoseBatch, PoseRecord, pose_batch

Array = NDArray[np.float64]


def check_joint_limits(arm: Arm, J: Array) -> None:
    """LimitError naming the first joint value outside its range, the sample, and by how much."""
    lower, upper = arm.lower - LIMIT_SLACK, arm.upper + LIMIT_SLACK
    bad = (lower > J) | (upper < J)
    if bad.any():
        i, k = np.argwhere(bad)[0]
        j = arm.joints[k]
        side, limit = ('lower', j.lower) if J[i, k] < lower[k] else ('upper', j.upper)
        where = f' (sample {i})' if J.shape[0] > 1 else ''
        shown, end = apart(float(J[i, k]), limit, 9)
        value = float(J[i, k])   # beyond a turn, yet within the limits in degrees: the hint a joint table gives
        hint = (f'; {value:.9g} deg would be within them: degrees given as radians?'
                if abs(value) > 2.0 * math.pi and j.lower <= math.radians(value) <= j.upper else '')
        raise LimitError(f'{j.name} = {shown} rad{where} is beyond its {side} limit {end} rad by '
                         f'{abs(J[i, k] - limit):.3g} rad; allowed: [{j.lower:g}, {j.upper:g}] rad{hint}')


def arm_transforms(arm: Arm, joints: Array) -> list[tuple[str, str, PoseBatch]]:
    """Parent-relative transforms ``(frame, parent, pose)`` of the arm's frames for joint values ``(N, n)``,
    from ``<arm>_link1`` (parent ``gpr_platform``) to ``<arm>_wafer`` (module docstring): what a tf tree needs."""
    n = joints.shape[0]
    out = []
    parent = 'gpr_platform'
    for k, frame in enumerate(arm.link_frames):
        if k == 0:
            pos = np.broadcast_to(np.asarray(arm.mount_position), (n, 3))
            rot = rotation_z(arm.mount_yaw + joints[:, 0] + arm.joints[0].zero_offset)
        else:
            prev = arm.joints[k - 1]
            pos = np.broadcast_to(np.array([prev.length, 0.0, prev.height]), (n, 3))
            rot = rotation_z(joints[:, k] + arm.joints[k].zero_offset)
        out.append((frame, parent, PoseBatch(pos, rot)))
        parent = frame
    last, blade = arm.joints[-1], arm.blade
    pos = np.array([last.length + blade.position[0], blade.position[1], last.height + blade.position[2]])
    out.append((arm.blade_frame, parent, PoseBatch.fixed(pos, rotation_z(blade.yaw), n)))
    out.append((arm.wafer_frame, arm.blade_frame, PoseBatch.fixed(blade.wafer_centre, np.eye(3), n)))
    return out


def blade_chain(arm: Arm, joints: Array, lengths: Array | None = None, zero_offsets: Array | None = None,
                mount_xy: Array | None = None) -> tuple[Array, Array]:
    """The blade's position ``(..., N, 3)`` and rotation ``(..., N, 3, 3)`` in ``gpr_platform`` for joint values
    ``(N, n)``: the chain of :func:`arm_transforms` in closed form (every joint turns about the platform normal, so
    the link directions add up: ``Theta_n = mount_yaw + (theta_1 + o_1) + ... + (theta_n + o_n)``). The link
    ``lengths``, ``zero_offsets`` and the mount's ``mount_xy`` are the arm's, or ``(..., 1, n)``, ``(..., 1, n)`` and
    ``(..., 1, 2)`` arrays of other values, one set per leading index (a calibration's parameter rows) [m, rad]."""
    offsets = arm.zero_offset if zero_offsets is None else zero_offsets
    Theta = arm.mount_yaw + np.cumsum(joints + offsets, axis=-1)
    shape = Theta.shape[:-1]
    if mount_xy is None:
        x, y = np.full(shape, arm.mount_position[0]), np.full(shape, arm.mount_position[1])
    else:
        x, y = np.broadcast_to(mount_xy[..., 0], shape), np.broadcast_to(mount_xy[..., 1], shape)
    for k, joint in enumerate(arm.joints):
        c, s = np.cos(Theta[..., k]), np.sin(Theta[..., k])
        length = joint.length if lengths is None else lengths[..., k]
        x, y = x + c * length, y + s * length
    bx, by = arm.blade.position[0], arm.blade.position[1]  # in the last link's frame, from the flange
    x, y = x + c * bx - s * by, y + s * bx + c * by
    z = arm.mount_position[2] + sum(j.height for j in arm.joints) + arm.blade.position[2]
    return np.stack([x, y, np.full(shape, z)], axis=-1), rotation_z(Theta[..., -1] + arm.blade.yaw)


def platform_to_blade(arm: Arm, joints: Array) -> tuple[PoseBatch, PoseBatch]:
    """Blade and wafer poses in ``gpr_platform`` for joint values ``(N, n)`` (:func:`blade_chain`)."""
    blade = PoseBatch(*blade_chain(arm, joints))
    return blade, PoseBatch(blade.apply(arm.blade.wafer_centre), blade.rotation)


@dataclass(frozen=True)
class PlatformRecord:
    """The GPR's part of one configuration: ``tilt``, ``tilt_azimuth``, ``twist`` [rad], ``centre_shift`` [m, in
    ``gpr_base``] and the virtual-joint ``model``."""

    tilt: float
    tilt_azimuth: float
    twist: float
    centre_shift: Array
    model: str


@dataclass(frozen=True)
class RobotForwardRecord:
    """One configuration of :class:`RobotForward` (``gpr robot fk --json``; SI units, world frame): the ``robot``, the
    arm (``arm_name``), the ``rods`` [m] and the arm's joints by name [rad]; the ``wafer``, ``blade`` and ``platform``
    poses, and where the naive model puts the wafer and the platform; the wafer's error under the naive model
    (``naive_wafer_error`` [m], its vector and ``naive_wafer_angle_error`` [rad]); the platform's ``gpr`` values and
    the wafer's ``station``."""

    robot: str
    arm_name: str
    rods: Array
    arm: dict[str, float]
    wafer: PoseRecord
    blade: PoseRecord
    platform: PoseRecord
    naive_wafer: PoseRecord
    naive_platform: PoseRecord
    naive_wafer_error: float
    naive_wafer_error_vector: Array
    naive_wafer_angle_error: float
    gpr: PlatformRecord
    station: StationRecord


@dataclass(frozen=True)
class RobotForward:
    """Whole-robot forward kinematics of ``N`` configurations (SI units, world frame unless named).

    Attributes:
        arm: name of the arm; rods ``(N, 3)`` [m]; joints ``(N, n)`` [rad].
        gpr: the platform's forward kinematics in ``gpr_base`` (tilt, centre shift, virtual joints, ...).
        platform, blade, wafer: poses in the world through the exact platform pose.
        naive_platform, naive_wafer: the same through the naive model (computed when first asked for).
    """

    arm: str
    rods: Array
    joints: Array
    gpr: ForwardBatch
    platform: PoseBatch
    blade: PoseBatch
    wafer: PoseBatch
    robot: RobotDescription
    wafer_on_platform: PoseBatch

    def __len__(self) -> int:
        return int(self.rods.shape[0])

    @cached_property
    def naive_platform(self) -> PoseBatch:
        """``gpr_platform`` in the world under the naive model (:func:`~gpr_kinematics.core.naive_forward`)."""
        position, rotation = naive_forward(self.rods, self.robot.config)
        return base_pose(self.robot, len(self)).compose(PoseBatch(position, rotation))

    @cached_property
    def naive_wafer(self) -> PoseBatch:
        """Where the naive model puts the wafer for these rods and joints (the old offline tool's belief)."""
        return self.naive_platform.compose(self.wafer_on_platform)

    @property
    def naive_wafer_error(self) -> Array:
        """Where the wafer really is minus where the naive model puts it ``(N, 3)`` [m, world]."""
        return self.wafer.position - self.naive_wafer.position

    @property
    def naive_wafer_error_norm(self) -> Array:
        return np.asarray(np.linalg.norm(self.naive_wafer_error, axis=1), dtype=np.float64)

    @property
    def naive_wafer_angle_error(self) -> Array:
        """Angle between the real and the naive wafer orientation ``(N,)`` [rad]."""
        return rotation_angle(self.naive_wafer.rotation, self.wafer.rotation)

    def record(self, i: int, station: StationRecord | None = None) -> RobotForwardRecord:
        """Configuration ``i`` as a :class:`RobotForwardRecord`; ``station`` defaults to the wafer's pose as a station
        (:func:`~gpr_kinematics.robot.stations.stations_from_poses`)."""
        i = batch_index(i, self.rods.shape[0], 'configuration')   # -1 read an empty slice, 5 an IndexError
        arm = self.robot.arm(self.arm)
        wafer = self.wafer.position[i:i + 1], self.wafer.rotation[i:i + 1]
        g = self.gpr
        return RobotForwardRecord(
            robot=self.robot.name, arm_name=arm.name, rods=np.array(self.rods[i]),
            arm=dict(zip(arm.joint_names, self.joints[i].tolist(), strict=True)),
            wafer=self.wafer.record(i), blade=self.blade.record(i), platform=self.platform.record(i),
            naive_wafer=self.naive_wafer.record(i), naive_platform=self.naive_platform.record(i),
            naive_wafer_error=float(self.naive_wafer_error_norm[i]),
            naive_wafer_error_vector=np.array(self.naive_wafer_error[i]),
            naive_wafer_angle_error=float(self.naive_wafer_angle_error[i]),
            gpr=PlatformRecord(float(g.tilt[i]), float(g.tilt_azimuth[i]), float(g.twist[i]),
                               np.array(g.centre_shift[i]), g.model),
            station=stations_from_poses(*wafer).record(0) if station is None else station)


def base_pose(robot: RobotDescription, n: int) -> PoseBatch:
    """``gpr_base`` in the world, repeated ``n`` times."""
    return PoseBatch.fixed(robot.base_position, robot.base_rotation, n)


def check_robot(robot: object) -> None:
    """Refuse a ``robot`` argument that is no :class:`RobotDescription` (an AttributeError later), naming it."""
    if not isinstance(robot, RobotDescription):
        raise InputError(f'robot = {brief(robot)}; allowed: a RobotDescription (load_robot or parse_robot)')


def robot_forward(robot: RobotDescription, rods: ArrayLike, joints: ArrayLike, arm: str | None = None,
                  check_limits: bool = True) -> RobotForward:
    """Forward kinematics of rod lengths ``(N, 3)`` [m] and the joints ``(N, n)`` [rad] of ``arm`` (default: the
    first arm), vectorised over ``N``.

    Raises:
        InputError: wrong shapes, NaN or infinity (naming the rod or joint and the sample).
        LimitError: a rod outside the stroke, a tilt beyond the limit, a joint beyond its range (``check_limits``;
            without, InputError for a joint beyond +-:data:`~gpr_kinematics.inputs.validation.MAX_COORDINATE` rad).
    """
    check_robot(robot)
    a = robot.arm(arm)
    Q = rows_of(rods, 'rods', 3, robot.rods.names)
    J = rows_of(joints, f'joints of {a.name}', len(a.joints), a.joint_names)
    if Q.shape[0] != J.shape[0]:
        raise InputError(f'rods and joints must have the same number of samples, got {Q.shape[0]} and {J.shape[0]}')
    if check_limits:
        check_rods(robot, Q)
        check_joint_limits(a, J)
    else:  # joints are periodic, but beyond the package's bound a float angle modulo 2 pi has no digits left
        bounded(J, f'joints of {a.name} [rad]')
    if Q.shape[0] == 1:
        return _robot_forward_one(robot, a, Q, J, check_limits)
    try:
        gpr = forward_batch(Q, robot.config, check_limits=check_limits, stroke=False)   # the stroke: checked above
    except LimitError as exc:
        raise rods_named(robot, exc) from None
    return forward_on_platform(robot, a, Q, J, gpr)


def rods_named(robot: RobotDescription, exc: LimitError) -> LimitError:
    """The core's refusal ``exc`` of rods (a tilt beyond the limit, no pose), which names them ``q``, with the robot's
    names of its rods in front (the stroke's own names them so)."""
    return type(exc)(f'{", ".join(robot.rods.names)}: {exc}')


def check_rods(robot: RobotDescription, Q: Array) -> None:
    """Refuse rods ``(N, 3)`` [m] outside the stroke naming the robot's rods: the core's one check
    (:func:`~gpr_kinematics.core.stroke.check_stroke`; its own named them ``q1``), after which the robot's paths call
    forward kinematics with ``stroke=False`` (no rod checked twice)."""
    if Q.shape[0] == 1:   # floats: one configuration's comparisons cost less than the columns'
        q0, q1, q2 = Q[0].tolist()
        check_stroke(SCALAR, [q0, q1, q2], robot.config, typed=True, names=robot.rods.names)
    else:
        check_stroke(ARRAY, [Q[:, 0], Q[:, 1], Q[:, 2]], robot.config, typed=True, names=robot.rods.names)


def forward_on_platform(robot: RobotDescription, arm: Arm, Q: Array, J: Array, gpr: ForwardBatch) -> RobotForward:
    """:func:`robot_forward` once the platform's forward kinematics ``gpr`` of ``Q`` is known (no checks)."""
    platform = base_pose(robot, Q.shape[0]).compose(PoseBatch(gpr.position, gpr.rotation))
    blade_p, wafer_p = platform_to_blade(arm, J)
    return RobotForward(arm=arm.name, rods=Q, joints=J, gpr=gpr, platform=platform, blade=platform.compose(blade_p),
                        wafer=platform.compose(wafer_p), robot=robot, wafer_on_platform=wafer_p)


def base_floats(robot: RobotDescription) -> tuple[Vec3, Mat3]:
    """``gpr_base`` in the world as floats (:func:`base_pose` of one row)."""
    return _base(robot.base_position, robot.base_rpy)


@functools.lru_cache(maxsize=64)
def _base(position: Vec3, rpy: Vec3) -> tuple[Vec3, Mat3]:
    (a, b, c), (d, e, f), (g, h, i) = rpy_matrix(*rpy).tolist()
    return position, ((a, b, c), (d, e, f), (g, h, i))


def platform_to_blade_one(arm: Arm, joints: list[float], floats: ArmFloats | None = None) -> tuple[Vec3, Mat3, Vec3]:
    """:func:`platform_to_blade` of one posture in floats (joints plus their ``zero_offset``, the cumulative sum
    first, then the mount yaw, as the batch adds them): the blade's position and rotation and the wafer's position in
    ``gpr_platform`` (the wafer's rotation is the blade's); ``floats``: :func:`arm_floats` of ``arm`` if known."""
    x, y, z, yaw, links, (bx, by), blade_yaw, wafer_centre = (arm_floats(arm) if floats is None else floats).chain
    cos, sin = math.cos, math.sin
    turned, c, s, last = 0.0, 1.0, 0.0, 0.0
    for k, (length, offset) in enumerate(links):
        turned = joints[0] + offset if k == 0 else turned + (joints[k] + offset)
        last = yaw + turned
        c, s = cos(last), sin(last)
        x, y = x + c * length, y + s * length
    x, y = x + c * bx - s * by, y + s * bx + c * by
    R = rot_z(last + blade_yaw)
    w = mat_vec(R, wafer_centre)
    return (x, y, z), R, (x + w[0], y + w[1], z + w[2])


def one_on_platform(robot: RobotDescription, arm: Arm, joints: list[float], position: Vec3, rotation: Mat3,
                    floats: ArmFloats | None = None) -> tuple[FloatPose, FloatPose, FloatPose, FloatPose]:
    """The platform, blade and wafer in the world and the wafer on the platform for one posture on the platform pose
    ``(position, rotation)`` in ``gpr_base`` (floats; :func:`forward_on_platform`). The wafer turns as the blade:
    its rotation is the blade's (:func:`~gpr_kinematics.core.floats.compose_one` twice, inline, its product made
    once); ``floats``: :func:`arm_floats` of ``arm`` if known."""
    (b0, b1, b2), R_wb = base_floats(robot)
    blade_p, blade_R, wafer_p = platform_to_blade_one(arm, joints, floats)
    x, y, z = mat_vec(R_wb, position)
    p0, p1, p2 = b0 + x, b1 + y, b2 + z
    R = mat_mul(R_wb, rotation)
    x, y, z = mat_vec(R, blade_p)
    R_blade = mat_mul(R, blade_R)
    u, v, w = mat_vec(R, wafer_p)
    blade = (p0 + x, p1 + y, p2 + z), R_blade
    return ((p0, p1, p2), R), blade, ((p0 + u, p1 + v, p2 + w), R_blade), (wafer_p, blade_R)


class ForwardFloats(NamedTuple):
    """:func:`robot_forward` of one configuration in floats: the platform's forward kinematics ``gpr`` (in
    ``gpr_base``), the ``platform``, ``blade`` and ``wafer`` poses in the world and the wafer's on the platform
    (``on_platform``, in ``gpr_platform``)."""

    gpr: ForwardResult
    platform: FloatPose
    blade: FloatPose
    wafer: FloatPose
    on_platform: FloatPose


def forward_floats(robot: RobotDescription, arm: Arm, rods: list[float], joints: list[float],
                   check_limits: bool = True, stroke: bool = True) -> ForwardFloats:
    """:func:`robot_forward` of one configuration (finite rods [m], the arm's finite joints [rad] within their limits:
    the caller checks them) in floats: the GPR's one-pose path, the chain in floats. With ``check_limits`` the rods
    are refused outside the stroke by the robot's names (``stroke=False``: the caller checked them so)."""
    if check_limits and stroke:
        check_stroke(SCALAR, rods, robot.config, typed=True, names=robot.rods.names)
    try:
        gpr = forward(rods, robot.config, check_limits=check_limits, stroke=False)
    except LimitError as exc:
        raise rods_named(robot, exc) from None
    (r0, r1, r2), (t0, t1, t2) = gpr.rotation.tolist(), gpr.position.tolist()
    return ForwardFloats(gpr, *one_on_platform(robot, arm, joints, (t0, t1, t2), ((r0[0], r0[1], r0[2]),
                                                                                    (r1[0], r1[1], r1[2]),
                                                                                    (r2[0], r2[1], r2[2]))))


def naive_platform_one(robot: RobotDescription, rods: list[float]) -> FloatPose | None:
    """:attr:`RobotForward.naive_platform` of one configuration in floats (:func:`~gpr_kinematics.core.naive_forward`:
    the naive centre ``(0, 0, z)`` tilted by the naive normal, in the world); ``None`` where the rods imply no
    orientation (the batch says so)."""
    z, h2, nx, ny, nz = one_pose(robot.config).naive(rods[0], rods[1], rods[2])
    if h2 >= 1.0:
        return None
    tilt, az = cast('tuple[float, float]', tilt_of_normal(SCALAR, nx, ny, nz))
    return compose_one(*base_floats(robot), (0.0, 0.0, z), tilt_matrix(tilt, az))


class NaiveFloats(NamedTuple):
    """:class:`RobotForward`'s naive side of one configuration in floats: ``naive_platform``, ``naive_wafer`` (world),
    ``naive_wafer_error`` (the wafer minus the naive one [m]), its ``norm`` and ``naive_wafer_angle_error`` [rad]."""

    naive_platform: FloatPose
    naive_wafer: FloatPose
    naive_wafer_error: Vec3
    norm: float
    naive_wafer_angle_error: float


def naive_floats(robot: RobotDescription, rods: list[float], one: ForwardFloats) -> NaiveFloats | None:
    """:class:`NaiveFloats` of the configuration ``one`` (:func:`forward_floats` of ``rods``); ``None`` where the
    rods imply no orientation (:func:`naive_platform_one`: the batch says so)."""
    platform = naive_platform_one(robot, rods)
    if platform is None:
        return None
    wafer = compose_one(*platform, *one.on_platform)
    (x, y, z), (u, v, w) = one.wafer[0], wafer[0]
    error = (x - u, y - v, z - w)
    norm = math.sqrt(error[0] * error[0] + error[1] * error[1] + error[2] * error[2])
    return NaiveFloats(platform, wafer, error, norm, angle_between(wafer[1], one.wafer[1]))


def joints_within_limits(arm: Arm, joints: list[float]) -> bool:
    """One posture's joints [rad] within their ranges and :data:`~.arm_chain.LIMIT_SLACK` (:func:`check_joint_limits`'
    rule, in floats)."""
    return all(j.lower - LIMIT_SLACK <= v <= j.upper + LIMIT_SLACK for j, v in zip(arm.joints, joints, strict=True))


def _robot_forward_one(robot: RobotDescription, arm: Arm, Q: Array, J: Array, check_limits: bool) -> RobotForward:
    """:func:`robot_forward` of one configuration (:func:`forward_floats`) as rows of one."""
    one = forward_floats(robot, arm, Q[0].tolist(), J[0].tolist(), check_limits, stroke=False)   # checked
    return RobotForward(arm=arm.name, rods=Q, joints=J, gpr=ForwardBatch.of_one(one.gpr),
                        platform=pose_batch(*one.platform), blade=pose_batch(*one.blade), wafer=pose_batch(*one.wafer),
                        robot=robot, wafer_on_platform=pose_batch(*one.on_platform))
