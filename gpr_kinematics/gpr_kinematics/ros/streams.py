"""The streams ``trajectory_node`` publishes, precomputed with the batch API (no ROS import).

A :class:`Trajectory` holds every sample of a stream: the platform's forward kinematics, the commanded tilt and
azimuth, the station (or, for a robot program, the waypoint) each sample is at, the points of the markers and, for
a whole-robot program, the :class:`~gpr_kinematics.robot.stream.RobotStream` (arm joints, wafer). Builders:

- :func:`sweep_trajectory`: the paper's grid (core ``sweep.paper_sweep``);
- :func:`program_trajectory`: a platform program (:mod:`.program`), interpolated between stations;
- :func:`robot_trajectory`: a whole-robot program (``format: gpr_robot_program``, docs/robot.md), planned and
  sampled by the robot core within the joints' limits.

:func:`goal_program` reads the program of a ``gpr/run_program`` goal (a file of either kind, or inline platform
stations): every bound is checked before the work it bounds (the stations of a goal, the samples of a program before
its stations are solved or its steps planned), and the files a goal names are read only under the folders
:class:`GoalFiles` allows (the package's ``config/programs`` and the node's parameter ``program_folders``), the
rule of :func:`gpr_kinematics.inputs.files.confined_reads`. SI units (m, rad, s).
"""
from __future__ import annotations

import dataclasses
import os
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..bags.program_record import PLATFORM_PROGRAM, ROBOT_PROGRAM, SWEEP, record_text
from ..core import ForwardBatch, inverse_batch
from ..core.config import GprConfig
from ..core.sweep import paper_sweep
from ..errors import ConfigError, GprError
from ..inputs.files import confined_reads
from ..inputs.resources import config_dir
from ..robot.description import RobotDescription, Rods
from ..robot.markers import marker_points
from ..robot.plan import check_sample_count
from ..robot.platform_program import (
    MAX_STATIONS,
    PlatformProgram,
    check_samples,
    move_time_of,
    parse_platform_program,
    rod_demand,
    sample_program,
)
from ..robot.program import RobotProgram, load_any_program, program_robot
from ..robot.stream import RobotStream, robot_stream

Array = NDArray[np.float64]
#: The relative rounding by which a move's need may exceed a limit and be at it (0.4 - 0.3 in 1 s: 0.15000000000000002
#: m/s for a limit of 0.15).
LIMIT_ROUNDING = 1e-9


@dataclasses.dataclass(frozen=True)
class Trajectory:
    """A precomputed stream: the platform's forward kinematics per sample, the commanded tilt and azimuth [rad],
    the station each sample is at (-1 while moving or in a sweep; for a robot program the waypoint held) with the
    stations' (waypoints') names, and the points of every marker of every sample by namespace (the machine's own
    rods and joints, :func:`gpr_kinematics.robot.markers.marker_points`, what ``gpr verify`` checks them against).
    ``robot``: the whole robot's samples of a robot program, else None. ``kind`` and ``spec`` say what was asked for,
    for the record of :mod:`gpr_kinematics.bags.program_record`: ``sweep`` and its parameters, or
    ``platform_program`` / ``robot_program`` and the program."""

    fk: ForwardBatch
    cmd_tilt: list[float]
    cmd_azimuth: list[float]
    station: list[int]
    station_names: tuple[str, ...]
    description: str
    markers: dict[str, np.ndarray]
    robot: RobotStream | None = None
    kind: str = 'sweep'
    spec: Any = None
    #: The station (waypoint) each sample moves to or is at (a program's; empty for a sweep).
    target: list[int] = dataclasses.field(default_factory=list)
    #: What a robot could not follow (a platform program's move beyond the rods' limits), in words; '' if nothing.
    warning: str = ''

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
    spec = {'height': height, 'max_tilt': max_tilt, 'tilt_step': tilt_step, 'azimuth_step': azimuth_step,
            'passes': passes}
    return Trajectory(sw.forward, np.asarray(sw.alpha, float).tolist(), np.asarray(sw.gamma, float).tolist(),
                      [-1] * n, (), desc, stream_markers(cfg, sw.forward), kind=SWEEP, spec=spec)


def first_failure(solve: Callable[[int, int], object], n: int) -> tuple[int, GprError]:
    """The first index ``i`` of ``n`` items whose ``solve(i, i + 1)`` fails, found by bisection on batches
    (``solve(a, b)`` solves items ``a`` to ``b`` at once and raises :class:`GprError` if one of them fails; it failed
    for all ``n``): ``log2 n`` batch calls instead of ``n`` single ones."""
    lo, hi = 0, n           # the first failure lies in [lo, hi)
    while hi - lo > 1:
        mid = (lo + hi) // 2
        try:
            solve(lo, mid)
        except GprError:
            hi = mid
        else:
            lo = mid
    try:
        solve(lo, lo + 1)
    except GprError as exc:
        return lo, exc
    raise AssertionError('first_failure: no item fails alone')  # pragma: no cover - solve is per item


def program_trajectory(cfg: GprConfig, prog: PlatformProgram, rate: float, move_time: float,
                       rods: Rods | None = None) -> Trajectory:
    """The stream of a platform program; :class:`ConfigError` names the first station out of reach. The sample count
    is checked first, then the stations are solved in one batch (a failing station is found by bisection), then
    the samples. With the robot's ``rods``, a move faster than their limits is a warning (``Trajectory.warning``,
    :func:`~gpr_kinematics.robot.platform_program.rod_demand`): a platform program is timed by its move times only."""
    check_samples(prog, rate, move_time)  # before any station is solved (100,000 stations took 91 s, then this)
    st = prog.stations

    def solve(a: int, b: int) -> Array:
        return inverse_batch([s.height for s in st[a:b]], [s.tilt for s in st[a:b]], [s.azimuth for s in st[a:b]],
                             cfg, cfg.model).q

    try:
        at_stations = solve(0, len(st))
    except GprError:
        i, exc = first_failure(solve, len(st))
        raise ConfigError(f'{prog.source}: station {i} ({st[i].name}): {exc}') from None
    samples = sample_program(prog, rate, move_time)
    ik = inverse_batch(samples.height, samples.tilt, samples.azimuth, cfg, cfg.model)
    desc = (f'program {prog.source}: {len(prog.stations)} stations, {samples.time[-1]:.6g} s, '
            f'{len(samples)} samples')
    warning = '' if rods is None else _beyond_rod_limits(prog, at_stations, move_time, rods)
    return Trajectory(ik.achieved, samples.tilt.tolist(), samples.azimuth.tolist(),
                      [int(s) for s in samples.station], tuple(st.name for st in prog.stations),
                      desc + (f'; warning: {warning}' if warning else ''),
                      stream_markers(cfg, ik.achieved), kind=PLATFORM_PROGRAM, spec=prog,
                      target=[int(s) for s in samples.target], warning=warning)


def _beyond_rod_limits(prog: PlatformProgram, at_stations: Array, move_time: float, rods: Rods) -> str:
    """The moves of ``prog`` whose rods exceed ``rods``' velocity or acceleration limits (beyond rounding: a move at
    a limit is within it), each with what it needs, in words; '' if none does."""
    speed, accel = rod_demand(prog, at_stations, move_time)
    over = np.flatnonzero((speed > rods.velocity * (1.0 + LIMIT_ROUNDING))
                          | (accel > rods.acceleration * (1.0 + LIMIT_ROUNDING)))
    if not over.size:
        return ''
    st = prog.stations
    moves = [f'to station {k + 1} ({st[k + 1].name}) about {speed[k]:.3g} m/s and {accel[k]:.3g} m/s^2'
             for k in over[:3].tolist()]
    more = f' and {over.size - 3} more' if over.size > 3 else ''
    return (f'{"a move needs" if over.size == 1 else f"{over.size} moves need"} the rods beyond their limits '
            f'{rods.velocity:g} m/s or {rods.acceleration:g} m/s^2 (rods.velocity, rods.acceleration): '
            f'{"; ".join(moves)}{more}; a robot cannot follow {"it" if over.size == 1 else "them"} as timed (a '
            'platform program is timed by its move_time only; a longer move_time, or a robot program, timed within '
            'the limits)')


def robot_trajectory(robot: RobotDescription, prog: RobotProgram, rate: float) -> Trajectory:
    """The stream of a whole-robot program on ``robot`` (:func:`gpr_kinematics.robot.stream.robot_stream`); the
    platform's commanded tilt and azimuth are its own tilt and tilt azimuth (the program commands joints). A program
    whose dwells and move times alone exceed the samples allowed is refused before it is planned."""
    check_sample_count(prog, rate)   # before the program is planned
    rs = robot_stream(robot, prog, rate)
    gpr = rs.gpr
    desc = (f'robot program {prog.source} on robot {robot.name}: {len(prog.steps)} steps, {len(rs.waypoint_names)} '
            f'waypoints, {rs.time[-1]:.6g} s, {len(rs)} samples')
    return Trajectory(gpr, gpr.tilt.tolist(), gpr.tilt_azimuth.tolist(), rs.waypoint.tolist(), rs.waypoint_names,
                      desc, stream_markers(robot.config, gpr), rs, kind=ROBOT_PROGRAM, spec=prog,
                      target=rs.target.tolist())


#: Longest ``program_file`` of a goal (Linux's ``PATH_MAX``, 4096 bytes; a longer one was looked up and quoted
#: whole).
MAX_PATH = 4096
#: How messages name the rule of the files a goal may read.
GOAL_FILES_RULE = ("the package's config folder (its programs, robots and cells) and trajectory_node's parameter "
                   "program_folders")


@dataclasses.dataclass(frozen=True)
class GoalFiles:
    """The folders a ``gpr/run_program`` goal's program file is looked up in: the package's ``config/programs`` and
    the operator's ``program_folders``; the files it names are read under :attr:`readable` (module docstring)."""

    folders: tuple[Path, ...]

    @property
    def readable(self) -> tuple[Path, ...]:
        """The folders read from: the package's whole ``config`` (a shipped program names ``../robots/`` and
        ``../cells/``) and the operator's ``program_folders``."""
        return (config_dir(), *self.folders[1:])

    @classmethod
    def of(cls, extra: Sequence[str]) -> GoalFiles:
        """The package's folder and the existing folders ``extra`` (empty strings ignored); :class:`ConfigError`
        names a parameter entry that is not a folder."""
        folders = [config_dir() / 'programs']
        for f in extra:
            if f and not os.path.isdir(f):
                raise ConfigError(f'program_folders: {f!r} is not a folder; allowed: existing folders (or \'\')')
            if f:
                folders.append(Path(f))
        return cls(tuple(folders))

    def path(self, name: str) -> Path:
        """The file a goal names: an absolute path as is, a relative one in the first folder that has it. A relative
        name that leads out of a folder (``..``) is not looked for there, so whether a file outside exists never
        changes the answer (the read is then refused naming the path in the first folder). :class:`ConfigError` for
        a name of more than :data:`MAX_PATH` bytes in UTF-8 (as the file system counts)."""
        size = len(name.encode('utf-8', 'surrogatepass'))
        if size > MAX_PATH:
            raise ConfigError(f'goal: program_file has {size} bytes (UTF-8); allowed: a path of at most {MAX_PATH}')
        if os.path.isabs(name):
            return Path(name)
        inside = [f / name for f in self.folders if _within(os.path.normpath(f / name), os.path.normpath(f))]
        return next((p for p in inside if _is(p, Path.is_file)), next((p for p in inside if _is(p, Path.exists)),
                                                                      self.folders[0] / name))


def _is(path: Path, test: Callable[[Path], bool]) -> bool:
    """``test(path)`` (a file, or anything there: a FIFO or a folder is then refused by the reader as such, not
    looked for in the first folder); False where it cannot be looked at (a name too long for the file system was an
    ``OSError`` that ended a goal as an internal error, its whole path quoted)."""
    try:
        return test(path)
    except (OSError, ValueError):
        return False


def _within(path: str, folder: str) -> bool:
    """``path`` lies in ``folder`` (both normalised; by their names, without touching the file system)."""
    return os.path.commonpath([path, folder]) == folder


def goal_program(goal: Any, robot: RobotDescription, files: GoalFiles) -> PlatformProgram | RobotProgram:
    """The program of a ``RunProgram`` goal: its file (a platform or a robot program; a robot program must be for
    ``robot``), read with every file it names under ``files`` only, or its inline stations (at most
    :data:`~gpr_kinematics.robot.platform_program.MAX_STATIONS`) validated as a platform program file's."""
    has_file, has_stations = bool(goal.program_file), len(goal.stations) > 0
    if has_file == has_stations:
        raise ConfigError('goal: give either program_file or stations; allowed: exactly one of the two')
    if has_file:
        with confined_reads(files.readable, GOAL_FILES_RULE):
            prog = load_any_program(files.path(goal.program_file))
            if isinstance(prog, RobotProgram):
                program_robot(prog, robot)
        if isinstance(prog, RobotProgram):
            if float(goal.move_time) != 0.0:
                raise ConfigError(f'goal: move_time = {goal.move_time!r} does not apply to the robot program '
                                  f'{prog.source} (its moves are timed within the joints\' limits, or by a step\'s '
                                  'time); allowed: 0')
            return prog
    else:
        if len(goal.stations) > MAX_STATIONS:
            raise ConfigError(f'goal: {len(goal.stations)} stations; allowed: at most {MAX_STATIONS}')
        stations = []
        for st in goal.stations:
            entry = {'height': st.height, 'tilt': st.tilt, 'azimuth': st.azimuth, 'dwell': st.dwell}
            if st.name:
                entry['name'] = st.name
            if st.move_time != 0.0:
                entry['move_time'] = st.move_time
            stations.append(entry)
        prog = parse_platform_program({'stations': stations}, 'goal stations')
    if goal.move_time != 0.0:   # 0: the program's default
        move_time = move_time_of(float(goal.move_time), 'goal', 'move_time field (0: the program\'s default)')
        prog = dataclasses.replace(prog, move_time=move_time)
    return prog


def record_of(traj: Trajectory, first_sample: int, rate: float, loop: bool, move_time: float,
              markers_every: int, frame_prefix: str) -> str:
    """The record of ``traj`` (:func:`gpr_kinematics.bags.program_record.record_text`), published on ``gpr/program``
    as it starts at sample ``first_sample``, its markers published every ``markers_every``-th sample, its frames
    named with ``frame_prefix``."""
    sweep = traj.spec if traj.kind == SWEEP else None
    program = traj.spec if traj.kind != 'sweep' else None
    return record_text(traj.kind, first_sample, len(traj), rate, loop, move_time, sweep=sweep, program=program,
                       markers_every=markers_every, frame_prefix=frame_prefix)


def trajectory_of(prog: PlatformProgram | RobotProgram, robot: RobotDescription, rate: float,
                  move_time: float) -> Trajectory:
    """The stream of a program of either kind (``move_time`` [s]: a platform program's default move duration)."""
    if isinstance(prog, RobotProgram):
        return robot_trajectory(robot, prog, rate)
    return program_trajectory(robot.config, prog, rate, move_time, robot.rods)
