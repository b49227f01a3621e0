"""The ``gpr`` console script (and ``python -m gpr_kinematics``): :func:`gpr_kinematics.cli.main.main`, imported
here so that Ctrl-C while the command line's modules load (numpy among them: tenths of a second, seconds on a
loaded machine) reads ``gpr: interrupted`` with status 130, as once a command runs, not a traceback of the import."""
from __future__ import annotations

import sys

from ..errors import EXIT_INTERRUPTED


def main() -> int:
    """Import the command line and run it on ``sys.argv``; returns the exit status."""
    try:
        from .main import main as run
    except KeyboardInterrupt:
        sys.stderr.write('gpr: interrupted\n')
        return EXIT_INTERRUPTED
    return run()
