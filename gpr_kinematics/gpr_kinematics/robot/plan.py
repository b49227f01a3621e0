"""Checking a program: every waypoint solved, the moves timed within the limits, the program sampled.

:func:`plan_program` expands the program's steps into waypoints (:func:`~gpr_kinematics.robot.program.expand`),
solves each for the rods and its arm's joints (:func:`~gpr_kinematics.robot.inverse.solve_stations`, the arms in
one batch each; an arm not in use holds its joints, from its ``home`` posture on), and times the joint-space moves
between them within the rods' and the joints' velocity and acceleration limits
(:func:`~gpr_kinematics.robot.timing.parameterise`). Any waypoint the robot cannot reach, and any requested move
time the limits cannot meet, refuses the program with the step and the reason. :func:`sample_plan` samples the
plan at a rate, with the wafer pose of the arm in use at every sample (forward kinematics, limits checked).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from ..errors import InputError, LimitError
from .description import RobotDescription
from .forward import robot_forward
from .inverse import solve_stations
from .program import RobotProgram, Waypoints, expand
from .timing import MAX_SAMPLES, Samples, Timing, check_rate, parameterise, sample
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


def check_sample_count(program: RobotProgram, rate: float) -> None:
    """Refuse, before the program is planned, a sampling at ``rate`` [Hz] that its dwells and move times alone take
    beyond :data:`~gpr_kinematics.robot.timing.MAX_SAMPLES` (:class:`InputError`)."""
    least = shortest_duration(program)
    if not least * check_rate(rate) < MAX_SAMPLES:
        raise InputError(f'{program.source}: the program lasts at least {least:.6g} s (its dwells and move times): at '
                         f'{rate:g} Hz more than {MAX_SAMPLES} samples; allowed: at most {MAX_SAMPLES}; lower the rate')


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


def plan_program(robot: RobotDescription, program: RobotProgram) -> ProgramPlan:
    """Check ``program`` on ``robot`` (module docstring).

    Raises:
        ConfigError: an unknown arm or branch in a step.
        LimitError: a waypoint out of reach or beyond a limit, a move time shorter than the limits allow; the
            message names the program, the step and the reason.
    """
    way = expand(program, robot)
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
        sol = solve_stations(robot, way.stations.take(idx), a.name, branch=[way.branch[i] for i in idx], check=False)
        rods[idx] = sol.rods
        own[idx, cols] = sol.joints
        wafer_p[idx], wafer_R[idx] = sol.forward.wafer.position, sol.forward.wafer.rotation
        naive[idx] = sol.naive_wafer_error
        feasible[idx] = sol.feasible
    plan_labels = tuple(_label(program, way, i) for i in range(W))
    if not feasible.all():
        i = int(np.argmax(~feasible))
        try:
            solve_stations(robot, way.stations.take([i]), way.arm[i], branch=way.branch[i])
        except LimitError as exc:
            more = int(np.count_nonzero(~feasible)) - 1
            tail = f' (and {more} more waypoint{"s" if more > 1 else ""})' if more else ''
            raise LimitError(f'{program.source}: {plan_labels[i]}: {exc}{tail}') from None
    positions = np.empty((W, len(names)))
    positions[:, :3] = rods
    for a, cols in zip(robot.arms, slices, strict=True):
        held = np.array(a.home)
        block = own[:, cols]
        for i in range(W):  # an arm not in use holds its joints
            if np.isnan(block[i, 0]):
                block[i] = held
            else:
                held = block[i]
        positions[:, cols] = block
    try:
        timing = parameterise(positions, velocity, acceleration, way.time, way.dwell, names, plan_labels)
    except LimitError as exc:
        raise LimitError(f'{program.source}: {exc}') from None
    return ProgramPlan(robot, program, way, names, positions, PoseBatch(wafer_p, wafer_R), naive, timing,
                       plan_labels)


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


def sample_plan(plan: ProgramPlan, rate: float) -> PlanSamples:
    """Sample ``plan`` at ``rate`` [Hz]; forward kinematics of every sample (limits checked)."""
    robot = plan.robot
    s = sample(plan.timing, rate)
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
