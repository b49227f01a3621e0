"""The record of what a stream is: the latched ``gpr/program`` topic, written by ``trajectory_node`` at the start
of every stream and read back by ``gpr verify``, which recomputes the stream from it.

``trajectory_node`` publishes its geometry (``gpr/geometry``) and its robot description (``gpr/robot``) once; a
recording then says *who* produced it, but not *what* it was asked to do: the rods of a robot program come from
station inverse kinematics with the arms' default branches, home postures, redundancy rules and limits, none of which
the recorded states show once the stream is made (a description whose ``branch: right`` was edited to ``left``
still passed every check). So with the first sample of each stream the node publishes, on ``gpr/program``
(:data:`~.typestore.PROGRAM_TOPIC`, ``std_msgs/String``, reliable, transient local, depth 1), the YAML of a
:class:`Record`: the kind of stream
(``sweep``, ``platform_program``, ``robot_program``), the sample counter of its first sample, its length, the rate,
whether it loops, which samples have markers (``markers_every``: those whose counter is a multiple of it,
:func:`~gpr_kinematics.robot.markers.marked`; optional, recorded since it was added, so records without it still
read), and the sweep's parameters or the program itself (:func:`program_dict`: every station and step
inline, in SI units, as the node parsed it). :func:`expected` recomputes from a record, with the recorded geometry
and robot, the numbers every sample must carry: the rods, the commanded tilt and azimuth and, for a robot program,
every arm's joints (:mod:`.checks_program` compares them); ``topic.markers_sequence`` (:mod:`.checks_topics`)
checks the markers against ``markers_every``. SI units (m, rad, s).
"""
from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..core import inverse_batch
from ..core.config import GprConfig
from ..core.messages import frame_prefix_refusal
from ..core.sweep import paper_sweep
from ..errors import ConfigError, GprError
from ..inputs import safe_yaml
from ..inputs.schema import check_keys, is_number
from ..robot.description import RobotDescription
from ..robot.markers import MARKERS_EVERY
from ..robot.platform_program import PlatformProgram, parse_platform_program, sample_program
from ..robot.program import FORMAT as ROBOT_FORMAT
from ..robot.program import RobotProgram, parse_program
from ..robot.stream import robot_stream
from ..robot.transforms import PoseBatch
from .metadata import INT_END
from .typestore import PROGRAM_TOPIC

#: The keys of a recorded robot program (:func:`program_dict`): its stations inline, no robot, cell or station file
#: (a record naming one was read as the file format, the robot dropped unchecked, a file opened).
RECORD_PROGRAM_KEYS = ('format', 'version', 'defaults', 'stations', 'steps', 'wafers')
#: The kinds of stream a record names (what ``trajectory_node`` streamed).
SWEEP, PLATFORM_PROGRAM, ROBOT_PROGRAM = 'sweep', 'platform_program', 'robot_program'
KINDS = (SWEEP, PLATFORM_PROGRAM, ROBOT_PROGRAM)
SWEEP_KEYS = ('height', 'max_tilt', 'tilt_step', 'azimuth_step', 'passes')
#: Largest record read [bytes] (a program of 10,000 stations is about 1 MB of YAML).
MAX_RECORD_BYTES = 8 << 20
_KEYS = ('kind', 'first_sample', 'samples', 'rate', 'loop', 'move_time', 'markers_every', 'frame_prefix', 'sweep',
         'program')


@dataclass(frozen=True)
class Record:
    """One stream as the node was asked for it (module docstring); ``markers_every`` None: not recorded."""

    kind: str
    first_sample: int
    samples: int
    rate: float
    loop: bool
    move_time: float
    sweep: dict[str, float] | None = None
    program: PlatformProgram | RobotProgram | None = None
    markers_every: int | None = None
    frame_prefix: str | None = None


def _optional(out: dict[str, Any], key: str, value: Any) -> None:
    if value is not None:
        out[key] = float(value) if isinstance(value, (float, np.floating)) else value


def program_dict(program: PlatformProgram | RobotProgram) -> dict[str, Any]:
    """A program as the mapping of its file format (SI units, every station inline, the robot left out: the record
    goes with the recorded robot), which :func:`~gpr_kinematics.robot.program.parse_any_program` reads back to an
    equal program."""
    if isinstance(program, PlatformProgram):
        stations = []
        for st in program.stations:
            entry: dict[str, Any] = {'name': st.name, 'height': st.height, 'tilt': st.tilt, 'azimuth': st.azimuth,
                                     'dwell': st.dwell}
            _optional(entry, 'move_time', st.move_time)
            stations.append(entry)
        out: dict[str, Any] = {'format': 'gpr_platform_program', 'version': 1, 'stations': stations}
        _optional(out, 'move_time', program.move_time)
        return out
    table, s = program.stations, program.stations.stations
    rows = []
    for i, name in enumerate(s.names):
        row: dict[str, Any] = {'name': name, 'position': [float(v) for v in s.position[i]], 'tilt': float(s.tilt[i]),
                               'azimuth': float(s.azimuth[i])}
        if not s.heading_free[i]:
            row['heading'] = float(s.heading[i])
        _optional(row, 'branch', table.branch[i])
        _optional(row, 'approach_height', table.approach_height[i])
        _optional(row, 'retract_height', table.retract_height[i])
        _optional(row, 'entry', table.entry[i] if table.entry else None)   # its straight lines: other samples
        rows.append(row)
    steps = []
    for step in program.steps:
        if step.kind == 'dwell':
            steps.append({'dwell': float(step.dwell or 0.0)})
            continue
        entry = {step.kind: step.station}
        for key in ('arm', 'branch', 'dwell', 'time'):
            _optional(entry, key, getattr(step, key))
        steps.append(entry)
    defaults: dict[str, Any] = {'approach_height': program.approach_height, 'retract_height': program.retract_height,
                                'dwell': program.dwell}
    _optional(defaults, 'arm', program.arm)
    _optional(defaults, 'branch', program.branch)
    out = {'format': ROBOT_FORMAT, 'version': 1, 'defaults': defaults, 'stations': rows, 'steps': steps}
    _optional(out, 'wafers', None if program.wafers is None else list(program.wafers))
    return out


def record_text(kind: str, first_sample: int, samples: int, rate: float, loop: bool, move_time: float,
                sweep: Mapping[str, float] | None = None,
                program: PlatformProgram | RobotProgram | None = None, markers_every: int | None = None,
                frame_prefix: str | None = None) -> str:
    """The YAML of a record (module docstring): the ``data`` of a :data:`PROGRAM_TOPIC` message (without
    ``markers_every`` or ``frame_prefix`` when None)."""
    data: dict[str, Any] = {'kind': kind, 'first_sample': int(first_sample), 'samples': int(samples),
                            'rate': float(rate), 'loop': bool(loop), 'move_time': float(move_time)}
    if markers_every is not None:
        data['markers_every'] = int(markers_every)
    if frame_prefix is not None:
        data['frame_prefix'] = str(frame_prefix)
    if sweep is not None:
        data['sweep'] = {k: (int(v) if k == 'passes' else float(v)) for k, v in sweep.items()}
    if program is not None:
        data['program'] = program_dict(program)
    return safe_yaml.dump(data, default_flow_style=None, sort_keys=False)


def _integer(data: Mapping[str, Any], key: str, where: str) -> int:
    value = data.get(key)
    if isinstance(value, bool) or not isinstance(value, int) or not 0 <= value < INT_END:
        raise ConfigError(f'{where}: {key} = {safe_yaml.brief(value)}; allowed: an integer from 0 to 2^63 - 1')
    return value


def _markers_every(data: Mapping[str, Any], where: str) -> int | None:
    """The record's ``markers_every``: None when it has none (recorded before it was), else an integer within
    :data:`~gpr_kinematics.robot.markers.MARKERS_EVERY`."""
    if 'markers_every' not in data:
        return None
    value = data['markers_every']
    low, high = MARKERS_EVERY
    if isinstance(value, bool) or not isinstance(value, int) or not low <= value <= high:
        raise ConfigError(f"{where}: markers_every = {safe_yaml.brief(value)}; allowed: an integer from {low} to "
                          f"{high} (trajectory_node's markers_every)")
    return value


def _frame_prefix(data: Mapping[str, Any], where: str) -> str | None:
    """The record's ``frame_prefix``: None when it has none (recorded before it was), else the node's prefix."""
    if 'frame_prefix' not in data:
        return None
    value = data['frame_prefix']
    allowed = frame_prefix_refusal(value, ())   # the node's own rule; its frames unknown
    if allowed is not None:
        raise ConfigError(f"{where}: frame_prefix = {safe_yaml.brief(value)}; allowed: {allowed} (trajectory_node's "
                          'frame_prefix)')
    return str(value)


def _positive(data: Mapping[str, Any], key: str, where: str) -> float:
    value: Any = data.get(key)
    if not is_number(value) or not value > 0:
        raise ConfigError(f'{where}: {key} = {safe_yaml.brief(value)}; allowed: a finite number > 0')
    return float(value)


def parse_record(text: str, where: str = PROGRAM_TOPIC) -> Record:
    """The :class:`Record` of a message's YAML (the package's YAML reader and its bounds); :class:`ConfigError`
    naming what is wrong."""
    if len(text) > MAX_RECORD_BYTES:
        raise ConfigError(f'{where}: {len(text)} characters; allowed: at most {MAX_RECORD_BYTES}')
    data = safe_yaml.load_text(text, where)
    if not isinstance(data, Mapping):
        raise ConfigError(f'{where}: not a mapping of {", ".join(_KEYS)}')
    check_keys(data, _KEYS, where)
    kind = data.get('kind')
    if kind not in KINDS:
        raise ConfigError(f'{where}: kind = {safe_yaml.brief(kind)}; allowed: {", ".join(KINDS)}')
    loop = data.get('loop')
    if not isinstance(loop, bool):
        raise ConfigError(f'{where}: loop = {safe_yaml.brief(loop)}; allowed: true or false')
    common = dict(kind=kind, first_sample=_integer(data, 'first_sample', where), rate=_positive(data, 'rate', where),
                  samples=_integer(data, 'samples', where), loop=loop, move_time=_positive(data, 'move_time', where),
                  markers_every=_markers_every(data, where), frame_prefix=_frame_prefix(data, where))
    if kind == SWEEP:
        sweep = data.get('sweep')
        if not isinstance(sweep, Mapping):
            raise ConfigError(f'{where}: sweep: a mapping of {", ".join(SWEEP_KEYS)}')
        check_keys(sweep, SWEEP_KEYS, f'{where}: sweep')
        if not all(is_number(sweep.get(k)) for k in SWEEP_KEYS):
            raise ConfigError(f'{where}: sweep: {", ".join(SWEEP_KEYS)} must be numbers')
        return Record(**common, sweep={k: float(sweep[k]) for k in SWEEP_KEYS})
    program = data.get('program')
    if kind == ROBOT_PROGRAM and isinstance(program, Mapping):   # what program_dict writes: no file named, none read
        check_keys(program, RECORD_PROGRAM_KEYS, f'{where}: program')
    parsed = (parse_program(program, f'{where}: program') if kind == ROBOT_PROGRAM else
              parse_platform_program(program, f'{where}: program'))
    return Record(**common, program=parsed)


@dataclass(frozen=True)
class Expected:
    """What every sample of a recorded stream must carry (``N`` samples): the rods ``q (N, 3)`` [m], the commanded
    tilt and azimuth ``(N,)`` [rad], and for a robot program every arm's joints ``(N, J)`` [rad] by name and the
    waypoint held ``(N,)`` (-1 while moving) with every waypoint's name (the station a RobotState names), the arm
    in use ``(N,)`` and its wafer in the world (what ``gpr/wafer_pose`` carries)."""

    q: NDArray[np.float64]
    commanded_tilt: NDArray[np.float64]
    commanded_azimuth: NDArray[np.float64]
    joint_names: tuple[str, ...] = ()
    joints: NDArray[np.float64] | None = None
    waypoint: NDArray[np.int64] | None = None
    waypoint_names: tuple[str, ...] = ()
    arm: tuple[str, ...] = ()
    wafer: PoseBatch | None = None

    def station(self, i: int) -> str:
        """The name of the waypoint held at sample ``i`` (empty while moving or without waypoints)."""
        k = -1 if self.waypoint is None else int(self.waypoint[i])
        return self.waypoint_names[k] if k >= 0 else ''


def expected(record: Record, config: GprConfig, robot: RobotDescription | None) -> Expected:
    """Recompute a recorded stream (the functions ``trajectory_node`` computes it with), with ``config`` as the
    geometry of sweeps and platform programs and ``robot`` (computing with that geometry) for a robot program;
    :class:`~gpr_kinematics.errors.GprError` when it cannot be (a station out of reach under this geometry, ...)."""
    if record.kind == SWEEP:
        assert record.sweep is not None  # parse_record sets it
        s = record.sweep
        sw = paper_sweep(height=s['height'], max_tilt=s['max_tilt'], tilt_step=s['tilt_step'],
                         azimuth_step=s['azimuth_step'], passes=int(s['passes']), config=config, model=config.model)
        return Expected(sw.forward.q, np.asarray(sw.alpha, dtype=float), np.asarray(sw.gamma, dtype=float))
    if isinstance(record.program, PlatformProgram):
        samples = sample_program(record.program, record.rate, record.move_time)
        ik = inverse_batch(samples.height, samples.tilt, samples.azimuth, config, config.model)
        return Expected(ik.q, samples.tilt, samples.azimuth)
    if robot is None or not isinstance(record.program, RobotProgram):
        raise ConfigError('a robot program needs the robot description it ran on (none recorded or given)')
    rs = robot_stream(robot, record.program, record.rate)   # the robot computes with the geometry verified against
    return Expected(rs.gpr.q, rs.gpr.tilt, rs.gpr.tilt_azimuth, rs.joint_names, rs.joints, rs.waypoint,
                    rs.waypoint_names, rs.arm, rs.wafer)


def recorded_prefix(records: list[Record]) -> str | None:
    """The ``frame_prefix`` the records name when every one names the same; None otherwise (no records, or records
    of a node from before it was recorded)."""
    prefixes = {r.frame_prefix for r in records}
    return next(iter(prefixes)) if len(prefixes) == 1 else None


class Recomputed:
    """The recorded ``records``' streams, each recomputed once (:func:`expected`, with ``config`` and ``robot``) for
    every check that compares with it (the stream's samples, the joint states and the wafer poses without their
    RobotState: a robot program was planned three times)."""

    def __init__(self, records: list[Record], config: GprConfig, robot: RobotDescription | None) -> None:
        self.records, self.config, self.robot = records, config, robot
        self._done: dict[int, Expected | GprError] = {}

    def __call__(self, k: int) -> Expected:
        """The stream of ``records[k]``; :class:`~gpr_kinematics.errors.GprError` as :func:`expected` raises it."""
        if k not in self._done:
            try:
                self._done[k] = expected(self.records[k], self.config, self.robot)
            except GprError as exc:
                self._done[k] = exc
        out = self._done[k]
        if isinstance(out, GprError):
            raise out
        return out


def sample_index(record: Record, sample: int) -> int:
    """The index in the recorded stream of the sample with counter ``sample`` (-1 when it is not one of its
    samples): counters run on from the first sample, and start over with the stream when it loops."""
    i = int(sample) - record.first_sample
    if i < 0 or record.samples <= 0:
        return -1
    if record.loop:
        return i % record.samples
    return i if i < record.samples else -1


__all__ = ['KINDS', 'PROGRAM_TOPIC', 'Expected', 'Recomputed', 'Record', 'expected', 'parse_record', 'program_dict',
           'record_text', 'sample_index']
