"""Exception classes of gpr_kinematics, the exit status for unusable input, and the one way a message quotes a
value a user supplied (:func:`brief`).

Every error the package raises on purpose derives from :class:`GprError`, so a caller
(a ROS node, the CLI) can catch the package's errors without catching programming bugs.
"""
from __future__ import annotations

import math
import re
import reprlib
from typing import Any

#: Exit status of the ``gpr`` command and of the nodes for input they cannot use (one line on stderr).
EXIT_BAD_INPUT = 2
#: Exit status of the ``gpr`` command for usable input it refuses as not safe (:class:`UnsafeError`; ``gpr program
#: check``'s NOT safe).
EXIT_UNSAFE = 1
#: Exit status of a command stopped by Ctrl-C (128 + SIGINT).
EXIT_INTERRUPTED = 130


class GprError(Exception):
    """Base class of the package's errors; ``exit_status``, the ``gpr`` command's when it ends with one."""

    exit_status: int = EXIT_BAD_INPUT


class ConfigError(GprError, ValueError):
    """A configuration value is missing, malformed or out of its allowed range."""


class InputError(GprError, ValueError):
    """An argument is malformed: wrong shape, NaN or infinity, unknown name."""


class LimitError(InputError):
    """A request lies outside the machine's limits (stroke, tilt, joint ranges)."""


class RobotStateError(LimitError):
    """The robot reports a state a command cannot start from (joints outside their limits): not the user's input."""


class NoPoseError(LimitError):
    """Rod lengths whose differences no tilt of the platform makes: beyond every limit, with no pose to show."""


class UnsafeError(GprError):
    """Usable input refused as not safe (a program ``gpr program check`` finds not safe, exported or sent): the ``gpr``
    command exits :data:`EXIT_UNSAFE`, as the check does, not :data:`EXIT_BAD_INPUT`."""

    exit_status = EXIT_UNSAFE


class ConvergenceError(GprError, ArithmeticError):
    """An iterative solver did not reach its tolerance within its iteration bound.

    Attributes: ``sample``, the batch's sample that did not (None: one pose, or not known); ``error``, its last error
    (NaN: a step that was not finite), or None."""

    def __init__(self, message: str, sample: int | None = None, error: float | None = None) -> None:
        super().__init__(message)
        self.sample, self.error = sample, error


class SingularityError(GprError, ArithmeticError):
    """A quantity was asked for at a configuration where it is not defined."""


class FileError(ConfigError, InputError):
    """A file cannot be read or written: missing, not a regular file, too large, not UTF-8, an output in a
    missing or read-only folder (:mod:`gpr_kinematics.inputs.files`), a unit of a column that is unknown
    (:mod:`gpr_kinematics.inputs.units`). It is a :class:`ConfigError` and an :class:`InputError`: configuration files
    and the files of a command both raise it."""


#: Longest text of a value quoted in an error message [characters].
BRIEF_LENGTH = 60
#: Longest path quoted whole in an error message (``brief(path, PATH_LENGTH)``) [characters]: a real path fits, a
#: name beyond the file system's (255 bytes) is cut.
PATH_LENGTH = 120
#: What a path too long for the file system (``ENAMETOOLONG``) is allowed: Linux's ``NAME_MAX`` and ``PATH_MAX``.
NAME_RULE = 'allowed: a path whose names have at most 255 bytes each, 4096 in all'


class _Repr(reprlib.Repr):
    """reprlib with a bounded text of every element, huge integers included (their repr is refused beyond 4300
    digits)."""

    def __init__(self) -> None:
        super().__init__()
        self.maxlist = self.maxtuple = self.maxdict = self.maxset = 8
        self.maxlevel = 3
        self.maxstring = self.maxother = self.maxlong = 2 * BRIEF_LENGTH

    def repr1(self, x: Any, level: int) -> str:
        """A numpy scalar as its number (numpy 2 writes ``np.float64(7.0)``; messages say 7.0, as numpy 1 did)."""
        if type(x).__module__ == 'numpy' and getattr(x, 'shape', None) == () and hasattr(x, 'item') and \
                type(x).__name__ != 'ndarray':
            x = x.item()
        return super().repr1(x, level)

    def repr_int(self, x: int, level: int) -> str:
        if x.bit_length() > 4 * BRIEF_LENGTH:
            return f'<an integer of about {int(x.bit_length() * 0.30103) + 1} digits>'
        return super().repr_int(x, level)


_REPR = _Repr()


#: A line break and the indentation around it, in a repr.
_LINES = re.compile(r'\s*\n\s*')


def brief(value: Any, limit: int = BRIEF_LENGTH) -> str:
    """``repr(value)`` cut to about ``limit`` characters, for messages about values a user supplied, which may be
    arbitrarily large: a string is quoted up to ``limit`` characters with its whole length named; a container is
    abbreviated without ever building its whole text (a list of a million items costs no more than one of eight).

    >>> brief('x' * 1000)
    "'xxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxx... (1000 characters)"
    >>> brief([1, 2]), brief(list(range(10 ** 6))), brief(10 ** 5000)
    ('[1, 2]', '[0, 1, 2, 3, 4, 5, 6, 7, ...]', '<an integer of about 5001 digits>')
    """
    # A string is in memory already: its repr costs as much as it does, and gives the whole length.
    text = repr(value) if isinstance(value, (str, bytes)) else _LINES.sub(' ', _REPR.repr(value))   # one line: an
    # array's repr spans several (a message is one line)
    if len(text) <= limit:
        return text
    size = f'{len(value)} bytes' if isinstance(value, bytes) else \
        f'{len(value) if isinstance(value, str) else len(text)} characters'   # the string's own, not its quotes'
    return f'{text[:limit]}... ({size})'


def apart(value: float, limit: float, digits: int = 6) -> tuple[str, str]:
    """``value`` and the ``limit`` it passed, in ``g`` form with ``digits`` significant digits or as many more as
    tell them apart (17 at most): a refusal that read "0.508 m is outside [0, 0.508] m" contradicted itself.

    >>> apart(0.5080000000010001, 0.508), apart(0.6, 0.508)
    (('0.508000000001', '0.508'), ('0.6', '0.508'))
    """
    for d in range(digits, 18):
        a, b = f'{value:.{d}g}', f'{limit:.{d}g}'
        if a != b:
            return a, b
    return repr(value), repr(limit)


def norm_text(values: tuple[float, ...], limit: float) -> tuple[str, str]:
    """The Euclidean norm of ``values`` against ``limit`` as :func:`apart` prints them; beyond the floats (1.7e308 m
    twice) ``more than`` the largest value."""
    norm = math.hypot(*values)
    if math.isfinite(norm):
        return apart(norm, limit)
    return f'more than {max(abs(v) for v in values):.6g}', f'{limit:g}'


#: Longest run of characters without a space an error line carries whole (a long path, or a value a message
#: quoted whole by mistake, is cut: the line stays readable).
LONG_WORD = 300


#: Longest error line [characters]: its middle is cut beyond (a list a message quoted whole by mistake). The
#: longest message written on purpose, the calibration gate's with several failed checks and long file names, is
#: about 1,000.
LONG_LINE = 1500


def kind_of(value: Any) -> str:
    """What a file gave where a mapping or a list was expected, in a user's words (``nothing (an empty file or
    null)`` where a message said ``NoneType``).

    >>> kind_of(None), kind_of([1]), kind_of((1,)), kind_of('x'), kind_of(2.5), kind_of(True)
    ('nothing (an empty file or null)', 'a list', 'a tuple', 'text', 'a number', 'true/false')
    """
    if value is None:
        return 'nothing (an empty file or null)'
    if isinstance(value, bool):
        return 'true/false'
    if isinstance(value, (int, float)):
        return 'a number'
    if isinstance(value, (str, bytes)):
        return 'text'
    if isinstance(value, list):
        return 'a list'
    if isinstance(value, tuple):   # a code caller's (a file has lists): "must be a list, got a list" contradicted it
        return 'a tuple'
    if isinstance(value, dict):
        return 'a mapping'
    return type(value).__name__


def key_value(data: Any, key: str) -> str:
    """:func:`brief` of ``data[key]``, ``(missing)`` where the mapping has no such key (``format = None`` read as if
    the file had given None)."""
    return brief(data[key]) if key in data else '(missing)'


def one_line(message: str) -> str:
    """An error message as one bounded line: newlines become spaces, words longer than :data:`LONG_WORD` are cut
    with their length named, and a line longer than :data:`LONG_LINE` loses the least of its middle that brings it
    to that length (its start names the problem, its end what is allowed).

    >>> one_line('bad value ' + '9' * 1000 + '\\nallowed: 1 to 3')
    'bad value 999999999999999999999999999999999999999999999999999999999999... (1000 characters) allowed: 1 to 3'
    """
    def cut(m: re.Match[str]) -> str:
        return f'{m.group(0)[:BRIEF_LENGTH]}... ({len(m.group(0))} characters)'

    line = re.sub(rf'\S{{{LONG_WORD + 1},}}', cut, message.replace('\n', ' '))
    if len(line) > LONG_LINE:
        mark = f' ... ({len(line)} characters) ... '
        tail = LONG_LINE // 4
        line = f'{line[:LONG_LINE - tail - len(mark)]}{mark}{line[-tail:]}'
    return line
