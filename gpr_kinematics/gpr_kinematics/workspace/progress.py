"""Progress display and clean interruption (Ctrl-C) of a covering run."""

from __future__ import annotations

import contextlib
import signal
import sys
import threading
import time
from collections.abc import Callable
from types import FrameType
from typing import Any, ClassVar, TextIO


class Progress:
    """One-line progress display on stderr, shown only once a run has lasted ``after`` seconds.

    It shows the share of the initial box's volume already decided (inner, outside or boundary), the
    bisection level and the pending boxes' diameter against ``delta`` (the "delta level") of the part that reported
    last (each part of a cut run its own), the boxes processed so far, and the inner and boundary volumes (in the
    output variables' units).

    On a terminal the bar is redrawn in place at every update; into a file or a pipe (a CI log) a plain line
    (without the bar's ``\\r`` redraws) is written at most every ``every`` seconds, and once when the whole
    volume is decided, as ``gpr program check`` reports its progress (:mod:`gpr_kinematics.cli.progress`).
    """

    def __init__(self, enabled: bool, stream: TextIO | None = None, after: float = 2.0, units: str = '',
                 every: float = 5.0, clock: Callable[[], float] = time.perf_counter) -> None:
        #: None: no stderr (``2>&-``: ``sys.stderr`` is None) or writing to it failed: the run goes on without the bar.
        self.stream: TextIO | None = stream or sys.stderr
        self.enabled = enabled and self.stream is not None
        self.after, self.every = after, every
        self.units = units
        self.clock = clock
        self.start = clock()
        try:
            #: A terminal: redrawn in place; else plain lines, at most one per ``every`` seconds.
            self.live = bool(getattr(self.stream, 'isatty', lambda: False)())
        except (OSError, ValueError):  # closed
            self.live, self.stream, self.enabled = False, None, False
        self.shown = False
        self._last: tuple[int, float, float, int, float, float, float] | None = None
        self._last_write = -float('inf')
        self._finished = self._forced = False
        self._written: tuple[int, float, float, int, float, float, float] | None = None

    def update(
        self,
        level: int,
        diameter: float,
        delta: float,
        processed: int,
        inner_volume: float,
        boundary_volume: float,
        done_frac: float,
    ) -> None:
        if not self.enabled:
            return
        self._last = (level, diameter, delta, processed, inner_volume, boundary_volume, done_frac)
        now = self.clock()
        elapsed = now - self.start
        if elapsed < self.after:
            return
        frac = min(max(done_frac, 0.0), 1.0)
        finished = frac >= 1.0
        if not self.live and not self._forced and (
                (finished and self._finished) or (not finished and now - self._last_write < self.every)):
            return
        text = (f'{100 * frac:5.1f}% of volume decided | level {level}, diameter {diameter * 1e3:.3g} mm (delta '
                f'{delta * 1e3:.3g} mm) | {processed:,} boxes processed | inner {inner_volume:.4g}, boundary '
                f'{boundary_volume:.4g} {self.units} | {elapsed:.1f} s')
        if self.live:
            width = 24
            fill = int(round(width * frac))
            self._write(f'\r[{"#" * fill}{"." * (width - fill)}] {text} ')
        else:
            self._write(f'{text}\n')
        self._last_write, self._finished, self._written = now, finished, self._last
        self.shown = self.enabled

    def _write(self, text: str) -> None:
        """Write and flush; a closed stream or a gone reader turns the bar off (the run goes on)."""
        if self.stream is None:
            return
        try:
            self.stream.write(text)
            self.stream.flush()
        except (OSError, ValueError):
            self.stream, self.enabled = None, False

    def refresh(self) -> None:
        """Show the last numbers again with the time elapsed (while waiting for a cluster's results)."""
        if self._last is not None:
            self.update(*self._last)

    def close(self) -> None:
        """End the bar's line on a terminal; off a terminal write the last numbers if they were not (the volume's
        float sum ended at 0.9999999999999999, and the line of the whole volume decided was never written)."""
        if self.shown and not self.live and self._last is not None and self._written != self._last:
            self._forced = True
            self.update(*self._last)
        if self.shown and self.live:
            self._write('\n')


class StopFlag:
    """While alive, SIGINT (Ctrl-C) and SIGTERM (a kill) set :attr:`raised` instead of ending the process (main
    thread).

    The covering checks the flag between chunks, so a chunk is never half recorded, and a run stopped by either
    signal leaves through its ``finally`` blocks: a Dask cluster it started is closed (killed with SIGTERM, a run on
    a local cluster left its workers' semaphores behind).
    """

    SIGNALS = (signal.SIGINT, signal.SIGTERM)
    #: The signal the last flag of this process caught (None: none since a flag was made): ``gpr workspace`` saves
    #: what was proved and exits with its status all the same (130, 143), as a script reads an interruption.
    caught: ClassVar[int | None] = None

    def __init__(self) -> None:
        self.raised = False
        StopFlag.caught = None
        self._old: dict[int, Any] = {}
        if threading.current_thread() is threading.main_thread():
            for sig in self.SIGNALS:
                with contextlib.suppress(ValueError, OSError):  # embedded interpreters
                    self._old[sig] = signal.signal(sig, self._handler)

    def _handler(self, signum: int, frame: FrameType | None) -> None:
        self.raised = True
        StopFlag.caught = signum

    def restore(self) -> None:
        for sig, old in self._old.items():
            signal.signal(sig, old)
        self._old = {}
