"""Platform programs: the platform's stations (height, tilt, azimuth), sampled in time, for ``trajectory_node``.

One of the two program formats; :func:`gpr_kinematics.robot.program.load_any_program` reads either, by the
``format:`` key. File format (SI units: metres, radians, seconds)::

    format: gpr_platform_program   # optional (a file without format is a platform program)
    version: 1                # optional
    move_time: 2.0            # optional default duration of each move [s]
    stations:
      - name: load            # optional: 1 to 64 letters, digits, _ . - (not - first), each once
        height: 0.30          # z of the platform centre in gpr_base [m]
        tilt: 0.0             # tilt angle [rad]; negative = about azimuth + pi
        azimuth: 0.0          # direction of the tilt axis [rad], within one turn ([-2pi, 2pi])
        dwell: 0.5            # time held at the station [s], >= 0
      - {name: a, height: 0.45, tilt: 0.0262, azimuth: 0.7854, dwell: 1.0, move_time: 3.0}

The program starts at the first station (dwell), then moves to each next station in ``move_time`` (the
station's own, else the file's, else the node's default) and dwells there.

Interpolation between stations (documented in docs/ros.md): the height ``h`` and the *tilt vector*
``v = tilt (cos azimuth, sin azimuth)`` -- the rotation vector of ``exp(tilt [a]x)``, which lies in the
horizontal plane -- are interpolated with the smooth step ``s(u) = 3u^2 - 2u^3`` (zero velocity at both
stations) over the move's normalised time ``u``. A move through the untilted, singular configuration is
therefore continuous (no azimuth jump), the interpolated rotations stay pure tilts (no twist) and
``|v| <= max(|v_from|, |v_to|)``, so no sample tilts beyond its stations. Commanded tilt and azimuth of a
sample are ``|v|`` and ``atan2(v_y, v_x)`` (0 when untilted). Samples are ``t_k = k / rate`` for
``k = 0 .. floor(T rate)``, plus the final instant ``T`` when it falls between samples (more than 1 ns after the
last) or the program is shorter than that; a last sample within 1 ns before ``T`` is moved to ``T``: the stream
always ends at the last station.
"""
from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import ConfigError, brief, kind_of
from ..inputs.schema import check_keys, is_number, is_version, orientation_angle, read_yaml
from ..inputs.validation import MAX_COORDINATE, plain_number
from .grid import grid_count, grid_times
from .station_files import station_name
from .timing import MAX_SAMPLES

#: The ``format:`` of a platform program (optional: a file without ``format`` is a platform program).
FORMAT = 'gpr_platform_program'
#: The keys of a platform program's station (a file's, and a goal's from `GprClient`).
STATION_KEYS = {'name', 'height', 'tilt', 'azimuth', 'dwell', 'move_time'}
#: Those a station must give (metres, radians).
REQUIRED_STATION_KEYS = ('height', 'tilt', 'azimuth')
#: Most stations of a platform program (a file's or a goal's), counted before any is read.
MAX_STATIONS = 10_000


@dataclass(frozen=True)
class PlatformStation:
    """One station of an offline program (SI units)."""

    name: str
    height: float
    tilt: float
    azimuth: float
    dwell: float
    move_time: float | None = None


@dataclass(frozen=True)
class PlatformProgram:
    """An offline program: stations visited in order; ``move_time`` is the file's default [s] or None."""

    stations: tuple[PlatformStation, ...]
    move_time: float | None = None
    source: str = 'program'


@dataclass(frozen=True)
class ProgramSamples:
    """Time samples of a program: ``time`` [s], ``height`` [m], ``tilt`` >= 0 and ``azimuth`` [rad],
    ``station`` (index of the station the platform is at, -1 while moving between stations) and ``target`` (the
    station moved to or held)."""

    time: np.ndarray
    height: np.ndarray
    tilt: np.ndarray
    azimuth: np.ndarray
    station: np.ndarray
    target: np.ndarray

    def __len__(self) -> int:
        return int(self.time.shape[0])


#: A move's duration [s]: a program file's, a station's, a ``RunProgram`` goal's and ``trajectory_node``'s
#: ``move_time`` parameter (a file took 1e-6 s and 5000 s, which the parameter refused).
MOVE_TIMES = (1e-3, 3600.0)


def move_time_of(value: Any, source: str, where: str) -> float:
    """A ``move_time`` [s] of a program file, a station or a goal: a number within :data:`MOVE_TIMES`
    (:class:`ConfigError` naming ``source`` and ``where``)."""
    lo, hi = MOVE_TIMES
    if not is_number(value) or not lo <= float(value) <= hi:
        raise ConfigError(f'{source}: {where}: move_time = {brief(value)} is invalid; allowed: seconds from {lo:g} to '
                          f'{hi:g}')
    return float(value)


def _number(source: str, where: str, key: str, value: Any, allowed: str, lo: float = -math.inf,
            lo_open: bool = False) -> float:
    if not is_number(value) or float(value) < lo or (lo_open and float(value) == lo):  # a 401-digit integer too
        raise ConfigError(f'{source}: {where}: {key} = {brief(value)} is invalid; allowed: {allowed} (of magnitude '
                          f'at most {MAX_COORDINATE:g})')
    return float(value)


def parse_platform_program(data: Any, source: str = 'program') -> PlatformProgram:
    """Validate a program mapping (as loaded from YAML) into a :class:`PlatformProgram`."""
    if not isinstance(data, Mapping):
        raise ConfigError(f'{source}: expected a mapping with a "stations" list, got {kind_of(data)}')
    check_keys(data, ('format', 'version', 'stations', 'move_time'), source)
    if data.get('format', FORMAT) != FORMAT or not is_version(data.get('version', 1), (1,)):
        raise ConfigError(f'{source}: format = {brief(data.get("format"))}, version = {brief(data.get("version"))} '
                          f'is invalid; allowed: format {FORMAT} (or none), version 1')
    move_time = data.get('move_time')
    if move_time is not None:
        move_time = move_time_of(move_time, source, 'file')
    raw = data.get('stations')
    if not isinstance(raw, list) or not raw:
        raise ConfigError(f'{source}: "stations" must be a non-empty list of stations')
    if len(raw) > MAX_STATIONS:
        raise ConfigError(f'{source}: {len(raw)} stations; allowed: at most {MAX_STATIONS}')
    stations: list[PlatformStation] = []
    first: dict[str, int] = {}   # each name's station, for a name given twice (robot programs refuse it too)
    for i, st in enumerate(raw):
        where = f'station {i}'
        if not isinstance(st, Mapping):
            raise ConfigError(f'{source}: {where} must be a mapping with height, tilt, azimuth, dwell')
        check_keys(st, STATION_KEYS, f'{source}: {where}')
        missing = [k for k in REQUIRED_STATION_KEYS if k not in st]
        if missing:
            raise ConfigError(f'{source}: {where}: missing {", ".join(missing)} (metres, radians)')
        name = station_name(st['name'], f'{source}: {where}') if 'name' in st else f'station_{i}'
        if name in first:
            raise ConfigError(f'{source}: station name {brief(name)} is given twice, as station {first[name]} and as '
                              f'station {i}; allowed: each station name once')
        first[name] = i
        where = f'station {i} ({name})'
        mt = st.get('move_time')
        stations.append(PlatformStation(
            name=name,
            height=_number(source, where, 'height', st['height'], 'a finite height in metres'),
            tilt=_number(source, where, 'tilt', st['tilt'], 'a finite angle in radians'),
            azimuth=orientation_angle(st['azimuth'], 'azimuth', f'{source}: {where}'),
            dwell=_number(source, where, 'dwell', st.get('dwell', 0.0), 'seconds >= 0', 0.0),
            move_time=None if mt is None else move_time_of(mt, source, where)))
    return PlatformProgram(stations=tuple(stations), move_time=move_time, source=source)


def load_platform_program(path: str | Path) -> PlatformProgram:
    """Read and validate a program YAML file; :class:`ConfigError` names what is wrong."""
    return parse_platform_program(read_yaml(path, 'program'), str(path))


def move_times(program: PlatformProgram, default_move_time: float) -> list[float]:
    """The duration [s] of each move, into stations 1 .. S - 1: the station's ``move_time``, else the file's, else
    ``default_move_time`` (the node's)."""
    return [st.move_time or program.move_time or default_move_time for st in program.stations[1:]]


def program_knots(program: PlatformProgram, default_move_time: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Knot times ``(K,)`` [s], knot states ``(K, 3)`` = (height, v_x, v_y) and the station index of each
    knot. Consecutive knots alternate dwell (equal states) and move segments."""
    times, states, index = [], [], []
    t = 0.0
    moves = [0.0, *move_times(program, default_move_time)]
    for i, st in enumerate(program.stations):
        state = (st.height, st.tilt * math.cos(st.azimuth), st.tilt * math.sin(st.azimuth))
        if i > 0:
            t += moves[i]
        times.append(t)
        states.append(state)
        index.append(i)
        t += st.dwell
        times.append(t)
        states.append(state)
        index.append(i)
    return np.asarray(times), np.asarray(states, dtype=float), np.asarray(index)


def rod_demand(program: PlatformProgram, rods: np.ndarray, default_move_time: float
               ) -> tuple[np.ndarray, np.ndarray]:
    """The peak speed [m/s] and acceleration [m/s^2] of the rods on each move of ``program`` (``(S - 1,)``) from
    the rods ``rods (S, 3)`` [m] at its stations: the smooth step's rate peaks at ``1.5 / T`` and its acceleration at
    ``6 / T^2`` of the change over a move of ``T`` s (``s' = 6u(1 - u)``, ``s'' = 6 - 12u``), the rods changing
    along the move as the step, to first order (the tilt's second-order part of a rod is below 1e-3 of it at 2 deg)."""
    change = np.max(np.abs(np.diff(np.asarray(rods, dtype=float), axis=0)), axis=1) if len(rods) > 1 else np.zeros(0)
    T = np.array(move_times(program, default_move_time))
    return 1.5 * change / T, 6.0 * change / (T * T)


def check_samples(program: PlatformProgram, rate: float, default_move_time: float = 2.0
                  ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The program's knots (:func:`program_knots`) once its sample count at ``rate`` [Hz] is within
    :data:`~gpr_kinematics.robot.timing.MAX_SAMPLES`: counted before any array of samples is made, and before its
    stations are solved (a dwell of 1e12 s included); :class:`ConfigError` otherwise."""
    if not 0.0 < plain_number(rate) < math.inf:
        raise ConfigError(f'rate = {brief(rate)} is invalid; allowed: a finite rate in Hz > 0')
    lo, hi = MOVE_TIMES
    if not lo <= plain_number(default_move_time) <= hi:   # the range of every other door (move_time_of)
        raise ConfigError(f'move_time = {brief(default_move_time)} is invalid; allowed: seconds from {lo:g} to {hi:g}')
    T, S, idx = program_knots(program, default_move_time)
    total = float(T[-1])
    count = grid_count(total, rate)
    if count > MAX_SAMPLES:
        raise ConfigError(f'{program.source}: the program lasts {total:.6g} s: {count} samples at {rate:g} Hz; '
                          f'allowed: at most {MAX_SAMPLES} samples (shorter dwells and moves, or a lower rate)')
    return T, S, idx


def sample_program(program: PlatformProgram, rate: float, default_move_time: float = 2.0) -> ProgramSamples:
    """Sample ``program`` at ``rate`` [Hz] with the smooth-step interpolation of the module docstring."""
    T, S, idx = check_samples(program, rate, default_move_time)
    t = grid_times(float(T[-1]), rate)   # a 1e-12 s move keeps its station: the end is always a sample
    if T.shape[0] == 1:
        seg = np.zeros(t.shape, dtype=int)
    else:
        seg = np.clip(np.searchsorted(T, t, side='right') - 1, 0, T.shape[0] - 2)
    t0, t1 = T[seg], T[np.minimum(seg + 1, T.shape[0] - 1)]
    dt = t1 - t0
    with np.errstate(divide='ignore', invalid='ignore'):
        u = np.where(dt > 0, (t - t0) / np.where(dt > 0, dt, 1.0), 1.0)
    u = np.clip(u, 0.0, 1.0)
    s = u * u * (3.0 - 2.0 * u)
    a = S[seg]
    b = S[np.minimum(seg + 1, S.shape[0] - 1)]
    x = a + s[:, None] * (b - a)
    tilt = np.hypot(x[:, 1], x[:, 2])
    az = np.where(tilt > 0.0, np.arctan2(x[:, 2], x[:, 1]), 0.0)
    nxt = idx[np.minimum(seg + 1, idx.shape[0] - 1)]
    station = np.where((idx[seg] == nxt) | (u <= 0.0), idx[seg], np.where(u >= 1.0, nxt, -1))
    return ProgramSamples(time=t, height=x[:, 0], tilt=tilt, azimuth=az, station=station,
                          target=np.where(station >= 0, station, nxt))
