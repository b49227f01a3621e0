"""Measurement files: commanded rod lengths and the measured pose (or point) of a target on the platform.

A measurement file is CSV text (UTF-8) with one header row naming its columns and one row per measured
configuration, as exported from a laser tracker's 6-DOF probe or reflector (docs/calibration.md): the pose of
``gpr_platform`` in ``gpr_base``, or of a target on the platform in the tracker's frame (the calibration
identifies the frames, :mod:`.frames`)::

    # GPR calibration run 2026-11-30, tracker frame registered to gpr_base
    # units: mm deg
    q1,q2,q3,x,y,z,qx,qy,qz,qw,sigma_position,sigma_angle
    250.0,252.1,248.3,0.0131,-0.0205,250.1,0.00731,0.00285,0.000012,0.99996,0.005,0.001

* Required columns: ``q1 q2 q3`` (commanded rod lengths) and ``x y z`` (the measured position); in any order.
* ``qx qy qz qw``: the measured orientation, a unit quaternion x y z w (all four, or none: measured points).
* Optional columns: ``sigma_position`` (standard deviation of each position coordinate) and ``sigma_angle``
  (standard deviation of each rotation-vector component, with an orientation); per row, > 0. Without them the
  caller's defaults weight the residuals.
* Units: metres and radians unless a ``# units:`` line before the header declares ``mm`` and/or ``deg``
  (lengths: ``q``, ``x y z``, ``sigma_position``; angles: ``sigma_angle``). The result is always SI.
* Lines starting with ``#`` are comments; blank lines are skipped.

Refused, with the file, the line and the column named (:class:`~gpr_kinematics.errors.InputError`): a missing,
unknown or repeated column, a value that is not a finite number, a quaternion whose norm differs from 1 by more
than :data:`~gpr_kinematics.inputs.validation.QUATERNION_NORM_TOLERANCE`, a value beyond :data:`MAX_VALUE`, a sigma
outside :data:`SIGMA_RANGE`, an unknown or misplaced unit declaration, a row repeated exactly, a file without
data rows, and files beyond :data:`MAX_FILE_BYTES`, :data:`MAX_ROWS` and :data:`MAX_LINE_CHARS`. Rows that repeat
another's rods and measurement to within :data:`~.repeats.REPEAT_TOLERANCE` of the noise (a copy with rounding
jitter) are refused by the identification, which knows the standard deviations (:func:`~.repeats.check_repeats`).
"""
from __future__ import annotations

import csv
import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from ..callbacks import StageProgress
from ..core.rotations import matrix_from_quaternion
from ..errors import InputError, brief
from ..inputs import units
from ..inputs.validation import MAX_COORDINATE, QUATERNION_NORM_TOLERANCE, decimal, number_hint
from .files import comment_lines, read_text, write_text

Array = NDArray[np.float64]

REQUIRED_COLUMNS = ('q1', 'q2', 'q3', 'x', 'y', 'z')
#: The orientation of a measured pose: all four, or none (a measured point: a reflector, not a 6-DOF probe).
ORIENTATION_COLUMNS = ('qx', 'qy', 'qz', 'qw')
SIGMA_COLUMNS = ('sigma_position', 'sigma_angle')
#: Largest measurement file [bytes]: 16 MiB holds ~100,000 rows of full-precision numbers.
MAX_FILE_BYTES = 16 * 1024 * 1024
#: Most data rows accepted (600,000 residuals; identification memory grows with rows x parameters).
MAX_ROWS = 100_000
#: Longest line accepted [characters].
MAX_LINE_CHARS = 2048
#: Largest magnitude of a value, in the file's units (a GPR is not a kilometre tall; bounded values cannot
#: overflow later).
MAX_VALUE = 1e6
#: Range of a standard deviation, SI: [m] for sigma_position, [rad] for sigma_angle.
SIGMA_RANGE = (1e-9, 0.1)

_LENGTH_COLUMNS = frozenset(('q1', 'q2', 'q3', 'x', 'y', 'z', 'sigma_position'))


@dataclass(frozen=True)
class Measurements:
    """Measured poses, SI units.

    Attributes:
        source: file name (or a label) used in messages.
        q: commanded rod lengths ``(N, 3)`` [m].
        position: measured platform origin in ``gpr_base`` ``(N, 3)`` [m].
        quaternion: measured orientation ``(N, 4)`` (x, y, z, w), normalised; ``None`` for measured points.
        sigma_position, sigma_angle: per-row standard deviations ``(N,)`` [m], [rad], or ``None`` when the file
            has no such column.
        lines: line number of each row in the file (for messages).
        units: the units the file gave, ``(length, angle)``: the rods' column's and the file's angle unit.
        files: the file of each row where rows of several files are merged (:func:`~.arm.merge`: two files may
            both have a line 40); empty when every row is ``source``'s.
    """

    source: str
    q: Array
    position: Array
    quaternion: Array | None
    sigma_position: Array | None
    sigma_angle: Array | None
    lines: tuple[int, ...]
    units: tuple[str, str] = ('m', 'rad')
    files: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        """Refuse arrays that are not the measurements of one set of rows (a library caller's; a file's pass); take
        lists of numbers as float arrays and the line numbers as a tuple of integers >= 0, as a file's are."""
        n = np.shape(self.q)[0] if np.ndim(self.q) == 2 else -1
        for name, shape in (('q', (n, 3)), ('position', (n, 3)), ('quaternion', (n, 4)), ('sigma_position', (n,)),
                            ('sigma_angle', (n,))):
            value = getattr(self, name)
            if value is None and name in ('q', 'position'):
                raise InputError(f'{self.source}: Measurements.{name} is None; allowed: an array {shape}')
            if value is None:
                continue
            v = np.asarray(value)
            if n < 1 or v.shape != shape or v.dtype.kind not in 'fiu':
                raise InputError(f'{self.source}: Measurements.{name} has shape {v.shape} ({v.dtype}); allowed: '
                                 f'numbers of shape {("N", *shape[1:]) if n < 1 else shape}, N >= 1 rows as q')
            bad = np.flatnonzero(~np.all(np.abs(v.reshape(n, -1)) <= MAX_COORDINATE, axis=1))   # NaN too
            if bad.size:   # 1e306 m reached scipy's "data must be finite" in the repeated-rows check
                raise InputError(f'{self.source}: Measurements.{name} of row {int(bad[0])} is not finite or beyond '
                                 f'+-{MAX_COORDINATE:g}; allowed: finite numbers within it (SI)')
            object.__setattr__(self, name, np.asarray(v, dtype=float))   # a list (a caller's) as the file's arrays
        object.__setattr__(self, 'lines', _line_numbers(self.lines, self.source))
        if len(self.lines) != n:
            raise InputError(f'{self.source}: {len(self.lines)} line numbers for {n} rows; allowed: one per row')
        if len(self.files) not in (0, n):
            raise InputError(f'{self.source}: {len(self.files)} file names for {n} rows; allowed: one per row, or '
                             'none (every row from the source)')
        lo, hi = SIGMA_RANGE
        for name, value in (('sigma_position', self.sigma_position), ('sigma_angle', self.sigma_angle)):
            if value is not None and not np.all((np.asarray(value) >= lo) & (np.asarray(value) <= hi)):
                raise InputError(f'{self.source}: Measurements.{name} outside [{lo:g}, {hi:g}] (SI); allowed: '
                                 'standard deviations in that range')
        if self.quaternion is not None:
            norm = np.linalg.norm(self.quaternion, axis=1)
            bad = np.flatnonzero(np.abs(norm - 1.0) > QUATERNION_NORM_TOLERANCE)
            if bad.size:
                raise InputError(f'{self.source}: Measurements.quaternion of row {int(bad[0])} has norm '
                                 f'{norm[bad[0]]:.9g}; allowed: unit quaternions, |norm - 1| <= '
                                 f'{QUATERNION_NORM_TOLERANCE:g}')

    def __len__(self) -> int:
        return int(self.q.shape[0])

    @property
    def rotation(self) -> Array:
        """Measured rotation matrices ``(N, 3, 3)`` (identities for measured points, which have none)."""
        if self.quaternion is None:
            return np.broadcast_to(np.eye(3), (len(self), 3, 3))
        return matrix_from_quaternion(self.quaternion)

    def where(self, i: int) -> str:
        """``'<file> line <n>'`` of row ``i`` (its own file where files are merged), for messages."""
        return f'{self.files[i] if self.files else self.source} line {self.lines[i]}'

    @property
    def row_names(self) -> tuple[str, ...]:
        """Each row's name in messages that name the source already: ``'line 40'``, ``'line 40 of arm1_blade.csv'``
        where files are merged (:func:`row_name`), ``'row 41 (line 40 of its file)'`` where lines repeat without
        files (rows joined in code)."""
        if self.files:
            return tuple(row_name(ln, f) for ln, f in zip(self.lines, self.files, strict=True))
        if len(set(self.lines)) < len(self.lines):
            return tuple(f'row {i + 1} (line {ln} of its file)' for i, ln in enumerate(self.lines))
        return tuple(row_name(ln) for ln in self.lines)


def _line_numbers(lines: object, source: str) -> tuple[int, ...]:
    """``Measurements.lines`` as a tuple of integers >= 0 (a list's too); else :class:`InputError`."""
    if isinstance(lines, (str, bytes)) or not isinstance(lines, Sequence | np.ndarray) or not all(
            isinstance(x, (int, np.integer)) and not isinstance(x, bool) and x >= 0 for x in lines):
        raise InputError(f'{source}: Measurements.lines = {brief(lines)}; allowed: the line number of each row, '
                         'integers >= 0')
    return tuple(int(x) for x in lines)


def row_name(line: int, file: str | None = None) -> str:
    """``'line 40'``, or ``'line 40 of arm1_blade.csv'`` for a row of merged files (``file`` given)."""
    return f'line {line} of {file}' if file else f'line {line}'


@dataclass(frozen=True)
class Columns:
    """The columns a CSV file of measurements may have: ``required`` ones, ``groups`` of which each comes whole or
    not at all, ``optional`` single ones, which of them are lengths and angles (for the units), ``needs``: a
    column that comes only with a group, and ``also``: what a header names besides ``required`` (an arm's joints)."""

    required: tuple[str, ...]
    groups: tuple[tuple[str, ...], ...] = ()
    optional: tuple[str, ...] = ()
    lengths: frozenset[str] = frozenset()
    angles: frozenset[str] = frozenset()
    needs: tuple[tuple[str, tuple[str, ...]], ...] = ()
    also: str = ''

    @property
    def allowed(self) -> tuple[str, ...]:
        return self.required + tuple(c for g in self.groups for c in g) + self.optional


#: The columns of a measurement file of the GPR (module docstring).
POSE_COLUMNS = Columns(REQUIRED_COLUMNS, (ORIENTATION_COLUMNS,), SIGMA_COLUMNS, _LENGTH_COLUMNS,
                       frozenset({'sigma_angle'}), (('sigma_angle', ORIENTATION_COLUMNS),))


def _header(fields: list[str], where: str, defaults: units.FileUnits, spec: Columns
            ) -> tuple[list[str], list[float]]:
    """The column names of the header row and each column's factor to SI (:mod:`gpr_kinematics.inputs.units`)."""
    named = [units.column(f, where) for f in fields]
    cols = [name.lower() for name, _ in named]
    allowed = spec.allowed
    for c in cols:
        if c not in allowed:
            raise InputError(f'{where}: unknown column {c[:40]!r}; allowed: {", ".join(allowed)}')
        if cols.count(c) > 1:
            raise InputError(f'{where}: column {brief(c)} appears {cols.count(c)} times; each column once')
    missing = [c for c in spec.required if c not in cols]
    if missing:
        raise InputError(f'{where}: missing column(s) {", ".join(missing)}; required: {", ".join(spec.required)} '
                         '(a header row naming the columns comes first)')
    for group in spec.groups:
        present = [c for c in group if c in cols]
        if present and len(present) < len(group):
            raise InputError(f'{where}: missing column(s) {", ".join(c for c in group if c not in cols)}; '
                             f'{" ".join(group)} come all together or not at all')
    for column, group in spec.needs:
        if column in cols and not all(c in cols for c in group):
            raise InputError(f'{where}: column {column} without {", ".join(group)}; a file without them has no '
                             f'{column}')
    kinds = {c: 'length' for c in spec.lengths} | {c: 'angle' for c in spec.angles}
    return cols, [units.scale(kinds.get(c, 'number'), unit, defaults, where, c)[0]
                  for c, (_, unit) in zip(cols, named, strict=True)]


def _number(text: str, where: str, column: str) -> float:
    try:
        v = decimal(text)   # float() read 1_0 as 10, and other scripts' digits
    except ValueError:
        raise InputError(f'{where}, column {column}: {text.strip()[:40]!r} is not a number{number_hint(text)}; '
                         'allowed: a decimal number such as 0.25 or -1.5e-3') from None
    if not math.isfinite(v):
        raise InputError(f'{where}, column {column}: {text.strip()[:40]} is not a finite number; allowed: finite '
                         'values')
    if abs(v) > MAX_VALUE:
        raise InputError(f'{where}, column {column}: {v:g} is implausibly large; allowed: |value| <= {MAX_VALUE:g} '
                         "in the file's units")
    return v


@dataclass
class _Table:
    """The rows of a measurement file as read, before unit conversion and the pose checks."""

    spec: Columns = POSE_COLUMNS
    units: units.FileUnits | None = None
    cols: list[str] | None = None
    scales: list[float] = field(default_factory=list)
    rows: list[list[float]] = field(default_factory=list)
    lines: list[int] = field(default_factory=list)
    seen: dict[tuple[float, ...], int] = field(default_factory=dict)

    def comment(self, line: str, where: str) -> None:
        if units.is_units_line(line):
            if self.cols is not None or self.units is not None:
                raise InputError(f'{where}: "# units:" must come once, before the header row')
            self.units = units.file_units(line, where)
        elif self.cols is None:
            units.refuse_unit_words(line, where)

    def row(self, fields: list[str], lineno: int, where: str) -> None:
        if self.cols is None:
            self.cols, self.scales = _header(fields, where, self.units or (None, None), self.spec)
            return
        if len(fields) != len(self.cols):
            raise InputError(f'{where}: {len(fields)} values, but the header names {len(self.cols)} columns')
        values = [_number(f, where, c) for f, c in zip(fields, self.cols, strict=True)]
        key = tuple(values)
        if key in self.seen:
            raise InputError(f'{where} repeats line {self.seen[key]} exactly (a copied row?); each measurement once')
        self.seen[key] = lineno
        self.rows.append(values)
        self.lines.append(lineno)


@dataclass(frozen=True)
class Table:
    """A measurement file as read (:func:`read_table`): columns in SI, factors to SI, lines, declared units."""

    columns: dict[str, Array]
    scales: dict[str, float]
    lines: list[int]
    units: tuple[str, str]

    def sigma(self, name: str, source: str) -> Array | None:
        """Column ``name`` checked against :data:`SIGMA_RANGE` (``None`` when the file has none)."""
        if name not in self.columns:
            return None
        lo, hi = SIGMA_RANGE
        v = self.columns[name]
        bad = np.flatnonzero(~((v >= lo) & (v <= hi)))
        if bad.size:
            i = int(bad[0])
            si, given = ('m', 'mm') if name == 'sigma_position' else ('rad', 'deg')
            raise InputError(f'{source} line {self.lines[i]}, column {name}: {float(v[i]):.9g} {si}'
                             f'{f" (converted from {given})" if self.scales[name] != 1.0 else ""} is outside '
                             f'[{lo:g}, {hi:g}] {si}')
        return v


def read_table(text: str, source: str, spec: Columns = POSE_COLUMNS, progress: StageProgress | None = None
               ) -> Table:
    """The :class:`Table` of the text of a CSV file of measurements with the columns ``spec`` (the checks of the
    module docstring); ``progress`` hears the share of the lines read (stage ``reading rows``)."""
    table = _read_table(text, source, spec, progress)
    data = np.array(table.rows)
    names = table.cols or []
    length, angle = table.units or (None, None)
    columns = {c: units.to_si(data[:, i], table.scales[i]) for i, c in enumerate(names)}
    return Table(columns, dict(zip(names, table.scales, strict=True)),
                 table.lines, (length or 'm', angle or 'rad'))


def _check_row_count(lines: list[str], source: str) -> None:
    """Refuse more than :data:`MAX_ROWS` data rows (lines neither blank nor comments, after the header's) before any
    is parsed, naming the line of the row too many (once all were parsed first: 7-12 s)."""
    seen = 0
    for lineno, raw in enumerate(lines if len(lines) > MAX_ROWS + 1 else (), 1):   # else too few lines to count
        line = raw.strip()
        if line and not line.startswith('#'):
            seen += 1
            if seen > MAX_ROWS + 1:
                raise InputError(f'{source} line {lineno}: more than {MAX_ROWS} data rows; allowed: at most '
                                 f'{MAX_ROWS}')


def _read_table(text: str, source: str, spec: Columns = POSE_COLUMNS, progress: StageProgress | None = None
                ) -> _Table:
    """The header, the rows and the declared units of a measurement file's text."""
    if not isinstance(text, str):   # bytes raised a bare TypeError at the split
        raise InputError(f'{source}: the text given is a {type(text).__name__}; allowed: a str (bytes: decode '
                         "them first, e.g. data.decode('utf-8'))")
    table = _Table(spec)
    lines = text.split('\n')
    _check_row_count(lines, source)
    for lineno, raw in enumerate(lines, 1):
        if progress is not None and lineno % 2000 == 0:   # its share read, every 2,000 lines
            progress('reading rows', lineno / len(lines))
        where = f'{source} line {lineno}'
        if len(raw) > MAX_LINE_CHARS:
            raise InputError(f'{where}: {len(raw)} characters; allowed: at most {MAX_LINE_CHARS} per line')
        line = raw.strip()
        if not line:
            continue
        if line.startswith('#'):
            table.comment(line, where)
            continue
        try:
            fields = next(csv.reader([line]))
        except csv.Error as exc:
            raise InputError(f'{where}: not a CSV row ({exc})') from None
        table.row(fields, lineno, where)
    if table.cols is None:
        empty = 'the file is empty' if not text.strip() else 'no header row'
        raise InputError(f'{source}: {empty}; the first line that is not a comment must name the columns '
                         f'({",".join(spec.required)}){spec.also}')
    if not table.rows:
        raise InputError(f'{source}: no data rows after the header')
    if progress is not None:   # the end of the stage
        progress('reading rows', 1.0)
    return table


def parse_measurements(text: str, source: str = 'measurements', progress: StageProgress | None = None
                       ) -> Measurements:
    """Parse the text of a measurement file (format in the module docstring); ``source`` names it in messages,
    ``progress`` hears the share read (:func:`read_table`)."""
    table = read_table(text, source, progress=progress)
    col, line_nos = table.columns, table.lines
    quat = None
    if 'qw' in col:
        q = np.column_stack([col['qx'], col['qy'], col['qz'], col['qw']])
        norm = np.linalg.norm(q, axis=1)
        bad = np.flatnonzero(np.abs(norm - 1.0) > QUATERNION_NORM_TOLERANCE)
        if bad.size:
            i = int(bad[0])
            raise InputError(f'{source} line {line_nos[i]}, columns qx qy qz qw: quaternion norm {norm[i]:.9g}; a unit '
                             f'quaternion is required, |norm - 1| <= {QUATERNION_NORM_TOLERANCE:g}')
        quat = q / norm[:, None]
    return Measurements(source=source, q=np.column_stack([col['q1'], col['q2'], col['q3']]),
                        position=np.column_stack([col['x'], col['y'], col['z']]), quaternion=quat,
                        sigma_position=table.sigma('sigma_position', source),
                        sigma_angle=table.sigma('sigma_angle', source), lines=tuple(line_nos),
                        units=('mm' if table.scales['q1'] == units.MM else 'm', table.units[1]))


def read_measurements(path: str | Path, progress: StageProgress | None = None) -> Measurements:
    """Read and check a measurement file (format in the module docstring); ``progress`` hears the share read.

    Raises:
        InputError: the file cannot be read, is not a regular file, is too large, is not UTF-8, or any check of
            :func:`parse_measurements` fails; the message names the file, the line and the column.
    """
    return parse_measurements(read_text(path, 'measurement', MAX_FILE_BYTES), str(path), progress)


def format_measurements(m: Measurements, comments: tuple[str, ...] = ()) -> str:
    """Measurement-file text of ``m`` in SI units, every value at full precision (``repr``), sigma columns when
    ``m`` has them; ``comments`` become ``#`` lines at the top."""
    cols = list(REQUIRED_COLUMNS) + (list(ORIENTATION_COLUMNS) if m.quaternion is not None else [])
    parts = [m.q, m.position] + ([m.quaternion] if m.quaternion is not None else [])
    for name, val in (('sigma_position', m.sigma_position), ('sigma_angle', m.sigma_angle)):
        if val is not None:
            cols.append(name)
            parts.append(np.asarray(val)[:, None])
    data = np.hstack(parts)
    out = ['# units: m rad', ','.join(cols)] + [','.join(repr(float(v)) for v in row) for row in data]
    return comment_lines(comments) + '\n'.join(out) + '\n'


def write_measurements(path: str | Path, m: Measurements, comments: tuple[str, ...] = ()) -> Path:
    """Write ``m`` as a measurement file (:func:`format_measurements`), atomically."""
    return write_text(path, format_measurements(m, comments), 'measurement')
