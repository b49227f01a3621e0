"""Checking a program: every waypoint solved, the moves timed within the limits, the program sampled.

:func:`plan_program` expands the program's steps into waypoints (:func:`~gpr_kinematics.robot.program.expand`),
solves each for the rods and its arm's joints (:func:`~gpr_kinematics.robot.inverse.solve_stations`, the arms in
one batch each; an arm not in use holds its joints, from its ``home`` posture on), and times the moves between them
(joint-space lines, and the straight entries of :mod:`~gpr_kinematics.robot.paths`) within the rods' and the joints'
velocity, acceleration and jerk limits (:func:`~gpr_kinematics.robot.timing.parameterise`). Any waypoint the
robot cannot reach, and any requested move
time the limits cannot meet, refuses the program with the step and the reason. :func:`sample_plan` samples the
plan at a rate, with the wafer pose of the arm in use at every sample (forward kinematics, limits checked).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import cast

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..errors import ConfigError, InputError, LimitError, brief
from ..inputs.validation import column_of, count_of
from .description import RobotDescription
from .forward import check_robot, robot_forward
from .grid import check_rate, grid_count, lower_rate
from .inverse import StationSolution, solve_stations
from .paths import GRID, line_gains, line_positions
from .program import RobotProgram, Waypoints, expand
from .timing import (
    MAX_SAMPLES,
    Samples,
    Timing,
    evaluate,
    least_total,
    locate,
    parameterise,
    sample,
    sample_at,
    sample_count,
    velocities,
)
from .transforms import PoseBatch

Array = NDArray[np.float64]


@dataclass(frozen=True)
class ProgramPlan:
    """A checked program.

    Attributes:
        waypoints: the expanded steps. joint_names: rods, then every arm's joints (the columns of ``positions``).
        positions: joint values at every waypoint ``(W, J)`` [m, rad].
        wafer: the wafer pose reached at every waypoint (its arm's), world frame.
        naive_wafer_error: where the naive model's joints would put the wafer minus the waypoint ``(W, 3)`` [m].
        timing: the moves in time. labels: how messages and tables name each waypoint,
            ``steps[s] (kind station, phase)``.
    """

    robot: RobotDescription
    program: RobotProgram
    waypoints: Waypoints
    joint_names: tuple[str, ...]
    positions: Array
    wafer: PoseBatch
    naive_wafer_error: Array
    timing: Timing
    labels: tuple[str, ...]


def shortest_duration(program: RobotProgram) -> float:
    """A lower bound of the program's duration [s], known before it is planned: its dwells and the move times it
    asks for (a move as fast as the limits allow takes more than 0; the first move's time is unused)."""
    total, first = 0.0, True
    for step in program.steps:
        if step.kind == 'dwell':
            total += step.dwell or 0.0
            continue
        total += (step.dwell if step.dwell is not None else program.dwell) + (0.0 if first else step.time or 0.0)
        first = False
    return total


def check_sample_count(program: RobotProgram, rate: float, least: float | None = None,
                       what: str = 'its dwells and move times') -> None:
    """Refuse a sampling at ``rate`` [Hz] beyond :data:`~gpr_kinematics.robot.timing.MAX_SAMPLES` of a program that
    lasts at least ``least`` [s] (:class:`InputError`; ``what`` says whence). By default, before the program is
    planned, its :func:`shortest_duration`; :func:`plan_program` checks its moves' least durations once the waypoints
    are solved."""
    least = shortest_duration(program) if least is None else least
    if grid_count(least, check_rate(rate)) > MAX_SAMPLES:
        raise InputError(f'{program.source}: the program lasts at least {least:.6g} s ({what}): at {rate:g} Hz more '
                         f'than {MAX_SAMPLES} samples; allowed: at most {MAX_SAMPLES}{lower_rate(rate)}')


def joint_limits(robot: RobotDescription) -> tuple[tuple[str, ...], Array, Array, list[slice]]:
    """Joint names (rods, then each arm's), velocity and acceleration limits, and each arm's column slice."""
    names = list(robot.rods.names)
    velocity = [robot.rods.velocity] * 3
    acceleration = [robot.rods.acceleration] * 3
    slices = []
    for a in robot.arms:
        slices.append(slice(len(names), len(names) + len(a.joints)))
        names += list(a.joint_names)
        velocity += list(a.velocity)
        acceleration += list(a.acceleration)
    return tuple(names), np.array(velocity), np.array(acceleration), slices


def position_limits(robot: RobotDescription) -> tuple[Array, Array]:
    """The lower and upper limits of the rods (the geometry's stroke [m]) and every arm's joints [rad], in
    :func:`joint_limits`' order."""
    cfg = robot.config
    lower = [cfg.stroke_min] * 3 + [v for a in robot.arms for v in a.lower]
    upper = [cfg.stroke_max] * 3 + [v for a in robot.arms for v in a.upper]
    return np.array(lower), np.array(upper)


def jerk_limits(robot: RobotDescription) -> Array:
    """The jerk limits of the rods and every arm's joints, in :func:`joint_limits`' order (``inf``: none)."""
    rods = np.inf if robot.rods.jerk is None else robot.rods.jerk
    return np.concatenate([[rods] * 3, *[a.jerk for a in robot.arms]])


def line_moves(plan_way: Waypoints) -> list[int]:
    """The moves (into waypoint ``m + 1``) that keep the wafer on a straight line."""
    return [m for m in range(len(plan_way) - 1) if plan_way.is_line(m)]


def move_rows(robot: RobotDescription, way: Waypoints, positions: Array, m: int, s: Array, label: str = '') -> Array:
    """Joint rows at ``s`` (profile values) of move ``m``: on the joint-space line, or solved on the wafer's line."""
    if not way.is_line(m):
        return np.asarray(positions[m] + s[:, None] * (positions[m + 1] - positions[m]), dtype=np.float64)
    _, _, _, slices = joint_limits(robot)
    cols = slices[robot.arm_names.index(way.arm[m + 1])]
    return line_positions(robot, way.stations, way.arm[m + 1], way.branch[m + 1], positions[m], cols, m, s, label)


@dataclass(frozen=True)
class ProgramSummary:
    """What a planned program comes to (``gpr program check``'s summary and the head of its ``--json``): the
    program and robot, counts, the duration [s], each joint's peak velocity and acceleration as a fraction of its
    limit (:func:`peak_usage`, in ``joint_names`` order), the largest naive-model wafer error [m] and the waypoint
    where."""

    program: str
    robot: str
    stations: int
    steps: int
    waypoints: int
    duration: float
    joint_names: tuple[str, ...]
    velocity_usage: Array
    acceleration_usage: Array
    max_naive_wafer_error: float
    max_naive_wafer_error_at: str


#: Instants per straight line at which :func:`peak_usage` evaluates the joints (besides its S-curve's corners), and
#: the step in the path parameter of its central differences.
PEAK_SAMPLES = 1000
_PEAK_STEP = 1e-4


def peak_usage(plan: ProgramPlan) -> tuple[Array, Array]:
    """Per joint, the largest speed and acceleration the program reaches as a fraction of its limit ``(J,)``. On a
    joint-space line exactly ``|D_k| v`` and ``|D_k| a`` (the profile's cruise speed and peak acceleration); on a
    straight line ``|q' s'|`` and ``|q'' s'^2 + q' s''|`` at :data:`PEAK_SAMPLES` instants and the S-curve's corners,
    ``q'``, ``q''`` by central differences of :func:`move_rows` in ``s`` (a sampled maximum, to about 1e-5 of the
    limit). The timing keeps the chain rule's bounds (:meth:`~gpr_kinematics.robot.timing.Timing.usage`) within the
    limits; on a line they lie above these peaks (the cell example's arm2_hand: 0.58 of its acceleration limit for
    0.24 reached)."""
    t = plan.timing
    if t.duration.shape[0] == 0:
        return np.zeros(t.velocity.shape), np.zeros(t.velocity.shape)
    vel, acc, _ = t.peaks()
    p, h = t.profiles, _PEAK_STEP
    for m in line_moves(plan.waypoints):
        if not np.isfinite(p.v[m]):
            continue
        T = p.T[m]
        tau = np.unique(np.concatenate([np.linspace(0.0, T, PEAK_SAMPLES),
                                        np.clip([p.tj[m], p.tj[m] + p.tc[m], p.ta[m]], 0.0, T),
                                        np.clip([T - p.ta[m], T - p.tj[m] - p.tc[m], T - p.tj[m]], 0.0, T)]))
        s, ds, dds = evaluate(p, np.full(tau.shape, m, dtype=np.int64), tau)
        c = np.clip(s, h, 1.0 - h)          # the stencil within the line
        n = c.shape[0]
        rows = move_rows(plan.robot, plan.waypoints, plan.positions, m, np.concatenate([c - h, c, c + h]),
                         plan.labels[m + 1])
        q2 = (rows[2 * n:] - 2.0 * rows[n:2 * n] + rows[:n]) / (h * h)
        q1 = (rows[2 * n:] - rows[:n]) / (2.0 * h) + q2 * (s - c)[:, None]
        vel[m] = np.max(np.abs(q1 * ds[:, None]), axis=0)
        acc[m] = np.max(np.abs(q2 * (ds * ds)[:, None] + q1 * dds[:, None]), axis=0)
    return np.max(vel, axis=0) / t.velocity, np.max(acc, axis=0) / t.acceleration


def program_summary(plan: ProgramPlan) -> ProgramSummary:
    """The :class:`ProgramSummary` of ``plan``."""
    v, a = peak_usage(plan)
    err = np.linalg.norm(plan.naive_wafer_error, axis=1)
    i = int(np.argmax(err))
    return ProgramSummary(plan.program.source, plan.robot.name, len(plan.program.stations), len(plan.program.steps),
                          len(plan.waypoints), plan.timing.total, tuple(plan.joint_names), v, a, float(err[i]),
                          plan.labels[i])


def _solve_waypoints(robot: RobotDescription, program: RobotProgram, way: Waypoints, arm: str, idx: NDArray[np.intp]
                     ) -> StationSolution:
    """The waypoints ``idx`` of ``arm`` solved in one batch (limits marked, not raised); a refusal of the batch names
    the program and the step of the waypoint it is about, found by solving each alone (the first one refused, with
    its own message; a 3-joint arm at a station without heading), as a limit's refusal does."""
    try:
        return solve_stations(robot, way.stations.take(idx), arm, branch=[way.branch[i] for i in idx], check=False)
    except InputError as exc:
        batch = exc
    for i in idx.tolist():
        try:
            solve_stations(robot, way.stations.take([i]), arm, branch=way.branch[i], check=False)
        except InputError as exc:
            raise type(exc)(f'{program.source}: {_label(program, way, i)}: {exc}') from None
    raise type(batch)(f'{program.source}: arm {arm}: {batch}') from None   # of the batch, no waypoint's alone


def _check_kinds(robot: object, program: object) -> None:
    """Refuse a robot that is no RobotDescription and a program that is no RobotProgram (an AttributeError later)."""
    check_robot(robot)
    if not isinstance(program, RobotProgram):
        raise InputError(f'program = {brief(program)}; allowed: a RobotProgram (load_program or parse_program)')


def plan_program(robot: RobotDescription, program: RobotProgram, rate: float | None = None) -> ProgramPlan:
    """Check ``program`` on ``robot`` (module docstring). With ``rate`` [Hz], a program that cannot be sampled at it
    is refused once its waypoints are solved, before its straight lines and moves are timed (the costly part): its
    dwells and each move's least time within the joints' limits (:func:`~gpr_kinematics.robot.timing.least_total`,
    the duration itself on joint-space lines) against :data:`~gpr_kinematics.robot.timing.MAX_SAMPLES`; and, by its
    duration, once its moves are timed, before it is sampled.

    Raises:
        InputError: with ``rate``, more than MAX_SAMPLES samples at it, or a rate outside the allowed ones.
        ConfigError: an unknown arm or branch in a step; a pick or place out of order (:func:`check_wafers`).
        LimitError: a waypoint out of reach or beyond a limit, a move time shorter than the limits allow; the
            message names the program, the step and the reason.
    """
    _check_kinds(robot, program)
    way = expand(program, robot)
    check_wafers(program, way)
    W = len(way)
    names, velocity, acceleration, slices = joint_limits(robot)
    rods = np.empty((W, 3))
    own = np.full((W, len(names)), np.nan)
    wafer_p, wafer_R, naive = np.empty((W, 3)), np.empty((W, 3, 3)), np.empty((W, 3))
    feasible = np.ones(W, dtype=bool)
    arm_of = np.array(way.arm)
    for a, cols in zip(robot.arms, slices, strict=True):
        idx = np.flatnonzero(arm_of == a.name)
        if idx.size == 0:
            continue
        sol = _solve_waypoints(robot, program, way, a.name, idx)
        rods[idx] = sol.rods
        own[idx, cols] = sol.joints
        wafer_p[idx], wafer_R[idx] = sol.forward.wafer.position, sol.forward.wafer.rotation
        naive[idx] = sol.naive_wafer_error
        feasible[idx] = sol.feasible
    plan_labels = tuple(_label(program, way, i) for i in range(W))
    if not feasible.all():
        i = int(np.argmax(~feasible))
        try:
            solve_stations(robot, way.stations.take([i]), way.arm[i], branch=way.branch[i],
                           unit_at=_station_at(program, way, i))   # the unit's hint judged at the station itself
        except LimitError as exc:
            more = int(np.count_nonzero(~feasible)) - 1
            tail = f' (and {more} more waypoint{"s" if more > 1 else ""})' if more else ''
            raise LimitError(f'{program.source}: {plan_labels[i]}: {exc}{tail}') from None
    positions = _held_positions(robot, rods, own, slices)
    jerk = jerk_limits(robot)
    if rate is not None:
        try:
            least = least_total(positions, velocity, acceleration, jerk, way.time, way.dwell, names, plan_labels)
        except LimitError as exc:
            raise LimitError(f'{program.source}: {exc}') from None
        check_sample_count(program, rate, least, "its dwells and its moves' least times within the joints' limits")
    D = np.abs(np.diff(positions, axis=0))
    gains = (D, np.zeros(D.shape), np.zeros(D.shape))
    grid = np.linspace(0.0, 1.0, GRID)
    try:
        for m in line_moves(way):
            label = plan_labels[m + 1]  # the program's name is added once, below (it read 'p.yaml: p.yaml: steps[4]')
            cols = slices[robot.arm_names.index(way.arm[m + 1])]
            g = line_gains(robot.arm(way.arm[m + 1]), cols, move_rows(robot, way, positions, m, grid, label), label)
            for k in range(3):
                gains[k][m] = g[k]
        timing = parameterise(positions, velocity, acceleration, way.time, way.dwell, names, plan_labels, jerk,
                              gains)
    except LimitError as exc:
        raise LimitError(f'{program.source}: {exc}') from None
    if rate is not None:   # the count itself, before anything is sampled or written
        try:
            sample_count(timing.total, rate)
        except InputError as exc:
            raise InputError(f'{program.source}: {exc}') from None
    return ProgramPlan(robot, program, way, names, positions, PoseBatch(wafer_p, wafer_R), naive, timing,
                       plan_labels)


def _held_positions(robot: RobotDescription, rods: Array, own: Array, slices: list[slice]) -> Array:
    """The joint rows ``(W, J)``: the rods, each arm's solved joints and, where an arm is not in use, its joints held
    (from its ``home`` posture on)."""
    positions = own.copy()
    positions[:, :3] = rods
    for a, cols in zip(robot.arms, slices, strict=True):
        held = np.array(a.home)
        block = own[:, cols]
        for i in range(block.shape[0]):  # an arm not in use holds its joints
            if np.isnan(block[i, 0]):
                block[i] = held
            else:
                held = block[i]
        positions[:, cols] = block
    return positions


def check_wafers(program: RobotProgram, way: Waypoints) -> None:
    """Follow the wafers through the steps, before anything is solved: a pick with a full blade, a place onto a full
    station and, where the program declares its ``wafers``, a pick from an empty station or a place with an empty
    blade are refused (ConfigError naming the step), for every command and node that plans the program."""
    declared = program.wafers is not None        # wafers: [] declares that no station holds one
    present, carrying = set(program.wafers or ()), set()
    for i, phase in enumerate(way.phase):
        if phase != 'at':
            continue
        step = program.steps[int(way.step[i])]
        arm, station = way.arm[i], str(step.station)
        where = f'{program.source}: {_label(program, way, i)}'
        if step.kind == 'pick':
            if arm in carrying:
                raise ConfigError(f'{where}: arm {arm} already carries a wafer; allowed: a pick with an empty blade '
                                  '(place the wafer first)')
            if station not in present and declared:
                raise ConfigError(f'{where}: station {station} holds no wafer (the program declares wafers: '
                                  f'[{", ".join(program.wafers or ())}]); allowed: a pick where a wafer lies')
            present.discard(station)
            carrying.add(arm)
        else:
            if arm not in carrying and declared:
                raise ConfigError(f'{where}: arm {arm} carries no wafer to place; allowed: a place after the arm\'s '
                                  'pick')
            if station in present:
                raise ConfigError(f'{where}: station {station} already holds a wafer; allowed: a place onto an empty '
                                  'station (pick its wafer first)')
            carrying.discard(arm)
            present.add(station)


def _station_at(program: RobotProgram, way: Waypoints, i: int) -> Array:
    """The position ``(1, 3)`` [m, world] of the station waypoint ``i`` is derived from (its approach, entry and
    retract lie beside it: pm1 typed in metres in a file in mm, 1.7 mm from the origin, had its entry 330 mm away
    refused without the hint of metres given as millimetres, and its approach hinted as 8.9 mm from it)."""
    table = program.stations
    k = table.index()[str(program.steps[int(way.step[i])].station)]
    return table.stations.position[k:k + 1]


def _label(program: RobotProgram, way: Waypoints, i: int) -> str:
    step = program.steps[int(way.step[i])]
    return f'steps[{int(way.step[i])}] ({step.kind} {step.station}, {way.phase[i]})'


@dataclass(frozen=True)
class PlanSamples:
    """A plan sampled in time: the :class:`~gpr_kinematics.robot.timing.Samples`, the arm in use at each sample
    (the arm of the waypoint held or moved to) and its wafer pose in the world."""

    samples: Samples
    arm: tuple[str, ...]
    wafer: PoseBatch

    def __len__(self) -> int:
        return len(self.samples)


def plan_samples(plan: ProgramPlan, s: Samples) -> Samples:
    """``s`` with the rows of the straight lines solved on the line (:func:`move_rows`)."""
    moving = s.held < 0
    pos = s.positions.copy()
    for m in line_moves(plan.waypoints):
        idx = np.flatnonzero(moving & (s.target == m + 1))
        if idx.size:
            pos[idx] = move_rows(plan.robot, plan.waypoints, plan.positions, m, s.s[idx], plan.labels[m + 1])
    return Samples(s.time, pos, s.held, s.target, s.s)


#: Step of the path parameter for the joints' rates on a straight line (central differences, error ~1e-12 rad/s).
_PATH_STEP = 1e-6


def plan_velocities(plan: ProgramPlan, s: Samples) -> Array:
    """The joints' velocities ``(S, J)`` at the samples ``s`` of :func:`plan_samples` [m/s, rad/s]: ``ds/dt D`` on
    the joint-space line of a move (:func:`~gpr_kinematics.robot.timing.velocities`), ``dq/ds ds/dt`` on a straight
    line of the wafer (``dq/ds`` by central differences of :func:`move_rows` in the path parameter)."""
    vel = velocities(plan.timing, s.time)
    moving = s.held < 0
    _, _, m_all, tau = locate(plan.timing, s.time)
    for m in line_moves(plan.waypoints):
        idx = np.flatnonzero(moving & (s.target == m + 1))
        if idx.size:
            lo = np.clip(s.s[idx] - _PATH_STEP, 0.0, 1.0)
            hi = np.clip(s.s[idx] + _PATH_STEP, 0.0, 1.0)
            rows = move_rows(plan.robot, plan.waypoints, plan.positions, m, np.concatenate([lo, hi]),
                             plan.labels[m + 1])
            dq_ds = (rows[idx.size:] - rows[:idx.size]) / (hi - lo)[:, None]
            ds_dt = evaluate(plan.timing.profiles, m_all[idx], tau[idx])[1]
            vel[idx] = dq_ds * ds_dt[:, None]
    return vel


def sample_times_of(times: ArrayLike) -> Array:
    """Times [s] to sample a plan at, as a float array ``(S,)``: finite, at most
    :data:`~gpr_kinematics.robot.timing.MAX_SAMPLES` of them (counted before they are converted); else
    :class:`~gpr_kinematics.errors.InputError`. Times outside the plan are clamped to its ends."""
    count = count_of(times)
    if count > MAX_SAMPLES:
        raise InputError(f'{count} times; allowed: at most {MAX_SAMPLES} samples')
    return column_of(times, 'times')


def sample_plan(plan: ProgramPlan, rate: float | None = None, times: Array | None = None) -> PlanSamples:
    """Sample ``plan`` at ``rate`` [Hz] or at ``times`` [s] (one of them); forward kinematics of every sample (limits
    checked). A time before the start or after the end is the robot at rest there: the start's or the end's
    posture, at the time given."""
    robot = plan.robot
    if (rate is None) == (times is None):   # a rate beside times was ignored, whatever it was
        given = 'neither a rate nor' if rate is None else 'both a rate and'
        raise InputError(f'sample_plan got {given} times; allowed: one of them')
    if times is None:
        s = plan_samples(plan, sample(plan.timing, cast(float, rate)))   # not None: refused above
    else:
        s = plan_samples(plan, sample_at(plan.timing, sample_times_of(times)))
    _, _, _, slices = joint_limits(robot)
    arm_of = np.array(plan.waypoints.arm)[s.target]
    S = len(s)
    pos, rot = np.empty((S, 3)), np.empty((S, 3, 3))
    for a, cols in zip(robot.arms, slices, strict=True):
        idx = np.flatnonzero(arm_of == a.name)
        if idx.size:
            fk = robot_forward(robot, s.positions[idx, :3], s.positions[idx, cols], a.name)
            pos[idx], rot[idx] = fk.wafer.position, fk.wafer.rotation
    return PlanSamples(s, tuple(arm_of.tolist()), PoseBatch(pos, rot))
