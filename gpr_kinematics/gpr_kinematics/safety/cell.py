"""The process cell: obstacles around the robot, from YAML (docs/cell.md).

File format (``config/cells/example_cell.yaml`` is a commented example)::

    format: gpr_cell
    version: 1
    frame: world                       # the robot description's world frame (base.frame); no other
    units: {length: mm, angle: deg}    # optional: m and rad by default
    obstacles:
      - {name: pm1_slit_top, box: [0.40, 0.05, 0.30], position: [1.25, 1.05, 0.50], rpy: [0, 0, 0.52]}
      - {name: column, cylinder: {radius: 0.05, length: 1.0}, position: [0.2, 0.2, 0.5], rpy: [0, 0, 0]}
      - {name: pm1, chamber: {size: [0.5, 0.5, 0.3], wall: 0.02, slit: [0.34, 0.04], slit_z: -0.005, front: 0.16},
         position: [1.2, 1.0, 0.455], tilt: 1.2, azimuth: 30, heading: 45}

A **box** is given by its full edge lengths and centred at ``position``; a **cylinder** lies along its local z,
centred at ``position``; the orientation is URDF ``rpy`` (``R = Rz(yaw) Ry(pitch) Rx(roll)``) or, as a station's,
``tilt``/``azimuth``/``heading`` (``R = tilt_rotation(tilt, azimuth) Rz(heading)``, docs/robot.md). A **chamber** is
shorthand for the walls of a process chamber around a station at ``position`` (its local x along the heading into
it): a box of outer ``size`` with walls ``wall`` thick whose front face (at ``x = -front``, ``front`` default half
the depth) has a ``slit`` ``[width, height]`` opening centred ``slit_z`` above the station plane; it becomes the
boxes ``NAME/front_top``, ``NAME/front_bottom``, ``NAME/front_left``, ``NAME/front_right``, ``NAME/back``,
``NAME/left``, ``NAME/right``, ``NAME/floor``, ``NAME/roof``. Every value is checked; an error names the file, the
key and the value, and at most :data:`MAX_OBSTACLES` obstacles are read.
"""
from __future__ import annotations

import re
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..core.rotations import rotation_z, rpy_matrix, tilt_rotation
from ..errors import ConfigError, brief, key_value, kind_of
from ..inputs.schema import check_keys, is_number, is_version, orientation_angle, read_yaml
from ..inputs.units import to_si
from ..inputs.validation import TURN, TURN_SLACK, WORLD_BOUND, text_hint
from ..robot.station_files import DECLARE_DEG, units_of

Array = NDArray[np.float64]

FORMAT = 'gpr_cell'
#: Most obstacles in a cell (after chambers are expanded), largest coordinate and size [m].
MAX_OBSTACLES = 10_000
_SIZE = 50.0
_KEYS = ('format', 'version', 'frame', 'units', 'obstacles')
_SHAPES = ('box', 'cylinder', 'chamber')
_OBSTACLE_KEYS = ('name', *_SHAPES, 'position', 'rpy', 'tilt', 'azimuth', 'heading')


@dataclass(frozen=True)
class Obstacle:
    """A fixed body of the cell: ``kind`` box (full edges) or cylinder (radius, length), ``size`` [m], its centre
    ``position`` [m] and ``rotation`` (3, 3) in the cell's frame."""

    name: str
    kind: str
    size: tuple[float, ...]
    position: Array
    rotation: Array


@dataclass(frozen=True)
class Cell:
    """A validated cell: its obstacles in the frame ``frame`` (``stated``: named by the file; else ``world``, the
    default), and the file it came from."""

    obstacles: tuple[Obstacle, ...]
    frame: str
    source: str
    stated: bool = True

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(o.name for o in self.obstacles)

    def in_frame(self, world: str) -> Cell:
        """This cell, if its obstacles are given in ``world`` (the robot description's world frame, in which the
        checks place the robot); a :class:`~gpr_kinematics.errors.ConfigError` naming both frames otherwise (the
        obstacles are not transformed: a cell in another frame would be checked off by that frame's offset)."""
        if self.frame != world:
            given = '' if self.stated else ' (the default: the file names no frame)'
            raise ConfigError(f'{self.source}: frame = {self.frame!r}{given}, but the robot description places the '
                              f'robot in {world!r}; allowed: {world!r} (the obstacles in the robot\'s world frame)')
        return self


def _number(value: Any, where: str, key: str, lo: float, hi: float, unit: str, scale: float = 1.0) -> float:
    if not is_number(value) or not lo <= to_si(float(value), scale) <= hi:
        si = 'm' if unit in ('m', 'mm') else 'rad' if unit in ('rad', 'deg') else unit
        given = f'{key} is missing' if value is None else f'{key} = {brief(value)} is invalid'   # not "length = None"
        metres = unit == 'mm' and is_number(value) and lo <= float(value) <= hi   # metres written in a mm file
        hint = f' ({value:g} mm is {to_si(float(value), scale):g} m: metres in a file of mm?)' if metres else ''
        if unit == 'm' and is_number(value) and abs(float(value)) >= 1.0 and lo <= float(value) / 1000.0 <= hi:
            # millimetres in a file of metres (a value of a metre or more, too large, within as millimetres)
            hint = f' ({value:g} m: millimetres? declare them, units: {{length: mm}})'
        ends = f'{lo / scale:g} to {hi / scale:g} deg' if unit == 'deg' else f'{lo:g} to {hi:g} {si} after conversion'
        raise ConfigError(f'{where}: {given}; allowed: a finite number in {unit}, {ends}{hint}')   # a tilt in deg
    return to_si(float(value), scale)


def _default(raw: Mapping[str, Any], key: str, si: float, where: str, lo: float, hi: float, unit: str,
             scale: float) -> float:
    """``raw[key]`` as :func:`_number`, or the default ``si`` [m] itself where the key is absent (the default in the
    file's unit and back moved a chamber's walls by an ulp: 2.8e-17 m in millimetres, 0 in metres)."""
    if key in raw:
        return _number(raw[key], where, key, lo, hi, unit, scale)
    if not lo <= si <= hi:
        raise ConfigError(f'{where}: {key} (default {si:g} m) is invalid; allowed: {lo:g} to {hi:g} m: give {key}')
    return si


def _vector(value: Any, where: str, key: str, n: int, lo: float, hi: float, unit: str, scale: float
            ) -> tuple[float, ...]:
    if not isinstance(value, list) or len(value) != n:
        raise ConfigError(f'{where}: {key} = {brief(value)} is invalid; allowed: a list of {n} numbers in {unit}')
    return tuple(_number(v, where, f'{key}[{i}]', lo, hi, unit, scale) for i, v in enumerate(value))


def _rotation(data: Mapping[str, Any], where: str, angle: float, aunit: str) -> Array:
    if 'rpy' in data and any(k in data for k in ('tilt', 'azimuth', 'heading')):
        raise ConfigError(f'{where}: give rpy or tilt/azimuth/heading, not both')
    if 'rpy' in data:
        rpy = data['rpy']
        if not isinstance(rpy, list) or len(rpy) != 3:
            raise ConfigError(f'{where}: rpy = {brief(rpy)} is invalid; allowed: a list of 3 numbers in {aunit}')
        r, p, y = (orientation_angle(v, f'rpy[{i}]', where, aunit, DECLARE_DEG) for i, v in enumerate(rpy))
        return np.asarray(rpy_matrix(r, p, y), dtype=np.float64)
    most = TURN + TURN_SLACK   # the one rule of a turn, as the azimuth's (orientation_angle)
    t = _number(data.get('tilt', 0.0), where, 'tilt', -most, most, aunit, angle)
    a, h = (orientation_angle(data.get(k, 0.0), k, where, aunit, DECLARE_DEG) for k in ('azimuth', 'heading'))
    return np.asarray(tilt_rotation(np.array([t]), np.array([a]))[0] @ rotation_z(np.array([h]))[0],
                      dtype=np.float64)


#: The least width and height of a chamber's slit [m].
_LEAST_SLIT = 1e-3


def _chamber(raw: Any, name: str, where: str, length: float, lunit: str, position: Array, R: Array
             ) -> list[Obstacle]:
    if not isinstance(raw, Mapping):
        raise ConfigError(f'{where}: chamber = {brief(raw)} is invalid; allowed: a mapping with size, wall, slit, '
                          'slit_z, front')
    check_keys(raw, ('size', 'wall', 'slit', 'slit_z', 'front'), f'{where}: chamber')
    w = f'{where}: chamber'
    dx, dy, dz = _vector(raw.get('size'), w, 'size', 3, _LEAST, _SIZE, lunit, length)
    wall = _default(raw, 'wall', 0.02, w, _LEAST, min(dx, dy, dz) / 2, lunit, length)
    inside = min(dy, dz) - 2 * wall
    if inside <= _LEAST_SLIT + _EVEN:   # the slit's refusal asked for one of 0 x 0 mm
        most = (min(dy, dz) - _LEAST_SLIT - _EVEN) / 2
        what = (f'a wall thinner than {most / length:.6g} {lunit}' if most >= _LEAST else
                f'a chamber wider and higher than {(_LEAST_SLIT + _EVEN + 2 * _LEAST) / length:.6g} {lunit}')
        wide, high = (max(d - 2 * wall, 0.0) / length for d in (dy, dz))
        raise ConfigError(f'{w}: wall = {wall / length:.6g} {lunit} leaves the chamber of size '
                          f'{dx / length:.6g} x {dy / length:.6g} x {dz / length:.6g} {lunit} an inside {wide:.6g} '
                          f'{lunit} wide and {high:.6g} {lunit} high: no room for a slit of {_LEAST_SLIT / length:g} '
                          f'{lunit} or more; allowed: {what}')
    sw, sh = (0.34, 0.04) if 'slit' not in raw else _vector(raw['slit'], w, 'slit', 2, _LEAST_SLIT, _SIZE, lunit,
                                                            length)
    if sw >= dy - 2 * wall - _EVEN or sh >= dz - 2 * wall - _EVEN:
        given = brief(raw['slit']) if 'slit' in raw else f'(the default {sw * 1000:g} x {sh * 1000:g} mm)'
        raise ConfigError(f'{w}: slit = {given} is invalid; allowed: narrower and lower than the chamber inside its '
                          f'walls, {(dy - 2 * wall) / length:.6g} x {(dz - 2 * wall) / length:.6g} {lunit}')
    front = _default(raw, 'front', dx / 2, w, wall, dx - wall, lunit, length)
    sz = _default(raw, 'slit_z', 0.0, w, -dz / 2 + wall + sh / 2, dz / 2 - wall - sh / 2, lunit, length)
    cx, cz = dx / 2 - front, 0.0   # the box centre in the station frame (x into the chamber)
    fx = -front + wall / 2
    lo, hi = sz - sh / 2, sz + sh / 2
    parts = [
        ('front_top', (wall, dy, dz / 2 - hi), (fx, 0.0, (hi + dz / 2) / 2)),
        ('front_bottom', (wall, dy, lo + dz / 2), (fx, 0.0, (lo - dz / 2) / 2)),
        ('front_left', (wall, (dy - sw) / 2, sh), (fx, (sw + dy) / 4, sz)),
        ('front_right', (wall, (dy - sw) / 2, sh), (fx, -(sw + dy) / 4, sz)),
        ('back', (wall, dy, dz), (cx + dx / 2 - wall / 2, 0.0, cz)),
        ('left', (dx - 2 * wall, wall, dz), (cx, dy / 2 - wall / 2, cz)),
        ('right', (dx - 2 * wall, wall, dz), (cx, -dy / 2 + wall / 2, cz)),
        ('floor', (dx - 2 * wall, dy - 2 * wall, wall), (cx, 0.0, -dz / 2 + wall / 2)),
        ('roof', (dx - 2 * wall, dy - 2 * wall, wall), (cx, 0.0, dz / 2 - wall / 2)),
    ]
    return [Obstacle(f'{name}/{part}', 'box', size, position + R @ np.array(centre), R)
            for part, size, centre in parts if min(size) > 0.0]


#: The least size of an obstacle [m] (a box, a cylinder's radius and length, a chamber): a cell in metres declared in
#: millimetres made its boxes 40 um specks at the origin, checked safe.
_LEAST = 1e-3
#: A slit within this of the chamber's inside [m] reaches it, and is refused: 0.4 less two walls of 0.02 is
#: 0.36000000000000004, and a slit 0.36 wide passed as narrower than 0.36.
_EVEN = 1e-12
#: An obstacle's name (in messages, markers and the check's pairs).
_NAME = re.compile(r'[A-Za-z0-9_\-]{1,64}')


def _obstacle(ob: Any, where: str, length: float, angle: float) -> list[Obstacle]:
    lunit, aunit = ('mm' if length != 1.0 else 'm'), ('deg' if angle != 1.0 else 'rad')
    if not isinstance(ob, Mapping):
        raise ConfigError(f'{where}: expected a mapping with name, a shape ({", ".join(_SHAPES)}) and position')
    name = ob.get('name')
    named = isinstance(name, str) and _NAME.fullmatch(name) is not None   # isalnum took any script's letters, digits
    check_keys(ob, _OBSTACLE_KEYS, f'{where} ({name})' if named else where)   # a misspelt key by the obstacle's name
    if not isinstance(name, str) or not named:
        raise ConfigError(f'{where}: name = {brief(name)} is invalid{text_hint(name)}; allowed: 1 to 64 letters, '
                          'digits, _ and - (ASCII)')
    where = f'{where} ({name})'
    shapes = [k for k in _SHAPES if k in ob]
    if len(shapes) != 1:
        raise ConfigError(f'{where}: shape = {", ".join(shapes) or "none"} is invalid; allowed: exactly one of '
                          f'{", ".join(_SHAPES)}')
    position = np.array(_vector(ob.get('position'), where, 'position', 3, -WORLD_BOUND, WORLD_BOUND, lunit, length))
    R = _rotation(ob, where, angle, aunit)
    kind = shapes[0]
    if kind == 'box':
        return [Obstacle(name, 'box', _vector(ob['box'], where, 'box', 3, _LEAST, _SIZE, lunit, length), position, R)]
    if kind == 'chamber':
        return _chamber(ob['chamber'], name, where, length, lunit, position, R)
    c = ob['cylinder']
    if not isinstance(c, Mapping):
        raise ConfigError(f'{where}: cylinder = {brief(c)} is invalid; allowed: {{radius: R, length: L}}')
    check_keys(c, ('radius', 'length'), f'{where}: cylinder')
    size = tuple(_number(c.get(k), where, k, _LEAST, _SIZE, lunit, length) for k in ('radius', 'length'))
    return [Obstacle(name, 'cylinder', size, position, R)]


def parse_cell(data: Any, source: str = 'cell') -> Cell:
    """Validate a cell mapping (as loaded from YAML); ConfigError names the file, the key and the value."""
    if not isinstance(data, Mapping):
        raise ConfigError(f'{source}: expected a mapping (format: {FORMAT}, obstacles), got {kind_of(data)}')
    if data.get('format') != FORMAT:
        raise ConfigError(f'{source}: format = {key_value(data, "format")} is invalid; allowed: {FORMAT}')
    check_keys(data, _KEYS, source)
    if not is_version(data.get('version', 1), (1,)):
        raise ConfigError(f'{source}: version = {brief(data.get("version"))} is invalid; allowed: 1')
    frame = data.get('frame', 'world')
    if not isinstance(frame, str) or not frame:
        raise ConfigError(f'{source}: frame = {brief(frame)} is invalid; allowed: a frame name')
    length, angle = units_of(data, source)
    if 'obstacles' not in data:   # a lost or misspelt list read as an empty cell: a program certified against nothing
        raise ConfigError(f'{source}: obstacles is missing; allowed: a list of obstacles ([] for none)')
    raw = data['obstacles']
    if raw is None:   # 'obstacles:' with nothing after it: YAML's null, not Python's None
        raise ConfigError(f'{source}: obstacles has no value (YAML null); allowed: a list of obstacles ([] for none)')
    if not isinstance(raw, list):
        raise ConfigError(f'{source}: obstacles = {brief(raw)} is invalid; allowed: a list of obstacles')
    if len(raw) > MAX_OBSTACLES:
        raise ConfigError(f'{source}: obstacles: {len(raw)} obstacles; allowed: at most {MAX_OBSTACLES}')
    out: list[Obstacle] = []
    for i, ob in enumerate(raw):
        out += _obstacle(ob, f'{source}: obstacles[{i}]', length, angle)
        if len(out) > MAX_OBSTACLES:
            raise ConfigError(f'{source}: obstacles: more than {MAX_OBSTACLES} bodies once chambers are expanded')
    names = [str(ob['name']) for ob in raw]  # as given: a box and a chamber of one name (its parts NAME/...) passed
    twice = sorted({n for n in names if names.count(n) > 1})
    if twice:
        raise ConfigError(f'{source}: obstacles: name {brief(twice[0])} is used twice; allowed: unique names')
    return Cell(tuple(out), frame, source, 'frame' in data)


def load_cell(path: str | Path) -> Cell:
    """Read and validate a cell file (module docstring)."""
    return parse_cell(read_yaml(path, 'cell'), str(path))
