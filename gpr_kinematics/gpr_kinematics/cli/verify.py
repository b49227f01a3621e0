"""``gpr verify BAG``: offline verification of a recorded bag against the current kinematics core.

Exit status 0 when every check holds, 1 when a check fails (each failure named on stdout: check, topic,
sample, value, limit), 2 when the bag cannot be read or an argument is unusable (one line on stderr starting
``gpr verify: error:``, "unreadable: ..." for the bag; no traceback).
"""
from __future__ import annotations

import argparse
import math
import sys
from typing import TYPE_CHECKING

from ..bags.errors import BagError
from ..bags.report import check_report_folder, write_report
from ..bags.verify import Tolerances, format_table, verify_bag
from ..core.config import load_config
from ..errors import InputError
from ..inputs.resources import ROBOTS
from .options import number, shipped
from .output import emit_json

if TYPE_CHECKING:
    from .main import Subparsers

#: ``--tolerance VALUE`` (no name) sets these: the per-message agreement with the core.
CORE_TOLERANCES = ('position', 'angle', 'virtual_joint', 'length', 'residual', 'agreement')


def parse_tolerances(items: list[str] | None) -> Tolerances:
    """``['1e-8', 'angle=1e-10', ...]`` -> :class:`Tolerances`; InputError naming a bad item."""
    tol = Tolerances()
    allowed = ', '.join(Tolerances.names())
    given: set[str] = set()
    for item in items or []:
        name, sep, value = item.partition('=')
        if sep and not name:
            raise InputError(f'--tolerance {item[:60]!r}: the name before = is empty; allowed: VALUE, or NAME=VALUE '
                             f'with NAME one of {allowed}')
        if not sep:
            name, value = '', item
        if name in given:  # the last one won silently
            raise InputError(f'--tolerance {item[:60]!r}: {name or "the value without a name"} is given twice; '
                             'allowed: each once')
        given.add(name)
        try:
            v = number(value)
        except ValueError:
            v = math.nan
        if not math.isfinite(v):   # a negative one is named with its name's range below (Tolerances.replace)
            raise InputError(f'--tolerance {item[:60]!r}: the value must be a finite number (SI units)')
        if name and name not in Tolerances.names():
            raise InputError(f'--tolerance {item[:60]!r}: unknown name {name[:40]!r}; allowed: a number, or '
                             f'NAME=VALUE with NAME one of {allowed}')
        try:
            tol = tol.replace(**({name: v} if name else dict.fromkeys(CORE_TOLERANCES, v)))
        except InputError as exc:
            raise InputError(f'--tolerance {item[:60]!r}: {exc}') from None
    return tol


def _verify(args: argparse.Namespace) -> int:
    tol = parse_tolerances(args.tolerance)
    if not args.bag:   # '' was read as '.', the folder the command runs in
        raise InputError('BAG is empty; allowed: a rosbag2 folder (with metadata.yaml), a .mcap or a .db3 file')
    if args.config is not None and not args.config:
        raise InputError('--config is empty; allowed: the path of a GPR configuration YAML file')
    cfg = load_config(args.config) if args.config else None
    if args.robot is not None and not args.robot:
        raise InputError('--robot is empty; allowed: the path of a robot description YAML file')
    robot = None
    if args.robot:
        from ..robot.description import load_robot

        robot = load_robot(args.robot)
    if args.report is not None:
        check_report_folder(args.report)
    try:
        result = verify_bag(args.bag, config=cfg, tolerances=tol, config_source=f'--config {args.config}',
                            allow_missing_checksums=args.allow_missing_checksums, robot=robot,
                            robot_source=f'--robot {args.robot}')
    except BagError as exc:
        raise BagError(f'unreadable: {exc}') from None
    files = write_report(result, args.report) if args.report is not None else []
    if args.json:
        emit_json(result.record(), report=[str(f) for f in files])
    else:
        sys.stdout.write(format_table(result) + '\n')
        if files:
            sys.stdout.write(f'report: {args.report} ({len(files)} files: '
                             + ', '.join(f.name for f in files) + ')\n')
    return 0 if result.passed else 1


def register(subparsers: Subparsers) -> None:
    p = subparsers.add_parser(
        'verify', help='verify a recorded bag against the current kinematics (exit 0 ok, 1 failed, 2 unreadable)',
        description='Check a rosbag2 bag (MCAP or SQLite3, split recordings read as one): its checksums and '
                    'metadata, every gpr_interfaces/PlatformState against forward kinematics of its q under the '
                    'recorded geometry, the stream (counters, stamps, no jump at singular crossings), the '
                    'companion topics (poses, joint states, markers) and, for a whole-robot program, every wafer '
                    'pose against the recorded robot description. SI units.')
    p.add_argument('bag', help='bag folder (with metadata.yaml), or a single .mcap / .db3 file')
    p.add_argument('--json', action='store_true', help='print the result as one JSON object (a value that is not '
                                                       'a finite number as the string "inf", "-inf" or "nan")')
    p.add_argument('--report', metavar='DIR', help='write verify.json, verify.txt and the PNG plots '
                                                   '(paper figures 5-11, centre shift vs tilt) into the folder DIR')
    p.add_argument('--tolerance', action='append', metavar='[NAME=]VALUE',
                   help='a number sets the agreement with the core for positions [m], angles [rad], virtual '
                        'joints, lengths, the residual and other state fields (default 1e-9); NAME=VALUE sets one '
                        'limit (names: ' + ', '.join(Tolerances.names()) + '); repeatable')
    p.add_argument('--config', metavar='YAML', help='GPR configuration to verify against instead of the geometry '
                                                    'recorded in the bag (/gpr/geometry; without it, the '
                                                    "package's config/gpr.yaml); the difference is reported")
    p.add_argument('--robot', metavar='YAML', type=shipped(ROBOTS),
                   help='robot description to verify the wafer poses of a whole-robot recording against instead of '
                        'the one recorded (/gpr/robot); it computes with the geometry verified against')
    p.add_argument('--allow-missing-checksums', action='store_true',
                   help='verify a bag written by another recorder (no gpr checksums in metadata.yaml): skip '
                        'bag.checksums instead of failing it')
    p.set_defaults(handler=_verify)
