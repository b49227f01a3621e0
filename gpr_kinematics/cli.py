"""The ``gpr`` command line: GPR kinematics, compensation, mobility, the paper's sweep; other mechanisms,
workspaces and the verification of recorded bags.

SI units (metres, radians) by default; ``--mm`` and ``--deg`` convert inputs only, outputs stay SI.
Subcommands of the other parts of the project are plugins listed in :data:`PLUGINS`: modules with a
``register(subparsers)`` function whose parsers set ``handler=fn`` with ``fn(args) -> int``.
Bad input raises a :class:`~gpr_kinematics.errors.GprError`; :func:`main` prints it as one line on stderr
and exits with status 2.
"""
from __future__ import annotations

import argparse
import importlib
import json
import re
import sys
from collections.abc import Sequence
from typing import Any

import numpy as np

from .errors import GprError

PLUGINS: tuple[str, ...] = ('gpr_kinematics.cli_workspace', 'gpr_kinematics.cli_mechanisms', 'gpr_kinematics.cli_bags',
                            'gpr_kinematics.cli_calibration', 'gpr_kinematics.cli_robot')

EXIT_USAGE = 2


class _Parser(argparse.ArgumentParser):
    """argparse that reports usage errors in one line (status 2) instead of the usage block, and takes
    negative numbers in scientific notation (``-2e-4``) as values, not options."""

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        self._negative_number_matcher = re.compile(r'^-(\d+\.?\d*|\.\d+)([eE][-+]?\d+)?$|^-(inf|nan)$')

    def error(self, message: str) -> None:  # noqa: D102
        self.exit(EXIT_USAGE, f'{self.prog}: error: {message}\n')


def _jsonable(obj: Any) -> Any:
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    if isinstance(obj, np.generic):
        return obj.item()
    if isinstance(obj, dict):
        return {str(k): _jsonable(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_jsonable(v) for v in obj]
    return obj


def emit_json(obj: Any) -> None:
    """Print ``obj`` as one JSON object on stdout (numpy arrays and scalars converted)."""
    json.dump(_jsonable(obj), sys.stdout, allow_nan=False)
    sys.stdout.write('\n')


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(prog='gpr', description=__doc__.split('\n\n')[0])
    sub = parser.add_subparsers(dest='command', metavar='COMMAND', parser_class=_Parser)
    sub.required = True
    from . import cli_core
    cli_core.register(sub)
    for name in PLUGINS:
        importlib.import_module(name).register(sub)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``gpr`` console script; returns the exit status."""
    parser = build_parser()
    try:
        args = parser.parse_args(argv)
    except SystemExit as exc:  # usage errors (status 2, one line) and --help (status 0)
        return exc.code if isinstance(exc.code, int) else EXIT_USAGE
    try:
        return int(args.handler(args))
    except GprError as exc:
        msg = str(exc).replace('\n', ' ')
        sys.stderr.write(f'gpr {args.command}: error: {msg}\n')
        return EXIT_USAGE
    except KeyboardInterrupt:
        sys.stderr.write(f'gpr {args.command}: interrupted\n')
        return 130
    except BrokenPipeError:
        return 0


if __name__ == '__main__':
    sys.exit(main())
