"""The ``gpr`` command line: GPR kinematics, compensation, mobility, the paper's sweep; the whole robot and its
programs, calibration and accuracy budgets; other mechanisms, workspaces and the verification of recorded bags.

SI units (metres, radians) by default; ``--mm`` and ``--deg`` convert inputs only, outputs stay SI.
Subcommands live in modules with a ``register(subparsers)`` function whose parsers set ``handler=fn`` with
``fn(args) -> int``. They are imported lazily: :data:`COMMANDS` maps each subcommand to its module, and only
the module of the subcommand being run is imported (all of them for ``gpr --help``), so the core commands
need only numpy, scipy and PyYAML. A subcommand whose optional dependency (the ``bags``, ``plot`` or ``ros``
extra) is missing exits with status 2 and one line naming the package to install. Bad input raises a
:class:`~gpr_kinematics.errors.GprError`; :func:`main` prints it as one line on stderr, after the command's full path
(``gpr robot ik: error: ...``, as argparse's usage errors), and exits with its ``exit_status``: 2, or 1 for an
:class:`~gpr_kinematics.errors.UnsafeError` (usable input refused as not safe).
``--json`` output is the result dataclass itself (:func:`gpr_kinematics.cli.output.jsonable`): one JSON key per field.
"""
from __future__ import annotations

import argparse
import codecs
import contextlib
import errno
import importlib
import os
import re
import signal
import sys
from collections.abc import Sequence
from types import FrameType
from typing import TYPE_CHECKING, Any, NoReturn, TextIO, TypeAlias, cast

from ..errors import BRIEF_LENGTH, EXIT_BAD_INPUT, EXIT_INTERRUPTED, NAME_RULE, PATH_LENGTH, GprError, brief, one_line
from ..inputs.files import command_reads, command_writes
from ..inputs.safe_yaml import UNSIGNED_DECIMAL
from .output import OUTPUT_OPTIONS, description, distinct_outputs

if TYPE_CHECKING:
    from signal import _HANDLER  # typeshed's: a handler, SIG_DFL or SIG_IGN, or None

#: Subcommand -> module that registers it (imported only when that subcommand runs, or for ``--help``).
COMMANDS: dict[str, str] = {
    'fk': 'gpr_kinematics.cli.core', 'ik': 'gpr_kinematics.cli.core', 'compensate': 'gpr_kinematics.cli.core',
    'mobility': 'gpr_kinematics.cli.core', 'sweep': 'gpr_kinematics.cli.core',
    'mechanism': 'gpr_kinematics.cli.mechanism', 'accuracy': 'gpr_kinematics.cli.accuracy',
    'dexterity': 'gpr_kinematics.cli.dexterity',
    'workspace': 'gpr_kinematics.cli.workspace',
    'verify': 'gpr_kinematics.cli.verify',
    'calibrate': 'gpr_kinematics.cli.calibrate',
    'robot': 'gpr_kinematics.cli.robot', 'program': 'gpr_kinematics.cli.program',
}
#: Plugin modules of other parts of the project not listed in :data:`COMMANDS` (imported for every command).
PLUGINS: tuple[str, ...] = ()
#: Optional third-party packages -> the extra of ``setup.py`` that installs them.
OPTIONAL_PACKAGES: dict[str, str] = {'rosbags': 'bags', 'mcap': 'bags', 'mcap_ros2': 'bags', 'zstandard': 'bags',
                                     'lz4': 'bags', 'matplotlib': 'plot', 'rclpy': 'ros',
                                     'fcl': 'safety'}

#: Exit status for bad input (:data:`gpr_kinematics.errors.EXIT_BAD_INPUT`).
EXIT_USAGE = EXIT_BAD_INPUT
#: An argument of ``argparse.ArgumentParser``'s constructor that a subclass passes on unchanged: its type is the
#: base class's parameter it lands in, which forwarding ``*args, **kwargs`` cannot name.
Forwarded = Any


class _Parser(argparse.ArgumentParser):
    """argparse that reports usage errors in one line (status 2) instead of the usage block, and takes
    negative numbers in scientific notation (``-2e-4``) as values, not options."""

    def __init__(self, *args: Forwarded, **kwargs: Forwarded) -> None:
        super().__init__(*args, **kwargs)
        # argparse's rule for a value that looks like a negative number, not an option: one reading of each text
        # (`\d+\.?\d*` split a run of digits n ways) in ASCII digits, as the numbers are read (options.number)
        self._negative_number_matcher = re.compile('-' + UNSIGNED_DECIMAL + r'\Z|-(?:inf|nan)\Z')

    def error(self, message: str) -> NoReturn:
        """Exit with status 2 and the one line ``prog: error: message`` (a long value argparse quotes in it, such as
        a number of 5000 digits, cut by :func:`~gpr_kinematics.errors.brief`)."""
        message = re.sub(rf"'([^'\n]{{{BRIEF_LENGTH + 1},}})'", lambda m: brief(m.group(1)), message)
        self.exit(EXIT_USAGE, f'{self.prog}: error: {message}\n')


#: What a subcommand module's ``register(sub)`` adds its parsers to (``ArgumentParser.add_subparsers()``).
Subparsers: TypeAlias = 'argparse._SubParsersAction[_Parser]'


def missing_dependency(exc: ModuleNotFoundError) -> GprError | None:
    """A one-line error for an optional package that is not installed (``None`` for any other import error)."""
    root = (exc.name or '').split('.')[0]
    extra = OPTIONAL_PACKAGES.get(root)
    if extra is None:
        return None
    return GprError(f'this command needs the optional package {root!r}, which is not installed; install it with '
                    f"pip install 'gpr_kinematics[{extra}]'")


def _unavailable(sub: Subparsers, command: str, error: GprError) -> None:
    def handler(args: argparse.Namespace) -> int:
        raise error

    # No option prefix: whatever follows the command is taken as is, and the handler gives the one-line error.
    p = sub.add_parser(command, help=f'(unavailable: {error})', add_help=False, prefix_chars='\0')
    p.add_argument('rest', nargs=argparse.REMAINDER)
    p.set_defaults(handler=handler)


def _register(sub: Subparsers, module: str) -> None:
    """Import ``module`` and let it add its subcommands; a missing optional package leaves placeholders."""
    try:
        importlib.import_module(module).register(sub)
    except ModuleNotFoundError as exc:
        error = missing_dependency(exc)
        if error is None:
            raise
        for command in (c for c, m in COMMANDS.items() if m == module and c not in sub.choices):
            _unavailable(sub, command, error)


def build_parser(command: str | None = None) -> argparse.ArgumentParser:
    """The ``gpr`` parser with the subcommand ``command`` fully registered (all of them when ``None``)."""
    parser = _Parser(prog='gpr', description=description(__doc__))
    sub = parser.add_subparsers(dest='command', metavar='COMMAND', parser_class=_Parser)
    sub.required = True
    wanted = [COMMANDS[command]] if command in COMMANDS else list(dict.fromkeys(COMMANDS.values()))
    for module in list(dict.fromkeys(wanted)) + list(PLUGINS):
        _register(sub, module)
    for name in COMMANDS:  # listed in the usage, registered when they run
        if name not in sub.choices:
            sub.add_parser(name)
    return parser


def command_parser(parser: argparse.ArgumentParser, args: argparse.Namespace) -> argparse.ArgumentParser:
    """The deepest parser the subcommands of ``args`` chose (``gpr robot ik``'s)."""
    while True:
        sub = next((a for a in parser._actions if isinstance(a, argparse._SubParsersAction)), None)
        name = None if sub is None else getattr(args, sub.dest, None)
        if sub is None or name not in sub.choices:
            return parser
        parser = sub.choices[name]


def command_path(parser: argparse.ArgumentParser, args: argparse.Namespace) -> str:
    """The command ``args`` ran, as typed (``gpr robot ik``): the ``prog`` of :func:`command_parser`, which
    argparse's own errors name too (the prefix of the command's errors; ``gpr robot`` before)."""
    return command_parser(parser, args).prog


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``gpr`` console script; returns the exit status."""
    _usable_streams()
    try:
        return _main(argv)
    except KeyboardInterrupt as exc:   # Ctrl-C before the command's own handler (its modules load: seconds), or a
        killed = isinstance(exc, _Terminated)   # signal while an error is being told
        sys.stderr.write(f'gpr: {"terminated" if killed else "interrupted"}\n')
        return 128 + signal.SIGTERM if killed else EXIT_INTERRUPTED


def _usable_streams() -> None:
    """Standard streams every command can write: one closed at the start (``2>&-``) takes what goes there to
    ``os.devnull``; one in an encoding other than UTF-8 (an ASCII locale) writes what it cannot encode as a backslash
    escape (``\\xa7``): the section sign of ``gpr sweep``'s paper reference, or a path's umlaut, was a traceback."""
    for name in ('stdout', 'stderr'):
        stream = getattr(sys, name)
        if stream is None:  # started with the stream closed (``2>&-``): what goes there is dropped
            setattr(sys, name, open(os.devnull, 'w', encoding='utf-8'))  # noqa: SIM115 - for the process' life
        elif _encoding(stream) != 'utf-8':
            with contextlib.suppress(AttributeError, ValueError, TypeError):   # not a text stream of the io module
                stream.reconfigure(errors='backslashreplace')
    if not isinstance(sys.stdout, _ReaderMayLeave):   # stderr too: a warning into `2>&1 | true` took them back
        sys.stdout = cast(TextIO, _ReaderMayLeave(sys.stdout))
    if not isinstance(sys.stderr, _ReaderMayLeave):
        sys.stderr = cast(TextIO, _ReaderMayLeave(sys.stderr))


class _ReaderMayLeave:
    """A standard stream of a command whose reader may leave (``| head``, ``| true``, ``2>&1 | true``): a write that
    finds the pipe closed sends the rest to ``os.devnull``, so the command ends its work and keeps every output it
    wrote (a BrokenPipeError in the summary or a warning took back the --boxes and --plot files already written,
    with status 0)."""

    def __init__(self, stream: TextIO) -> None:
        self.stream = stream

    def write(self, text: str) -> int:
        try:
            return self.stream.write(text)
        except BrokenPipeError:
            self._gone()
            return len(text)

    def flush(self) -> None:
        try:
            self.stream.flush()
        except BrokenPipeError:
            self._gone()

    def _gone(self) -> None:
        with contextlib.suppress(OSError, ValueError):   # what is left, and the interpreter's flush at its exit
            null = os.open(os.devnull, os.O_WRONLY)
            os.dup2(null, self.stream.fileno())
            os.close(null)

    def __getattr__(self, name: str) -> Forwarded:   # the stream's own (fileno, isatty, encoding, buffer, ...)
        return getattr(self.stream, name)


def _encoding(stream: object) -> str:
    """The codec name of ``stream``'s encoding (``utf_8`` and ``UTF8`` are ``utf-8``; unknown: itself)."""
    name = str(getattr(stream, 'encoding', None) or 'utf-8')
    try:
        return codecs.lookup(name).name
    except LookupError:
        return name


def _main(argv: Sequence[str] | None) -> int:
    """:func:`main` once its streams are usable."""
    args_in = list(sys.argv[1:] if argv is None else argv)
    first = next((a for a in args_in if not a.startswith('-')), None)
    parser = build_parser(first if first in COMMANDS else None)
    try:
        args, extra = parser.parse_known_args(args_in)
        _check_arguments(command_parser(parser, args), extra, args_in)
    except SystemExit as exc:  # usage errors (status 2, one line) and --help (status 0)
        return exc.code if isinstance(exc.code, int) else EXIT_USAGE
    command = command_path(parser, args)
    stop = _Stop()
    previous = _catch_stops(stop)
    try:
        from ..core.stroke import typed_in_millimetres
        from .options import resolve_shipped
        chosen = command_parser(parser, args)
        resolve_shipped(args, chosen)  # a shipped kind's bare name: the packaged file (cli.options.shipped)
        distinct_outputs(args, chosen)
        # no output may be a file the command read; all outputs or none; no "millimetres given as metres?" under a --mm
        # that converts every length the command takes (a file's of gpr accuracy keeps its hint under --mm)
        mm = bool(getattr(args, 'mm', False)) and bool(getattr(args, 'mm_converts_all', False))
        kept = False
        try:
            with command_reads(), command_writes(), typed_in_millimetres(mm):
                status = int(args.handler(args))
                stop.committing = True   # the outputs are being kept: a signal now waits for the end of it
            kept = True
        finally:
            stop.committed(kept)
        sys.stdout.flush()   # here, not at the interpreter's exit: a failed write is then reported below
        return status
    except GprError as exc:
        sys.stderr.write(f'{command}: error: {one_line(str(exc))}\n')
        return exc.exit_status   # 2, bad input; 1 for an UnsafeError
    except MemoryError as exc:   # numpy's allocation of an input's arrays (a 20,000-row calibration under 650 MB)
        sys.stderr.write(f'{command}: error: out of memory: {one_line(str(exc)) or "an allocation failed"}; allowed: '
                         'inputs this machine has the memory for (fewer rows or samples, coarser settings)\n')
        return EXIT_USAGE
    except ModuleNotFoundError as exc:  # an optional package imported by the handler itself
        error = missing_dependency(exc)
        if error is None:
            raise
        sys.stderr.write(f'{command}: error: {error}\n')
        return EXIT_USAGE
    except KeyboardInterrupt as exc:   # Ctrl-C, or SIGTERM (_Terminated): the outputs taken back on the way out
        return _stopped(command, exc, stop.kept)
    except TypeError as exc:   # the same raised while pybind11 converted a value (rclpy's messages): a traceback
        if not isinstance(exc.__cause__, KeyboardInterrupt):
            raise
        return _stopped(command, exc.__cause__, stop.kept)
    except BrokenPipeError:
        return 0
    except OSError as exc:  # the standard output on a full disk or a failing device (files are the handlers' to name)
        with contextlib.suppress(OSError):
            sys.stderr.write(f'{command}: error: {os_error(exc, args)}\n')
        return EXIT_USAGE
    finally:
        for signum, handler in previous.items():
            signal.signal(signum, handler)


def _stopped(command: str, exc: KeyboardInterrupt, kept: bool) -> int:
    """The line and status of a command a signal stopped: interrupted (130) or terminated (143), ``kept``: after its
    outputs were kept."""
    killed = isinstance(exc, _Terminated)
    after = ' after it had finished' if kept else ''   # its outputs whole, as the work left them
    sys.stderr.write(f'{command}: {"terminated" if killed else "interrupted"}{after}\n')
    return 128 + signal.SIGTERM if killed else EXIT_INTERRUPTED


def _check_arguments(chosen: argparse.ArgumentParser, extra: Sequence[str], argv: Sequence[str]) -> None:
    """Usage errors argparse lets through (status 2): arguments the command does not take (argparse named the top
    parser, ``gpr: error: ...``), an option that takes values given twice (:func:`repeated_option`)."""
    if extra:
        chosen.error(f'unrecognized arguments: {" ".join(extra)}; allowed: the options of {chosen.prog} --help')
    twice = repeated_option(chosen, argv)
    if twice:
        chosen.error(f'{twice}; allowed: each option that takes values once')


def repeated_option(parser: argparse.ArgumentParser, argv: Sequence[str]) -> str:
    """An option of ``parser`` that stores values given twice in ``argv``, in words (``''`` for none): argparse keeps
    the last without a word (``--tool 0 0 0.1 ... --tool 0.3 0 0.1``); options that add up (``append``,
    ``extend``) and flags may repeat. Abbreviations count as their option, as argparse reads them."""
    seen: dict[argparse.Action, list[str]] = {}
    longs = [o for o in parser._option_string_actions if o.startswith('--')]
    for token in argv:
        if token == '--':
            break
        typed = token.split('=', 1)[0]
        if not typed.startswith('-') or parser._negative_number_matcher.match(token):
            continue
        action = parser._option_string_actions.get(typed)
        if action is None and typed.startswith('--') and parser.allow_abbrev:
            found = [o for o in longs if o.startswith(typed)]
            action = parser._option_string_actions[found[0]] if len(found) == 1 else None
        if isinstance(action, argparse._StoreAction):
            seen.setdefault(action, []).append(typed)
    for action, given in seen.items():
        if len(given) > 1:
            return (f'{action.option_strings[-1]} given {len(given)} times ({", ".join(given)}): the last would '
                    'replace the others')
    return ''


class _Terminated(KeyboardInterrupt):
    """SIGTERM during a command: it ends as Ctrl-C does, its outputs taken back (a kill left a 17 MB ``.tmp`` file
    and the outputs written before it)."""


class _Stop:
    """SIGINT's and SIGTERM's handler while a command runs: KeyboardInterrupt and :class:`_Terminated`, except while
    the outputs are being kept (``committing``), when the signal waits for the end of it (:meth:`committed`): a kill
    there had left some outputs kept and others not, or whole outputs beside "terminated" as if taken back."""

    def __init__(self) -> None:
        self.committing = False
        self.kept = False
        self.deferred: int | None = None

    def __call__(self, signum: int, frame: FrameType | None) -> None:
        if self.committing:
            self.deferred = signum
            return
        raise _Terminated if signum == signal.SIGTERM else KeyboardInterrupt

    def committed(self, kept: bool) -> None:
        """The outputs' commit is over (``kept``: they are kept); a signal that came during it is raised now."""
        self.committing, self.kept = False, kept
        if self.deferred is not None:
            self(self.deferred, None)


def _catch_stops(handler: _Stop) -> dict[int, _HANDLER]:
    """Make SIGINT and SIGTERM call ``handler`` while a command runs; the handlers it replaces (none where no handler
    can be set: not the main thread; a signal the process was started ignoring stays ignored)."""
    previous: dict[int, _HANDLER] = {}
    for signum in (signal.SIGINT, signal.SIGTERM):
        if signal.getsignal(signum) is signal.SIG_IGN:
            continue
        try:
            previous[signum] = signal.signal(signum, handler)
        except ValueError:
            break
    return previous


#: The errors of a write only: a full disk or quota, a file too large, a read-only file system.
WRITE_ERRORS = frozenset({errno.ENOSPC, errno.EDQUOT, errno.EFBIG, errno.EROFS})


def os_error(exc: OSError, args: argparse.Namespace) -> str:
    """The one line of an ``OSError`` no handler named: without a file, the standard output could not be written;
    with one, a write where the error is a write's (:data:`WRITE_ERRORS`) or the file is one of the command's outputs
    (:data:`~gpr_kinematics.cli.output.OUTPUT_OPTIONS`, or in one), else a read (a bag of 300 characters was
    "cannot write" whole); the path cut to :data:`~gpr_kinematics.errors.PATH_LENGTH`."""
    reason = exc.strerror or str(exc)
    if not exc.filename:
        return f'cannot write the standard output: {reason}; allowed: an output with room for it'
    name = os.fsdecode(exc.filename)
    shown = brief(name, PATH_LENGTH)
    if exc.errno in WRITE_ERRORS or _is_output(name, args):
        return f'cannot write {shown}: {reason}; allowed: an output with room for it'
    rule = NAME_RULE if exc.errno == errno.ENAMETOOLONG else 'allowed: a file or folder this user can read'
    return f'cannot read {shown}: {reason}; {rule}'


def _is_output(name: str, args: argparse.Namespace) -> bool:
    """Whether ``name`` is an output the command was given, or lies in one (a report folder's files)."""
    path = os.path.abspath(name)
    for key in OUTPUT_OPTIONS:
        value = getattr(args, key, None)
        for out in value if isinstance(value, (list, tuple)) else [value]:
            if isinstance(out, (str, os.PathLike)) and os.fspath(out):
                out = os.path.abspath(os.fspath(out))
                if path == out or path.startswith(out.rstrip(os.sep) + os.sep):
                    return True
    return False


if __name__ == '__main__':
    sys.exit(main())
