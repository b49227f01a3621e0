"""A progress line on stderr for the long commands (``gpr program check``, ``gpr calibrate``, ``gpr accuracy``'s
Monte Carlo): the stage, the share of it done and the time so far, shown once the command has run ``after`` seconds
(:data:`AFTER`), so that a quick run prints nothing; ``--no-progress`` never shows it (:func:`progress_line`).

On a terminal the line is redrawn in place; into a file or a pipe (a CI log) a line is written at most every
``every`` seconds, and at the start and the end of each stage. stdout is untouched: ``--json`` stays one object.
"""
from __future__ import annotations

import argparse
import sys
import time
from collections.abc import Callable
from typing import TextIO

#: Seconds a command runs before its progress line shows.
AFTER = 2.0


class ProgressLine:
    """``line(stage, share)`` reports ``share`` in [0, 1] of ``stage`` done; :meth:`close` ends the line.

    >>> import io
    >>> out = io.StringIO()
    >>> line = ProgressLine(out, after=0.0, clock=iter([0.0, 1.5, 3.0]).__next__)
    >>> line('clearance', 0.25)
    >>> line.close()
    >>> out.getvalue()
    'clearance:  25.0 % (1.5 s)\\n'
    """

    def __init__(self, stream: TextIO | None = None, after: float = 2.0, every: float = 5.0,
                 clock: Callable[[], float] = time.monotonic) -> None:
        #: None: no stderr (``2>&-``) or it failed: nothing is shown.
        self.stream: TextIO | None = stream if stream is not None else sys.stderr
        self.after, self.every = after, every
        self.clock = clock
        self.start = self.clock()
        try:
            self.live = bool(getattr(self.stream, 'isatty', lambda: False)())
        except (OSError, ValueError):  # closed
            self.live, self.stream = False, None
        self.shown = False
        self._last_stage = ''
        self._ended = False
        self._last_write = -float('inf')

    def __call__(self, stage: str, share: float) -> None:
        now = self.clock()
        elapsed = now - self.start
        if elapsed < self.after or self.stream is None:
            return
        new_stage = stage != self._last_stage
        self._last_stage = stage
        if not self.live and not new_stage and (self._ended or share < 1.0 and now - self._last_write < self.every):
            return   # the stage's end is written once (the search tells it again as it closes)
        self._ended = share >= 1.0
        text = f'{stage}: {100.0 * min(max(share, 0.0), 1.0):5.1f} % ({elapsed:.1f} s)'
        try:
            self.stream.write(f'\r{text:<60}' if self.live else f'{text}\n')
            self.stream.flush()
        except (OSError, ValueError):  # stderr closed or its reader gone: the check goes on without its progress
            self.stream = None
            return
        self._last_write = now
        self.shown = True

    def close(self) -> None:
        """End the line on a terminal (nothing was shown: nothing to end)."""
        if self.shown and self.live and self.stream is not None:
            try:
                self.stream.write('\n')
                self.stream.flush()
            except (OSError, ValueError):
                self.stream = None
        self.shown = False


def progress_line(no_progress: bool) -> ProgressLine:
    """The progress line of a command on stderr: shown after :data:`AFTER` s, or never with ``--no-progress``."""
    return ProgressLine(after=float('inf') if no_progress else AFTER)


def add_no_progress(parser: argparse.ArgumentParser) -> None:
    """The option ``--no-progress`` of a command with a progress line."""
    parser.add_argument('--no-progress', action='store_true',
                        help=f'no progress line on stderr (shown by default once the command has run {AFTER:g} s)')
