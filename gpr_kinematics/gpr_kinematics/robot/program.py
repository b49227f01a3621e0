"""Offline programs: the one entry for both program formats (:func:`load_any_program`, by the ``format:`` key), and
the whole robot's format: named stations and steps (moves, picks, places, dwells), from YAML.

File format (``config/programs/example_robot_program.yaml`` is a commented example; times in seconds)::

    format: gpr_robot_program          # required: tells a robot program from a platform program
    version: 1
    robot: ../robots/example_robot.yaml   # optional: relative to this file (the CLI's --robot overrides it)
    cell: ../cells/example_cell.yaml   # optional: the process cell (safety.cell), relative to this file (--cell)
    wafers: [load_port_1]              # optional: stations that hold a wafer at the start
    units: {length: mm, angle: deg}    # for the stations and heights in this file; m and rad by default
    defaults: {arm: arm1, approach_height: 10, retract_height: 10, dwell: 0.5}
    stations:                          # inline stations (robot.station_files), and/or
      - {name: load_port, position: [1500, 700, 480], tilt: 0, azimuth: 0, heading: 0}
    import: [more_stations.csv]        # station files, relative to this file, each with its own units
    steps:
      - {move: load_port}              # go to the station (a via pose, e.g. in front of a tool)
      - {pick: load_port, time: 2.0}   # below the wafer, up to the station (dwell), above it
      - {place: chamber_a, arm: arm1, branch: left, dwell: 1.0}
      - {dwell: 0.5}                   # hold where the robot is

Each step becomes waypoints (wafer poses): ``move S`` -> ``S`` (held for the dwell too); ``pick S`` -> ``S``
lowered by the approach height along the station normal (the blade under the wafer), ``S`` (dwell: the wafer is
taken), ``S`` raised by the retract height; ``place S`` -> ``S`` raised by the approach height (the wafer above
its place), ``S`` (dwell: the wafer is set down), ``S`` lowered by the retract height (the blade under it): each
step's first waypoint is offset by the approach height, its last by the retract height. The dwell of a move, pick
or place is the step's own ``dwell``, else the program's default. A station with a straight ``entry`` ``e`` adds a
waypoint (phase ``entry``) ``e`` back along the wafer's heading before the first and one (phase ``exit``) after the
last: the moves out of ``entry`` and into ``exit`` keep the wafer on that straight line with its orientation fixed
(:mod:`gpr_kinematics.robot.paths`). ``time`` is the duration of the move into the
step's first waypoint (default: as fast as the limits allow); the moves between a step's own waypoints are as fast
as the limits allow. A step's arm defaults to the program's, then the robot's first; its branch to the station's,
then the program's, then the arm's own (a station has a branch, no arm). The defaults' arm and branch are checked
whether a step takes them or not.

The platform programs of ``trajectory_node`` (``format: gpr_platform_program``, or no ``format`` key: stations with
``height``, ``tilt``, ``azimuth`` of the platform, :mod:`gpr_kinematics.robot.platform_program`) are the other
format: :func:`load_any_program` reads either; :func:`load_program` wants a robot program, names a platform program
and refuses it.
"""
from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import ConfigError, FileError, brief, key_value, kind_of
from ..inputs.schema import check_keys, is_number, is_version, read_yaml
from ..inputs.units import to_si
from ..inputs.validation import MAX_COORDINATE, did_you_mean, listed_names, text_hint
from .description import BRANCHES, Arm, RobotDescription, load_robot
from .platform_program import FORMAT as PLATFORM_FORMAT
from .platform_program import PlatformProgram, parse_platform_program
from .station_files import (
    MAX_APPROACH,
    MAX_STATIONS,
    StationRows,
    StationTable,
    height_refusal,
    read_station_rows,
    stations_from_yaml,
    units_of,
)
from .stations import Stations

FORMAT = 'gpr_robot_program'
VERSIONS = (1,)
STEP_KINDS = ('move', 'pick', 'place', 'dwell')
#: The keys a step may have: its kind and the options of a move, pick or place.
STEP_KEYS = (*STEP_KINDS, 'arm', 'branch', 'time')
#: Most steps in a program, most imported files. A step costs ``gpr program check`` about 30 ms and 0.5 MB in the
#: example cell (2,000 moves between two stations: 62 s, 1.1 GB; 20,000 ran out of 4 GB).
MAX_STEPS = 2_000
MAX_IMPORTS = 64
_KEYS = ('format', 'version', 'robot', 'cell', 'wafers', 'units', 'defaults', 'stations', 'import', 'steps')
_DEFAULT_KEYS = ('arm', 'branch', 'approach_height', 'retract_height', 'dwell')
#: What an empty branch (or none) of the program's defaults and of a step stands for, in their refusals.
DEFAULT_BRANCH = "the arm's own"
STEP_BRANCH = "the station's, else the defaults', else the arm's own"


@dataclass(frozen=True)
class Step:
    """One step: ``kind`` (move, pick, place, dwell), the ``station`` name (None for dwell), the ``arm`` (None: the
    default), ``branch`` (None: the station's or the arm's), ``dwell`` [s] (None: the default) and the move's
    ``time`` [s] (None: as fast as the limits allow)."""

    kind: str
    station: str | None
    arm: str | None
    branch: str | None
    dwell: float | None
    time: float | None


@dataclass(frozen=True)
class RobotProgram:
    """A validated program: its stations (SI), steps, defaults, the robot file it names, its source."""

    stations: StationTable
    steps: tuple[Step, ...]
    arm: str | None
    branch: str | None
    approach_height: float
    retract_height: float
    dwell: float
    robot: Path | None
    source: str
    #: The process cell the program names (relative paths resolved), and the stations holding a wafer at the start
    #: (``None``: not declared, so the wafers are not followed; ``()``: none, every pick is refused).
    cell: Path | None = None
    wafers: tuple[str, ...] | None = None


def _seconds(value: Any, where: str, key: str, positive: bool = False) -> float:
    if not is_number(value) or value < 0 or (positive and value == 0):   # is_number: at most MAX_COORDINATE
        raise ConfigError(f'{where}: {key} = {brief(value)} is invalid; allowed: seconds, '
                          f'{"> 0" if positive else ">= 0"} and at most {MAX_COORDINATE:g}')
    return float(value)


def _platform_program(data: Mapping[str, Any]) -> bool:
    raw = data.get('stations')
    return data.get('format') == PLATFORM_FORMAT or ('format' not in data and isinstance(raw, list) and any(
        isinstance(s, Mapping) and 'height' in s for s in raw))


def parse_any_program(data: Any, source: str = 'program', base_dir: str | Path = '.') -> RobotProgram | PlatformProgram:
    """A program of either format, by its ``format:`` key: ``gpr_robot_program`` (:func:`parse_program`), else a
    platform program (``gpr_platform_program`` or no ``format``:
    :func:`~gpr_kinematics.robot.platform_program.parse_platform_program`)."""
    if isinstance(data, Mapping) and data.get('format') == FORMAT:
        return parse_program(data, source, base_dir)
    if isinstance(data, Mapping) and data.get('format', PLATFORM_FORMAT) != PLATFORM_FORMAT:
        raise ConfigError(f'{source}: format = {key_value(data, "format")} is invalid; allowed: {FORMAT} (a robot '
                          f'program) or {PLATFORM_FORMAT} (a platform program; also a file without format)')
    return parse_platform_program(data, source)


def load_any_program(path: str | Path) -> RobotProgram | PlatformProgram:
    """Read and validate a program file of either format (:func:`parse_any_program`)."""
    return parse_any_program(read_yaml(path, 'program'), str(path), Path(path).parent)


def parse_program(data: Any, source: str = 'program', base_dir: str | Path = '.') -> RobotProgram:
    """Validate a program mapping (as loaded from YAML); imported station files are read from ``base_dir``."""
    if not isinstance(data, Mapping):
        raise ConfigError(f'{source}: expected a mapping (format: {FORMAT}, stations, steps), got '
                          f'{kind_of(data)}')
    if _platform_program(data):
        raise ConfigError(f'{source}: this is a platform program (stations with height, tilt and azimuth of the '
                          f'platform), the format trajectory_node runs; a robot program places the wafer: '
                          f'"format: {FORMAT}" with stations (position, tilt, azimuth, heading) and steps '
                          '(docs/robot.md#programs)')
    if data.get('format') != FORMAT:
        raise ConfigError(f'{source}: format = {key_value(data, "format")} is invalid; allowed: {FORMAT}')
    check_keys(data, _KEYS, source)
    if not is_version(data.get('version', 1), VERSIONS):   # true and 1.0 passed as 1
        raise ConfigError(f'{source}: version = {brief(data.get("version"))} is invalid; allowed: 1')
    length, _ = units_of(data, source)
    base = Path(base_dir)
    rows = stations_from_yaml({'units': data.get('units', {}), 'stations': data.get('stations', [])}, source)
    rows = _imports(data.get('import', []), rows, base, source)
    table = rows.table(source)
    if len(table) == 0:
        raise ConfigError(f'{source}: no stations; give "stations" or "import"')
    defaults = data.get('defaults', {})
    if not isinstance(defaults, Mapping):
        raise ConfigError(f'{source}: defaults must be a mapping ({", ".join(_DEFAULT_KEYS)})')
    check_keys(defaults, _DEFAULT_KEYS, f'{source}: defaults')
    dw = f'{source}: defaults'
    heights = []
    for key in ('approach_height', 'retract_height'):
        value = defaults.get(key, 0.01 / length)
        if not is_number(value) or not 0 <= to_si(value, length) <= MAX_APPROACH:
            raise height_refusal(dw, key, value, 'mm' if length != 1.0 else 'm', MAX_APPROACH)
        heights.append(to_si(float(value), length))
    robot, cell = (_path(data, key, base, source) for key in ('robot', 'cell'))
    return RobotProgram(
        stations=table, steps=_steps(data.get('steps'), table, source), arm=_optional_text(defaults, 'arm', dw),
        branch=_branch(defaults, dw, DEFAULT_BRANCH), approach_height=heights[0], retract_height=heights[1],
        dwell=_seconds(defaults.get('dwell', 0.0), dw, 'dwell'),
        robot=robot, source=source, cell=cell,
        wafers=_wafers(data['wafers'], table, source) if 'wafers' in data else None)


def _path(data: Mapping[str, Any], key: str, base: Path, source: str) -> Path | None:
    value = data.get(key)
    if value is not None and (not isinstance(value, str) or not value):
        what = 'a robot description' if key == 'robot' else 'a cell file'
        raise ConfigError(f'{source}: {key} = {brief(value)} is invalid; allowed: a path to {what}')
    return None if value is None else (base / value if not Path(value).is_absolute() else Path(value))


#: The station names a program's refusals list (:func:`~..inputs.validation.listed_names`).
_STATIONS = 'stations of the program and its imports'


def _wafers(raw: Any, table: StationTable, source: str) -> tuple[str, ...]:
    names = table.index()
    if not isinstance(raw, list) or any(not isinstance(n, (str, int)) or str(n) not in names for n in raw):
        unknown = [n for n in raw if not isinstance(n, (str, int)) or str(n) not in names] if isinstance(raw, list) \
            else []
        what = (f'names no station {brief(unknown[0])}{did_you_mean(names, str(unknown[0]))}' if unknown
                else 'is invalid')
        raise ConfigError(f'{source}: wafers = {brief(raw)} {what}; allowed: a list of station names (the stations '
                          f'that hold a wafer at the start): '
                          f'{listed_names(names, _STATIONS, str(unknown[0]) if unknown else None)}')
    if len({str(n) for n in raw}) != len(raw):
        raise ConfigError(f'{source}: wafers = {brief(raw)} names a station twice; allowed: one wafer per station')
    return tuple(str(n) for n in raw)


def _imports(raw: Any, rows: StationRows, base: Path, source: str) -> StationRows:
    if isinstance(raw, str):
        raw = [raw]
    if not isinstance(raw, list) or len(raw) > MAX_IMPORTS or not all(isinstance(p, str) for p in raw):
        raise ConfigError(f'{source}: import = {brief(raw)}; allowed: a station file path (.csv, .yaml) or a list of '
                          f'at most {MAX_IMPORTS} of them')
    origin = {name: 'its stations' for name in rows.names}  # where each name came from, for a name given twice
    for p in raw:
        if p.strip() in ('', '.'):   # it was read as the program's folder: "station file 'programs' is a folder"
            raise ConfigError(f'{source}: import entry {brief(p)} names no file; allowed: a station file path (.csv, '
                              '.yaml) relative to the program')
        path, here = Path(p) if Path(p).is_absolute() else base / p, f'import {brief(p)}'
        try:
            new = read_station_rows(path)
        except FileError as e:   # "cannot read station file 'imp/st_typo.csv'" named neither program nor key
            relative = '' if Path(p).is_absolute() else ' (named by the program, relative to its folder)'
            raise FileError(f'{source}: {here}{relative}: {e}') from None
        for name in new.names:
            if name in origin:
                where = f'in {here}' if origin[name] == here else f'in {origin[name]} and in {here}'
                raise ConfigError(f'{source}: station name {brief(name)} is used twice, {where}; allowed: unique '
                                  'names over the program and its imports')
            origin[name] = here
        rows.extend(new)
        if len(rows.names) > MAX_STATIONS:  # each file within the bound, 64 of them 6.4 million: 3 min and 1.9 GB
            raise ConfigError(f'{source}: import {brief(p)}: {len(rows.names)} stations so far; allowed: at most '
                              f'{MAX_STATIONS} in a program (inline and imported)')
    return rows


def _optional_text(data: Mapping[str, Any], key: str, where: str) -> str | None:
    value = data.get(key)
    if value is not None and not isinstance(value, str):
        raise ConfigError(f'{where}: {key} = {brief(value)} is invalid{text_hint(value)}; allowed: a name')
    return value


def _branch(data: Mapping[str, Any], where: str, empty: str) -> str | None:
    """The ``branch`` of ``data`` (the defaults or a step): left, right, or empty or none (``empty`` says what it
    stands for), checked with the file, not when a step takes it."""
    value = data.get('branch')
    if value is not None and (not isinstance(value, str) or (value and value not in BRANCHES)):
        raise ConfigError(f'{where}: branch = {brief(value)} is invalid; allowed: left, right or empty ({empty})')
    return value


def _steps(raw: Any, table: StationTable, source: str) -> tuple[Step, ...]:
    if not isinstance(raw, list) or not raw:
        raise ConfigError(f'{source}: steps must be a non-empty list of steps ({", ".join(STEP_KINDS)})')
    if len(raw) > MAX_STEPS:
        raise ConfigError(f'{source}: {len(raw)} steps; allowed: at most {MAX_STEPS}')
    names = table.index()
    out = []
    for i, st in enumerate(raw):
        where = f'{source}: steps[{i}]'
        if not isinstance(st, Mapping):
            raise ConfigError(f'{where}: expected a mapping such as {{pick: STATION}}')
        kinds = [k for k in STEP_KINDS[:3] if k in st] or [k for k in STEP_KINDS[3:] if k in st]
        if kinds in ([], ['dwell']) and any(k not in STEP_KEYS for k in st):  # a misspelt kind (pik): named
            try:
                check_keys(st, STEP_KEYS, where)
            except ConfigError as e:
                raise ConfigError(f'{e} (a step gives exactly one of {", ".join(STEP_KINDS)})') from None
        if len(kinds) != 1:  # 'dwell' is a step of its own, or the hold of a move, pick or place
            raise ConfigError(f'{where}: give exactly one of {", ".join(STEP_KINDS)}, got {", ".join(kinds) or "none"}')
        kind = kinds[0]
        if kind == 'dwell':
            check_keys(st, ('dwell',), where)
            out.append(Step('dwell', None, None, None, _seconds(st['dwell'], where, 'dwell'), None))
            continue
        check_keys(st, (kind, 'arm', 'branch', 'dwell', 'time'), where)
        station = st[kind]
        if not isinstance(station, str) or station not in names:   # move: 007 read as 7 too: quote it
            raise ConfigError(f'{where}: {kind} {brief(station)}: no such station{text_hint(station)}'
                              f'{did_you_mean(names, station)}; allowed: '
                              f'{listed_names(names, _STATIONS, station)}')
        time = None if st.get('time') is None else _seconds(st['time'], where, 'time', positive=True)
        if time is not None and all(s.kind == 'dwell' for s in out):  # it was dropped without a word
            raise ConfigError(f'{where}: time = {time:g} s on the first move: the program starts at its first '
                              'waypoint, so no move leads into it; allowed: a time on a later step (a dwell holds '
                              'the robot where it is)')
        out.append(Step(kind, str(station), _optional_text(st, 'arm', where), _branch(st, where, STEP_BRANCH),
                        _seconds(st['dwell'], where, 'dwell') if 'dwell' in st else None, time))
    if all(s.kind == 'dwell' for s in out):
        raise ConfigError(f'{source}: the steps only dwell; at least one move, pick or place is required')
    return tuple(out)


def load_program(path: str | Path) -> RobotProgram:
    """Read and validate a robot program file; :class:`ConfigError` names what is wrong."""
    data = read_yaml(path, 'program')  # the name as given: an empty one is refused, not read as '.'
    return parse_program(data, str(path), Path(path).parent)


@dataclass(frozen=True)
class Waypoints:
    """The program's steps expanded into wafer poses, in order.

    Attributes:
        stations: the wafer pose of each waypoint (named ``STATION``, ``STATION/approach``, ``STATION/retract``).
        arm, branch: per waypoint. step: index of the step. phase: ``move``, ``entry``, ``approach``, ``at``,
        ``retract``, ``exit``.
        dwell: time held at the waypoint [s]. time: requested duration of the move into it [s] (NaN: minimum).
        path: how the move into the waypoint goes: ``joint`` (a line in joint space) or ``line`` (the wafer on a
            straight line, its orientation fixed: out of an ``entry`` waypoint and into an ``exit`` one).
    """

    stations: Stations
    arm: tuple[str, ...]
    branch: tuple[str, ...]
    step: np.ndarray
    phase: tuple[str, ...]
    dwell: np.ndarray
    time: np.ndarray
    path: tuple[str, ...] = ()

    def __len__(self) -> int:
        return len(self.stations)

    def is_line(self, m: int) -> bool:
        """Whether move ``m`` (into waypoint ``m + 1``) keeps the wafer on a straight line (its ``path`` is
        ``line``); without ``path`` every move is a line in joint space."""
        return bool(self.path) and self.path[m + 1] == 'line'


def expand(program: RobotProgram, robot: RobotDescription) -> Waypoints:
    """Waypoints of ``program`` for ``robot`` (module docstring); unknown arms and branches are refused."""
    if program.arm and program.arm not in robot.arm_names:   # blamed on steps[0], and unchecked when unused
        raise ConfigError(f'{program.source}: defaults: arm = {brief(program.arm)} is invalid; allowed: '
                          f'{", ".join(robot.arm_names)}')
    table = program.stations
    index = table.index()
    st = table.stations
    idx: list[int] = []
    offset: list[float] = []
    arms: list[str] = []
    branches: list[str] = []
    steps: list[int] = []
    phases: list[str] = []
    dwell: list[float] = []
    times: list[float] = []
    back: list[float] = []
    paths: list[str] = []
    for s, step in enumerate(program.steps):
        where = f'{program.source}: steps[{s}]'
        if step.kind == 'dwell':
            if not dwell:
                raise ConfigError(f'{where}: a dwell before any move has nowhere to hold; move to a station first')
            dwell[-1] += step.dwell or 0.0
            continue
        assert step.station is not None
        i = index[step.station]
        arm = step.arm or program.arm or robot.arm_names[0]
        try:
            a = robot.arm(arm)
        except ConfigError:
            raise ConfigError(f'{where}: arm = {brief(arm)} is invalid; allowed: {", ".join(robot.arm_names)}'
                              ) from None
        branch = step.branch or table.branch[i] or program.branch or a.branch   # each checked when read, but in code
        if branch not in BRANCHES:
            raise ConfigError(f'{where}: branch = {brief(branch)} is invalid; allowed: left, right or empty '
                              f'({STEP_BRANCH})')
        own_approach, own_retract = table.approach_height[i], table.retract_height[i]
        approach = own_approach if own_approach is not None else program.approach_height
        retract = own_retract if own_retract is not None else program.retract_height
        d = step.dwell if step.dwell is not None else program.dwell
        entry = None
        if step.kind == 'move':
            plan = [(0.0, 'move', d)]
        else:
            sign = -1.0 if step.kind == 'pick' else 1.0
            plan = [(sign * approach, 'approach', 0.0), (0.0, 'at', d), (-sign * retract, 'retract', 0.0)]
            entry = table.entry[i] if table.entry else None
            if entry:
                _check_entry(a, where, str(step.station))
                plan = [(sign * approach, 'entry', 0.0), *plan, (-sign * retract, 'exit', 0.0)]
        for k, (off, phase, hold) in enumerate(plan):
            back.append(entry if phase in ('entry', 'exit') and entry else 0.0)
            paths.append('line' if phase == 'exit' or (phase == 'approach' and k == 1 and plan[0][1] == 'entry')
                         else 'joint')
            idx.append(i)
            offset.append(off)
            arms.append(a.name)
            branches.append(branch)
            steps.append(s)
            phases.append(phase)
            dwell.append(hold)
            times.append(step.time if (k == 0 and step.time is not None) else math.nan)
    way = st.take(idx).offset(np.array(offset))
    names = tuple(n if ph in ('move', 'at') else f'{n}/{ph}' for n, ph in zip(way.names, phases, strict=True))
    position = way.position - np.array(back)[:, None] * way.rotation[:, :, 0]   # back along the heading
    way = Stations(position, way.tilt, way.azimuth, way.heading, way.heading_free, names)
    return Waypoints(way, tuple(arms), tuple(branches), np.array(steps), tuple(phases), np.array(dwell),
                     np.array(times), tuple(paths))


def _check_entry(arm: Arm, where: str, station: str) -> None:
    """A straight entry keeps the wafer's orientation: a 2-joint arm cannot, and a 4-joint arm does it with its
    redundant joint held (``fixed_joint``)."""
    if len(arm.joints) == 2 or (arm.redundancy is not None and arm.redundancy.rule != 'fixed_joint'):
        why = ('has 2 joints and cannot hold the blade\'s heading' if len(arm.joints) == 2 else
               'chooses its posture by the rule nearest, not with a held joint (fixed_joint)')
        raise ConfigError(f'{where}: station {station} has a straight entry, but arm {arm.name} {why}; allowed: a '
                          '3-joint arm, or a 4-joint arm under fixed_joint')


def robot_structure(robot: RobotDescription) -> tuple[object, ...]:
    """What a program is written against: the robot's name, its rods' names, its arms and their joints' names. Its
    dimensions are not: a calibrated description (``gpr calibrate --robot``) keeps these and moves those."""
    return robot.name, robot.rods.names, tuple((a.name, a.joint_names) for a in robot.arms)


#: How :func:`program_robot` names the robot a program is run on, and what it asks for, per caller.
NODE_ROBOT = ('this node runs robot', "start trajectory_node with robot_file:= that robot's description or its "
              'calibration')
GIVEN_ROBOT = ('--robot is robot', "give --robot that robot's description or its calibration, or leave it out")


def program_robot(prog: RobotProgram, robot: RobotDescription, who: tuple[str, str] = NODE_ROBOT) -> None:
    """:class:`ConfigError` when a robot program names a robot other than ``robot`` (the node's, or ``--robot``'s):
    another name, rods or arms (:func:`robot_structure`). ``robot`` may be that robot's calibration (it was refused,
    and the message sent the user back to the uncalibrated arms); ``--robot`` of another robot was refused only as
    its stations out of reach (2550 mm too far), without naming either."""
    if prog.robot is None:
        return
    other = load_robot(prog.robot, geometry=robot.config)
    if robot_structure(other) != robot_structure(robot):
        def arms(r: RobotDescription) -> str:
            return '; '.join(f'{a.name}: {", ".join(a.joint_names)}' for a in r.arms)
        raise ConfigError(f'{prog.source} is a program for robot {other.name} ({prog.robot}; arms {arms(other)}); '
                          f'{who[0]} {robot.name} ({robot.source}; arms {arms(robot)}): {who[1]}')
