"""A worker that runs ``gpr`` command lines each in a forked child under hard limits, for the CLI fuzz test.

Run as a script, it imports every subcommand's module once (so each case costs a fork, not an interpreter start),
then reads one JSON request per line on stdin, ``{"argv": [...], "cwd": DIR, "timeout": S}``, and answers one JSON
line on stdout, ``{"status": N | null, "signal": NAME | null, "out": TEXT, "err": TEXT}``. The child of each case:

* runs under an address space of :data:`ADDRESS_SPACE` bytes (``RLIMIT_AS``: an allocation beyond it raises
  ``MemoryError``, which nothing in the package catches, so it shows as a traceback), files of at most
  :data:`FILE_SIZE` bytes (``RLIMIT_FSIZE``) and :data:`TIMEOUT` seconds (``alarm``: a hang, even in a blocking
  ``open``, ends in ``SIGALRM``);
* runs ``gpr_kinematics.cli.main.main(argv)`` with its stdout and stderr in files, so a warning printed by numpy or a
  traceback is seen exactly as a user would see it; an exception escaping ``main`` is printed as a traceback and
  exits with status :data:`ESCAPED`.

:class:`Worker` is the test's side: it starts the script and sends the cases.
"""
from __future__ import annotations

import contextlib
import json
import os
import resource
import signal
import subprocess
import sys
import tempfile
import traceback
from dataclasses import dataclass
from pathlib import Path
from typing import Any

#: Address space of one case [bytes]: the loaded worker uses about 0.2 GiB; the rest is the case's.
ADDRESS_SPACE = 1 << 30
#: Largest file a case may write [bytes].
FILE_SIZE = 256 << 20
#: Seconds a case may run.
TIMEOUT = 30
#: Exit status of a child whose exception escaped ``cli.main``.
ESCAPED = 99
#: Characters of stdout (its end) and stderr (its beginning and end) kept in an answer.
KEEP = 4000


@dataclass(frozen=True)
class Outcome:
    """What one command line did: exit ``status`` (None when killed by ``signal``), stdout and stderr."""

    argv: tuple[str, ...]
    status: int | None
    signal: str | None
    out: str
    err: str

    def describe(self) -> str:
        how = f'status {self.status}' if self.signal is None else f'killed by {self.signal}'
        return f'gpr {" ".join(self.argv)!r}: {how}\nstdout: {self.out[-1500:]!r}\nstderr: {self.err[-3000:]!r}'


def _child(argv: list[str], cwd: str, out_path: str, err_path: str, timeout: int) -> None:
    """In the forked child: limits, redirections, ``cli.main``; never returns."""
    status = ESCAPED
    try:
        resource.setrlimit(resource.RLIMIT_AS, (ADDRESS_SPACE, ADDRESS_SPACE))
        resource.setrlimit(resource.RLIMIT_FSIZE, (FILE_SIZE, FILE_SIZE))
        signal.signal(signal.SIGALRM, signal.SIG_DFL)
        signal.alarm(timeout)
        os.chdir(cwd)
        for fd, path in ((1, out_path), (2, err_path)):
            target = os.open(path, os.O_WRONLY | os.O_TRUNC)
            os.dup2(target, fd)
            os.close(target)
        sys.stdout = open(1, 'w', encoding='utf-8', closefd=False)  # noqa: SIM115 - lives until _exit
        sys.stderr = open(2, 'w', encoding='utf-8', closefd=False)  # noqa: SIM115
        from gpr_kinematics.cli import main as cli
        status = cli.main(argv)
    except BaseException:  # noqa: BLE001 - the test fails on whatever escapes main: print it, as Python would
        traceback.print_exc()
        status = ESCAPED
    finally:
        for stream in (sys.stdout, sys.stderr):
            with contextlib.suppress(OSError, ValueError):  # a closed or full output: the status says enough
                stream.flush()
        os._exit(status if isinstance(status, int) else ESCAPED)


def _run(request: dict[str, Any], scratch: str) -> dict[str, Any]:
    out_path, err_path = os.path.join(scratch, 'out'), os.path.join(scratch, 'err')
    for p in (out_path, err_path):
        open(p, 'w').close()
    pid = os.fork()
    if pid == 0:
        _child(list(request['argv']), request['cwd'], out_path, err_path, int(request.get('timeout', TIMEOUT)))
    _, wstatus = os.waitpid(pid, 0)
    with open(out_path, encoding='utf-8', errors='replace') as fh:
        out = fh.read()
    with open(err_path, encoding='utf-8', errors='replace') as fh:
        err = fh.read()
    sig = signal.Signals(os.WTERMSIG(wstatus)).name if os.WIFSIGNALED(wstatus) else None
    if len(err) > 2 * KEEP:
        err = f'{err[:KEEP]}[... {len(err) - 2 * KEEP} characters ...]{err[-KEEP:]}'
    return {'status': os.WEXITSTATUS(wstatus) if sig is None else None, 'signal': sig, 'out': out[-KEEP:],
            'err': err}


def serve() -> None:
    """The worker's loop (module docstring)."""
    import importlib

    from gpr_kinematics.cli import main as cli
    from gpr_kinematics.cli import progress
    progress.AFTER = float('inf')   # a long check's progress line comes after 2 s of wall time: not what is fuzzed
    for module in dict.fromkeys(cli.COMMANDS.values()):
        with contextlib.suppress(ModuleNotFoundError):  # an optional extra is missing: the CLI says so per case
            importlib.import_module(module)
    try:
        import matplotlib
        matplotlib.use('Agg')
        import matplotlib.pyplot
    except ModuleNotFoundError:
        pass
    with tempfile.TemporaryDirectory(prefix='gpr-fuzz-') as scratch:
        for line in sys.stdin:
            answer = _run(json.loads(line), scratch)
            sys.stdout.write(json.dumps(answer) + '\n')
            sys.stdout.flush()


class Worker:
    """The test's handle on a running worker (module docstring)."""

    def __init__(self) -> None:
        # A user's environment: the default warning filters (a RuntimeWarning is printed), one BLAS thread.
        env = {k: v for k, v in os.environ.items() if k != 'PYTHONWARNINGS'} | {'OPENBLAS_NUM_THREADS': '1',
                                                                              'MPLBACKEND': 'Agg'}
        self._proc = subprocess.Popen([sys.executable, str(Path(__file__).resolve())], stdin=subprocess.PIPE,
                                      stdout=subprocess.PIPE, text=True, env=env)

    def run(self, argv: list[str], cwd: Path, timeout: int = TIMEOUT) -> Outcome:
        """Run ``gpr ARGV`` in ``cwd`` (a fresh child under the limits, ``timeout`` seconds)."""
        assert self._proc.stdin is not None and self._proc.stdout is not None
        self._proc.stdin.write(json.dumps({'argv': argv, 'cwd': str(cwd), 'timeout': timeout}) + '\n')
        self._proc.stdin.flush()
        line = self._proc.stdout.readline()
        assert line, f'the fuzz worker died (status {self._proc.poll()})'
        a = json.loads(line)
        return Outcome(tuple(argv), a['status'], a['signal'], a['out'], a['err'])

    def close(self) -> None:
        assert self._proc.stdin is not None
        self._proc.stdin.close()
        self._proc.wait(timeout=60)


if __name__ == '__main__':
    serve()
