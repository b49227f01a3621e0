"""Bounded reading and safe writing of the calibration's text files (measurements, plans, calibrated geometry).

Reading refuses, before reading a byte, anything that is not a regular file (a directory, a FIFO that would
block, a device) and files larger than a stated limit; text must be UTF-8 and an error names the line of the
first bad byte. Writing refuses to replace anything that is not a regular file (``--output /dev/full``, a
directory) and replaces the target atomically (a temporary file in the same directory, then a rename), so an
interrupted run never leaves half a file.
"""
from __future__ import annotations

import os
import stat
from pathlib import Path

from ..errors import InputError


def comment_lines(comments: tuple[str, ...] | list[str]) -> str:
    r"""``comments`` as ``# `` lines, control characters (a newline in a file name) replaced by spaces, so a
    comment can never end early and inject content into a YAML or CSV file.

    >>> comment_lines(['from a\nradius: 5.csv'])
    '# from a radius: 5.csv\n'
    """
    return ''.join('# ' + ''.join(ch if ch.isprintable() else ' ' for ch in c) + '\n' for c in comments)


def read_text(path: str | Path, what: str, max_bytes: int) -> str:
    """The UTF-8 text of the regular file ``path`` of at most ``max_bytes`` bytes (a leading BOM is dropped).

    Raises:
        InputError: missing or unreadable, not a regular file, larger than ``max_bytes``, or not UTF-8 (the
            message names the line and byte of the first bad byte).
    """
    name = str(path)
    try:
        # O_NONBLOCK: opening a FIFO must not wait for a writer; fstat then judges what was opened.
        fd = os.open(name, os.O_RDONLY | os.O_NONBLOCK)
    except OSError as exc:
        raise InputError(f'cannot read {what} file {name!r}: {exc.strerror or exc}') from None
    try:
        info = os.fstat(fd)
        if not stat.S_ISREG(info.st_mode):
            raise InputError(f'{what} file {name!r} is not a regular file (a directory, FIFO or device); '
                             'allowed: a regular text file')
        if info.st_size > max_bytes:
            raise InputError(f'{what} file {name!r} has {info.st_size} bytes; allowed: at most {max_bytes}')
        with os.fdopen(fd, 'rb', closefd=False) as fh:
            data = fh.read(max_bytes + 1)
    except OSError as exc:
        raise InputError(f'cannot read {what} file {name!r}: {exc.strerror or exc}') from None
    finally:
        os.close(fd)
    if len(data) > max_bytes:  # grew since fstat
        raise InputError(f'{what} file {name!r} has more than {max_bytes} bytes; allowed: at most {max_bytes}')
    try:
        text = data.decode('utf-8')
    except UnicodeDecodeError as exc:
        line = data.count(b'\n', 0, exc.start) + 1
        raise InputError(f'{name} line {line}: not UTF-8 text (byte {exc.start} is {data[exc.start]:#04x}); '
                         f'allowed: a UTF-8 {what} file') from None
    return text[1:] if text.startswith('\ufeff') else text


def write_text(path: str | Path, text: str, what: str) -> Path:
    """Write ``text`` (UTF-8) to ``path`` atomically; returns the path written.

    Raises:
        InputError: ``path`` exists and is not a regular file, or its directory is missing or not writable.
    """
    target = Path(path)
    if str(path) == '':
        raise InputError(f'{what} output path is empty; allowed: a file name')
    try:
        info = os.stat(target)
    except FileNotFoundError:
        info = None
    except OSError as exc:
        raise InputError(f'cannot write {what} file {str(target)!r}: {exc.strerror or exc}') from None
    if info is not None and not stat.S_ISREG(info.st_mode):
        raise InputError(f'{what} output {str(target)!r} exists and is not a regular file (a directory, FIFO or '
                         'device); allowed: a new file or a regular file to replace')
    tmp = target.with_name(f'.{target.name}.{os.getpid()}.tmp')
    try:
        with open(tmp, 'x', encoding='utf-8', newline='\n') as fh:
            fh.write(text)
        os.replace(tmp, target)
    except OSError as exc:
        tmp.unlink(missing_ok=True)
        raise InputError(f'cannot write {what} file {str(target)!r}: {exc.strerror or exc}') from None
    return target
