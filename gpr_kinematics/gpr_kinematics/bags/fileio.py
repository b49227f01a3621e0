"""Opening the files of a bag safely: regular files only, bounded reads, SHA-256 digests.

A FIFO (or a device, a socket, a folder) where a bag expects a storage file or ``metadata.yaml`` would block a
reader forever or feed it without end; :func:`open_regular` refuses it *without* blocking: it opens with
``O_NONBLOCK`` (an open of a FIFO for reading returns at once instead of waiting for a writer) and checks
``fstat`` of the open descriptor, so a file swapped between a check and the open is caught too.
"""
from __future__ import annotations

import errno
import hashlib
import os
import stat
from pathlib import Path
from typing import BinaryIO

from ..errors import NAME_RULE, PATH_LENGTH, brief
from ..inputs.files import kind_of, note_read
from .errors import BagError

#: Bytes read at a time when hashing a file.
BLOCK = 1 << 20


def shown(path: str | os.PathLike[str]) -> str:
    """``path`` as a message names it: whole up to :data:`~gpr_kinematics.errors.PATH_LENGTH` characters, else cut
    (:func:`~gpr_kinematics.errors.brief`)."""
    text = os.fspath(path)
    return text if len(text) <= PATH_LENGTH else brief(text, PATH_LENGTH)


def path_error(path: str | os.PathLike[str], exc: OSError, what: str = '') -> str:
    """The message of an ``OSError`` met looking ``path`` up: ``name too long`` with
    :data:`~gpr_kinematics.errors.NAME_RULE`
    (``ENAMETOOLONG``), else ``cannot be read`` and the system's reason; ``what`` names the kind of file."""
    if exc.errno == errno.ENAMETOOLONG:
        return f'{shown(path)}: {what + " " if what else ""}name too long; {NAME_RULE}'
    return f'{shown(path)}: {what + " " if what else ""}cannot be read: {exc.strerror or exc}'


def status_of(path: Path, what: str = '') -> os.stat_result | None:
    """``os.stat`` of ``path`` (links followed); None where nothing is there (missing, or a part of it is no
    folder); :class:`BagError` (:func:`path_error`) for another error, a name too long (``Path.exists`` raised it)."""
    try:
        return os.stat(path)
    except (FileNotFoundError, NotADirectoryError):
        return None
    except OSError as exc:
        raise BagError(path_error(path, exc, what)) from None


def require_regular(path: Path, what: str) -> int:
    """Size [bytes] of ``path`` if it is a regular file (symbolic links followed); :class:`BagError` naming
    ``what`` and the kind of file otherwise. Does not open the file."""
    try:
        st = os.stat(path)
    except OSError as exc:
        raise BagError(f'{path}: {what} cannot be read: {exc.strerror or exc}') from None
    if not stat.S_ISREG(st.st_mode):
        raise BagError(f'{path}: {what} is {kind_of(st.st_mode)}; allowed: a regular file')
    return st.st_size


def open_regular(path: Path, what: str) -> tuple[BinaryIO, int]:
    """Open ``path`` for reading in binary mode if it is a regular file; returns the file and its size.

    Raises:
        BagError: missing, unreadable, or not a regular file (never blocks on a FIFO).
    """
    try:
        fd = os.open(path, os.O_RDONLY | getattr(os, 'O_NONBLOCK', 0) | getattr(os, 'O_CLOEXEC', 0))
    except OSError as exc:
        raise BagError(f'{path}: {what} cannot be opened: {exc.strerror or exc}') from None
    try:
        st = os.fstat(fd)
        if not stat.S_ISREG(st.st_mode):
            raise BagError(f'{path}: {what} is {kind_of(st.st_mode)}; allowed: a regular file')
        note_read(st)  # a command's outputs may not overwrite it (gpr_kinematics.inputs.files)
        os.set_blocking(fd, True)
        return os.fdopen(fd, 'rb'), st.st_size
    except BaseException:
        os.close(fd)
        raise


def read_bounded(path: Path, what: str, limit: int) -> bytes:
    """The bytes of the regular file ``path``, refused (:class:`BagError`) beyond ``limit`` bytes."""
    f, size = open_regular(path, what)
    with f:
        if size > limit:
            raise BagError(f'{path}: {what} has {size} bytes; allowed: at most {limit}')
        try:
            data = f.read(limit + 1)
        except OSError as exc:
            raise BagError(f'{path}: {what} cannot be read: {exc.strerror or exc}') from None
    if len(data) > limit:
        raise BagError(f'{path}: {what} grew beyond {limit} bytes while being read')
    return data


def read_head(path: Path, what: str, n: int) -> tuple[bytes, int]:
    """The first ``n`` bytes of the regular file ``path`` and its size."""
    f, size = open_regular(path, what)
    with f:
        try:
            return f.read(n), size
        except OSError as exc:
            raise BagError(f'{path}: {what} cannot be read: {exc.strerror or exc}') from None


def sha256_file(path: Path, what: str) -> str:
    """Hex SHA-256 of a regular file, read in blocks of :data:`BLOCK` bytes."""
    f, _ = open_regular(path, what)
    digest = hashlib.sha256()
    with f:
        try:
            while block := f.read(BLOCK):
                digest.update(block)
        except OSError as exc:
            raise BagError(f'{path}: {what} cannot be read: {exc.strerror or exc}') from None
    return digest.hexdigest()


def check_sqlite_pages(path: Path, head: bytes, size: int) -> None:
    """Refuse a database file whose size is not its header's page count times its page size (bytes appended or cut;
    the count is valid where the header's version-valid-for number equals its change counter, as SQLite writes it
    on every commit)."""
    page = int.from_bytes(head[16:18], 'big') or 1
    page = 65536 if page == 1 else page
    count = int.from_bytes(head[28:32], 'big')
    if len(head) == 100 and head[92:96] == head[24:28] and count and size != page * count:
        raise BagError(f'{path}: {size} bytes where its header declares {count} pages of {page} bytes '
                       f'({page * count} bytes): bytes appended or cut; allowed: the database as SQLite wrote it')
