"""Joint trajectories as a robot controller takes them (``trajectory_msgs/JointTrajectory``, without ROS).

A :class:`JointTrajectory` names its joints and gives points: a time from the start ``t_i`` [s], the joints'
positions [m, rad] and optionally their velocities and accelerations. :func:`evaluate` interpolates it as ros2_control's
``joint_trajectory_controller`` does (its spline interpolator): between two points a polynomial in ``tau = t - t_i``
that meets both points' positions (degree 1, *linear*, when the points give positions only), and velocities (degree 3,
*cubic* Hermite) and accelerations (degree 5, *quintic*) when they give them:

    ``p(tau) = c0 + c1 tau + ... + c5 tau^5``,  ``c0 = p_i``, ``c1 = v_i``, ``c2 = a_i / 2`` and, with
    ``D = p_{i+1} - p_i`` and ``h = t_{i+1} - t_i``:
    ``c3 = (20 D - (8 v_{i+1} + 12 v_i) h - (3 a_i - a_{i+1}) h^2) / (2 h^3)``,
    ``c4 = (-30 D + (14 v_{i+1} + 16 v_i) h + (3 a_i - 2 a_{i+1}) h^2) / (2 h^4)``,
    ``c5 = (12 D - 6 (v_{i+1} + v_i) h + (a_{i+1} - a_i) h^2) / (2 h^5)`` (quintic; the cubic's ``c2, c3`` are
    ``(3 D / h - 2 v_i - v_{i+1}) / h`` and ``(-2 D / h + v_i + v_{i+1}) / h^2``).

At ``tau = 0`` the value is ``p_i`` exactly, so every point is met to the last bit at its own time. When the first point
lies after ``t = 0`` the motion starts from the given start positions at rest (zero velocity and acceleration) and
reaches the first point by the same rule; after the last point the joints hold it. The polynomials themselves, and
every joint's exact travel between two instants, are :func:`spline`'s (:mod:`.spline`).

:func:`program_trajectory` turns a checked robot program (:mod:`.plan`) into the trajectory that executes it as
``gpr program export`` times it: one point per sample at a rate (:func:`~gpr_kinematics.robot.timing.sample`), with
the positions and the exact velocities of the time parameterisation; :func:`lead_in` prepends the move from where the
robot is to the program's first waypoint, timed within the joints' limits. :func:`trajectory_yaml` writes the
``trajectory_msgs/JointTrajectory`` YAML that ``ros2 action send_goal`` reads. The rods are the joints ``rod_1 ..
rod_3`` of the robot model and ``joint_states`` (:data:`~gpr_kinematics.core.messages.ROD_JOINT_NAMES`).
"""
from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import NDArray

from ..core.forward import forward
from ..core.messages import ROD_JOINT_NAMES, duration_parts
from ..errors import GprError, InputError, LimitError, RobotStateError
from ..inputs.files import check_suffix, write_text
from .grid import check_rate
from .plan import ProgramPlan, joint_limits, plan_samples, plan_velocities, position_limits
from .spline import Spline
from .timing import MAX_SAMPLES, parameterise, sample, sample_times, velocities

Array = NDArray[np.float64]

#: Most points a trajectory may have, and most joints (the example robot has 10).
MAX_POINTS = MAX_SAMPLES
MAX_JOINTS = 64
#: Longest trajectory [s] (a day).
MAX_DURATION = 86_400.0


@dataclass(frozen=True)
class JointTrajectory:
    """Points ``P`` over joints ``J``: ``time (P,)`` [s from the start], ``positions (P, J)`` [m, rad],
    ``velocities`` and ``accelerations`` ``(P, J)`` or None (not given)."""

    joint_names: tuple[str, ...]
    time: Array
    positions: Array
    velocities: Array | None = None
    accelerations: Array | None = None

    def __len__(self) -> int:
        return int(self.time.shape[0])

    @property
    def degree(self) -> int:
        """1 (linear: positions only), 3 (cubic: with velocities) or 5 (quintic: with accelerations too)."""
        return 1 if self.velocities is None else 3 if self.accelerations is None else 5

    @property
    def duration(self) -> float:
        """Time of the last point [s]."""
        return float(self.time[-1])

    def shifted(self, dt: float) -> JointTrajectory:
        """The same points ``dt`` seconds later."""
        return replace(self, time=self.time + dt)


def spline(traj: JointTrajectory, start: Array) -> Spline:
    """The polynomials :func:`evaluate` follows (:class:`~gpr_kinematics.robot.spline.Spline`), from ``start (J,)`` at
    rest when the first point lies after ``t = 0`` (module docstring)."""
    P = traj.positions
    V = traj.velocities if traj.velocities is not None else np.zeros_like(P)
    A = traj.accelerations if traj.accelerations is not None else np.zeros_like(P)
    times = traj.time
    if times[0] > 0.0:
        rest = np.zeros((1, P.shape[1]))
        times = np.concatenate([[0.0], times])
        P, V, A = np.vstack([np.asarray(start, dtype=float)[None, :], P]), np.vstack([rest, V]), np.vstack([rest, A])
    return Spline.of(times, P, V, A, traj.degree)


def evaluate(traj: JointTrajectory, start: Array, t: Array) -> tuple[Array, Array, Array]:
    """Positions, velocities and accelerations ``(K, J)`` of ``traj`` at times ``t (K,)`` [s], starting at rest from
    ``start (J,)`` when the first point lies after ``t = 0`` (module docstring)."""
    return spline(traj, start).evaluate(np.asarray(t, dtype=float))


def trajectory_joint_names(plan: ProgramPlan) -> tuple[str, ...]:
    """The joints of a program's trajectory: the rods as the robot model names them, then every arm's joints."""
    return (*ROD_JOINT_NAMES, *plan.joint_names[3:])


def within_a_day(duration: float, what: str = 'the trajectory') -> None:
    """:class:`InputError` for a trajectory of ``duration`` [s] beyond :data:`MAX_DURATION`, the longest a goal of the
    controller may last (its points' ``time_from_start``): a program that long is checked and exported as samples,
    not sent as one goal."""
    if duration > MAX_DURATION:
        raise InputError(f'{what} lasts {duration:.6g} s; allowed: at most {MAX_DURATION:g} s (a day, the longest a '
                         'FollowJointTrajectory goal of the controller lasts): split the program')


def program_trajectory(plan: ProgramPlan, rate: float) -> JointTrajectory:
    """The trajectory that executes ``plan``: one point per sample at ``rate`` [Hz] (``t_k = k / rate`` and the final
    instant, as ``gpr program export --samples`` samples it), positions and velocities of the time parameterisation,
    over the rods and every arm's joints (module docstring); :func:`within_a_day`."""
    within_a_day(plan.timing.total, f'{plan.program.source}: the program')
    s = plan_samples(plan, sample(plan.timing, rate))
    return JointTrajectory(trajectory_joint_names(plan), s.time, s.positions, plan_velocities(plan, s))


#: How far beyond a joint's limits a robot may report itself for :func:`lead_in` [m or rad] (an encoder's overshoot
#: at a limit, taken as the limit: a goal starting beyond it is refused; 50 m or 1e300 are not a state of this robot).
REPORTED_SLACK = 1e-3


def lead_in(plan: ProgramPlan, traj: JointTrajectory, current: Array, rate: float) -> tuple[JointTrajectory, float]:
    """``traj`` (of :func:`program_trajectory`) preceded by the move from ``current`` (the robot's positions of
    ``traj.joint_names``) to its first point, timed within the joints' velocity and acceleration limits and rounded up
    to whole sample periods; the trajectory and the move's duration [s] (0 when the robot is at the first point).
    :class:`~gpr_kinematics.errors.RobotStateError` where the robot reports joints beyond their limits by more than
    :data:`REPORTED_SLACK` or rods that tilt the platform beyond its limit."""
    rate = check_rate(rate)
    current = np.asarray(current, dtype=float)
    if current.shape != (len(traj.joint_names),) or not np.all(np.isfinite(current)):
        raise InputError(f'the current positions must be {len(traj.joint_names)} finite numbers, one per joint of '
                         f'the trajectory ({", ".join(traj.joint_names)})')
    _, velocity, acceleration, _ = joint_limits(plan.robot)
    names = traj.joint_names
    lower, upper = position_limits(plan.robot)
    over = np.maximum(lower - current, current - upper)
    outside = np.flatnonzero(over > REPORTED_SLACK)
    if outside.size:   # a lead-in from there would leave the limits (or last for ever: 1e300 m)
        j = int(outside[0])
        unit = 'm' if j < 3 else 'rad'
        raise RobotStateError(f'the robot reports {names[j]} = {current[j]:.9g} {unit}, {over[j]:.3g} {unit} outside '
                              f'its limits [{lower[j]:.9g}, {upper[j]:.9g}] {unit}; allowed: a robot within its limits '
                              f'(to {REPORTED_SLACK:g} {unit}; are these joint states of this robot?)')
    current = np.clip(current, lower, upper)   # an encoder's overshoot: the goal starts within the limits
    current[:3] = _within_the_tilt(plan, current[:3], names)
    ends = np.vstack([current, traj.positions[0]])
    shortest = parameterise(ends, velocity, acceleration, np.full(2, np.nan), np.zeros(2), names,
                            ('the current state', 'the first point')).total
    if shortest == 0.0:
        return traj, 0.0
    periods = max(1, math.ceil(shortest * rate))
    timing = parameterise(ends, velocity, acceleration, np.array([np.nan, periods / rate]), np.zeros(2), names,
                          ('the current state', 'the first point'))
    t = sample_times(timing, rate)[:-1]    # the move's samples before its end: the program's first point follows
    move = sample(timing, rate)
    if len(traj) + t.shape[0] > MAX_POINTS:
        raise InputError(f'the trajectory would have {len(traj) + t.shape[0]} points; allowed: at most {MAX_POINTS}; '
                         'lower the rate')
    # The program's points keep their place on the rate's grid (t = (periods + k) / rate), so a controller sampling at
    # the rate meets them at their own instants; a final instant off the grid moves by the whole lead-in.
    k = np.round(traj.time * rate)
    time = np.where(np.abs(traj.time * rate - k) <= 1e-6, (periods + k) / rate, traj.time + periods / rate)
    within_a_day(float(time[-1]), 'the trajectory with its lead-in')
    vel = traj.velocities if traj.velocities is not None else np.zeros_like(traj.positions)
    out = JointTrajectory(traj.joint_names, np.concatenate([t, time]),
                          np.vstack([move.positions[:t.shape[0]], traj.positions]),
                          np.vstack([velocities(timing, t), vel]))
    return out, periods / rate


def _within_the_tilt(plan: ProgramPlan, rods: Array, names: Sequence[str]) -> Array:
    """Reported rods ``(3,)`` [m] whose platform tilts at most :data:`REPORTED_SLACK` rad beyond the tilt limit (an
    encoder's overshoot at a station on the limit), their differences drawn in to the limit: a goal starts there;
    :class:`~gpr_kinematics.errors.RobotStateError` for rods farther beyond, or of no platform pose."""
    cfg = plan.robot.config
    limit = cfg.tilt_limit
    for _ in range(3):   # the tilt goes with the rods' differences, to first order: a step or two
        try:
            tilt = float(forward(rods, cfg, check_limits=False, stroke=False).tilt)
        except GprError:
            break   # no pose at all: named by the check below
        if not limit < tilt <= limit + REPORTED_SLACK:
            break
        mean = float(np.mean(rods))
        rods = mean + (rods - mean) * (limit / tilt)
    try:   # rods no platform takes (tilted beyond the limit): no move starts there (the simulator ignores them)
        forward(rods, cfg, stroke=False)
    except LimitError as exc:
        allowed = '' if 'allowed:' in str(exc) else '; allowed: rods within the tilt limit'
        raise RobotStateError(f'the robot reports {", ".join(names[:3])}: {exc}{allowed} (to {REPORTED_SLACK:g} rad '
                              'beyond: taken as at the limit; are these joint states of this robot?)') from None
    return rods


def _duration(t: float) -> str:
    sec, nanosec = duration_parts(t)
    return f'{{sec: {sec}, nanosec: {nanosec}}}'


def _numbers(values: Array) -> str:
    return '[' + ', '.join(repr(float(v)) for v in values) + ']'


def trajectory_yaml(traj: JointTrajectory) -> str:
    """``trajectory_msgs/JointTrajectory`` as YAML in flow style (one point per line), as ``ros2 action send_goal``
    reads it: ``"{trajectory: $(cat FILE)}"``. Numbers round-trip exactly; times are ``builtin_interfaces/Duration``
    (whole nanoseconds)."""
    lines = ['{header: {frame_id: ""},', f'  joint_names: [{", ".join(traj.joint_names)}],', '  points: [']
    for i in range(len(traj)):
        fields = [f'positions: {_numbers(traj.positions[i])}']
        if traj.velocities is not None:
            fields.append(f'velocities: {_numbers(traj.velocities[i])}')
        if traj.accelerations is not None:
            fields.append(f'accelerations: {_numbers(traj.accelerations[i])}')
        fields.append(f'time_from_start: {_duration(float(traj.time[i]))}')
        lines.append('    {' + ', '.join(fields) + '}' + (',' if i + 1 < len(traj) else ''))
    lines.append('  ]}')
    return '\n'.join(lines) + '\n'


def write_trajectory(path: str, traj: JointTrajectory) -> str:
    """Write :func:`trajectory_yaml` to ``path`` atomically (a ``.yaml`` or ``.yml`` file); the path written."""
    check_suffix(path, 'trajectory file', ('.yaml', '.yml'))
    return str(write_text(path, trajectory_yaml(traj), 'trajectory'))
