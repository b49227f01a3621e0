"""The streams ``trajectory_node`` publishes, precomputed with the batch API (no ROS import).

A :class:`Trajectory` holds every sample of a stream: the platform's forward kinematics, the commanded tilt and
azimuth, the station (or, for a robot program, the waypoint) each sample is at, the points of the markers and, for
a whole-robot program, the :class:`~gpr_kinematics.robot.stream.RobotStream` (arm joints, wafer). Builders:

- :func:`sweep_trajectory`: the paper's grid (core ``sweep.paper_sweep``);
- :func:`program_trajectory`: a platform program (:mod:`.program`), interpolated between stations;
- :func:`robot_trajectory`: a whole-robot program (``format: gpr_robot_program``, docs/robot.md), planned and
  sampled by the robot core within the joints' limits.

:func:`goal_program` reads the program of a ``gpr/run_program`` goal (a file of either kind, or inline platform
stations). SI units (m, rad, s).
"""
from __future__ import annotations

import dataclasses
import math
from pathlib import Path
from typing import Any

import numpy as np

from ..core import ForwardBatch, inverse_batch
from ..core.config import GprConfig
from ..core.sweep import paper_sweep
from ..errors import ConfigError, GprError
from ..robot.description import RobotDescription, load_robot
from ..robot.markers import marker_points
from ..robot.platform_program import PlatformProgram, parse_platform_program, sample_program
from ..robot.program import RobotProgram, load_any_program
from ..robot.stream import RobotStream, robot_stream


@dataclasses.dataclass(frozen=True)
class Trajectory:
    """A precomputed stream: the platform's forward kinematics per sample, the commanded tilt and azimuth [rad],
    the station each sample is at (-1 while moving or in a sweep; for a robot program the waypoint held) with the
    stations' (waypoints') names, and the points of every marker of every sample by namespace (the machine's own
    rods and joints, :func:`gpr_kinematics.robot.markers.marker_points`, what ``gpr verify`` checks them against).
    ``robot``: the whole robot's samples of a robot program, else None."""

    fk: ForwardBatch
    cmd_tilt: list[float]
    cmd_azimuth: list[float]
    station: list[int]
    station_names: tuple[str, ...]
    description: str
    markers: dict[str, np.ndarray]
    robot: RobotStream | None = None

    def __len__(self) -> int:
        return len(self.fk)

    @property
    def unit(self) -> str:
        """What ``station`` counts: ``station`` (platform programs) or ``waypoint`` (robot programs)."""
        return 'station' if self.robot is None else 'waypoint'


def stream_markers(cfg: GprConfig, fk: ForwardBatch) -> dict[str, np.ndarray]:
    """The ``gpr/markers`` points of every sample of a stream."""
    return marker_points(cfg, fk.q, fk.nominal_position, fk.nominal_rotation)


def sweep_trajectory(cfg: GprConfig, height: float, max_tilt: float, tilt_step: float, azimuth_step: float,
                     passes: int) -> Trajectory:
    sw = paper_sweep(height=height, max_tilt=max_tilt, tilt_step=tilt_step, azimuth_step=azimuth_step,
                     passes=passes, config=cfg, model=cfg.model)
    desc = (f'sweep at height {height} m, |alpha| <= {max_tilt:.6g} rad in steps of {tilt_step:.6g} rad, '
            f'azimuth step {azimuth_step:.6g} rad, {passes} pass(es)')
    n = len(sw.forward)
    return Trajectory(sw.forward, np.asarray(sw.alpha, float).tolist(), np.asarray(sw.gamma, float).tolist(),
                      [-1] * n, (), desc, stream_markers(cfg, sw.forward))


def program_trajectory(cfg: GprConfig, prog: PlatformProgram, rate: float, move_time: float) -> Trajectory:
    """The stream of a platform program; :class:`ConfigError` names the first station out of reach."""
    for i, st in enumerate(prog.stations):  # stations first, for a message that names the station at fault
        try:
            inverse_batch(st.height, st.tilt, st.azimuth, cfg, cfg.model)
        except GprError as exc:
            raise ConfigError(f'{prog.source}: station {i} ({st.name}): {exc}') from None
    samples = sample_program(prog, rate, move_time)
    ik = inverse_batch(samples.height, samples.tilt, samples.azimuth, cfg, cfg.model)
    desc = (f'program {prog.source}: {len(prog.stations)} stations, {samples.time[-1]:.6g} s, '
            f'{len(samples)} samples')
    return Trajectory(ik.achieved, samples.tilt.tolist(), samples.azimuth.tolist(),
                      [int(s) for s in samples.station], tuple(st.name for st in prog.stations), desc,
                      stream_markers(cfg, ik.achieved))


def robot_trajectory(robot: RobotDescription, prog: RobotProgram, rate: float) -> Trajectory:
    """The stream of a whole-robot program on ``robot`` (:func:`gpr_kinematics.robot.stream.robot_stream`); the
    platform's commanded tilt and azimuth are its own tilt and tilt azimuth (the program commands joints)."""
    rs = robot_stream(robot, prog, rate)
    gpr = rs.gpr
    desc = (f'robot program {prog.source} on robot {robot.name}: {len(prog.steps)} steps, {len(rs.waypoint_names)} '
            f'waypoints, {rs.time[-1]:.6g} s, {len(rs)} samples')
    return Trajectory(gpr, gpr.tilt.tolist(), gpr.tilt_azimuth.tolist(), rs.waypoint.tolist(), rs.waypoint_names,
                      desc, stream_markers(robot.config, gpr), rs)


def same_robot(a: RobotDescription, b: RobotDescription) -> bool:
    """The same robot whatever its file and geometry: name, base, rods and arms."""
    return dataclasses.replace(a, config=b.config, source=b.source) == b


def program_robot(prog: RobotProgram, robot: RobotDescription) -> None:
    """:class:`ConfigError` when a robot program names a robot description other than ``robot`` (the node's)."""
    if prog.robot is None:
        return
    other = load_robot(prog.robot, geometry=robot.config)
    if not same_robot(other, robot):
        raise ConfigError(f'{prog.source} is a program for robot {other.name} ({prog.robot}); this node runs robot '
                          f'{robot.name} ({robot.source}): start trajectory_node with robot_file:={prog.robot}')


def goal_program(goal: Any, robot: RobotDescription) -> PlatformProgram | RobotProgram:
    """The program of a ``RunProgram`` goal: its file (a platform or a robot program; a robot program must be for
    ``robot``), or its inline stations validated as a platform program file's."""
    has_file, has_stations = bool(goal.program_file), len(goal.stations) > 0
    if has_file == has_stations:
        raise ConfigError('goal: give either program_file or stations; allowed: exactly one of the two')
    if has_file:
        prog = load_any_program(Path(goal.program_file))
        if isinstance(prog, RobotProgram):
            program_robot(prog, robot)
            if float(goal.move_time) != 0.0:
                raise ConfigError(f'goal: move_time = {goal.move_time!r} does not apply to the robot program '
                                  f'{prog.source} (its moves are timed within the joints\' limits, or by a step\'s '
                                  'time); allowed: 0')
            return prog
    else:
        stations = []
        for st in goal.stations:
            entry = {'height': st.height, 'tilt': st.tilt, 'azimuth': st.azimuth, 'dwell': st.dwell}
            if st.name:
                entry['name'] = st.name
            if st.move_time != 0.0:
                entry['move_time'] = st.move_time
            stations.append(entry)
        prog = parse_platform_program({'stations': stations}, 'goal stations')
    move_time = float(goal.move_time)
    if move_time != 0.0:
        if not (math.isfinite(move_time) and move_time > 0.0):
            raise ConfigError(f'goal: move_time = {move_time!r} is invalid; allowed: seconds > 0, or 0 for the '
                              'program\'s default')
        prog = dataclasses.replace(prog, move_time=move_time)
    return prog


def trajectory_of(prog: PlatformProgram | RobotProgram, robot: RobotDescription, rate: float,
                  move_time: float) -> Trajectory:
    """The stream of a program of either kind (``move_time`` [s]: a platform program's default move duration)."""
    if isinstance(prog, RobotProgram):
        return robot_trajectory(robot, prog, rate)
    return program_trajectory(robot.config, prog, rate, move_time)
