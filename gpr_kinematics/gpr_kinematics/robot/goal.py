"""A ``control_msgs/action/FollowJointTrajectory`` goal, checked and planned from its fields as plain data: the
rules the simulator node (``robot_simulator_node``) applies before it moves, as ros2_control's
joint_trajectory_controller applies them (docs/ros.md, "The robot simulator"). The node converts the message into a
:class:`Goal`; everything that decides lives here.
"""
from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from ..core.config import GprConfig
from ..core.messages import NS_PER_S, SEC_MAX
from ..errors import brief
from .controller import (
    INVALID_GOAL,
    Clearance,
    ControllerJoints,
    GoalError,
    Motion,
    Tolerances,
    late_start,
    plan_motion,
    refuse_tilt,
    trajectory_from_points,
)
from .servo import Lag, after_wait
from .trajectory import MAX_DURATION, MAX_POINTS

Array = NDArray[np.float64]


#: One entry of a goal's tolerance list: joint name, position, velocity, acceleration (control_msgs/JointTolerance).
JointTolerance = tuple[str, float, float, float]


def _apply(joints: ControllerJoints, entries: Sequence[JointTolerance], position: Array, velocity: Array,
           where: str) -> tuple[Array, Array]:
    position, velocity = position.copy(), velocity.copy()
    seen: dict[int, int] = {}
    for i, (name, *values) in enumerate(entries):
        if name not in joints.names:   # a bad tolerance, as docs/ros.md classes it (INVALID_JOINTS is joint_names')
            raise GoalError(INVALID_GOAL, f'{where}[{i}].name: unknown joint {brief(name)}; allowed: '
                            f'{", ".join(joints.names)}')
        k = joints.names.index(name)
        if seen.setdefault(k, i) != i:   # which entry holds would be a guess
            raise GoalError(INVALID_GOAL, f'{where}[{i}] names joint {name!r} as {where}[{seen[k]}] does; allowed: '
                            'one entry per joint')
        for target, what, v in ((position, 'position', values[0]), (velocity, 'velocity', values[1]),
                                (None, 'acceleration', values[2])):
            if not (math.isfinite(v) and (v >= 0.0 or v == -1.0)):
                raise GoalError(INVALID_GOAL, f'{where}[{i}].{what} = {v!r}; allowed: 0 (the default), -1 (not '
                                'checked) or a positive tolerance')
            if target is not None and v != 0.0:
                target[k] = np.inf if v == -1.0 else v
    return position, velocity


def resolve_tolerances(joints: ControllerJoints, defaults: Tolerances, path: Sequence[JointTolerance],
                       goal: Sequence[JointTolerance], goal_time: float) -> Tolerances:
    """A goal's ``path_tolerance`` / ``goal_tolerance`` with control_msgs' rules (0: the controller's default; -1:
    not checked) over ``defaults``; ``goal_time`` 0: the default. Acceleration tolerances
    are validated and not checked (the simulated joints' accelerations are not measured)."""
    if not (math.isfinite(goal_time) and 0.0 <= goal_time <= MAX_DURATION):
        raise GoalError(INVALID_GOAL, f'goal_time_tolerance = {goal_time!r} s; allowed: 0 (the default) or positive, '
                        f'at most {MAX_DURATION:g} s')
    for where, entries in (('path_tolerance', path), ('goal_tolerance', goal)):
        if len(entries) > len(joints.names):
            raise GoalError(INVALID_GOAL, f'{where} has {len(entries)} entries; allowed: at most one per joint '
                            f'({len(joints.names)})')
    path_p, path_v = _apply(joints, path, defaults.path_position, defaults.path_velocity, 'path_tolerance')
    goal_p, goal_v = _apply(joints, goal, defaults.goal_position, defaults.goal_velocity, 'goal_tolerance')
    return Tolerances(path_p, path_v, goal_p, goal_v, goal_time or defaults.goal_time)



@dataclass(frozen=True)
class Goal:
    """A goal's fields [s, rad, m]: the trajectory's joints, its points' times, positions, velocities and
    accelerations (empty lists where a point gives none), whether some point carries efforts, whether its
    multi-DOF trajectory or component tolerances are given, its path and goal tolerances, the goal time tolerance
    and the trajectory's ``header.stamp`` [ns] (0: start at once)."""

    joint_names: Sequence[str]
    times: Sequence[float]
    positions: Sequence[Sequence[float]]
    velocities: Sequence[Sequence[float]]
    accelerations: Sequence[Sequence[float]]
    efforts: bool
    multi_dof: bool
    component_tolerances: bool
    path_tolerance: Sequence[JointTolerance]
    goal_tolerance: Sequence[JointTolerance]
    goal_time_tolerance: float
    stamp_ns: int


@dataclass(frozen=True)
class Controller:
    """The simulated controller's setting: its joints, default tolerances, sampling ``rate`` [Hz], the machine,
    the ``start_tolerance`` [rad or m], whether a trajectory may end moving, the cell's clearance check
    (None: no cell) and the joints' first-order lag [s] (0: they follow the samples exactly)."""

    joints: ControllerJoints
    defaults: Tolerances
    rate: float
    config: GprConfig
    start_tolerance: float
    allow_nonzero_velocity_at_end: bool
    clearance: Clearance | None = None
    servo_time_constant: float = 0.0


def check_point_count(count: int) -> None:
    """Refuse a trajectory of more than :data:`~.trajectory.MAX_POINTS` points, before its points are read."""
    if count > MAX_POINTS:
        raise GoalError(INVALID_GOAL, f'the trajectory has {count} points; allowed: at most {MAX_POINTS}')


def _check_fields(goal: Goal) -> None:
    if goal.multi_dof:
        raise GoalError(INVALID_GOAL, 'multi_dof_trajectory: this robot has no multi-DOF joints; allowed: an empty '
                        'multi_dof_trajectory')
    if goal.component_tolerances:
        raise GoalError(INVALID_GOAL, 'component tolerances apply to multi-DOF joints, which this robot has none of; '
                        'allowed: empty component_path_tolerance and component_goal_tolerance')
    check_point_count(len(goal.times))
    if goal.efforts:
        raise GoalError(INVALID_GOAL, 'points carry efforts; allowed: positions, velocities and accelerations (this '
                        'controller commands positions)')


def plan_goal(goal: Goal, controller: Controller, current: Array, now_ns: int, held: Array | None = None
              ) -> tuple[Motion, int]:
    """The motion of ``goal`` from the joints at ``current`` and its start [ns] on the clock that reads ``now_ns``,
    the joints it leaves out held at ``held`` (lagging joints' command; None: ``current``): the fields checked, the
    trajectory built (:func:`~.controller.trajectory_from_points`), a stamp at most
    :data:`~.trajectory.MAX_DURATION` ahead, a stamp in the past taken as joint_trajectory_controller takes it (from
    the next sample on the stamp's grid, :func:`~.controller.late_start`), then planned and checked
    (:func:`~.controller.plan_motion`). With the controller's lag the joints converge to ``held`` while the goal
    waits for its start, the motion is planned from where that leaves them, and the tilt and the cell's clearance
    are checked along the path the lag takes (:class:`~.servo.Lag`: ``motion.lag``). :class:`~.controller.GoalError`
    with the result code on a refusal."""
    _check_fields(goal)
    c = controller
    joints = c.joints
    traj = trajectory_from_points(joints, list(goal.joint_names), list(goal.times), list(goal.positions),
                                  list(goal.velocities), list(goal.accelerations))
    end = traj.velocities[-1] if traj.velocities is not None else np.zeros(0)
    moving = np.flatnonzero(end != 0.0)
    if moving.size and not c.allow_nonzero_velocity_at_end:   # as joint_trajectory_controller
        k = int(moving[0])
        name = traj.joint_names[k]
        unit = joints.units[joints.names.index(name)]
        raise GoalError(INVALID_GOAL, f'points[{len(goal.times) - 1}] (the last) gives {name} a velocity of '
                        f'{float(end[k])!r} {unit}/s; allowed: 0 at the last point (parameter '
                        'allow_nonzero_velocity_at_trajectory_end, false as joint_trajectory_controller\'s)')
    tol = resolve_tolerances(joints, c.defaults, goal.path_tolerance, goal.goal_tolerance, goal.goal_time_tolerance)
    stamp, period = goal.stamp_ns, 1.0 / c.rate
    start = now_ns if stamp == 0 else stamp
    if stamp and stamp > now_ns + round(MAX_DURATION * NS_PER_S):
        raise GoalError(INVALID_GOAL, f'header.stamp lies {(stamp - now_ns) / NS_PER_S:.6g} s ahead; allowed: at '
                        f'most {MAX_DURATION:g} s')
    late = (now_ns - stamp) / NS_PER_S if stamp and stamp < now_ns - round(period * NS_PER_S) else 0.0
    under_way = False
    if late:   # as joint_trajectory_controller: refused only when it ended before it arrived
        # from the next sample on the stamp's grid (stamp + k / rate), where an on-time goal's samples lie, unless
        # that would pass a first point still ahead on arrival
        grid = math.ceil(late / period - 1e-9) * period
        if grid < traj.duration and not late < traj.time[0] <= grid:
            late = grid
        under_way = bool(traj.time[0] <= late)
        traj = late_start(joints, traj, current, late, c.start_tolerance)
        start = stamp + round(late * NS_PER_S)
    last = start + round((traj.duration + tol.goal_time) * NS_PER_S)   # the last stamp it may publish
    if last // NS_PER_S > SEC_MAX:
        raise GoalError(INVALID_GOAL, f'the goal would run until {last / NS_PER_S:.12g} s on the clock, beyond the '
                        f'int32 sec of a message stamp; allowed: a goal ending by {SEC_MAX} s (2038-01-19T03:14:07Z)')
    tau = c.servo_time_constant
    wait = max(start - now_ns, 0) / NS_PER_S if tau > 0.0 and held is not None else 0.0
    try:
        if not tau > 0.0:
            motion = plan_motion(joints, traj, current, c.rate, c.config, tol, c.start_tolerance, c.clearance,
                                 under_way, held)
            return dataclasses.replace(motion, late=late), start
        # lagging: the joints converge to the last command while the goal waits, the goal planned from there, then
        # its checks along the path the lag takes (the tilt, the cell's clearance: GoalClearance follows motion.lag)
        begin = after_wait(current, held, wait, tau) if held is not None else current
        motion = plan_motion(joints, traj, begin, c.rate, c.config, tol, c.start_tolerance, None, under_way, held,
                             current)
        lag = Lag.of(tau, current, held, wait, motion.time, motion.positions)
        refuse_tilt(lag.samples[:, :3], motion.time, c.config, f'; lagging {tau:g} s (servo_time_constant) behind '
                    'the samples', 'the joints at sample')
        motion = dataclasses.replace(motion, late=late, lag=lag)
        refusal = c.clearance(motion) if c.clearance is not None else None
        if refusal:
            raise GoalError(INVALID_GOAL, refusal)
        return motion, start
    except GoalError as exc:
        if not late:
            raise
        raise GoalError(exc.code, f'{exc} (times from the goal\'s arrival, {late:.6g} s after its header.stamp)'
                        ) from None


def clock_set_back(last_ns: int, now_ns: int, period: float, at: float | None) -> str | None:
    """The abort of a running goal whose clock went back more than a sample ``period`` [s] (a simulation reset, ``ros2
    bag play --loop --clock``): from ``last_ns``, its latest reading, to ``now_ns``; ``at`` [s] the last sample sent
    (None: still waiting for its ``header.stamp``). None for a clock that did not go back (it froze the goal for as
    long as the jump). A tick or more back, as ``trajectory_node`` tells a reset from jitter."""
    back = last_ns - now_ns
    if back <= round(period * NS_PER_S):
        return None
    where = 'while it waited for its header.stamp' if at is None else f'at t = {at:.6g} s of the goal'
    return (f'the clock was set back {back / NS_PER_S:.10g} s (from {last_ns / NS_PER_S:.12g} s to '
            f'{now_ns / NS_PER_S:.12g} s) {where}: its samples are stamped on that clock; allowed: a clock that does '
            'not go back while a goal runs (send the goal again)')
