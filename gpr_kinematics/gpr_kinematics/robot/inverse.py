"""Station inverse kinematics: a wafer pose in the world -> rod lengths and arm joints, vectorised.

Solved under the virtual-joint model (Bratovanov & Sotirov, §IV-V) so that :func:`robot_forward` of the answer
reproduces the station (tests: 1e-9 m and 1e-9 rad; in practice ~1e-15):

1. The station in ``gpr_base``: ``p_b = R_wb^T (p - t_wb)``, ``R_b = R_wb^T R_station``; the platform normal
   must be the station plane's normal ``n = R_b e3`` (the arm's joint axes are parallel to it): the platform
   tilt and azimuth follow, and must lie within the GPR's tilt limit.
2. **Height.** A planar arm cannot move the wafer along the platform normal: the platform plane at the arm's
   wafer height ``z_w`` (:attr:`Arm.wafer_height`) must pass through ``p_b``, ``n . (p_b - t) = z_w``. The rods
   for the normal are solved once (:func:`gpr_kinematics.core.inverse_batch`); a common change ``c`` of
   the three rods translates a platform on parallel rods by ``c`` along ``gpr_base`` z without turning it, so
   ``c = (n . (p_b - t) - z_w) / n_z`` puts the plane through the station exactly. Forward kinematics of the
   result verifies the normal and the plane (if they were off -- rods that are not parallel -- the rods are
   solved again at the corrected height, up to :data:`PLANE_ITERATIONS` times); only the converged rods are
   judged against the stroke.
3. **Arm.** The wafer in the platform frame ``w = R^T (p_b - t)`` and the blade heading ``psi`` from
   ``R^T R_b = Rz(psi)``: the arm absorbs the platform's centre shift and twist exactly. In the mount frame the
   planar chain is solved in closed form (:mod:`gpr_kinematics.robot.planar_arm`), on the chosen branch.
4. **The naive model's joints** for the same station (what the old offline tool would command): the platform at
   ``(0, 0, h)`` tilted about its centre, ``h = (n . p_b - z_w) / n_z``, rods from the naive inverse and the arm
   solved on that platform; forward kinematics of those joints on the real machine gives the wafer error the old
   tool makes at the station (out of reach by the tool's error the arm is stretched as far as it goes).

Refusals (:class:`~gpr_kinematics.errors.LimitError`) name the station and by how much: a station plane beyond
the tilt limit, a rod outside the stroke, a target out of the arm's reach, a joint beyond its limits (with a hint
when the other branch fits), a heading a 2-joint arm cannot make.
"""
from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, fields

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..core import STROKE_SLACK, ForwardBatch, forward_batch, inverse_batch, naive_inverse
from ..core.heights import solvable_heights
from ..core.inverse import tilt_target_slack
from ..core.rotations import rotate_z, rotation_angle, tilt_from_normal, tilt_rotation, wrap_angle
from ..errors import ConvergenceError, InputError, LimitError, apart, brief
from ..inputs.validation import TURN, TURN_SLACK, bounded, switch
from .arm_chain import LIMIT_SLACK
from .description import BRANCHES, Arm, ArmJoint, RobotDescription
from .fields import unit_hint
from .forward import RobotForward, RobotForwardRecord, base_pose, forward_on_platform, platform_to_blade
from .one_station import (
    HEADING_TOLERANCE,
    NORMAL_TOLERANCE,
    PLANE_ITERATIONS,
    PLANE_TOLERANCE,
    StationFloats,
    frozen,
    parallel_rods,
    solve_one,
)
from .planar_arm import ArmSolution, branch_sign, solve_arm
from .self_motion import self_motion_fault
from .stations import Stations, per_station
from .transforms import PoseBatch

Array = NDArray[np.float64]


@dataclass(frozen=True)
class NaiveJoints:
    """The naive model's answer for one station: its ``rods`` [m] and the arm's joints by name [rad]."""

    rods: Array
    arm: dict[str, float]


@dataclass(frozen=True)
class StationSolutionRecord(RobotForwardRecord):
    """One station of :class:`StationSolution` (``gpr robot ik --json``): the forward kinematics of the answer
    (:class:`RobotForwardRecord`, with the target ``station``, and the ``naive_wafer_error`` fields measured from
    it: where the naive model's joints really put the wafer), the elbow ``branch``, the ``naive`` joints, and how
    closely the wafer reaches the station (``position_error`` [m], ``angle_error`` [rad])."""

    branch: str
    naive: NaiveJoints
    position_error: float
    angle_error: float


@dataclass(frozen=True)
class StationSolution:
    """Inverse kinematics of ``N`` stations with one arm (SI units, world frame).

    Attributes:
        stations: the targets. arm: the arm's name. branch: ``left``/``right`` per station.
        rods ``(N, 3)`` [m], joints ``(N, n)`` [rad]: the answer.
        forward: whole-robot forward kinematics of the answer (platform, blade, wafer reached).
        naive_rods, naive_joints: the naive model's answer for the same stations (the old tool's).
        naive_wafer: where the naive answer really puts the wafer (forward kinematics on the real machine).
        position_error, angle_error ``(N,)``: wafer reached versus station [m, rad] (the angle between the
            normals where the heading is free).
        feasible ``(N,)``: the station is within every limit (all True unless ``check=False``).
    """

    stations: Stations
    arm: str
    branch: tuple[str, ...]
    rods: Array
    joints: Array
    forward: RobotForward
    naive_rods: Array
    naive_joints: Array
    naive_wafer: PoseBatch
    position_error: Array
    angle_error: Array
    feasible: NDArray[np.bool_]

    def __len__(self) -> int:
        return int(self.rods.shape[0])

    @property
    def naive_wafer_error(self) -> Array:
        """Where the naive model's joints really put the wafer minus the station ``(N, 3)`` [m, world]."""
        return self.naive_wafer.position - self.stations.position

    @property
    def naive_wafer_error_norm(self) -> Array:
        return np.asarray(np.linalg.norm(self.naive_wafer_error, axis=1), dtype=np.float64)

    @property
    def naive_wafer_angle_error(self) -> Array:
        """Angle between the wafer orientation the naive joints give and the station's ``(N,)`` [rad] (between
        the normals where the heading is free)."""
        return _angle_to(self.stations, self.naive_wafer.rotation)

    def floats(self, i: int) -> StationFloats:
        """Station ``i`` as the one-station path's :class:`~gpr_kinematics.robot.one_station.StationFloats`."""
        fk = self.forward
        x, y, z = self.naive_wafer_error[i].tolist()
        return StationFloats(
            self.rods[i].tolist(), self.joints[i].tolist(), fk.gpr[i], fk.platform.floats(i), fk.blade.floats(i),
            fk.wafer.floats(i), fk.wafer_on_platform.floats(i), self.naive_rods[i].tolist(),
            self.naive_joints[i].tolist(), self.naive_wafer.floats(i), float(self.position_error[i]),
            float(self.angle_error[i]), (x, y, z), float(self.naive_wafer_angle_error[i]))

    def record(self, i: int) -> StationSolutionRecord:
        """Station ``i`` as a :class:`StationSolutionRecord`."""
        reached = self.forward.record(i, self.stations.record(i))
        names = self.forward.robot.arm(self.arm).joint_names
        naive = NaiveJoints(np.array(self.naive_rods[i]), dict(zip(names, self.naive_joints[i].tolist(), strict=True)))
        # The forward record's naive fields compare the naive model with the answer's own joints; here they are
        # those of the naive model's joints against the station.
        return StationSolutionRecord(
            **{f.name: getattr(reached, f.name) for f in fields(reached)} | {
                'naive_wafer_error': float(self.naive_wafer_error_norm[i]),
                'naive_wafer_error_vector': np.array(self.naive_wafer_error[i]),
                'naive_wafer_angle_error': float(self.naive_wafer_angle_error[i])},
            branch=self.branch[i], naive=naive, position_error=float(self.position_error[i]),
            angle_error=float(self.angle_error[i]))


def _angle_to(stations: Stations, R: Array) -> Array:
    """Angle between orientations ``R (N, 3, 3)`` and the stations' (between the normals where the heading is
    free) [rad]."""
    angle = rotation_angle(stations.rotation, R)
    free = stations.heading_free
    if free.any():
        n, m = R[free, :, 2], stations.normal[free]
        angle[free] = np.arctan2(np.linalg.norm(np.cross(n, m), axis=1), np.einsum('ni,ni->n', n, m))
    return angle


def _signs(arm: Arm, branch: str | Sequence[str] | None, n: int) -> tuple[tuple[str, ...], Array]:
    if branch is None or isinstance(branch, str):
        name = branch or arm.branch
        if name not in BRANCHES:
            raise InputError(f"branch = {brief(name)} is invalid; allowed: left, right, or empty or None (the arm's "
                             f'own, {arm.branch} for arm {arm.name})')
        return (name,) * n, np.array([branch_sign(name)]) if n == 1 else np.full(n, branch_sign(name))
    if not isinstance(branch, Sequence | np.ndarray):
        raise InputError(f'branch = {brief(branch)} is invalid; allowed: left or right, one or one per station')
    names = tuple(branch)
    if len(names) != n:
        raise InputError(f'branch must be one value or one per station ({n}), got {len(names)}')
    for b in set(names):
        if b not in BRANCHES:
            raise InputError(f'branch = {brief(b)} is invalid; allowed: left or right')
    right = np.asarray(names) == 'right' if n else np.zeros(0, dtype=bool)
    return names, np.where(right, branch_sign('right'), branch_sign('left'))


def _platform_height(robot: RobotDescription, tilt: Array, az: Array, p_b: Array, n_b: Array,
                     zw: float) -> tuple[Array, ForwardBatch]:
    """Rods putting the platform plane at the wafer height through ``p_b`` with normal ``n_b`` (step 2). The
    iterates are not judged against the stroke, the answer is (:func:`_fault_mask`). A height the core does not
    solve (:func:`~gpr_kinematics.core.heights.solvable_heights`: 1 cm beyond the stroke) is solved at the nearest
    one and the rest moved along the rods as if parallel: a station beyond the stroke, its rods to ~1e-3 of the rest."""
    cfg = robot.config
    ik = inverse_batch(0.5 * (cfg.stroke_min + cfg.stroke_max), tilt, az, cfg, stroke=False)
    q, gpr = ik.q, ik.achieved
    lo, hi = solvable_heights(tilt, az, cfg)
    parallel = parallel_rods(cfg)
    far = np.zeros(q.shape[0], dtype=bool)
    for _ in range(PLANE_ITERATIONS):
        n = gpr.rotation[:, :, 2]
        e = np.einsum('ni,ni->n', n, p_b - gpr.position) - zw
        normal_error = np.max(np.abs(n - n_b), axis=1)
        turned = ~far & (normal_error > NORMAL_TOLERANCE)
        if np.all(far | (np.abs(e) <= PLANE_TOLERANCE)) and not turned.any():
            if far.any():
                q = q + np.where(far, e / n[:, 2], 0.0)[:, None]
                gpr = forward_batch(q, cfg, check_limits=False)
            return q, gpr
        if turned.any() or not parallel:  # rods that move together would turn the platform: solve again
            h = gpr.position[:, 2] + e / n[:, 2]
            far |= (h < lo) | (h > hi)
            ik = inverse_batch(np.clip(h, lo, hi), tilt, az, cfg, stroke=False)
            q, gpr = ik.q, ik.achieved
        else:
            q = q + np.where(far, 0.0, e / n[:, 2])[:, None]
            gpr = forward_batch(q, cfg, check_limits=False)
    raise ConvergenceError(f'station height did not converge in {PLANE_ITERATIONS} iterations: plane residual '
                           f'{np.max(np.abs(e[~far])):.3e} m, normal error {np.max(normal_error[~far]):.3e}')


def _arm_target(arm: Arm, w: Array, psi: Array) -> tuple[Array, Array]:
    """Wafer position and heading in the platform frame -> in the arm's mount frame."""
    m = np.asarray(arm.mount_position[:2])
    return rotate_z(-arm.mount_yaw, w[:, :2] - m), psi - arm.mount_yaw


def _heading_in(R_platform: Array, R_b: Array) -> Array:
    M = np.swapaxes(R_platform, 1, 2) @ R_b
    return np.arctan2(M[:, 1, 0], M[:, 0, 0])


def _held_values(a: Arm, redundancy_value: ArrayLike, stations: Stations) -> Array:
    """The held joint's values ``(N,)`` [rad], per station or once, each within the joint's limits as given (the
    robot file's rule: 5 rad on [-2.5, 2.5] rad was held at -1.28 rad without a word), one beyond a turn named so."""
    if a.redundancy is None or a.redundancy.rule != 'fixed_joint':
        raise InputError(f'a redundancy value applies to 4-joint arms under the fixed_joint rule; arm {a.name} '
                         'has ' + (f'{len(a.joints)} joints' if a.redundancy is None else 'the nearest rule') +
                         f'; allowed: no redundancy value for arm {a.name} (the service: use_redundancy_value false)')
    value = per_station(redundancy_value, 'redundancy value', len(stations))
    joint = a.joints[a.redundancy.joint]
    limits = f'the held joint {joint.name} ranges over [{joint.lower:g}, {joint.upper:g}] rad'
    beyond = np.abs(value) > TURN + TURN_SLACK   # the files' rule (beyond_turn): a slip (degrees), never meant
    if beyond.any():
        i = int(np.argmax(beyond))
        shown = apart(abs(float(value[i])), TURN)[0]
        raise InputError(f'redundancy value = {"-" if value[i] < 0 else ""}{shown} rad ({stations.label(i)}) is '
                         f'beyond one turn; allowed: radians within [-2pi, 2pi] ({limits}); in degrees? give radians')
    outside = (value < joint.lower - LIMIT_SLACK) | (value > joint.upper + LIMIT_SLACK)   # held_refusal's, batched
    if outside.any():
        i = int(np.argmax(outside))
        raise InputError(held_refusal(joint, float(value[i]), f'redundancy value = {{}} ({stations.label(i)})'))
    return value


def held_refusal(joint: ArmJoint, value: float, label: str, deg: bool = False) -> str:
    """The refusal of a held ``value`` [rad] outside ``joint``'s limits ('' within, to LIMIT_SLACK): ``label`` with
    ``{}`` where the value goes, ``deg``: as typed in degrees; the value modulo a turn where that lies within."""
    if joint.lower - LIMIT_SLACK <= value <= joint.upper + LIMIT_SLACK:
        return ''
    unit, f = ('deg', math.degrees) if deg else ('rad', float)
    shown, end = apart(f(value), f(joint.lower if value < joint.lower else joint.upper))
    mid = 0.5 * (joint.lower + joint.upper)
    turned = math.remainder(value - mid, 2.0 * math.pi) + mid
    hint = (f'; {f(value):g} {unit} is {f(turned):.6g} {unit} modulo a turn' if joint.lower <= turned <= joint.upper
            else '')
    return (f'{label.format(f"{shown} {unit}")} is outside the limits of {joint.name}, [{f(joint.lower):g}, '
            f'{f(joint.upper):g}] {unit}; allowed: a value within them{hint}')


def solve_stations(robot: RobotDescription, stations: Stations, arm: str | None = None,
                   branch: str | Sequence[str] | None = None, redundancy_value: ArrayLike | None = None,
                   check: bool = True, unit_at: ArrayLike | None = None) -> StationSolution:
    """Rods and arm joints that put the wafer of ``arm`` at ``stations`` (module docstring), vectorised.

    Args:
        arm: arm name (default: the first arm).
        branch: ``left`` or ``right`` for all stations or one per station (default: the arm's).
        redundancy_value: for a 4-joint arm under ``fixed_joint``, the held joint's value [rad] (one or per station).
        check: raise on the first station that violates a limit (else return the solution with ``feasible``
            marking the stations within every limit).
        unit_at: the positions ``(N, 3)`` [m, world] a refusal's hint of a unit slip is judged at (default the
            stations'; a program's waypoints are judged at their station: an approach 8 mm above it is not it).

    Raises:
        InputError: malformed stations, branch or unit_at; no heading for a 3- or 4-joint arm; ``check`` no bool.
        LimitError: tilt, stroke, reach, joint limits, 2-joint heading (module docstring).
    """
    if not isinstance(stations, Stations):
        raise InputError(f'stations = {brief(stations)}; allowed: Stations (Stations.of, stations_from_poses, a '
                         'station file)')
    if not isinstance(robot, RobotDescription):   # None raised a bare AttributeError
        raise InputError(f'robot = {brief(robot)}; allowed: a RobotDescription (load_robot)')
    check = switch(check, 'check')   # 'no' checked, '' and 0 did not
    a = robot.arm(arm)
    n, cfg = len(stations), robot.config
    at = stations.position if unit_at is None else bounded(unit_at, 'unit_at [m]', (n, 3))
    names, sign = _signs(a, branch, n)
    if len(a.joints) > 2 and (stations.heading_free.item() if n == 1 else stations.heading_free.any()):
        i = int(np.argmax(stations.heading_free))
        raise InputError(f'{stations.label(i)}: arm {a.name} has {len(a.joints)} joints and needs the blade heading; '
                         'only a 2-joint arm leaves it free')
    value = None if redundancy_value is None else _held_values(a, redundancy_value, stations)
    if n == 1:  # one station per call: the float path, the batch below where it refuses (the messages' one source)
        one = solve_one(robot, stations, a, float(sign[0]), None if value is None else float(value[0]))
        if one is not None:
            rods, joints, fk, naive_rods, naive_joints, naive_wafer, position_error, angle_error = one
            return frozen(StationSolution, stations=stations, arm=a.name, branch=names, rods=rods, joints=joints,
                          forward=fk, naive_rods=naive_rods, naive_joints=naive_joints, naive_wafer=naive_wafer,
                          position_error=position_error, angle_error=angle_error, feasible=np.array([True]))
    base = base_pose(robot, n)
    R_b = np.swapaxes(base.rotation, 1, 2) @ stations.rotation
    p_b = base.inverse_apply(stations.position)
    n_b = R_b[:, :, 2]
    tilt, az = tilt_from_normal(n_b)
    over = tilt - cfg.tilt_limit
    tilted = over > tilt_target_slack(cfg)   # inverse kinematics' rule for its targets
    if check and tilted.any():
        i = int(np.argmax(tilted))
        given = float(stations.tilt[i])  # a station tilt of 1 typed for 1 deg: the plane tilts 57 deg
        hint = (f'; a tilt of {given:g} deg would be within it: degrees given as radians?'
                if given > 10.0 * cfg.tilt_limit and math.radians(given) <= cfg.tilt_limit else '')  # not 0.05 rad
        shown, limit = apart(math.degrees(float(tilt[i])), math.degrees(cfg.tilt_limit))
        raise LimitError(f'{stations.label(i)}: the station plane tilts {shown} deg in gpr_base, beyond the tilt limit '
                         f'{limit} deg by {np.degrees(over[i]):.3g} deg ({over[i]:.3g} rad){hint}' + _more(tilted))
    if tilted.any():  # check=False: solved level instead, marked infeasible (the caller names them)
        n_b = np.where(tilted[:, None], np.array([0.0, 0.0, 1.0]), n_b)
        tilt, az = np.where(tilted, 0.0, tilt), np.where(tilted, 0.0, az)
    zw = a.wafer_height
    q, gpr = _platform_height(robot, tilt, az, p_b, n_b, zw)
    w = np.einsum('nji,nj->ni', gpr.rotation, p_b - gpr.position)
    p_m, phi_m = _arm_target(a, w, _heading_in(gpr.rotation, R_b))
    sol = solve_arm(a, p_m, phi_m, sign, value)
    fk = forward_on_platform(robot, a, q, sol.theta, gpr)
    # The naive model's answer: platform at (0, 0, h) tilted about its centre.
    h = (np.einsum('ni,ni->n', n_b, p_b) - zw) / n_b[:, 2]
    R_n = tilt_rotation(tilt, az)
    w_n = np.einsum('nji,nj->ni', R_n, p_b - np.stack([np.zeros(n), np.zeros(n), h], axis=1))
    pn_m, phin_m = _arm_target(a, w_n, _heading_in(R_n, R_b))
    naive_sol = solve_arm(a, pn_m, phin_m, sign, value)
    q_n = naive_inverse(h, tilt, az, cfg)
    naive_gpr = forward_batch(q_n, cfg, check_limits=False)
    _, naive_wafer_p = platform_to_blade(a, naive_sol.theta)
    naive_wafer = base.compose(PoseBatch(naive_gpr.position, naive_gpr.rotation)).compose(naive_wafer_p)
    free = stations.heading_free
    targets = _Targets(p_m, phi_m, sign, value)
    bad = _fault_mask(robot, a, q, sol, targets, free) | tilted
    result = StationSolution(
        stations=stations, arm=a.name, branch=names, rods=q, joints=sol.theta, forward=fk, naive_rods=q_n,
        naive_joints=naive_sol.theta, naive_wafer=naive_wafer,
        position_error=np.linalg.norm(fk.wafer.position - stations.position, axis=1),
        angle_error=_angle_to(stations, fk.wafer.rotation), feasible=~bad)
    if check and bad.any():
        i = int(np.argmax(bad))
        hint = unit_hint(float(np.linalg.norm(base.inverse_apply(at)[i])), float(np.linalg.norm(at[i])))
        raise LimitError(f'{stations.label(i)}: {_fault_message(robot, a, result, sol, targets, i)}{hint}'
                         f'{_more(bad)}')
    return result


def _more(mask: NDArray[np.bool_]) -> str:
    extra = int(np.count_nonzero(mask)) - 1
    return f' (and {extra} more station{"s" if extra > 1 else ""})' if extra > 0 else ''


@dataclass(frozen=True)
class _Targets:
    """The arm's targets in its mount frame, the branch signs and held-joint values (for messages)."""

    p: Array
    phi: Array
    sign: Array
    value: Array | None

    def other_branch(self, arm: Arm, i: int) -> ArmSolution:
        """Station ``i`` solved on the other branch."""
        value = None if self.value is None else self.value[i:i + 1]
        return solve_arm(arm, self.p[i:i + 1], self.phi[i:i + 1], -self.sign[i:i + 1], value)


def _stroke(robot: RobotDescription, q: Array) -> NDArray[np.bool_]:
    cfg = robot.config
    return (q < cfg.stroke_min - STROKE_SLACK) | (q > cfg.stroke_max + STROKE_SLACK)


def _heading_miss(arm: Arm, sol: ArmSolution, targets: _Targets, free: NDArray[np.bool_]) -> NDArray[np.bool_]:
    if len(arm.joints) != 2:
        return np.zeros(free.shape, dtype=bool)
    diff = np.abs(wrap_angle(sol.heading - targets.phi))
    return ~free & (diff > HEADING_TOLERANCE)


def _fault_mask(robot: RobotDescription, arm: Arm, q: Array, sol: ArmSolution, targets: _Targets,
                free: NDArray[np.bool_]) -> NDArray[np.bool_]:
    """Stations that violate a limit: stroke, reach, joint limits, a 2-joint heading."""
    out: NDArray[np.bool_] = (_stroke(robot, q).any(axis=1) | ~sol.reachable | (np.max(sol.violation, axis=1) > 0.0)
                              | _heading_miss(arm, sol, targets, free))
    return out


def _fault_message(robot: RobotDescription, a: Arm, result: StationSolution, sol: ArmSolution, targets: _Targets,
                   i: int) -> str:
    """What is wrong with station ``i``, by how much (the first of stroke, reach, limits, heading)."""
    cfg = robot.config
    q = result.rods
    stroke = _stroke(robot, q)
    if stroke[i].any():
        k = int(np.argmax(stroke[i]))
        above = q[i, k] > cfg.stroke_max
        limit = cfg.stroke_max if above else cfg.stroke_min
        by = abs(q[i, k] - limit)   # in metres, and in mm for the small ones
        return (f'{robot.rods.names[k]} = {q[i, k]:.9g} m is {"above" if above else "below"} the stroke '
                f'[{cfg.stroke_min:g}, {cfg.stroke_max:g}] m by {by:.4g} m ({by * 1e3:.4g} mm): the station '
                f'is too {"high" if above else "low"} for arm {a.name}')
    other = targets.other_branch(a, i)
    fits = bool(other.reachable[0] and np.max(other.violation[0]) <= 0.0)
    hint = '; the other branch stays within the limits' if fits else ''
    if a.redundancy is not None and a.redundancy.rule == 'nearest' and (
            not sol.reachable[i] or np.max(sol.violation[i]) > 0.0):   # no posture of the self-motion fits
        return self_motion_fault(a, targets.p[i], float(targets.phi[i]), float(targets.sign[i]),
                                 f'branch {result.branch[i]}{hint}')
    if not sol.reachable[i]:
        far = sol.reach[i] > sol.reach_max[i]
        excess = sol.reach[i] - sol.reach_max[i] if far else sol.reach_min[i] - sol.reach[i]
        what = 'wafer centre' if len(a.joints) == 2 else 'wrist axis'
        return (f'out of reach of arm {a.name}: the {what} would be {sol.reach[i]:.6g} m from the shoulder axis, '
                f'the arm spans [{sol.reach_min[i]:.6g}, {sol.reach_max[i]:.6g}] m ({excess * 1e3:.4g} mm too '
                f'{"far" if far else "close"})')
    if np.max(sol.violation[i]) > 0.0:
        k = int(np.argmax(sol.violation[i]))
        j = a.joints[k]
        value = sol.theta[i, k]
        side, limit = ('upper', j.upper) if value > j.upper else ('lower', j.lower)
        shown, end = apart(float(value), limit)
        return (f'{j.name} = {shown} rad is beyond its {side} limit {end} rad by {abs(value - limit):.4g} '
                f'rad (branch {result.branch[i]}{hint})')
    # The headings as the station gives its own (about its normal, in its plane): the platform lies in that plane,
    # so the mount frame's heading is the station's plus one angle (a base's yaw, the mount's, the platform's twist).
    given = float(result.stations.heading[i])
    offset = float(targets.phi[i]) - given
    mine, theirs = wrap_angle(sol.heading[i] - offset), wrap_angle(other.heading[0] - offset)
    if abs(wrap_angle(other.heading[0] - targets.phi[i])) <= HEADING_TOLERANCE:   # the other branch's, as checked
        side = 'right' if result.branch[i] == 'left' else 'left'
        return (f'arm {a.name} has 2 joints and cannot choose the blade heading: at this position it is '
                f'{mine:.12g} rad on branch {result.branch[i]}; {wrap_angle(given):.12g} rad is '
                f'the heading of branch {side}: give branch {side}, or leave the heading free')
    return (f'arm {a.name} has 2 joints and cannot choose the blade heading: at this position it is '
            f'{mine:.12g} rad (branch {result.branch[i]}) or {theirs:.12g} rad (the other branch), not '
            f'{wrap_angle(given):.12g} rad; leave the heading free or give one of these (to {HEADING_TOLERANCE:g} rad)')
