"""Units of the columns of the package's CSV files: one rule for measurement files, station files and joint tables.

A column's unit is, in this order (docs/core.md, "Units in CSV files"):

1. its own, in brackets in the header: ``x [mm]``, ``tilt [deg]``;
2. else the file's, from a comment line before the header: ``# units: mm deg`` (one length unit and/or one
   angle unit, in any order);
3. else SI: metres and radians.

Length columns take ``m`` or ``mm``, angle columns ``rad`` or ``deg`` (empty brackets, ``q1 []``, are refused: they
read as metres, even under ``# units: mm``); a column of another kind (a name, a quaternion component) takes none.
Every value is converted to SI when read. A unit that is unknown or does not fit its column is a
:class:`~gpr_kinematics.errors.FileError` (a ConfigError and an InputError, as the file's readers raise) naming the
line and the column.

>>> column('x [mm]', 'line 1'), column(' tilt ', 'line 1')
(('x', 'mm'), ('tilt', None))
>>> file_units('# units: deg mm', 'line 1')
('mm', 'deg')
>>> scale('length', None, ('mm', None), 'line 2', 'x')
(0.001, 'mm')
>>> to_si(9.0, 0.001), 9.0 * 0.001, to_si(437.1, 0.001), 437.1 / 1000   # the metres typed for the same decimal
(0.009, 0.009000000000000001, 0.4371, 0.43710000000000004)
"""
from __future__ import annotations

import math
import re
from collections.abc import Sequence
from typing import TypeVar

import numpy as np
from numpy.typing import NDArray

from ..errors import FileError, brief

#: A length's or an angle's value: one, or an array of them.
Quantity = TypeVar('Quantity', float, NDArray[np.float64])

#: Millimetres in a metre: a length in mm is divided by it (:func:`to_si`).
MM_PER_M = 1000.0
#: The factor to SI of millimetres (the key of :data:`LENGTH_UNITS` :func:`to_si` divides by :data:`MM_PER_M`).
MM = 1e-3
LENGTH_UNITS = {'m': 1.0, 'mm': MM}
ANGLE_UNITS = {'rad': 1.0, 'deg': math.pi / 180.0}
#: Kinds of columns and the units each takes.
KINDS = {'length': LENGTH_UNITS, 'angle': ANGLE_UNITS, 'text': {}, 'number': {}}

_UNITS_LINE = re.compile(r'#\s*units\s*:(.*)$', re.IGNORECASE)
#: A comment that speaks of units (:func:`refuse_unit_words`).
_UNIT_WORD = re.compile(r'\bunits?\b', re.IGNORECASE)
_CELL = re.compile(r'^\s*([A-Za-z_][A-Za-z0-9_]*)\s*(?:\[\s*([A-Za-z]*)\s*\])?\s*$')

#: The file's units, ``(length, angle)``; ``None`` where it declares none.
FileUnits = tuple[str | None, str | None]


def _milli(value: float) -> float:
    """``value`` [mm] in metres: the number its shortest decimal text (``repr``, the text typed) names, its exponent
    less 3, so ``437.1`` mm is the double nearest 0.4371 m, as ``0.4371`` typed is (``437.1 / 1000`` is
    0.43710000000000004: a quarter of the one-decimal millimetres, and 9 * 1e-3 is 0.009000000000000001)."""
    if not math.isfinite(value):
        return value / MM_PER_M
    mantissa, _, exponent = repr(float(value)).partition('e')
    return float(f'{mantissa}e{int(exponent or 0) - 3}')


def to_si(value: Quantity, factor: float) -> Quantity:
    """``value`` in the unit whose factor to SI is ``factor`` (of :data:`LENGTH_UNITS` or :data:`ANGLE_UNITS`), in SI:
    millimetres as :func:`metres`, the others multiplied (degrees as :func:`math.radians` does)."""
    return metres(value, True) if factor == MM else value * factor


def metres(value: Quantity, mm: bool) -> Quantity:
    """A length typed in millimetres (``mm``, the option ``--mm``) or metres, in metres: the metres a person would
    have typed for the same decimal (:func:`_milli`; one or an array)."""
    if not mm:
        return value
    if isinstance(value, np.ndarray):
        flat = [_milli(v) for v in value.ravel().tolist()]
        return np.array(flat, dtype=np.float64).reshape(value.shape)
    return _milli(float(value))


def is_units_line(line: str) -> bool:
    """``line`` (stripped) is a ``# units:`` declaration."""
    return _UNITS_LINE.match(line) is not None


def refuse_unit_words(line: str, where: str) -> None:
    """Refuse a comment before the header that speaks of units in another form than ``# units:`` (``# unit: deg``,
    ``# units = deg``, ``# angle units: deg``): taken as a comment, its file's degrees were read as radians."""
    if _UNIT_WORD.search(line) is not None:
        raise FileError(f'{where}: {brief(line)} speaks of units but is not a "# units:" line, so they would be '
                        'ignored; allowed: "# units: mm deg" (one length unit and/or one angle unit), or a comment '
                        'that does not name units')


def file_units(line: str, where: str) -> FileUnits:
    """The ``(length, angle)`` units of a ``# units:`` line; :class:`InputError` for an unknown or repeated unit."""
    m = _UNITS_LINE.match(line.strip())
    if m is None:
        raise FileError(f'{where}: {brief(line)} is not a "# units:" line')
    length = angle = None
    for tok in re.split(r'[\s,]+', m.group(1).strip()):
        if not tok:
            continue
        unit = tok.lower()
        if unit in LENGTH_UNITS and length is None:
            length = unit
        elif unit in ANGLE_UNITS and angle is None:
            angle = unit
        else:
            raise FileError(f'{where}: unit {brief(tok, 20)} in "# units:" is unknown or repeated; allowed: one of '
                             'm, mm (lengths) and one of rad, deg (angles), e.g. "# units: mm deg"')
    if length is None and angle is None:   # a line meant to say something: SI was a guess
        raise FileError(f'{where}: "# units:" names no unit; allowed: one of m, mm (lengths) and/or one of rad, deg '
                        '(angles), e.g. "# units: mm deg", or no "# units:" line for m and rad')
    return length, angle


def separator_hint(cell: str) -> str:
    """For a header cell that is no column name: a hint where the row separates its columns by semicolons or tabs,
    as spreadsheets of many locales export CSV (else '').

    >>> separator_hint('name;x [mm]')
    ' (the columns are separated by semicolons: separate them by commas, and write numbers with a decimal point)'
    """
    for sep, name in ((';', 'semicolons'), ('\t', 'tabs')):
        if sep in cell:
            return f' (the columns are separated by {name}: separate them by commas, and write numbers with a ' \
                'decimal point)'
    return ''


def column(cell: str, where: str) -> tuple[str, str | None]:
    """A header cell's column name and its unit in brackets (``None`` without one)."""
    m = _CELL.match(cell)
    if m is None and not cell.strip():   # 'header column '' is not a name ...' for a trailing comma
        raise FileError(f'{where}: a header column without a name (a comma too many, at the end of the line?); '
                        'allowed: a name with an optional unit in brackets in every column, e.g. "x [mm]"')
    if m is None:
        raise FileError(f'{where}: header column {brief(cell, 40)} is not a name with an optional unit in brackets, '
                         f'e.g. "x [mm]"{separator_hint(cell)}')
    return m.group(1), (m.group(2).lower() if m.group(2) is not None else None)


def scale(kind: str, unit: str | None, defaults: FileUnits, where: str, name: str) -> tuple[float, str]:
    """The factor to SI and the unit of a column of ``kind`` (a key of :data:`KINDS`) with its own ``unit`` (or
    ``None``) in a file whose ``# units:`` line gave ``defaults``."""
    units = KINDS[kind]
    if not units:
        if unit is not None:
            raise FileError(f'{where}: column {name} takes no unit, got [{unit[:20]}]')
        return 1.0, ''
    if unit == '':   # q1 [] read as metres, even under "# units: mm"
        raise FileError(f'{where}: column {name}: the unit in brackets is empty; allowed: '
                        + ' or '.join(units) + f' ({"an" if kind[0] in "aeiou" else "a"} {kind}), or no brackets for '
                        'the file\'s units')
    if unit is None:
        unit = defaults[0] if kind == 'length' else defaults[1]
    unit = unit or ('m' if kind == 'length' else 'rad')
    if unit not in units:
        raise FileError(f'{where}: column {name}: unit [{unit[:20]}] is invalid; allowed: '
                         + ' or '.join(units) + f' ({"an" if kind[0] in "aeiou" else "a"} {kind})')
    return units[unit], unit


def as_typed(typed: float | Sequence[float], si: float | Sequence[float], unit: str, own: str) -> str:
    """A value or a point as typed (each its shortest decimal) in ``own`` (mm, deg), SI beside it: ``20 deg
    (0.349066 rad)``, ``(20000, 0, 0) mm ((20, 0, 0) m)``; ``0.5 rad`` when ``own`` is the SI ``unit``.

    >>> as_typed(20.0, math.radians(20.0), 'rad', 'deg'), as_typed([20000, 0, -1.5], [20, 0, -0.0015], 'm', 'mm')
    ('20 deg (0.349066 rad)', '(20000, 0, -1.5) mm ((20, 0, -0.0015) m)')
    """
    def shortest(v: float) -> str:
        return repr(float(v)).removesuffix('.0')

    shown = '(' + ', '.join(map(shortest, typed)) + ')' if isinstance(typed, Sequence) else shortest(typed)
    si_shown = '(' + ', '.join(f'{float(v):.6g}' for v in si) + ')' if isinstance(si, Sequence) else f'{si:.6g}'
    return f'{shown} {unit}' if own == unit else f'{shown} {own} ({si_shown} {unit})'


def both_units(lo: float, hi: float | None, unit: str, own: str) -> str:
    """An upper bound (``hi`` None) or a range ``lo`` to ``hi`` in the SI ``unit``, and in ``own`` when another,
    to 4 digits rounded inwards (every value shown is allowed: 5.73 deg was shown for 0.1 rad and refused):
    ``0.01 m (10 mm)``, ``1e-09 to 0.1 rad (5.73e-08 to 5.729 deg)``."""
    f = {**LENGTH_UNITS, **ANGLE_UNITS}.get(own, 1.0)
    si = f'{lo:g}' if hi is None else f'{lo:g} to {hi:g}'
    if own == unit:
        return f'{si} {unit}'
    shown = _inwards(lo / f, False) if hi is None else f'{_inwards(lo / f, True)} to {_inwards(hi / f, False)}'
    return f'{si} {unit} ({shown} {own})'


def _inwards(x: float, up: bool) -> str:
    """``x`` to 4 significant digits, rounded up (``up``: a lower bound) or down (an upper bound)."""
    text = f'{x:.4g}'
    if x != 0.0 and math.isfinite(x) and (float(text) < x if up else float(text) > x):
        step = 10.0 ** (math.floor(math.log10(abs(x))) - 3)
        text = f'{float(text) + (step if up else -step):.4g}'
    return text
