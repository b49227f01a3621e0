"""The field rules of the robot description (and of the files that reuse them): names, numbers in a range, vectors,
angles, mappings, each refused with the file, the key, the value and what is allowed."""
from __future__ import annotations

import math
import re
from collections.abc import Mapping, Sequence
from typing import Any

from ..core.messages import ROD_JOINT_NAMES
from ..errors import ConfigError, GprError, brief, kind_of
from ..inputs.schema import is_huge_number, number_key, orientation_angle
from ..inputs.validation import TURN, TURN_SLACK, WORLD_BOUND, radians_hint, text_hint

_NAME = re.compile(r'[A-Za-z][A-Za-z0-9_]{0,63}')
NAME_RULE = 'a name of letters, digits and _ starting with a letter, at most 64 characters'


def _where(source: str, path: str) -> str:
    return f'{source}: {path}' if path else source


def _number(data: Mapping[str, Any], key: str, where: str, lo: float, hi: float, allowed: str,
            default: float | None = None, unit: str = 'm') -> float:
    raw = data.get(key, default)
    # beyond every number's bound, or not finite: the key's own range (a friction of .inf was told "a finite number
    # in ", the unit of a coefficient empty)
    if is_huge_number(raw) or (isinstance(raw, float) and not math.isfinite(raw)):
        raise ConfigError(f'{where}: {key} = {brief(raw)} is invalid; allowed: {allowed}')
    value = number_key(data, key, where, default=default, positive=False, unit=unit)
    if not lo <= value <= hi:
        raise ConfigError(f'{where}: {key} = {brief(value)} is invalid; allowed: {allowed}')
    return value


def check_world_position(xyz: Sequence[float], label: str, mm_hint: str = '',
                         error: type[GprError] = ConfigError, typed: str | None = None) -> None:
    """Refuse a station's position ``xyz`` [m] with a coordinate beyond :data:`WORLD_BOUND` (``error`` naming
    ``label``), for the station files, ``gpr robot ik`` and the station service alike; ``mm_hint`` (``{mm}``: the
    farthest coordinate as millimetres [m]) is added where the numbers fit the world as millimetres; ``typed``: the
    position as its user typed it, with its unit (``(1300, 600, 450000) mm ((1.3, 0.6, 450) m)``)."""
    far = max(abs(float(v)) for v in xyz)
    if far > WORLD_BOUND:
        hint = mm_hint.format(mm=f'{far / 1000.0:g}') if far / 1000.0 <= WORLD_BOUND else ''
        shown = f'({", ".join(f"{float(v):.6g}" for v in xyz)}) m' if typed is None else typed
        raise error(f'{label} = {shown}; allowed: each coordinate within '
                    f'+-{WORLD_BOUND:g} m of the world origin{hint}')


#: The least value of a quantity that must be positive (a body's size [m], a mass [kg], a speed, acceleration or jerk
#: limit): 0 is refused and so is 5e-324, which overflows what divides by it.
LEAST = 1e-6


def _positive_number(data: Mapping[str, Any], key: str, where: str, hi: float, unit: str, words: str,
                     default: float | None = None, note: str = '') -> float:
    """``data[key]`` within ``[LEAST, hi]`` in ``unit``; the message's range is these bounds (``words`` name the
    unit, ``note`` follows them)."""
    return _number(data, key, where, LEAST, hi, f'{words}, {LEAST:g} <= {key} <= {hi:g}{note}', default, unit)


def _vector(data: Mapping[str, Any], key: str, where: str, n: int, bound: float, unit: str = 'm',
            default: Sequence[float] | None = None, lowest: float | None = None) -> tuple[float, ...]:
    """A list of ``n`` finite numbers within ``[-bound, bound]`` (``[lowest, bound]`` where given)."""
    raw = data.get(key, default)
    low = -bound if lowest is None else lowest
    allowed = f'a list of {n} finite numbers in {unit}, each within [{low:g}, {bound:g}]'
    if not isinstance(raw, (list, tuple)) or len(raw) != n:
        raise ConfigError(f'{where}: {key} = {brief(raw)} is invalid; allowed: {allowed}')
    out = []
    for i, v in enumerate(raw):
        out.append(_number({f'{key}[{i}]': v}, f'{key}[{i}]', where, low, bound, allowed, unit=unit))
    return tuple(out)


def _xyz(data: Mapping[str, Any], key: str, where: str, bound: float, default: Sequence[float] | None = None
         ) -> tuple[float, float, float]:
    x, y, z = _vector(data, key, where, 3, bound, default=default)
    return x, y, z


def _rpy(data: Mapping[str, Any], where: str) -> tuple[float, float, float]:
    """URDF ``rpy`` [rad], each an orientation angle within one turn (robot descriptions are in radians only)."""
    raw = data.get('rpy', (0.0, 0.0, 0.0))
    if not isinstance(raw, (list, tuple)) or len(raw) != 3:
        raise ConfigError(f'{where}: rpy = {brief(raw)} is invalid; allowed: a list of 3 finite numbers in rad, each '
                          'within [-2pi, 2pi]')
    r, p, y = (orientation_angle(v, f'rpy[{i}]', where) for i, v in enumerate(raw))
    return r, p, y


def _name(data: Mapping[str, Any], key: str, where: str, default: str | None = None) -> str:
    value = data.get(key, default)
    if not isinstance(value, str) or not _NAME.fullmatch(value):
        raise ConfigError(f'{where}: {key} = {brief(value)} is invalid{text_hint(value)}; allowed: {NAME_RULE}')
    return value


def _named(data: Mapping[str, Any], where: str) -> str:
    """``where`` with the mapping's ``name`` when it is a valid one: its keys' refusal names it before it is read."""
    value = data.get('name')
    return f'{where} ({value})' if isinstance(value, str) and _NAME.fullmatch(value) else where


def _mapping(value: Any, where: str, what: str) -> Mapping[str, Any]:
    if not isinstance(value, Mapping):
        raise ConfigError(f'{where}: expected a mapping ({what}), got {kind_of(value)}')
    return value


def _yaw(data: Mapping[str, Any], where: str) -> float:
    """A frame's ``yaw`` [rad] (default 0), an orientation angle within one turn (in radians only)."""
    return orientation_angle(data.get('yaw', 0.0), 'yaw', where)


def _angle(data: Mapping[str, Any], key: str, where: str, default: float | None = None) -> float:
    most = TURN + TURN_SLACK   # the one rule of a turn (beyond_turn): typed, in files and requests alike
    try:
        return _number(data, key, where, -most, most, 'radians within [-2pi, 2pi]', default, 'rad')
    except ConfigError as exc:   # a joint limit in degrees, named so as the mount's yaw and the base's rpy are
        raw = data.get(key)
        if isinstance(raw, (int, float)) and not isinstance(raw, bool) and most < abs(raw) <= 720.0:
            raise ConfigError(f'{exc}{radians_hint(float(raw))}') from None
        raise


def check_names(rods: Sequence[str], joints: Sequence[str], arms: Sequence[str], source: str) -> None:
    """Refuse a robot description's names that repeat across its rods, arm ``joints`` and ``arms``, and names that
    clash with the rods' joint names on ``joint_states`` and in trajectories, ``rod_1 .. rod_3``
    (:data:`~gpr_kinematics.core.messages.ROD_JOINT_NAMES`): an arm joint named ``rod_1`` made a trajectory name
    ``rod_1`` twice, rods named ``[rod_2, rod_1, rod_3]`` a table's ``rod_2`` column hold ``q1``."""
    names = [*rods, *joints, *arms]
    duplicates = sorted({n for n in names if names.count(n) > 1})
    if duplicates:
        raise ConfigError(f'{source}: names must be unique across rods, arms and joints; repeated: '
                          + ', '.join(duplicates))
    taken = [n for n in joints if n in ROD_JOINT_NAMES]
    if taken:
        raise ConfigError(f'{source}: arm joint name(s) {", ".join(taken)} are the rods\' joint names on joint_states '
                          f'and in trajectories; allowed: other names than {", ".join(ROD_JOINT_NAMES)}')
    for k, n in enumerate(rods):
        if n in ROD_JOINT_NAMES and n != ROD_JOINT_NAMES[k]:
            raise ConfigError(f'{source}: rods: names[{k}] = {n!r} is rod {ROD_JOINT_NAMES.index(n) + 1}\'s joint name '
                              f'on joint_states and in trajectories; allowed: {ROD_JOINT_NAMES[k]!r} for rod {k + 1}, '
                              f'or a name other than {", ".join(ROD_JOINT_NAMES)}')


#: A station this close to the world's origin [m] that no arm reaches: metres given as millimetres (a station file
#: in mm with metres in it put pm4 at (0.45, 0.5, 0.65) mm; blamed on the heights alone).
NEAR_THE_ORIGIN = 0.01
#: The end of :func:`unit_hint`'s hint to a station near the origin, and the pattern of the whole hint at the end of a
#: message (a command that says it its own way takes it off: :func:`without_origin_hint`).
METRES_AS_MM = ': metres given as millimetres?'
_ORIGIN_HINT = re.compile(r"; the station lies [^;]* mm from the world's origin" + re.escape(METRES_AS_MM) + '$')


def without_origin_hint(message: str) -> str:
    """``message`` without :func:`unit_hint`'s hint of metres given as millimetres at its end."""
    return _ORIGIN_HINT.sub('', message)


def unit_hint(from_base: float, from_origin: float) -> str:
    """The hint to a station no arm reaches by its distances [m] from ``gpr_base`` and the world's origin: beyond
    :data:`WORLD_BOUND` but in reach as millimetres, millimetres given as metres; within :data:`NEAR_THE_ORIGIN` of
    the origin, metres given as millimetres; else ''."""
    if from_base > WORLD_BOUND and from_base / 1000.0 < 10.0:   # a position in mm typed as m: 1.5 km from the base
        return (f'; the station lies {from_base:.4g} m from gpr_base, {from_base / 1000.0:.4g} m as millimetres: '
                'millimetres given as metres?')
    if from_origin < NEAR_THE_ORIGIN:
        return f'; the station lies {from_origin * 1000.0:.4g} mm from the world\'s origin{METRES_AS_MM}'
    return ''

