"""Station lists from YAML and CSV, with their units declared in the file (SI by default).

YAML (inline in a program, or a file of its own)::

    units: {length: mm, angle: deg}      # optional: m and rad by default
    stations:
      - {name: load_port_1, position: [1100, 250, 420], tilt: 0, azimuth: 0, heading: 90}
      - {name: chamber_a, position: [400, 900, 455], tilt: 1.2, azimuth: 30, heading: 180, branch: left,
         approach_height: 8, retract_height: 5}

CSV: a header row names the columns, each with its unit in brackets (none: SI)::

    name,x [mm],y [mm],z [mm],tilt [deg],azimuth [deg],heading [deg],branch
    load_port_1,1100,250,420,0,0,90,
    chamber_a,400,900,455,1.2,30,180,left

Columns: ``name``, ``x``, ``y``, ``z`` (required), ``tilt``, ``azimuth`` (default 0), ``heading`` (empty: free, for
a 2-joint arm), ``branch`` (empty: the arm's), ``approach_height``, ``retract_height`` (empty: the program's),
``entry`` (a straight entry: the distance back along the heading, outside the slit, 0 to 2 m; empty: none).
Length units ``m`` or ``mm``, angle units ``rad`` or ``deg``. Names are unique. Every problem is a
:class:`~gpr_kinematics.errors.ConfigError` naming the file, the line or station, the field and what is allowed;
files are bounded (:data:`MAX_BYTES`, :data:`MAX_STATIONS`).
"""
from __future__ import annotations

import csv
import io
import math
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ..core.stroke import within_as_millimetres
from ..errors import ConfigError, brief, kind_of
from ..inputs import units
from ..inputs.files import path_name, read_text
from ..inputs.safe_yaml import MAX_BYTES
from ..inputs.schema import check_keys, is_number, orientation_angle
from ..inputs.units import ANGLE_UNITS, LENGTH_UNITS, to_si
from ..inputs.validation import MAX_COORDINATE, WORLD_BOUND, decimal, number_hint, text_hint
from .description import BRANCHES
from .fields import check_world_position
from .stations import Stations, name_refusal

#: Most stations in a program (a station file is read up to the YAML files' bound, :data:`MAX_BYTES`).
MAX_STATIONS = 100_000
#: Longest straight entry [m].
MAX_ENTRY = 2.0
#: Highest approach and retract above a station [m] (the program's defaults too).
MAX_APPROACH = 0.1
_LENGTH_FIELDS = ('x', 'y', 'z', 'approach_height', 'retract_height', 'entry')
_ANGLE_FIELDS = ('tilt', 'azimuth', 'heading')
_STATION_KEYS = ('name', 'position', 'tilt', 'azimuth', 'heading', 'branch', 'approach_height', 'retract_height',
                 'entry')
#: How a station file (or a program, or a cell) in YAML, and one in CSV, declares its angles in degrees.
DECLARE_DEG = 'units: {angle: deg}'
_DECLARE_CSV = '"{key} [deg]" in the header or a "# units: deg" line before it'


@dataclass(frozen=True)
class StationTable:
    """Named stations in SI units with their optional per-station settings (``None``: the program's default)."""

    stations: Stations
    branch: tuple[str | None, ...]
    approach_height: tuple[float | None, ...]
    retract_height: tuple[float | None, ...]
    #: Straight entry distance [m] per station (None: the wafer enters joint-interpolated).
    entry: tuple[float | None, ...] = ()

    def __len__(self) -> int:
        return len(self.stations)

    def index(self) -> dict[str, int]:
        return {name: i for i, name in enumerate(self.stations.names)}


@dataclass
class StationRows:
    """Stations as they are read, before they become a :class:`StationTable`."""

    names: list[str]
    position: list[tuple[float, float, float]]
    tilt: list[float]
    azimuth: list[float]
    heading: list[float | None]
    branch: list[str | None]
    approach: list[float | None]
    retract: list[float | None]
    entry: list[float | None]

    @staticmethod
    def empty() -> StationRows:
        return StationRows([], [], [], [], [], [], [], [], [])

    def extend(self, other: StationRows) -> None:
        for field in ('names', 'position', 'tilt', 'azimuth', 'heading', 'branch', 'approach', 'retract', 'entry'):
            getattr(self, field).extend(getattr(other, field))

    def table(self, source: str) -> StationTable:
        seen: dict[str, int] = {}
        for i, name in enumerate(self.names):
            if name in seen:
                raise ConfigError(f'{source}: station name {brief(name)} is used twice (stations {seen[name]} and '
                                  f'{i}); names must be unique')
            seen[name] = i
        if len(self.names) > MAX_STATIONS:
            raise ConfigError(f'{source}: {len(self.names)} stations; allowed: at most {MAX_STATIONS}')
        n = len(self.names)
        heading = np.array([0.0 if h is None else h for h in self.heading])
        free = np.array([h is None for h in self.heading], dtype=bool)
        st = Stations(np.array(self.position, dtype=float).reshape(n, 3), np.array(self.tilt, dtype=float),
                      np.array(self.azimuth, dtype=float), heading, free, tuple(self.names))
        return StationTable(st, tuple(self.branch), tuple(self.approach), tuple(self.retract), tuple(self.entry))


def units_of(data: Mapping[str, Any], where: str) -> tuple[float, float]:
    """Scale factors (length, angle) to SI from a ``units`` mapping (absent: SI)."""
    units = data.get('units', {})
    if not isinstance(units, Mapping):
        raise ConfigError(f'{where}: units must be a mapping {{length: m|mm, angle: rad|deg}}, got {brief(units)}')
    check_keys(units, ('length', 'angle'), f'{where}: units')
    length, angle = units.get('length', 'm'), units.get('angle', 'rad')
    if not isinstance(length, str) or length not in LENGTH_UNITS:   # a list from YAML is not even hashable
        raise ConfigError(f'{where}: units: length = {brief(length)} is invalid; allowed: m or mm')
    if not isinstance(angle, str) or angle not in ANGLE_UNITS:
        raise ConfigError(f'{where}: units: angle = {brief(angle)} is invalid; allowed: rad or deg')
    return LENGTH_UNITS[length], ANGLE_UNITS[angle]


def _number(value: Any, where: str, key: str, unit: str, rule: str = '') -> float:
    """A finite number in the file's ``unit``; the refusal names the key's own ``rule`` where given (a station at
    2.3e6 mm was told 'at most 1e+06 mm' where positions are within 100 m)."""
    if not is_number(value):
        raise ConfigError(f'{where}: {key} = {brief(value)} is invalid; allowed: a finite number in {unit} '
                          + (f'({rule})' if rule else f'(of magnitude at most {MAX_COORDINATE:g})'))
    return float(value)


def _position(xyz: tuple[float, float, float], where: str, unit: str) -> tuple[float, float, float]:
    """A station's position [m] within :data:`~gpr_kinematics.inputs.validation.WORLD_BOUND` of the world origin
    (:func:`~.fields.check_world_position`; the mm hint where the file's metres would fit as millimetres): an unused
    imported station at 2.3 km (a CSV in millimetres without its unit) passed the program's check unmentioned."""
    check_world_position(xyz, f'{where}: position', '; as millimetres it would be {mm} m: millimetres given as '
                         'metres? (declare them: "# units: mm" or a column "x [mm]" in a CSV, units: {{length: mm}} in '
                         'YAML)' if unit == 'm' else '')
    return xyz


def station_name(value: Any, where: str) -> str:
    """A station's name: text of 1 to 64 letters, digits, ``_ . -``, not ``-`` first; a YAML boolean or number is
    refused with the hint to quote it (``007`` read as 7 named the station ``7``, which a CSV file's ``007`` was not;
    ``1.5`` was refused by the rule it meets), as a cell obstacle's name; :class:`ConfigError` naming ``where``
    otherwise (the rule of :func:`~.stations.name_refusal`, which ``Stations.of`` applies too)."""
    refusal = name_refusal(value, f'{where}: name', text_hint(value))
    if refusal:
        raise ConfigError(refusal)
    return str(value)


def _branch(value: Any, where: str) -> str | None:
    if value is None or value == '':
        return None
    if value not in BRANCHES:
        raise ConfigError(f'{where}: branch = {brief(value)} is invalid; allowed: left, right or empty (the arm\'s)')
    return str(value)


def height_refusal(where: str, key: str, value: Any, unit: str, most: float, cell: bool = False) -> ConfigError:
    """The refusal of a height or an entry ``value`` (as given, in ``unit``; ``cell``: a CSV's number as written) not
    within ``[0, most]`` [m]: the bound in the unit (and in metres where that is mm), with the millimetres' hint where
    the value in mm would lie within it."""
    scale = units.MM if unit == 'mm' else 1.0
    si = f' ({most:g} m)' if unit != 'm' else ''
    shown = str(value).strip() if cell else brief(value)   # a CSV's cell unquoted; YAML's '8' quoted: text, not 8
    number = float(shown) if cell else float(value) if is_number(value) else math.nan
    mm = unit == 'm' and within_as_millimetres(number, 0.0, most)
    hint = f'; {number:g} mm would be within it: millimetres given as metres?' if mm else ''
    return ConfigError(f'{where}: {key} = {shown} {unit} is invalid; allowed: 0 to {most / scale:g} {unit}{si}{hint}')


def _height(value: Any, where: str, key: str, scale: float, unit: str, most: float = MAX_APPROACH) -> float | None:
    if value is None or value == '':
        return None
    h = to_si(_number(value, where, key, unit, f'0 to {most / scale:g} {unit}, {most:g} m'), scale)   # as below
    if not 0.0 <= h <= most:
        raise height_refusal(where, key, value, unit, most)
    return h


def stations_from_yaml(data: Any, where: str) -> StationRows:
    """Stations of a mapping with ``stations`` (and optional ``units``), validated."""
    if not isinstance(data, Mapping):
        raise ConfigError(f'{where}: expected a mapping with "stations" (and "units"), got {kind_of(data)}')
    check_keys(data, ('stations', 'units'), where)
    length, angle = units_of(data, where)
    if 'stations' not in data:
        raise ConfigError(f'{where}: no "stations" key; a station file is a mapping with "stations" (and "units")')
    lunit, aunit = ('mm' if length != 1.0 else 'm'), ('deg' if angle != 1.0 else 'rad')
    raw = data.get('stations', [])
    if not isinstance(raw, list):
        raise ConfigError(f'{where}: stations must be a list of stations')
    if len(raw) > MAX_STATIONS:
        raise ConfigError(f'{where}: {len(raw)} stations; allowed: at most {MAX_STATIONS}')
    rows = StationRows.empty()
    for i, st in enumerate(raw):
        w = f'{where}: stations[{i}]'
        if not isinstance(st, Mapping):
            raise ConfigError(f'{w}: expected a mapping with name, position, tilt, azimuth, heading')
        try:   # a misspelt key named by the station's name when it has a valid one
            label = f'{w} ({station_name(st.get("name"), w)})'
        except ConfigError:
            label = w
        check_keys(st, _STATION_KEYS, label)
        if 'name' not in st or 'position' not in st:
            raise ConfigError(f'{w}: name and position are required')
        name = station_name(st['name'], w)
        w = f'{w} ({name})'
        pos = st['position']
        if not isinstance(pos, (list, tuple)) or len(pos) != 3:   # a tuple as the robot's base.position
            raise ConfigError(f'{w}: position = {brief(pos)} is invalid; allowed: [x, y, z] in {lunit}')
        rows.names.append(name)
        x, y, z = (to_si(_number(v, w, k, lunit, f'within +-{WORLD_BOUND:g} m of the world origin'), length)
                   for v, k in zip(pos, 'xyz', strict=True))
        rows.position.append(_position((x, y, z), w, lunit))
        rows.tilt.append(orientation_angle(st.get('tilt', 0.0), 'tilt', w, aunit, DECLARE_DEG))
        rows.azimuth.append(orientation_angle(st.get('azimuth', 0.0), 'azimuth', w, aunit, DECLARE_DEG))
        h = st.get('heading')
        rows.heading.append(None if h is None else orientation_angle(h, 'heading', w, aunit, DECLARE_DEG))
        rows.branch.append(_branch(st.get('branch'), w))
        rows.approach.append(_height(st.get('approach_height'), w, 'approach_height', length, lunit))
        rows.retract.append(_height(st.get('retract_height'), w, 'retract_height', length, lunit))
        rows.entry.append(_height(st.get('entry'), w, 'entry', length, lunit, MAX_ENTRY))
    return rows


@dataclass(frozen=True)
class CsvTable:
    """A CSV table whose header names its columns with units in brackets (``x [mm]``, ``tilt [deg]``)."""

    where: str
    columns: dict[str, tuple[int, float, str]]  # name -> (index, scale to SI, unit)
    rows: list[list[str]]
    lines: list[int]

    def __len__(self) -> int:
        return len(self.rows)

    def row_where(self, r: int) -> str:
        return f'{self.where}: line {self.lines[r]}'

    def text(self, r: int, key: str) -> str | None:
        """The cell (stripped), or None when the column is absent."""
        return self.rows[r][self.columns[key][0]].strip() if key in self.columns else None

    def number(self, r: int, key: str, default: float | None, where: str | None = None) -> float | None:
        """The cell in SI units (``default`` when the column is absent or the cell empty)."""
        value = self.written(r, key, where)
        return default if value is None else to_si(value, self.columns[key][1])

    def angle(self, r: int, key: str, default: float | None, where: str | None = None) -> float | None:
        """An orientation angle's cell in radians (``default`` when the column is absent or the cell empty), at
        most one turn (:func:`~gpr_kinematics.inputs.schema.orientation_angle`)."""
        value = self.written(r, key, where)
        return default if value is None else orientation_angle(value, key, where or self.row_where(r),
                                                               self.columns[key][2], _DECLARE_CSV.format(key=key))

    def written(self, r: int, key: str, where: str | None = None) -> float | None:
        """The cell as a finite number in the column's unit (None when the column is absent or the cell empty)."""
        text = self.text(r, key)
        if text is None or text == '':
            return None
        try:
            value = decimal(text)   # float() read 1_0 as 10
        except ValueError:
            value = math.nan
        if not math.isfinite(value):
            raise ConfigError(f'{where or self.row_where(r)}: {key} = {brief(text)} is invalid; allowed: a finite '
                              f'number in {self.columns[key][2]}{number_hint(text)}')
        return value


def _comment(line: str, where: str, after_header: bool, defaults: units.FileUnits) -> units.FileUnits:
    """A comment line: the file's units where it is the ``# units:`` line (once, before the header), else
    ``defaults``; a comment before the header that speaks of units otherwise is refused."""
    if units.is_units_line(line):
        if after_header or defaults != (None, None):
            raise ConfigError(f'{where}: "# units:" must come once, before the header row')
        return units.file_units(line, where)
    if not after_header:
        units.refuse_unit_words(line, where)
    return defaults


def read_csv_table(text: str, where: str, kinds: dict[str, str], required: tuple[str, ...]) -> CsvTable:
    """Parse a CSV text with a header row; ``kinds`` maps each allowed column to ``length``, ``angle`` or
    ``text``; ``required`` columns must be there. Units (:mod:`gpr_kinematics.inputs.units`): a column's own in brackets
    (``x [mm]``), else the file's from a ``# units: mm deg`` line before the header, else SI. Lines whose first
    field starts with ``#`` are comments. Bounded by :data:`MAX_STATIONS` rows; ConfigError names the line and
    the field."""
    numbered: list[tuple[int, list[str]]] = []
    defaults: units.FileUnits = (None, None)
    try:  # row by row, kept rows counted as they come: 10 MiB of blank lines or short rows held 0.5-0.8 GB as a list
        for n, row in enumerate(csv.reader(io.StringIO(text, newline='')), start=1):
            if not row or (len(row) == 1 and not row[0].strip()):
                continue
            if row[0].lstrip().startswith('#'):
                defaults = _comment(','.join(row).strip(), f'{where}: line {n}', bool(numbered), defaults)
                continue
            if len(numbered) > MAX_STATIONS:
                raise ConfigError(f'{where}: line {n}: more than {MAX_STATIONS} rows; allowed: at most {MAX_STATIONS}')
            numbered.append((n, row))
    except csv.Error as exc:
        raise ConfigError(f'{where}: not valid CSV ({exc})') from None
    if not numbered:
        raise ConfigError(f'{where}: empty; a header row ({", ".join(required)}, ...) and one row per entry are '
                          'required')
    header = numbered[0][1]
    cols = _header_columns(header, where, kinds, defaults)
    missing = [k for k in required if k not in cols]
    if missing:
        raise ConfigError(f'{where}: the header lacks the column(s) {", ".join(missing)}; required: '
                          + ', '.join(required))
    if len(numbered) == 1:   # a header alone passed as no stations, a program then missing every one it names
        raise ConfigError(f'{where}: no rows after the header (line {numbered[0][0]}); one row per entry is required')
    for n, row in numbered[1:]:
        if len(row) != len(header):
            raise ConfigError(f'{where}: line {n}: {len(row)} fields, the header has {len(header)}')
    return CsvTable(where, cols, [row for _, row in numbered[1:]], [n for n, _ in numbered[1:]])


def _unit_example(kinds: dict[str, str]) -> str:
    """A header cell of the first column with a unit, e.g. ``"x [mm]"`` (a station file), ``"rod_1 [mm]"``."""
    key, kind = next(((k, v) for k, v in kinds.items() if v in ('length', 'angle')), ('x', 'length'))
    return f'"{key} [{"mm" if kind == "length" else "deg"}]"'


def _header_columns(header: list[str], where: str, kinds: dict[str, str], defaults: units.FileUnits
                    ) -> dict[str, tuple[int, float, str]]:
    """Column name -> (index, factor to SI, unit) of a header row (:mod:`gpr_kinematics.inputs.units`)."""
    cols: dict[str, tuple[int, float, str]] = {}
    for i, cell in enumerate(header):
        try:
            key, unit = units.column(cell, where)
        except ConfigError:
            key, unit = '', None
        if key not in kinds:   # the example one of the table's own columns (a teach table has no x)
            raise ConfigError(f'{where}: header column {i + 1} {brief(cell)} is invalid; allowed: {", ".join(kinds)}, '
                              f'each with an optional unit in brackets, e.g. {_unit_example(kinds)}'
                              f'{units.separator_hint(cell)}')
        if key in cols:
            raise ConfigError(f'{where}: column {key} appears twice in the header')
        factor, name = units.scale(kinds[key], unit, defaults, where, key)
        cols[key] = (i, factor, name)
    return cols


_CSV_KINDS = {'name': 'text', 'branch': 'text', **{k: 'length' for k in _LENGTH_FIELDS},
              **{k: 'angle' for k in _ANGLE_FIELDS}}


def stations_from_csv(text: str, where: str) -> StationRows:
    """Stations of a CSV text (module docstring), validated."""
    table = read_csv_table(text, where, _CSV_KINDS, ('name', 'x', 'y', 'z'))
    rows = StationRows.empty()
    for r in range(len(table)):
        name = station_name(table.text(r, 'name'), table.row_where(r))
        w = f'{table.row_where(r)} ({name})'
        x, y, z = (table.number(r, k, None, w) for k in 'xyz')
        if x is None or y is None or z is None:
            raise ConfigError(f'{w}: x, y and z are required')
        rows.names.append(name)
        rows.position.append(_position((x, y, z), w, table.columns['x'][2]))
        rows.tilt.append(table.angle(r, 'tilt', 0.0, w) or 0.0)
        rows.azimuth.append(table.angle(r, 'azimuth', 0.0, w) or 0.0)
        rows.heading.append(table.angle(r, 'heading', None, w))
        rows.branch.append(_branch(table.text(r, 'branch'), w))
        for key, target, most in (('approach_height', rows.approach, MAX_APPROACH),
                                  ('retract_height', rows.retract, MAX_APPROACH),
                                  ('entry', rows.entry, MAX_ENTRY)):
            value = table.number(r, key, None, w)
            if value is not None and not 0.0 <= value <= most:
                unit = table.columns[key][2]
                raise height_refusal(w, key, table.text(r, key), unit, most, cell=True)   # table.number read it
            target.append(value)
    return rows


def load_stations(path: str | Path) -> StationTable:
    """Read a station file: ``.csv`` (header with units) or ``.yaml``/``.yml`` (``units`` and ``stations``)."""
    name = path_name(path, 'station')   # '' was read as the folder '.', 5 a bare TypeError
    return read_station_rows(Path(name)).table(name)


def read_station_rows(path: Path) -> StationRows:
    suffix = path.suffix.lower()
    if suffix == '.csv':
        return stations_from_csv(read_text(path, 'station', MAX_BYTES), str(path))
    if suffix in ('.yaml', '.yml'):
        from ..inputs.schema import read_yaml
        rows = stations_from_yaml(read_yaml(path, 'station'), str(path))
        if not rows.names:   # a file of no station, as a CSV of a header alone (a program's inline list may be empty)
            raise ConfigError(f'{path}: stations = [] has no station; allowed: a list of one or more stations')
        return rows
    try:
        folder = path.is_dir()
    except OSError:   # a name too long for the file system: a bare OSError (ENAMETOOLONG) of the API's call
        folder = False
    what = 'a folder' if folder else f'of unknown type {suffix or "(no suffix)"}'
    raise ConfigError(f'station file {brief(str(path))} is {what}; allowed: a .csv, .yaml or .yml file')
