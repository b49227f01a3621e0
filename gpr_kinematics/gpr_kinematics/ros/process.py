"""Start the package's nodes as separate processes, the way ``ros2 run gpr_kinematics <exe>`` does (no ROS import).

:class:`NodeProcess` finds ``<prefix>/lib/gpr_kinematics/<exe>`` through the ament index
(:func:`gpr_kinematics.ros.env.find_executable`), starts it with ``--ros-args ...`` in the given environment
(default: this process's), keeps its output in a log folder (or passes it through), and stops it with a signal.
The tests, ``make demo``, the offline loop and the benchmarks all start nodes through it.

>>> import os
>>> env = {'AMENT_PREFIX_PATH': '/nonexistent'}
>>> NodeProcess('kinematics_node', env=env)   # doctest: +ELLIPSIS
Traceback (most recent call last):
...
FileNotFoundError: package 'gpr_kinematics' not found in the ament index (AMENT_PREFIX_PATH)
"""
from __future__ import annotations

import contextlib
import os
import shutil
import signal as signals
import subprocess
import tempfile
import time
import weakref
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from types import TracebackType
from typing import IO

from ..inputs.resources import PACKAGE
from . import env as ros_env


class NodeProcess:
    """A node executable running as its own process: ``<exe> --ros-args <ros_args>``.

    Args:
        exe: executable name in ``lib/gpr_kinematics`` (``kinematics_node``, ``trajectory_node``, ...).
        ros_args: arguments after ``--ros-args`` (``-p name:=value``, ``-r __ns:=/x``, ``--params-file f``).
        env: environment of the process (default ``os.environ``; it must hold the ROS environment, see
            :mod:`gpr_kinematics.ros.env`).
        log_dir: folder of ``<exe>.out``/``<exe>.err`` (default: a new temporary folder, removed with this object:
            every test's node left one in ``/tmp``); ``echo=True`` passes the output through to this process's
            stdout/stderr instead (and makes no folder unless given one).
        preexec: called in the child before the executable starts (e.g. to set a resource limit).
    """

    def __init__(self, exe: str, ros_args: Sequence[str] = (), *, env: Mapping[str, str] | None = None,
                 log_dir: str | Path | None = None, echo: bool = False,
                 preexec: Callable[[], object] | None = None) -> None:
        self.exe = exe
        self.env = dict(os.environ if env is None else env)
        self.path = ros_env.find_executable(PACKAGE, exe, self.env)
        self.args = [str(self.path), *(['--ros-args', *ros_args] if ros_args else [])]
        if log_dir is None and not echo:   # a folder of this object's: removed with it
            log_dir = tempfile.mkdtemp(prefix=f'gpr_{exe}_')
            weakref.finalize(self, shutil.rmtree, log_dir, ignore_errors=True)
        self.log_dir = None if log_dir is None else Path(log_dir)
        self.out_path: Path | None = None
        self.err_path: Path | None = None
        self._files: list[IO[bytes]] = []
        out = err = None
        if self.log_dir is not None:
            self.log_dir.mkdir(parents=True, exist_ok=True)
            self.out_path, self.err_path = self.log_dir / f'{exe}.out', self.log_dir / f'{exe}.err'
            if not echo:
                self._files = [open(self.out_path, 'wb'), open(self.err_path, 'wb')]  # noqa: SIM115 - see _close
                out, err = self._files
        self.proc = subprocess.Popen(self.args, stdout=out, stderr=err, stdin=subprocess.DEVNULL, env=self.env,
                                     preexec_fn=preexec)

    @property
    def command(self) -> str:
        """The command line, for a log."""
        return ' '.join(self.args)

    def alive(self) -> bool:
        return self.proc.poll() is None

    def output(self) -> str:
        """Everything the process wrote so far, stdout then stderr (empty with ``echo``)."""
        for f in self._files:
            if not f.closed:
                f.flush()
        return ''.join(p.read_text(errors='replace') for p in (self.out_path, self.err_path) if p and p.exists())

    def tail(self, n: int = 5) -> str:
        """The last ``n`` lines of :meth:`output`."""
        return '\n'.join(self.output().splitlines()[-n:])

    def wait(self, timeout: float | None = None) -> int:
        """Wait for the exit; return the status (negative: killed by that signal). ``TimeoutExpired`` on timeout."""
        status = self.proc.wait(timeout=timeout)
        self._close()
        return status

    def signal(self, sig: int = signals.SIGINT, timeout: float = 2.0) -> tuple[int | None, float]:
        """Send ``sig``; return (exit status, or None if still running after ``timeout`` s; seconds taken)."""
        t0 = time.monotonic()
        if self.alive():
            self.proc.send_signal(sig)
        try:
            status: int | None = self.proc.wait(timeout=timeout)
        except subprocess.TimeoutExpired:
            status = None
        return status, time.monotonic() - t0

    def stop(self, sig: int = signals.SIGINT, timeout: float = 15.0) -> int:
        """Stop the process with ``sig`` (SIGKILL after ``timeout`` s); return its exit status."""
        if self.alive():
            status, _ = self.signal(sig, timeout)
            if status is None:
                self.proc.kill()
                self.proc.wait(timeout=10)
        self._close()
        return int(self.proc.returncode)

    def _close(self) -> None:
        for f in self._files:
            with contextlib.suppress(OSError):
                f.close()

    def __enter__(self) -> NodeProcess:
        return self

    def __exit__(self, exc_type: type[BaseException] | None, exc: BaseException | None,
                 tb: TracebackType | None) -> None:
        self.stop()
