"""Checks of user input shared by the core, the CLI and the ROS nodes.

Each raises :class:`~gpr_kinematics.errors.InputError` with a message naming the field, its value and what
is allowed, so a caller (CLI: exit 2; node: ``success: false``) can pass it on as is.
"""
from __future__ import annotations

import math
import re
from collections.abc import Iterable, Sequence, Sized
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..errors import InputError, apart, brief
from .safe_yaml import DECIMAL

#: Largest accepted deviation of a quaternion's norm from 1 (messages and commands carry unit quaternions).
QUATERNION_NORM_TOLERANCE = 1e-6
#: Largest magnitude of a position coordinate [m], a joint value [m, rad] or a geometric parameter [m] of the
#: mechanisms and stations the package accepts: far beyond any of them, and small enough that no product of a few
#: of them overflows.
MAX_COORDINATE = 1e6
#: The largest coordinate [m] of a place in the world: the robot's base, a station, a cell's obstacle, a registered
#: base in a tracker's frame (a cell is a few metres; 2300 m is a station in millimetres read as metres).
WORLD_BOUND = 100.0
#: One turn [rad]: the most an orientation angle (a heading, an azimuth, a yaw, an rpy angle) of a file or of the
#: command line may be; beyond it the value is degrees written as radians (``heading: 90``: 14.3 turns) almost surely.
TURN = 2.0 * math.pi
#: How far a file's orientation angle may pass :data:`TURN` [rad]: a turn written to more digits than a double keeps.
TURN_SLACK = 1e-9
#: What a number that is NaN or infinite should have been.
FINITE = 'finite values in SI units'


#: A decimal number as text: YAML 1.2's forms (:data:`~gpr_kinematics.inputs.safe_yaml.DECIMAL`), one way to read each
#: text (``[0-9]+\.?[0-9]*`` split a run of n digits n ways: a parameter text of 30,000 digits and an ``x`` took 22 s).
_DECIMAL = re.compile(DECIMAL)
#: The words of the numbers that are not finite, which CSV readers take and then refuse as not finite.
_NOT_FINITE = re.compile(r'[-+]?(?:inf|infinity|nan)', re.IGNORECASE)
#: A number written with a decimal comma (``1200,5``): :func:`number_hint`.
_DECIMAL_COMMA = re.compile(r'[-+]?[0-9]*,[0-9]+(?:[eE][-+]?[0-9]+)?')
#: Longest text read as a number (a double has 17 significant digits; ``-1.2345678901234567e-308`` has 25 characters).
MAX_NUMBER_TEXT = 64


def decimal(text: str) -> float:
    """The number a CSV field ``text`` writes (blanks around it allowed): ``float(text)`` for the forms of
    :data:`_DECIMAL` and the words inf and nan, else ValueError. Python's float also reads ``1_0`` as 10 and the
    digits of other scripts (``\u0661`` as 1, fullwidth ``\uff15`` as 5), which YAML files of the package refuse as
    text.

    >>> decimal(' -2.5e-3 '), decimal('.5')
    (-0.0025, 0.5)
    """
    bare = text.strip(' \t\r\n')
    if not (_DECIMAL.fullmatch(bare) or _NOT_FINITE.fullmatch(bare)):
        raise ValueError(f'not a decimal number: {brief(text)}')
    return float(bare)


def number_hint(text: str) -> str:
    """For a text that is no number: how to write it where it is one with a decimal comma, as spreadsheets of many
    locales export numbers (else '').

    >>> number_hint(' 1200,5 '), number_hint('12a')
    (' (a decimal comma: write a decimal point, 1200.5)', '')
    """
    bare = text.strip(' \t\r\n')
    if len(bare) <= MAX_NUMBER_TEXT and _DECIMAL_COMMA.fullmatch(bare):
        return f' (a decimal comma: write a decimal point, {bare.replace(",", ".")})'
    return ''


def decimal_number(text: str) -> float | None:
    """The float of ``text`` (a parameter's text, as ``ros2 param set x 1e-13`` sends it) when it is a decimal number
    of :data:`_DECIMAL` (blanks around it allowed) of at most :data:`MAX_NUMBER_TEXT` characters, else None
    (``'nan'``, ``'inf'`` and ``'1e'`` are no decimal numbers)."""
    if len(text) > MAX_NUMBER_TEXT or _DECIMAL.fullmatch(text.strip()) is None:
        return None
    return float(text)


def switch(value: Any, name: str) -> bool:
    """``value`` where it is a truth value (Python's or numpy's), else :class:`InputError` naming it: the string
    ``'False'`` is true, and 0 or None turned a check off without a word.

    >>> switch(np.bool_(True), 'check_limits')
    True
    """
    if value is True or value is False or isinstance(value, np.bool_):
        return bool(value)
    raise InputError(f'{name} = {brief(value)}; allowed: True or False')


def text_hint(value: Any) -> str:
    """For a name that a YAML file gave as something else than text: how to keep it as written (else '').

    >>> text_hint(False)
    ' (YAML reads true and false as booleans: quote the name)'
    """
    if isinstance(value, bool):
        return ' (YAML reads true and false as booleans: quote the name)'
    if isinstance(value, (int, float)):
        return ' (YAML read it as a number: quote the name to keep it as written)'
    return ''


def plain_number(value: Any) -> float:
    """``value`` as a float where it is a Python or numpy int or float (a bool is not; an int too large for a float
    is infinite, of its sign; a 0-d array of one counts as it), else NaN: for range checks that name the value as
    given."""
    if isinstance(value, np.ndarray) and value.ndim == 0 and value.dtype.kind in 'iuf':   # np.array(100.0)
        value = value[()]
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, float, np.integer, np.floating)):
        return math.nan
    try:
        return float(value)
    except OverflowError:   # an int beyond a float's range
        return math.inf if value > 0 else -math.inf


def count_of(values: Any) -> int:
    """How many values a sized sequence holds (1 for anything else), read before it is converted: so a bound on the
    count refuses ``range(10**12)`` instead of allocating it."""
    if isinstance(values, np.ndarray) and values.ndim == 0:   # a 0-d array: one value (len() raises)
        return 1
    return len(values) if isinstance(values, Sized) and not isinstance(values, (str, bytes)) else 1


def random_seed(value: Any, name: str = 'seed') -> int:
    """A seed of ``numpy.random.default_rng``: an integer from 0 to 2**63 - 1; else :class:`InputError`."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, np.integer)) or not 0 <= value < 2 ** 63:
        raise InputError(f'{name} = {brief(value)} is invalid; allowed: an integer from 0 to 2**63 - 1')
    return int(value)


def _is_text(value: Any) -> bool:
    return isinstance(value, (str, bytes))   # numpy's str_ and bytes_ too


def _float(value: Any) -> float:
    """``float(value)``, but text (``'0.5'``) is a TypeError."""
    if type(value) is float:
        return value
    if _is_text(value) or isinstance(value, (bool, np.bool_)):
        raise TypeError('text or a truth value')
    return float(value)


def _holds_truth_value(values: list[Any] | tuple[Any, ...]) -> bool:
    """Whether nested lists or tuples hold a truth value (``bool``, numpy's too) among their items."""
    return any(isinstance(v, (bool, np.bool_)) or isinstance(v, (list, tuple)) and _holds_truth_value(v)
               for v in values)


def float_array(values: Any, name: str, expected: str = 'numbers') -> NDArray[np.float64]:
    """``values`` as a float array of its own shape, NaN and infinity kept; text (numpy reads ``'0.5'`` as 0.5), None
    (numpy reads it as NaN), complex numbers (an array of them numpy casts to its real parts) and what numpy cannot
    convert (ragged lists, an int of 400 digits: OverflowError) are an :class:`InputError` saying ``name`` must be
    ``expected`` and quoting the value. The one conversion of numbers a user gives."""
    if isinstance(values, np.ma.MaskedArray) and np.ma.is_masked(values):   # asarray would take the hidden values
        raise InputError(f'{name} must be {expected}, got a masked array with masked values ({brief(values)}); '
                         'allowed: numbers (fill or drop the masked ones first)')
    try:
        raw = np.asarray(values)
        if raw.dtype.kind in 'SUcb' or (raw.dtype.kind == 'O' and any(
                v is None or _is_text(v) or isinstance(v, (bool, np.bool_)) for v in raw.ravel())):
            # numpy casts complex numbers to their real parts, None to NaN (told as "nan is not a finite number")
            raise TypeError('text, truth values, None or complex numbers')
        if isinstance(values, (list, tuple)) and raw.dtype.kind in 'fiu' and _holds_truth_value(values):
            raise TypeError('a truth value among numbers')   # [0.0, 0.0, False]: numpy made it floats, False 0 m
        return np.asarray(raw, dtype=float)
    except (TypeError, ValueError, OverflowError):
        raise InputError(f'{name} must be {expected}, got {brief(values)}') from None


def finite_number(value: Any, name: str) -> float:
    """``value`` as a finite float (not text: ``float('0.5')`` is 0.5); else :class:`InputError` naming ``name``."""
    try:
        v = _float(value)
    except (TypeError, ValueError, OverflowError):  # OverflowError: an int of 400 digits
        raise InputError(f'{name} must be a number, got {brief(value)}') from None
    if not np.isfinite(v):
        raise InputError(f'{name} = {v} is not a finite number; allowed: finite values in SI units')
    return v


def beyond_turn(angle: float) -> bool:
    """An orientation angle [rad] beyond one turn, :data:`TURN` (+ :data:`TURN_SLACK`): degrees given as radians,
    almost surely (``azimuth: 90`` is 14.3 turns). The rule of the files' and the requests' angles."""
    return abs(angle) > TURN + TURN_SLACK


def radians_hint(value: float) -> str:
    """What ``value`` given in degrees would be in radians, for a refusal where only radians are taken."""
    return f' (radians only here: {value:g} deg is {math.radians(value):.9g} rad)'


def within_turn(value: Any, name: str) -> float:
    """An orientation angle of a request (a heading, an azimuth) [rad]: a finite number not :func:`beyond_turn`, as
    the files' (:func:`~gpr_kinematics.inputs.schema.orientation_angle`); else :class:`InputError` naming it."""
    v = finite_number(value, name)
    if beyond_turn(v):
        shown = apart(abs(v), TURN)[0]
        raise InputError(f'{name} = {"-" if v < 0 else ""}{shown} rad is beyond one turn; allowed: [-2pi, 2pi] rad'
                         f'{radians_hint(v)}')
    return v


def finite_vector(values: Any, name: str, size: int) -> NDArray[np.float64]:
    """``values`` as a float array of shape ``(size,)``, all finite; else :class:`InputError`."""
    a = float_array(values, name, f'{size} numbers')
    if a.shape != (size,):
        raise InputError(f'{name} must be {size} numbers, got shape {a.shape}')
    bad = ~np.isfinite(a)
    if bad.any():
        i = int(np.argmax(bad))
        raise InputError(f'{name} = {a.tolist()} contains NaN or infinity: {element(name, i)} = {a[i]} is not a '
                         'finite number; allowed: finite values in SI units')
    return a


def element(name: str, j: int) -> str:
    """How a message names value ``j`` of ``name``: ``q2`` for rod 2 and ``dq2`` for its change (numbered 1..3, like
    the paper's ``q1..q3``; ``dq[0]`` read beside ``q1 + dq1``), else ``name[j]``."""
    return f'{name}{j + 1}' if name in ('q', 'dq') else f'{name}[{j}]'


def unit_quaternion(values: Any, name: str) -> NDArray[np.float64]:
    """A quaternion (x, y, z, w), finite and of unit norm within :data:`QUATERNION_NORM_TOLERANCE`;
    returned normalised."""
    a = finite_vector(values, name, 4)
    norm = float(np.linalg.norm(a))
    if abs(norm - 1.0) > QUATERNION_NORM_TOLERANCE:
        raise InputError(f'{name} = ({a[0]:.9g}, {a[1]:.9g}, {a[2]:.9g}, {a[3]:.9g}) has norm {norm:.9g}; '
                         f'a unit quaternion (x, y, z, w) is required, |norm - 1| <= {QUATERNION_NORM_TOLERANCE:g}')
    return a / norm


def rotation_matrices(values: Any, name: str, tolerance: float = 1e-9) -> NDArray[np.float64]:
    """``values`` as rotation matrices ``(N, 3, 3)`` (one ``(3, 3)`` becomes ``(1, 3, 3)``): finite, orthonormal
    within ``tolerance`` (``max |R R^T - I|``) and of determinant +1 (not a mirror image); else :class:`InputError`
    naming the first matrix that is not."""
    R = float_array(values, name, 'rotation matrices (3 x 3 numbers each)')
    if R.ndim == 2:
        R = R[None]
    if R.ndim != 3 or R.shape[1:] != (3, 3):
        raise InputError(f'{name} must be rotation matrices, shape (3, 3) or (N, 3, 3); got shape {np.shape(values)}')
    with np.errstate(all='ignore'):
        error = np.max(np.abs(R @ np.swapaxes(R, 1, 2) - np.eye(3)), axis=(1, 2), initial=0.0)
        bad = ~np.all(np.isfinite(R), axis=(1, 2)) | ~(error <= tolerance) | ~(np.linalg.det(R) > 0.0)
    if bad.any():
        i = int(np.argmax(bad))
        where = f'{name}[{i}]' if R.shape[0] > 1 else name
        raise InputError(f'{where} = {brief(R[i].tolist())} is not a rotation matrix; allowed: finite, orthonormal '
                         f'(|R R^T - I| <= {tolerance:g}) with determinant +1 (not a mirror image)')
    return R


def number_rows(values: Any, name: str, width: int) -> NDArray[np.float64]:
    """``values`` as a float array ``(N, width)`` (one row given as ``(width,)`` becomes ``(1, width)``), NaN and
    infinity kept; else :class:`InputError` naming ``name`` (strings, complex numbers, a 400-digit int, the shape)."""
    a = float_array(values, name)
    if a.ndim == 1:
        a = a[None, :]
    if a.ndim != 2 or a.shape[1] != width:
        raise InputError(f'{name} must have {width} values per sample (shape (N, {width})), '
                         f'got shape {np.shape(values)}')
    return a


def rows_of(values: Any, name: str, width: int, names: Sequence[str] | None = None) -> NDArray[np.float64]:
    """``values`` as a float array ``(N, width)`` (one row given as ``(width,)`` becomes ``(1, width)``), all
    finite; else :class:`InputError` naming the value (by ``names`` when given, e.g. a robot's joint names;
    ``q2`` for rod 2, like the paper's ``q1..q3``) and, in a batch, the sample."""
    a = number_rows(values, name, width)
    bad = ~np.isfinite(a)
    if bad.any():
        i, j = np.argwhere(bad)[0]
        label = names[j] if names else element(name, int(j))
        where = f' (sample {i})' if a.shape[0] > 1 else ''
        raise InputError(f'{label} = {a[i, j]}{where} is not a finite number; allowed: {FINITE}')
    return a


def column_of(values: Any, name: str) -> NDArray[np.float64]:
    """A scalar or a 1-D sequence as a finite float array ``(N,)``; else :class:`InputError` naming ``name``."""
    a = np.atleast_1d(float_array(values, name, 'a number or an array of numbers'))
    if a.ndim != 1:
        raise InputError(f'{name} must be a scalar or a 1-D array, got shape {a.shape}')
    bad = ~np.isfinite(a)
    if bad.any():
        i = int(np.argmax(bad))
        where = f'{name}[{i}]' if np.ndim(values) else name   # one value given: no index ("height[0] = nan")
        raise InputError(f'{where} = {a[i]} is not a finite number; allowed: {FINITE}')
    return a


def three_floats(values: Any, name: str) -> list[float]:
    """Three finite floats from a sequence (fast for a list, tuple or array of 3), with the messages of
    :func:`rows_of`."""
    if isinstance(values, np.ndarray) and values.shape == (3,) and values.dtype.kind in 'fiu' and \
            not np.ma.is_masked(values):   # a masked value's tolist() is None: float_array names the masked array
        values = values.tolist()
    if isinstance(values, (list, tuple)) and len(values) == 3:
        try:
            out = [_float(v) for v in values]
        except (TypeError, ValueError, OverflowError):  # OverflowError: an int of 400 digits
            out = []
        if out and all(math.isfinite(v) for v in out):
            return out
    a = float_array(values, name)
    if a.shape not in ((3,), (1, 3)):   # [0.5, 0.5] was told 'must have 3 values per sample (shape (N, 3))'
        raise InputError(f'{name} must be 3 values, got shape {a.shape}')
    return [float(v) for v in rows_of(a, name, 3)[0]]


def single_number(value: Any, name: str) -> float:
    """One finite number (not an array); else :class:`InputError` naming ``name``."""
    if type(value) is float and math.isfinite(value):  # the common case, without numpy
        return value
    if np.ndim(value) != 0:
        raise InputError(f'{name} must be a single number, got shape {np.shape(value)}')
    return float(column_of(value, name)[0])


def empty_beside_one(values: Sequence[Any]) -> None:
    """ValueError where one of the batch arguments ``values`` is an empty array and another a non-empty one: numpy
    stretches a length-1 array over no target at all (``inverse_batch([0.5], [], [0.0])`` answered nothing); a
    scalar (or None) stretches over an empty batch as over any."""
    lengths = [len(v) for v in values if v is not None and np.ndim(v) > 0]
    if 0 in lengths and max(lengths) > 0:
        raise ValueError('an empty argument beside a non-empty one')


def bounded(values: Any, name: str, shape: tuple[int, ...] | None = None) -> NDArray[np.float64]:
    """``values`` as a float array (of ``shape``), finite and within +-:data:`MAX_COORDINATE`; else
    :class:`InputError` naming ``name``."""
    arr = float_array(values, name)
    if shape is not None and arr.shape != shape:
        raise InputError(f'{name} must have shape {shape}; got {arr.shape}')
    if not np.all(np.isfinite(arr)) or (arr.size and np.max(np.abs(arr)) > MAX_COORDINATE):
        raise InputError(f'{name} = {brief(arr.tolist())}; allowed: finite values within +-{MAX_COORDINATE:g} (SI)')
    return arr


#: Most Newton iterations a caller may ask of a mechanism's forward kinematics (:mod:`gpr_kinematics.mechanisms.base`);
#: the finest tolerance [m or rad].
MAX_NEWTON_ITERATIONS = 1000
MIN_NEWTON_TOLERANCE = 1e-15


def newton_settings(name: str, tol: Any, max_iterations: Any) -> tuple[float, int]:
    """A forward-kinematics tolerance in [:data:`MIN_NEWTON_TOLERANCE`, 1] (m or rad) and an iteration count in
    1 .. :data:`MAX_NEWTON_ITERATIONS`; else :class:`InputError` (1e9 iterations at a zero tolerance never end)."""
    if not MIN_NEWTON_TOLERANCE <= plain_number(tol) <= 1.0:
        raise InputError(f'{name}: tol = {brief(tol)} is invalid; allowed: a number from {MIN_NEWTON_TOLERANCE:g} to 1 '
                         '(m or rad)')
    if not isinstance(max_iterations, (int, np.integer)) or not 1 <= plain_number(max_iterations) <= \
            MAX_NEWTON_ITERATIONS:
        raise InputError(f'{name}: max_iterations = {brief(max_iterations)} is invalid; allowed: an integer from 1 to '
                         f'{MAX_NEWTON_ITERATIONS}')
    return float(tol), int(max_iterations)


def difference_step(name: str, step: Any) -> float:
    """A central-difference step in (0, 0.01] (the parameter's SI unit); else :class:`InputError` (a zero step
    divides by zero)."""
    if not 0.0 < plain_number(step) <= 0.01:
        raise InputError(f'{name}: step = {brief(step)} is invalid; allowed: a number > 0 and at most 0.01 (SI units)')
    return float(step)


def closest_names(names: Iterable[str], given: Any) -> list[str]:
    """Up to three of ``names`` close to a misspelt ``given`` (difflib's ratio of at least 0.6)."""
    import difflib
    return difflib.get_close_matches(given, list(names), n=3, cutoff=0.6) if isinstance(given, str) else []


def did_you_mean(names: Iterable[str], given: Any) -> str:
    """`` (did you mean pm4?)`` for a misspelt ``given`` close to one of ``names``, else ''."""
    close = closest_names(names, given)
    return f' (did you mean {" or ".join(close)}?)' if close else ''


def listed_names(names: Iterable[str], what: str, given: Any = None) -> str:
    """``names`` for an 'allowed:': their count (``what`` they are), the ones closest to a misspelt ``given`` first,
    then the first eight (a program may have 100,000 stations; a list cut after eight hid the imported ones a typo
    meant)."""
    listed = list(names)
    close = closest_names(listed, given)
    shown = close + [n for n in listed[:8] if n not in close]
    rest = len(listed) - len(shown)
    return f'one of the {len(listed)} {what}: {", ".join(shown)}' + (f', ... ({rest} more)' if rest > 0 else '')

