"""The rules every file format of the package reads its YAML with: known keys only, numbers by one rule.

Each format (the GPR geometry, robots, programs, stations, mechanisms, tolerances, workspaces, cells) checks its
mapping with :func:`check_keys` and reads its numbers with :func:`number_key` / :func:`is_number` /
:func:`number_array`; a file is parsed by :func:`read_yaml` (:mod:`gpr_kinematics.inputs.safe_yaml`'s bounds).
Every failure is a :class:`~gpr_kinematics.errors.ConfigError` naming the file, the key, the value and what is
allowed.
"""
from __future__ import annotations

import math
from collections.abc import Iterable, Mapping
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from ..errors import ConfigError, apart, brief
from . import safe_yaml
from .safe_yaml import YamlValue
from .units import ANGLE_UNITS
from .validation import MAX_COORDINATE, TURN, beyond_turn, radians_hint


def is_number(value: YamlValue) -> bool:
    """The one rule for a number read from YAML: an int or a float (not a bool, not a string), finite and within
    +-:data:`~gpr_kinematics.inputs.validation.MAX_COORDINATE` (1e6: no value of the package's files is larger, and
    products of a few of them cannot overflow)."""
    # abs() before isfinite(): an integer of 400 digits has no float (isfinite would raise OverflowError). numpy's
    # real scalars count as their Python kinds (a config built in code: replace(radius=np.float32(0.1))).
    if isinstance(value, (np.integer, np.floating)) and not isinstance(value, np.bool_):
        value = value.item()
    return (not isinstance(value, bool) and isinstance(value, (int, float)) and abs(value) <= MAX_COORDINATE
            and math.isfinite(value))


def is_huge_number(value: YamlValue) -> bool:
    """A number (an int, or a finite float; not a bool) beyond :func:`is_number`'s bound: refused as that number,
    with the range of its key where the caller knows one."""
    return (not isinstance(value, bool) and isinstance(value, (int, float)) and abs(value) > MAX_COORDINATE
            and (isinstance(value, int) or math.isfinite(value)))


def is_version(value: YamlValue, versions: Iterable[int]) -> bool:
    """``value`` is one of a format's ``versions``: an int, not a bool or a float (``true`` and ``1.0`` equal 1 in
    Python)."""
    return type(value) is int and value in tuple(versions)


def number_array(value: YamlValue, shape: tuple[int, ...]) -> NDArray[np.float64] | None:
    """``value``, nested lists of numbers of ``shape`` each passing :func:`is_number`, as a float array; ``None``
    when it is anything else (the caller names the key and what is allowed)."""
    if len(shape) == 0:
        return np.asarray(float(value)) if is_number(value) else None
    if not isinstance(value, (list, tuple)) or len(value) != shape[0]:
        return None
    rows = [number_array(v, shape[1:]) for v in value]
    if any(r is None for r in rows):
        return None
    return np.array(rows, dtype=float).reshape(shape)


def check_keys(data: Mapping[YamlValue, YamlValue], allowed: Iterable[str], where: str) -> None:
    """Refuse keys of a YAML mapping outside ``allowed``: :class:`ConfigError` names them (those that are names:
    :func:`~gpr_kinematics.inputs.safe_yaml.quoted_key`; the others are only counted, so a file that is not of the
    package's formats is not repeated in the message) and the allowed ones."""
    allowed = set(allowed)
    unknown = [k for k in data if k not in allowed]
    if unknown:
        names = sorted(brief(k, 40).strip("'") for k in unknown if safe_yaml.is_name(k))
        parts = names[:8]
        if len(names) > 8:
            parts[-1] += f' and {len(names) - 8} more'
        others = len(unknown) - len(names)
        if others:
            parts.append(f'{others} that {"is" if others == 1 else "are"} not a name (not quoted)')
        raise ConfigError(f'{where}: unknown key(s) {", ".join(parts)}; allowed keys: ' + ', '.join(sorted(allowed)))


def number_key(data: Mapping[YamlValue, YamlValue], key: str, source: str, default: float | None = None,
               positive: bool = True, unit: str = 'm') -> float:
    """A finite number (not a bool, not a string) under ``key`` of a YAML mapping, positive unless
    ``positive=False``; ``default`` when absent; else :class:`ConfigError` naming file, key and value.

    Every YAML loader of the package reads its numbers with this rule (:func:`is_number`).
    """
    val = data.get(key, default)
    what = f'{"positive " if positive else ""}finite {"length" if unit == "m" else "number"} in {unit}'
    if val is None:
        raise ConfigError(f'{source}: missing key {key} (a {what})')
    if not is_number(val) or (positive and val <= 0):
        if is_huge_number(val):   # finite, but beyond the bound of every number
            what += f' of magnitude at most {MAX_COORDINATE:g}'
        raise ConfigError(f'{source}: {key} must be a {what}; got {brief(val)}')
    return float(val)


def orientation_angle(value: YamlValue, key: str, where: str, unit: str = 'rad', declare: str | None = None) -> float:
    """An orientation angle of a file (a heading, an azimuth, a yaw, an rpy angle) in radians: ``value`` a number
    (:func:`is_number`) in the file's angle ``unit`` (``rad`` or ``deg``) of magnitude at most one turn,
    :data:`~gpr_kinematics.inputs.validation.TURN` (+ :data:`~gpr_kinematics.inputs.validation.TURN_SLACK`) rad or
    360 deg. Beyond it the value is degrees written in a file in radians (``heading: 90`` is 14.3 turns, taken modulo
    2 pi as 2.04 rad): :class:`ConfigError` naming ``where``, the key, the value and how the file declares degrees
    (``declare``, e.g. ``'units: {angle: deg}'``; ``None`` for a format in radians only). The one check of them."""
    scale = ANGLE_UNITS[unit]
    most = '[-360, 360] deg' if unit == 'deg' else '[-2pi, 2pi] rad'
    if not is_number(value):
        raise ConfigError(f'{where}: {key} = {brief(value)} is invalid; allowed: a finite angle in {unit} within one '
                          f'turn, {most}')
    angle = float(value) * scale
    if beyond_turn(angle):
        if unit == 'deg':
            hint = ''
        elif declare is not None:
            hint = f' (degrees? a file in degrees declares them: {declare})'
        else:
            hint = radians_hint(float(value))
        shown = apart(abs(float(value)), 360.0 if unit == 'deg' else TURN)[0]   # 360.0000001 read 360
        raise ConfigError(f'{where}: {key} = {"-" if value < 0 else ""}{shown} {unit} is beyond one turn; allowed: '
                          f'{most}{hint}')
    return angle


def read_yaml(path: str | Path, what: str = 'config') -> YamlValue:
    """Parse a YAML file with the package's bounds (:func:`gpr_kinematics.inputs.safe_yaml.read_file`: no aliases,
    bounded nesting and size, UTF-8, regular files only); any problem raises :class:`ConfigError` naming the file
    (``what`` says which kind of file it is in the message: config, program, mechanism)."""
    return safe_yaml.read_file(path, what)
