"""The files a user hands the package: one bounded reader of text files and one checked, atomic writer.

Reading (:func:`read_text`) opens the path with ``O_NONBLOCK`` and judges what was opened with ``fstat``: a
directory, a FIFO (whose open would otherwise wait for a writer forever), a device (``/dev/zero`` never ends) or
a socket is refused before a byte is read, and so is a file larger than the caller's limit; the text must be
UTF-8 (a leading byte-order mark is dropped), and an error names the line and the byte offset of the first bad
byte.

Writing (:func:`atomic_output`, :func:`write_text`) refuses, before any work and again just before the file is
replaced, an empty path, an existing directory, FIFO, device, socket (a rename replaced a device node as root, a
write into a FIFO blocks) or symbolic link (the output would land elsewhere), and a folder missing or not writable.
A temporary file in the folder replaces the target in one rename: an interrupted run never leaves half a file.
The functions return the path written so that a command can say what it wrote where.

Two rules hold within a context (a ``contextvars`` context: a thread, a task):

* **confined reads** (:func:`confined_reads`): while a node serves a remote client's request (a ``gpr/run_program``
  goal's ``program_file``, and every file that program names: its robot, the robot's geometry, imported station
  files), :func:`read_text` opens only files whose real path (symbolic links and ``..`` resolved) lies under the
  folders its operator allowed; any other is refused before it is opened, with a message that names the path and
  the rule, never the file's content;
* **a command's outputs are not its inputs** (:func:`command_reads`): while a command runs, every file it reads is
  noted (device and inode, :func:`note_read`), and :func:`check_output` refuses an output that is one of them
  (``gpr calibrate M.csv --output M.csv`` overwrote its measurements with the calibrated geometry). The CLI also
  refuses, before any work, an output named like one of its inputs (:mod:`gpr_kinematics.cli.output`), and
  ``gpr program export`` notes its cell before its check reads it;
* **all of a command's outputs or none** (:func:`command_writes`): a command that fails (an exception, Ctrl-C) after
  writing some outputs takes them back: files it created removed, files it replaced given their old content back (a
  hard link kept until the end), folders it created removed when empty, files it removed (:func:`remove_output`) put
  back. What another process replaced meanwhile is left, and a command that ends to find one of its outputs replaced
  fails naming it (two commands writing the same pair of files each said it had written both).

Every problem is a :class:`~gpr_kinematics.errors.FileError` naming the kind of file, the path, what is allowed."""
from __future__ import annotations

import contextlib
import contextvars
import errno
import os
import shutil
import stat
from collections.abc import Iterable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import IO, Any

from ..errors import NAME_RULE, FileError, brief

#: Largest text file read when a caller names no limit [bytes] (configuration and mechanism files are a few kB).
MAX_TEXT_BYTES = 16 * 1024 * 1024


@dataclass(frozen=True)
class ReadRule:
    """The folders reads are confined to (real paths) and how a message names the rule (e.g. ``the folders of
    trajectory_node's parameter program_folders``)."""

    folders: tuple[str, ...]
    rule: str

    def resolve(self, name: str, what: str) -> str:
        """The real path of ``name`` when it lies under one of :attr:`folders`; :class:`FileError` otherwise."""
        real = os.path.realpath(name)
        if not any(real == f or real.startswith(f.rstrip(os.sep) + os.sep) for f in self.folders):
            raise FileError(f'{what} file {name!r} is outside the folders this node reads files from; allowed: a file '
                            f'under {", ".join(self.folders) or "no folder"} ({self.rule})')
        return real


_CONFINED: contextvars.ContextVar[ReadRule | None] = contextvars.ContextVar('gpr_confined_reads', default=None)
_READS: contextvars.ContextVar[set[tuple[int, int]] | None] = contextvars.ContextVar('gpr_command_reads',
                                                                                      default=None)


@contextlib.contextmanager
def confined_reads(folders: Iterable[str | os.PathLike[str]], rule: str) -> Iterator[ReadRule]:
    """Within the block, :func:`read_text` reads only under ``folders`` (module docstring)."""
    token = _CONFINED.set(ReadRule(tuple(os.path.realpath(f) for f in folders), rule))
    try:
        yield _CONFINED.get()  # type: ignore[misc]  # set just above
    finally:
        _CONFINED.reset(token)


@contextlib.contextmanager
def command_reads() -> Iterator[set[tuple[int, int]]]:
    """Within the block, the files read are noted and no output may be one of them (module docstring)."""
    token = _READS.set(set())
    try:
        yield _READS.get()  # type: ignore[misc]  # set just above
    finally:
        _READS.reset(token)


def _identity(info: os.stat_result) -> tuple[int, int]:
    """What tells a file written from another one at the same path: its device and inode, exact while the command
    holds the file open (:attr:`_Written.held`: a replacement cannot reuse the number then). Not its modification
    time: a ``touch`` of an output is no replacement."""
    return info.st_dev, info.st_ino


@dataclass
class _Written:
    """One output written: its ``target``, a hard link to the content it replaced (``backup``; None: created), the
    :func:`_identity` of what the command wrote and a descriptor ``held`` open on it until the command ends."""

    target: Path
    backup: Path | None
    identity: tuple[int, int]
    held: int

    def ours(self) -> bool:
        """Whether the target still holds what the command wrote."""
        try:
            return _identity(os.lstat(self.target)) == self.identity
        except OSError:
            return False


@dataclass
class _Writes:
    """What the running command wrote (:class:`_Written`, in order), the folders it created and the files it removed
    (``(target, backup)``: the target renamed to its backup until the command ends)."""

    files: list[_Written]
    folders: list[Path]
    removed: list[tuple[Path, Path]]

    def undo(self) -> list[Path]:
        """Take back what still holds what the command wrote; the targets another process replaced or removed since,
        left."""
        left = []
        for w in reversed(self.files):
            with contextlib.suppress(OSError):
                if not w.ours():
                    left.append(w.target)
                    if w.backup is not None:
                        w.backup.unlink()
                elif w.backup is None:
                    w.target.unlink()
                else:
                    os.replace(w.backup, w.target)
        for folder in reversed(self.folders):
            with contextlib.suppress(OSError):
                folder.rmdir()   # only when empty
        for target, backup in reversed(self.removed):
            with contextlib.suppress(OSError):
                if os.path.lexists(target):   # another process wrote there since: its file stays
                    left.append(target)
                    backup.unlink()
                else:
                    os.rename(backup, target)
        return left

    def replaced(self) -> list[Path]:
        """The outputs another process replaced or removed since the command wrote them (each target's last write)."""
        last = {w.target: w for w in self.files}
        return [t for t, w in last.items() if not w.ours()]

    def keep(self) -> None:
        for backup in [w.backup for w in self.files] + [b for _, b in self.removed]:
            if backup is not None:
                with contextlib.suppress(OSError):
                    backup.unlink()

    def close(self) -> None:
        for w in self.files:
            with contextlib.suppress(OSError):
                os.close(w.held)


def _clash(paths: list[Path], what: str) -> FileError:
    """Outputs another process replaced or removed (named which) while the command ran."""
    gone = [p for p in paths if not os.path.lexists(p)]
    said = ' and '.join(f'{", ".join(str(p) for p in group)} {"was" if len(group) == 1 else "were"} {verb}'
                        for verb, group in (('replaced', [p for p in paths if p not in gone]), ('removed', gone))
                        if group)
    return FileError(f'{said} by another process while this command ran; {what}; allowed: one command writing an '
                     'output at a time')


_WRITES: contextvars.ContextVar[_Writes | None] = contextvars.ContextVar('gpr_command_writes', default=None)


@contextlib.contextmanager
def command_writes() -> Iterator[None]:
    """Within the block, the outputs written are all kept when it ends normally, all taken back when it raises
    (module docstring)."""
    writes = _Writes([], [], [])
    token = _WRITES.set(writes)
    clash = None
    try:
        yield
        clashed = writes.replaced()
        if clashed:   # another command's output: this one's are no pair with it
            how = 'wrote' if all(os.path.lexists(p) for p in clashed) else 'left'
            clash = _clash(clashed, f"left as the other process {how} it, this command's other outputs taken back")
            raise clash
    except Exception as error:
        left = writes.undo()
        if left and error is not clash:
            raise _clash(left, f'left as it is (this command failed: {error})') from error
        raise
    except BaseException:   # Ctrl-C: what another process wrote is left, silently as before
        writes.undo()
        raise
    else:
        writes.keep()
    finally:
        writes.close()
        _WRITES.reset(token)


def output_folder(path: str | os.PathLike[str]) -> Path:
    """Create the folder ``path`` and its missing parents (``mkdir -p``), noting those created for
    :func:`command_writes`; returns it. OSError as ``Path.mkdir`` raises it."""
    folder = Path(path)
    missing = [p for p in (folder, *folder.parents) if not p.exists()]
    folder.mkdir(parents=True, exist_ok=True)
    writes = _WRITES.get()
    if writes is not None:
        writes.folders.extend(reversed(missing))   # parents first: undone children first
    return folder


def remove_output(path: Path) -> None:
    """Remove the regular file ``path`` left by an earlier run (a report's figure the new one does not draw), taken
    back with the command's other outputs if it fails (:func:`command_writes`); nothing else at ``path`` is touched."""
    if not path.is_file() or path.is_symlink():
        return
    writes = _WRITES.get()
    if writes is None:
        return path.unlink()
    backup = path.with_name(f'.{path.name}.{os.getpid()}.{len(writes.removed)}.removed')
    os.rename(path, backup)
    writes.removed.append((path, backup))


def _replace(tmp: Path, target: Path) -> None:
    """``os.replace(tmp, target)``, noted for :func:`command_writes` (a hard link to a replaced target's content)."""
    writes = _WRITES.get()
    if writes is None:
        os.replace(tmp, target)
        return
    backup = None
    if target.exists():
        backup = target.with_name(f'.{target.name}.{os.getpid()}.{len(writes.files)}.bak')
        try:
            os.link(target, backup)
        except OSError:   # a file system without hard links: a copy
            shutil.copyfile(target, backup)
    held = None
    try:
        held = os.open(tmp, os.O_RDONLY | os.O_CLOEXEC)   # the inode stays this file's while the command runs
        identity = _identity(os.fstat(held))
        os.replace(tmp, target)
    except BaseException:
        if held is not None:
            os.close(held)
        if backup is not None:
            with contextlib.suppress(OSError):
                backup.unlink()
        raise
    writes.files.append(_Written(target, backup, identity, held))


def note_input(path: str | os.PathLike[str]) -> None:
    """Note a file the running command takes as an input without reading it (a program's cell, when the program is
    only exported), so that no output replaces it; a missing or unreadable file is left to the command's own read."""
    with contextlib.suppress(OSError):
        note_read(os.stat(path))


def note_read(info: os.stat_result) -> None:
    """Note a file the running command reads (by its ``fstat``), for :func:`check_output`."""
    reads = _READS.get()
    if reads is not None:
        reads.add((info.st_dev, info.st_ino))


def kind_of(mode: int) -> str:
    """What a file of ``st_mode`` ``mode`` is, for messages (``'a directory'``, ``'a FIFO'``, ...)."""
    for test, name in ((stat.S_ISDIR, 'a directory'), (stat.S_ISFIFO, 'a FIFO'), (stat.S_ISCHR, 'a character device'),
                       (stat.S_ISBLK, 'a block device'), (stat.S_ISSOCK, 'a socket'),
                       (stat.S_ISLNK, 'a symbolic link'), (stat.S_ISREG, 'a regular file')):
        if test(mode):
            return name
    return 'not a regular file'


def path_name(path: str | os.PathLike[str], what: str, role: str = 'file') -> str:
    """The name of a file path as given (``str`` or ``Path``, not empty, no NUL); else :class:`FileError`."""
    name = os.fspath(path) if isinstance(path, (str, os.PathLike)) else None
    if not isinstance(name, str):   # 5, None, bytes: a bare TypeError of os.fspath or of the NUL test
        raise FileError(f'{what} {role} path = {brief(path)}; allowed: a file path (str or Path)')
    if name == '':
        raise FileError(f'{what} {role} path is empty; allowed: the path of a file')
    if '\0' in name:
        raise FileError(f'{what} {role} path {brief(name)} contains a NUL character; allowed: the path of a file')
    return name


def read_text(path: str | os.PathLike[str], what: str, max_bytes: int = MAX_TEXT_BYTES) -> str:
    """The UTF-8 text of the regular file ``path`` of at most ``max_bytes`` bytes (module docstring).

    >>> read_text('/dev/zero', 'config')  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    gpr_kinematics.errors.FileError: config file '/dev/zero' is not a regular file (a character device); allowed: ...

    Raises:
        FileError: missing or unreadable, not a regular file, larger than ``max_bytes``, not UTF-8.
    """
    name = path_name(path, what)
    rule = _CONFINED.get()
    real = rule.resolve(name, what) if rule is not None else name
    try:
        fd = os.open(real, os.O_RDONLY | os.O_NONBLOCK | os.O_CLOEXEC)
    except OSError as exc:   # it named no rule
        allowed = NAME_RULE if exc.errno == errno.ENAMETOOLONG else 'allowed: an existing file this user can read'
        raise FileError(f'cannot read {what} file {name!r}: {exc.strerror or exc}; {allowed}') from None
    try:
        info = os.fstat(fd)
        if not stat.S_ISREG(info.st_mode):
            raise FileError(f'{what} file {name!r} is not a regular file ({kind_of(info.st_mode)}); allowed: a '
                            'regular text file')
        if info.st_size > max_bytes:
            raise FileError(f'{what} file {name!r} has {info.st_size} bytes; allowed: at most {max_bytes}')
        note_read(info)
        chunks, size = [], 0
        while size <= max_bytes:  # read(n) of a regular file may return less than n
            chunk = os.read(fd, max_bytes + 1 - size)
            if not chunk:
                break
            chunks.append(chunk)
            size += len(chunk)
    except OSError as exc:
        raise FileError(f'cannot read {what} file {name!r}: {exc.strerror or exc}') from None
    finally:
        os.close(fd)
    data = b''.join(chunks)
    if len(data) > max_bytes:  # it grew since fstat
        raise FileError(f'{what} file {name!r} has more than {max_bytes} bytes; allowed: at most {max_bytes}')
    try:
        text = data.decode('utf-8')
    except UnicodeDecodeError as exc:
        line = data.count(b'\n', 0, exc.start) + 1
        raise FileError(f'{what} file {name!r} is not UTF-8 text (byte {exc.start} is {data[exc.start]:#04x}) on '
                        f'line {line}; allowed: a UTF-8 {what} file') from None
    return text[1:] if text.startswith('\ufeff') else text


def check_output(path: str | os.PathLike[str], what: str) -> Path:
    """The path an output will be written to, checked before any work (module docstring): not empty, not an
    existing non-regular file or symbolic link, in an existing, writable folder.

    Raises:
        FileError: naming the path, what is wrong and what is allowed.
    """
    name = path_name(path, what, 'output')
    target = Path(name)
    allowed = 'allowed: a new file or a regular file to replace, in an existing, writable folder'
    try:
        info = os.lstat(target)
    except FileNotFoundError:
        info = None
    except OSError as exc:
        raise FileError(f'cannot write {what} file {name!r}: {exc.strerror or exc}; {allowed}') from None
    if info is not None and not stat.S_ISREG(info.st_mode):
        raise FileError(f'{what} output {name} exists and is not a regular file (it is {kind_of(info.st_mode)}); '
                        f'{allowed}')
    if info is not None and (info.st_dev, info.st_ino) in (_READS.get() or ()):
        raise FileError(f'{what} output {name!r} is a file this command reads; allowed: a file the command does not '
                        'read (write the output elsewhere)')
    folder = target.parent
    if not folder.is_dir():
        raise FileError(f'cannot write {what} file {name!r}: No such file or directory (the folder {str(folder)!r} '
                        f'does not exist); {allowed}')
    if not os.access(folder, os.W_OK | os.X_OK):
        raise FileError(f'{what} output {name!r}: the folder {str(folder)!r} is not writable; {allowed}')
    return target


def check_suffix(path: str | os.PathLike[str], option: str, suffixes: tuple[str, ...], why: str = '') -> None:
    """Refuse an output named ``path`` by ``option`` whose name does not end in one of ``suffixes`` (lower case, any
    case matches), before any work: ``gpr calibrate --output x.csv`` wrote YAML under a CSV's name.

    Raises:
        FileError: naming the option, the name given and the suffixes allowed (``why``: what is written, appended).
    """
    name = os.fspath(path)
    if not name.lower().endswith(suffixes):
        found = 'is a folder' if os.path.isdir(name) else 'has another suffix'  # said which ('outdir': a folder)
        raise FileError(f'{option} {brief(name)} {found}; allowed: a {" or ".join(suffixes)} file{why}')


@contextlib.contextmanager
def atomic_output(path: str | os.PathLike[str], what: str, binary: bool = False) -> Iterator[IO[Any]]:
    """Write ``path`` atomically (module docstring): yields a file open on a temporary file in the target's
    folder (text mode: UTF-8, newlines as written; ``binary``: bytes), which replaces the target when the block
    ends without an exception; on an exception the temporary file is removed and the target is left as it was.

    Raises:
        FileError: the checks of :func:`check_output`, or the file cannot be written (full disk, ...).
    """
    target = check_output(path, what)
    tmp = target.with_name(f'.{target.name}.{os.getpid()}.tmp')
    not_made = False
    try:   # from the creation on: a signal right after it (SIGTERM, Ctrl-C) left the file
        try:
            fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL | os.O_CLOEXEC, 0o666)
        except OSError:
            not_made = True
            raise
        with (os.fdopen(fd, 'wb') if binary else os.fdopen(fd, 'w', encoding='utf-8', newline='')) as fh:
            yield fh
        check_output(target, what)  # the target may have been replaced by something else meanwhile
        _replace(tmp, target)
    except OSError as exc:   # the writing, the folder (no temporary file: /proc/self/fd/1.csv) or the name failed
        allowed = ('an output with room for it' if exc.errno in (errno.ENOSPC, errno.EDQUOT) else 'a shorter file '
                   'name (its temporary file adds .PID.tmp)' if exc.errno == errno.ENAMETOOLONG else 'a new file or a '
                   'regular file to replace, in a folder where files can be created and renamed')
        raise FileError(f'cannot write {what} file {os.fspath(path)!r}: {exc.strerror or exc}; allowed: {allowed}'
                        ) from None
    finally:
        if not not_made:
            with contextlib.suppress(FileNotFoundError):
                tmp.unlink()


def write_text(path: str | os.PathLike[str], text: str, what: str) -> Path:
    """Write ``text`` (UTF-8) to ``path`` through :func:`atomic_output` (its FileError); returns the path written."""
    with atomic_output(path, what) as fh:
        fh.write(text)
    return Path(path)


def writable_folder(path: str | os.PathLike[str], what: str) -> Path:
    """The nearest existing ancestor of a path to be created (a bag or report folder), which must be a writable
    folder; :class:`FileError` otherwise."""
    out = Path(path_name(path, what))
    parent = out.parent
    while not parent.exists() and parent != parent.parent:
        parent = parent.parent
    if not parent.is_dir():
        raise FileError(f'{what} {str(out)!r}: {str(parent)!r} is not a folder; allowed: a path in a writable folder')
    if not os.access(parent, os.W_OK | os.X_OK):
        raise FileError(f'{what} {str(out)!r}: the folder {str(parent)!r} is not writable; allowed: a path in a '
                        'writable folder')
    return parent
