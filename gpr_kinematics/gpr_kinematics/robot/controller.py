"""The robot as a joint trajectory controller drives it, and the checks of a trajectory goal (no ROS import).

``robot_simulator_node`` serves ``control_msgs/action/FollowJointTrajectory`` as ros2_control's
``joint_trajectory_controller`` does; everything it decides is here, tested without ROS:

- :class:`ControllerJoints`: the joints a goal may name: the rods ``rod_1 .. rod_3`` (prismatic, the stroke, the rods'
  velocity) and every arm's joints (revolute, the description's limits), and the state before any goal (:attr:`rest`:
  the platform level at mid-stroke, equal rods on a machine without rod offsets, and each arm at its ``home``);
- :func:`trajectory_from_points`: a goal's points (as the message carries them, one list per point) into a
  :class:`~gpr_kinematics.robot.trajectory.JointTrajectory`, every size bounded before the work it bounds;
- :func:`late_start`: a goal whose ``header.stamp`` lies in the past, as joint_trajectory_controller takes it;
- :func:`plan_motion`: the checks before moving and the motion sampled at the controller's rate. A goal is refused
  with a :class:`GoalError` carrying the standard error code and a message that names the joint, the point, the value
  and what is allowed: joint names unknown or repeated (``INVALID_JOINTS``); no points, positions of the wrong length,
  velocities or accelerations on some points only, times not finite or not strictly increasing, a position beyond the
  joint's limits, a point velocity or a segment's mean velocity ``|q_{i+1} - q_i| / (t_{i+1} - t_i)`` beyond the joint's
  velocity limit (the move from the current state to a first point after ``t = 0`` included), a first point at ``t =
  0`` beyond ``start_tolerance`` or one sample at the velocity limit from the current state, a spline that overflows,
  an interpolated sample beyond a position limit or a velocity limit by more than :data:`SPLINE_VELOCITY_SLACK`, the
  platform tilted beyond ``tilt_limit`` at any sample (virtual-joint model), or what a ``clearance`` check refuses
  (``INVALID_GOAL``: the simulator's :class:`gpr_kinematics.safety.goal.GoalClearance`, the cell's clearance of the
  whole interpolated motion and the jump to a first point at ``t = 0``, certified between samples);
- :class:`Tolerances`: per joint, over the defaults (a goal's own: :func:`gpr_kinematics.robot.goal.resolve_tolerances`;
  the actuators and the check of a tolerance at run time: :mod:`gpr_kinematics.robot.servo`). SI units.
"""
from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from ..core import STROKE_SLACK, TILT_LIMIT_SLACK, forward_batch, inverse
from ..core.config import GprConfig
from ..core.messages import ROD_JOINT_NAMES
from ..core.stroke import within_as_millimetres
from ..errors import GprError, InputError, apart, brief
from ..inputs.validation import beyond_turn, radians_hint
from .arm_chain import LIMIT_SLACK
from .description import RobotDescription
from .grid import grid_count, grid_times
from .plan import joint_limits, position_limits
from .servo import Lag
from .timing import MAX_SAMPLES
from .trajectory import MAX_DURATION, MAX_JOINTS, MAX_POINTS, JointTrajectory, evaluate, spline

Array = NDArray[np.float64]

#: ``control_msgs/action/FollowJointTrajectory`` result codes.
SUCCESSFUL, INVALID_GOAL, INVALID_JOINTS, OLD_HEADER_TIMESTAMP = 0, -1, -2, -3
PATH_TOLERANCE_VIOLATED, GOAL_TOLERANCE_VIOLATED = -4, -5
ERROR_NAMES = {SUCCESSFUL: 'SUCCESSFUL', INVALID_GOAL: 'INVALID_GOAL', INVALID_JOINTS: 'INVALID_JOINTS',
               OLD_HEADER_TIMESTAMP: 'OLD_HEADER_TIMESTAMP', PATH_TOLERANCE_VIOLATED: 'PATH_TOLERANCE_VIOLATED',
               GOAL_TOLERANCE_VIOLATED: 'GOAL_TOLERANCE_VIOLATED'}
#: Relative slack of the velocity limits (rounding of a trajectory timed exactly at a limit).
VELOCITY_SLACK = 1e-9
#: A message's time quantum [s]: whole nanoseconds (a segment timed at a limit over 1/7 s arrives 0.86 ns shorter).
TIME_QUANTUM = 1e-9
#: Relative slack of the velocity limits at the samples of the interpolated motion: a spline through a program's
#: S-curve samples overshoots their velocity between them (the example programs' cubic at 10 Hz by 0.21 % and 0.63 %,
#: at 100 Hz by 0.002 % and 0.006 %), where one through points at rest overshoots its mean by half (cubic) or more.
SPLINE_VELOCITY_SLACK = 0.01


class GoalError(InputError):
    """A goal the controller refuses: ``code`` is the result's ``error_code``, the message its ``error_string``."""

    def __init__(self, code: int, message: str) -> None:
        super().__init__(message)
        self.code = code


@dataclass(frozen=True)
class ControllerJoints:
    """The controller's joints ``N``: names, limits (``lower``, ``upper`` [m, rad], ``velocity`` [m/s, rad/s]), the
    units of their messages, and the state before any goal :attr:`rest`."""

    names: tuple[str, ...]
    lower: Array
    upper: Array
    velocity: Array
    units: tuple[str, ...]
    rest: Array

    @classmethod
    def of(cls, robot: RobotDescription) -> ControllerJoints:
        """The rods (the stroke of the geometry, the rods' velocity) and every arm's joints of ``robot``."""
        cfg = robot.config
        _, velocity, _, _ = joint_limits(robot)
        lower, upper = position_limits(robot)
        rest = inverse(0.5 * (cfg.stroke_min + cfg.stroke_max), 0.0, 0.0, cfg).q.tolist()   # level (rod offsets)
        arms = [j for a in robot.arms for j in a.joint_names]
        return cls((*ROD_JOINT_NAMES, *arms), lower, upper, velocity, ('m',) * 3 + ('rad',) * len(arms),
                   np.array(rest + [v for a in robot.arms for v in a.home]))

    def indices(self, names: Sequence[str], where: str = 'joint_names') -> NDArray[np.int64]:
        """Positions of ``names`` among the joints; GoalError (``INVALID_JOINTS``) for none, an unknown or a repeated
        name."""
        if not names:
            raise GoalError(INVALID_JOINTS, f'{where} is empty; allowed: some of {", ".join(self.names)}')
        if len(names) > MAX_JOINTS:
            raise GoalError(INVALID_JOINTS, f'{where} names {len(names)} joints; allowed: at most {len(self.names)}')
        out = []
        for n in names:
            if n not in self.names:
                raise GoalError(INVALID_JOINTS, f'{where}: unknown joint {brief(n)}; allowed: {", ".join(self.names)}')
            if self.names.index(n) in out:
                raise GoalError(INVALID_JOINTS, f'{where}: joint {brief(n)} named twice; allowed: each joint once')
            out.append(self.names.index(n))
        return np.array(out, dtype=np.int64)


def joint_state_values(known: Sequence[str], names: Sequence[str], positions: Sequence[float]
                       ) -> tuple[NDArray[np.int64], Array, list[str]]:
    """The positions a ``sensor_msgs/JointState`` carries for the joints ``known`` (a controller's names, a
    trajectory's): their indices in ``known`` and finite values (other names are left out; no positions at all:
    none), and the names of the joints among ``known`` whose
    value is not finite (left out too: the caller warns; they were dropped without a word). :class:`InputError` for a
    message whose ``position`` is not one per ``name`` or that names one of ``known`` twice (which value holds would
    be a guess; the first values of a longer ``name`` were taken), as ``robot_state_publisher`` ignores it. Memory:
    one entry per joint of ``known``, whatever the message's size."""
    if not len(positions):
        return np.zeros(0, dtype=np.int64), np.zeros(0), []
    if len(positions) != len(names):
        raise InputError(f'{len(names)} names and {len(positions)} positions; allowed: one position per '
                         'name, or none')
    index = {n: k for k, n in enumerate(known)}
    taken: dict[int, float] = {}
    for n, v in zip(names, positions, strict=True):
        k = index.get(n)
        if k is None:
            continue
        if k in taken:
            raise InputError(f'joint {brief(n)} named twice; allowed: each joint once')
        taken[k] = float(v)
    finite = [(k, v) for k, v in taken.items() if math.isfinite(v)]
    left = [known[k] for k, v in taken.items() if not math.isfinite(v)]
    return np.array([k for k, _ in finite], dtype=np.int64), np.array([v for _, v in finite], dtype=float), left


def _values(n: int) -> str:
    """``n`` values, in words (``1 value``, ``2 values``)."""
    return f'{n} value' + ('s' if n != 1 else '')


def _rows(values: Sequence[Sequence[float]], J: int, what: str, optional: bool) -> Array | None:
    """Per-point lists of one kind (positions, velocities, accelerations) as ``(P, J)``; None when every point leaves
    an optional kind empty."""
    lengths = {len(v) for v in values}
    if optional and lengths == {0}:
        return None
    if lengths != {J}:
        i = next(k for k, v in enumerate(values) if len(v) != J)
        allowed = f'{_values(J)} (one per joint) on every point' + (', or none on every point' if optional else '')
        raise GoalError(INVALID_GOAL, f'points[{i}].{what} has {_values(len(values[i]))}; allowed: {allowed}')
    out = np.array(values, dtype=float).reshape(len(values), J)
    if not np.all(np.isfinite(out)):
        i, k = np.argwhere(~np.isfinite(out))[0]
        raise GoalError(INVALID_GOAL, f'points[{i}].{what}[{k}] = {float(out[i, k])!r}; allowed: finite numbers')
    return out


def trajectory_from_points(joints: ControllerJoints, names: Sequence[str], times: Sequence[float],
                           positions: Sequence[Sequence[float]], velocities: Sequence[Sequence[float]],
                           accelerations: Sequence[Sequence[float]]) -> JointTrajectory:
    """A goal's trajectory from its points (``times`` [s], one list per point of each kind), checked for sizes, finite
    numbers and strictly increasing times (:class:`GoalError`)."""
    joints.indices(names)
    if not times:
        raise GoalError(INVALID_GOAL, 'the trajectory has no points; allowed: at least one point')
    if len(times) > MAX_POINTS:
        raise GoalError(INVALID_GOAL, f'the trajectory has {len(times)} points; allowed: at most {MAX_POINTS}')
    J = len(names)
    t = np.array(times, dtype=float)
    bad = ~np.isfinite(t) | (t < 0.0) | (t > MAX_DURATION)
    if bad.any():
        i = int(np.argmax(bad))
        raise GoalError(INVALID_GOAL, f'points[{i}].time_from_start = {float(t[i])!r} s; allowed: 0 to '
                        f'{MAX_DURATION:g} s')
    if np.any(np.diff(t) <= 0.0):
        i = int(np.argmax(np.diff(t) <= 0.0)) + 1
        raise GoalError(INVALID_GOAL, f'points[{i}].time_from_start = {float(t[i])!r} s is not after points[{i - 1}] '
                        f'({float(t[i - 1])!r} s); allowed: strictly increasing times')
    for what, rows in (('positions', positions), ('velocities', velocities), ('accelerations', accelerations)):
        if len(rows) != len(times):   # a message has one list per point; the Python API is told the same
            raise GoalError(INVALID_GOAL, f'{len(rows)} lists of {what} for {len(times)} points; allowed: one list per '
                            'point (empty where a point gives none)')
    pos = _rows(positions, J, 'positions', optional=False)
    assert pos is not None
    vel = _rows(velocities, J, 'velocities', optional=True)
    acc = _rows(accelerations, J, 'accelerations', optional=True)
    if acc is not None and vel is None:
        raise GoalError(INVALID_GOAL, 'points have accelerations but no velocities; allowed: positions, positions '
                        'and velocities, or all three')
    return JointTrajectory(tuple(names), t, pos, vel, acc)


@dataclass(frozen=True)
class Tolerances:
    """Per joint ``(N,)``: the largest position [m, rad] and velocity [m/s, rad/s] error along the path and at the
    goal (``inf``: not checked), and the time after the last point by which the goal tolerance must hold [s]."""

    path_position: Array
    path_velocity: Array
    goal_position: Array
    goal_velocity: Array
    goal_time: float

    @classmethod
    def uniform(cls, n: int, path: float, goal: float, goal_time: float) -> Tolerances:
        """The same position tolerance on every joint (0: not checked), velocities not checked."""
        def value(x: float) -> Array:
            return np.full(n, np.inf if x == 0.0 else float(x))

        return cls(value(path), np.full(n, np.inf), value(goal), np.full(n, np.inf), float(goal_time))


@dataclass(frozen=True)
class Motion:
    """A checked goal sampled at the controller's rate: sample times ``time (K,)`` [s from the start], every joint's
    desired ``positions`` and ``velocities`` ``(K, N)`` (the joints the goal does not name held), the goal's joints
    ``goal (G,)`` (indices), its tolerances, its trajectory and every joint where it was at the goal's arrival
    ``current (N,)`` (a first point at ``t = 0`` is reached from there in one sample); ``late`` [s]: the goal's own
    time at the motion's start (a ``header.stamp`` in the past: its feedback and result count from the stamp). Its
    arrays are read-only: a motion is built once, checked, then executed as checked. ``lag``: where the joints are at
    each sample under the simulator's first-order lag (:class:`~.servo.Lag`; None: at ``positions``)."""

    time: Array
    positions: Array
    velocities: Array
    goal: NDArray[np.int64]
    tolerances: Tolerances
    trajectory: JointTrajectory
    current: Array
    late: float = 0.0
    lag: Lag | None = None

    def __post_init__(self) -> None:
        for a in (self.time, self.positions, self.velocities, self.goal, self.current):
            a.flags.writeable = False

    def __len__(self) -> int:
        return int(self.time.shape[0])

    @property
    def duration(self) -> float:
        return float(self.time[-1])


#: A check of the cell's clearance: a checked goal's :class:`Motion` (its trajectory, the goal's joints, every joint at
#: the start and where it was) -> a refusal (the message of an ``INVALID_GOAL``) or None.
Clearance = Callable[[Motion], str | None]


def _refuse_beyond(joints: ControllerJoints, cols: NDArray[np.int64], values: Array, time: Array, what: str) -> None:
    slack = np.where(cols < 3, STROKE_SLACK, LIMIT_SLACK)   # the rods first; the planner's and nodes' rule
    bad = ~((values >= joints.lower[cols] - slack) & (values <= joints.upper[cols] + slack))   # NaN is bad too
    if bad.any():
        i, k = (int(v) for v in np.argwhere(bad)[0])
        j, v = int(cols[k]), float(values[i, k])
        u = joints.units[j]
        if not math.isfinite(v):   # the spline overflowed (a point's acceleration of 1e308: inf - inf)
            raise GoalError(INVALID_GOAL, f'{what} {i} (t = {time[i]:.6g} s): {joints.names[j]} = {v} {u}: the spline '
                            'between the points overflows; allowed: velocities and accelerations that keep it finite')
        lo, hi = float(joints.lower[j]), float(joints.upper[j])
        # a driver's mm or degrees (the files' hints): far beyond as given, within once converted
        hint = (' (millimetres given as metres?)' if within_as_millimetres(v, lo, hi) else '') if u == 'm' else \
            (radians_hint(v) if beyond_turn(v) and lo <= math.radians(v) <= hi else '')
        raise GoalError(INVALID_GOAL, f'{what} {i} (t = {time[i]:.6g} s): {beyond_words(joints.names[j], v, lo, hi, u)}'
                        f'; allowed: [{lo:.12g}, {hi:.12g}] {u}{hint}')


def beyond_words(name: str, value: float, lower: float, upper: float, unit: str) -> str:
    """'name = value unit is beyond its upper limit ... by ...', value and limit told apart (:func:`apart`: 3.0500000001
    rad read '3.05 rad is beyond its limits; allowed: [-3.05, 3.05] rad')."""
    side, limit = ('lower', lower) if value < lower else ('upper', upper)
    shown, end = apart(value, limit, 12)
    return f'{name} = {shown} {unit} is beyond its {side} limit {end} {unit} by {abs(value - limit):.3g} {unit}'


def _check_velocities(joints: ControllerJoints, cols: NDArray[np.int64], traj: JointTrajectory, start: Array,
                      under_way: bool) -> None:
    """Points' velocities and segments' means (over a duration and :data:`TIME_QUANTUM`) within the limits;
    ``under_way``: the first point is a spline's sample (:func:`late_start`), it and its segment within its slack."""
    slack = np.full((traj.time.shape[0], 1), VELOCITY_SLACK)
    if under_way:
        slack[0] = SPLINE_VELOCITY_SLACK
    limits = joints.velocity[cols] * (1.0 + slack)
    unit = [f'{joints.units[j]}/s' for j in cols]
    if traj.velocities is not None:
        bad = np.abs(traj.velocities) > limits
        if bad.any():
            i, k = (int(v) for v in np.argwhere(bad)[0])
            raise GoalError(INVALID_GOAL, f'points[{i}].velocities: {traj.joint_names[k]} = '
                            f'{traj.velocities[i, k]:.6g} {unit[k]}; allowed: at most {joints.velocity[cols[k]]:g} '
                            f'{unit[k]} in size')
    t, P = traj.time, traj.positions
    if t[0] > 0.0:
        t, P = np.concatenate([[0.0], t]), np.vstack([start, P])
    if t.shape[0] > 1:
        step = np.abs(np.diff(P, axis=0))
        mean = step / np.diff(t)[:, None]
        bad = step > (limits if traj.time[0] > 0.0 else limits[:-1]) * (np.diff(t) + TIME_QUANTUM)[:, None]
        if bad.any():
            i, k = (int(v) for v in np.argwhere(bad)[0])
            into = i + (0 if traj.time[0] > 0.0 else 1)
            frm = 'the current state' if traj.time[0] > 0.0 and i == 0 else f'points[{into - 1}]'
            raise GoalError(INVALID_GOAL, f'the move from {frm} into points[{into}] needs {traj.joint_names[k]} at '
                            f'{mean[i, k]:.6g} {unit[k]} on average; allowed: at most {joints.velocity[cols[k]]:g} '
                            f'{unit[k]} (give the point a later time_from_start)')


def _refuse_off_start(joints: ControllerJoints, cols: NDArray[np.int64], traj: JointTrajectory, first: Array,
                      start: Array, start_tolerance: float, what: str, otherwise: str) -> None:
    """Refuse (``INVALID_GOAL``) a trajectory whose ``first`` positions lie farther than ``start_tolerance`` from where
    the joints are (``start``): ``what`` puts the joint there; ``otherwise`` what else is allowed."""
    off = np.abs(first - start)
    k = int(np.argmax(off))
    if off[k] > start_tolerance:
        unit = joints.units[cols[k]]
        raise GoalError(INVALID_GOAL, f'{what} puts {traj.joint_names[k]} {off[k]:.6g} {unit} from where it is '
                        f'({start[k]:.9g} {unit}); allowed: at most {start_tolerance:g} {unit} (start_tolerance), or '
                        f'{otherwise}')


def _refuse_jump(joints: ControllerJoints, cols: NDArray[np.int64], traj: JointTrajectory, start: Array, rate: float,
                 what: str, otherwise: str) -> None:
    """Refuse (``INVALID_GOAL``) a first point at ``t = 0`` that a joint cannot reach from ``start`` within its velocity
    limit in the one sample (``1 / rate`` [s]) the controller takes to get there: ``|q_0 - q_start| rate > v_max``."""
    jump = np.abs(traj.positions[0] - start)
    reach = joints.velocity[cols] / rate
    bad = jump > reach * (1.0 + VELOCITY_SLACK)
    if bad.any():
        k = int(np.argmax(bad))
        u = joints.units[cols[k]]
        raise GoalError(INVALID_GOAL, f'{what} makes {traj.joint_names[k]} jump {jump[k]:.6g} {u} from where it is '
                        f'({start[k]:.9g} {u}) in one sample ({1.0 / rate:.6g} s at rate {rate:g} Hz): '
                        f'{jump[k] * rate:.6g} {u}/s; allowed: at most {reach[k]:.6g} {u} (its velocity limit '
                        f'{joints.velocity[cols[k]]:g} {u}/s for one sample), or {otherwise}')


def _refuse_fast_samples(joints: ControllerJoints, cols: NDArray[np.int64], vel: Array, time: Array) -> None:
    """Only a cubic or quintic overshoots (points without velocities are joined by lines, their means checked
    before): the hint names what helps a goal whose points carry velocities, not to give them."""
    limit = joints.velocity[cols]
    bad = ~(np.abs(vel) <= limit * (1.0 + SPLINE_VELOCITY_SLACK))   # a velocity of NaN (an overflow) too
    if bad.any():
        i, k = (int(v) for v in np.argwhere(bad)[0])
        j, unit = int(cols[k]), f'{joints.units[int(cols[k])]}/s'
        raise GoalError(INVALID_GOAL, f'sample {i} (t = {time[i]:.6g} s): {joints.names[j]} moves at '
                        f'{vel[i, k]:.6g} {unit} (the spline between the points overshoots); allowed: at most '
                        f'{limit[k] * (1.0 + SPLINE_VELOCITY_SLACK):.6g} {unit} in size (the limit {limit[k]:g} and '
                        f'{SPLINE_VELOCITY_SLACK:.0%} for a spline through a timed motion\'s samples; give the points '
                        'other velocities, later times or more points)')


def plan_motion(joints: ControllerJoints, traj: JointTrajectory, current: Array, rate: float, config: GprConfig,
                tolerances: Tolerances, start_tolerance: float, clearance: Clearance | None = None,
                under_way: bool = False, held: Array | None = None, arrival: Array | None = None) -> Motion:
    """Check ``traj`` from the ``current`` positions of every joint ``(N,)`` and sample it at ``rate`` [Hz]: samples at
    ``t_k = k / rate`` and the last point's time (module docstring; :class:`GoalError` with the code). ``under_way``:
    ``traj`` goes on from a trajectory's state at a late arrival (:func:`late_start`), its first point a sample.
    ``held`` ``(N,)``: where the joints ``traj`` leaves out are commanded (lagging joints: the last goal's end;
    None: ``current``); ``arrival``: where they are now, when a lag moves them to ``current`` by the start."""
    cols = joints.indices(traj.joint_names)
    current = np.array(current, dtype=float)   # a copy: the motion's arrays are read-only
    start = current[cols]
    _refuse_beyond(joints, cols, traj.positions, traj.time, 'point')
    if traj.time[0] == 0.0:   # reached in one sample: within start_tolerance, the velocity limits and the clearance
        what, otherwise = (('the trajectory at its arrival', 'a stamp of 0 (start at once) or one whose first point '
                            'lies ahead') if under_way else ('points[0] at time_from_start 0', 'a first point after '
                                                             '0 s, which the joints then reach from where they are'))
        _refuse_off_start(joints, cols, traj, traj.positions[0], start, start_tolerance, what, otherwise)
        _refuse_jump(joints, cols, traj, start, rate, what, otherwise)
    _check_velocities(joints, cols, traj, start, under_way)
    count = grid_count(traj.duration, rate)
    if count > MAX_SAMPLES:
        raise GoalError(INVALID_GOAL, f'the trajectory lasts {traj.duration:.6g} s: {count} samples at {rate:g} Hz; '
                        f'allowed: at most {MAX_SAMPLES} samples')
    t, moving = grid_times(traj.duration, rate), spline(traj, start)
    if not np.all(np.isfinite(moving.coefficients)):   # inf - inf: NaN between samples as well as at them
        raise GoalError(INVALID_GOAL, 'the spline between the points overflows; allowed: velocities and accelerations '
                        'that keep it finite')
    pos, vel, _ = moving.evaluate(t)
    _refuse_beyond(joints, cols, pos, t, 'sample')
    _refuse_fast_samples(joints, cols, vel, t)
    positions = np.repeat((current if held is None else np.asarray(held, dtype=float))[None, :], t.shape[0], axis=0)
    positions[:, cols] = pos
    velocities = np.zeros_like(positions)
    velocities[:, cols] = vel
    now = current if arrival is None else arrival
    lagging = [f'{joints.names[k]} {float(now[k]):.9g} m' for k in range(3)
               if held is not None and k not in cols and held[k] != now[k]]   # quoted at the command, not there
    refuse_tilt(positions[:, :3], t, config, f'; the rods it leaves out at their command, lagging now at '
                f'{", ".join(lagging)}' if lagging else '')
    motion = Motion(t, positions, velocities, cols, tolerances, traj, current)
    if clearance is not None:
        refusal = clearance(motion)
        if refusal:
            raise GoalError(INVALID_GOAL, refusal)
    return motion


def refuse_tilt(rods: Array, time: Array, config: GprConfig, note: str = '', what: str = 'sample') -> None:
    """:class:`GoalError` (``INVALID_GOAL``) for the first of the samples ``rods (K, 3)`` [m] at ``time (K,)`` [s]
    with no platform pose or a tilt beyond ``tilt_limit`` (forward kinematics' rule), ``note`` after its rods."""
    try:
        fk = forward_batch(rods, config, check_limits=False)
    except GprError as exc:
        raise GoalError(INVALID_GOAL, f'the rods have no platform pose on the way: {exc}') from None
    tilted = fk.tilt > config.tilt_limit + TILT_LIMIT_SLACK   # forward kinematics' rule (core.forward.check_tilt)
    if tilted.any():
        i = int(np.argmax(tilted))
        shown, limit = apart(float(fk.tilt[i]), config.tilt_limit)
        raise GoalError(INVALID_GOAL, f'{what} {i} (t = {time[i]:.6g} s): the platform would tilt {shown} rad '
                        f'(rods {", ".join(f"{q:.9g}" for q in rods[i])} m{note}); allowed: at most tilt_limit '
                        f'{limit} rad')


def late_start(joints: ControllerJoints, traj: JointTrajectory, current: Array, late: float,
               start_tolerance: float) -> JointTrajectory:
    """``traj`` with its times from the goal's arrival, ``late`` [s] after the instant its ``header.stamp`` names, as
    joint_trajectory_controller takes a stamp in the past: a trajectory that ended before it arrived is refused
    (``OLD_HEADER_TIMESTAMP``); one whose first point is still ahead keeps every point at its instant (the joints reach
    the first from ``current`` in the time left); one under way goes on from its state at the arrival (the spline
    evaluated at ``late``, then the same polynomials: a segment's positions, velocities and accelerations at ``late``
    determine the rest of it), which must lie within ``start_tolerance`` of where the joints are (``INVALID_GOAL``)."""
    if late <= 0.0:
        return traj
    if late >= traj.duration:
        raise GoalError(OLD_HEADER_TIMESTAMP, f'header.stamp lies {late:.6g} s in the past: the trajectory '
                        f'({traj.duration:.6g} s) ended before it arrived; allowed: 0 (start at once) or a stamp whose '
                        'trajectory ends after it arrives')
    if traj.time[0] > late:
        return traj.shifted(-late)
    cols = joints.indices(traj.joint_names)
    start = np.asarray(current, dtype=float)[cols]
    p, v, a = (x[0] for x in evaluate(traj, start, np.array([late])))
    _refuse_off_start(joints, cols, traj, p, start, start_tolerance,
                      f'header.stamp lies {late:.6g} s in the past: at its arrival the trajectory',
                      'a stamp of 0 (start at once) or one whose first point lies ahead')
    after = traj.time > late
    return JointTrajectory(traj.joint_names, np.concatenate([[0.0], traj.time[after] - late]),
                           np.vstack([p, traj.positions[after]]),
                           None if traj.velocities is None else np.vstack([v, traj.velocities[after]]),
                           None if traj.accelerations is None else np.vstack([a, traj.accelerations[after]]))
