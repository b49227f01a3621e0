"""``gpr program check|export``: offline programs of the whole robot (docs/robot.md#programs).

``--robot FILE`` names the robot description (default: the program's ``robot``, else the shipped example),
``--config FILE`` a GPR geometry replacing the description's, ``--json`` prints one JSON object on stdout. Bad input
exits with status 2 and one line on stderr.
"""
from __future__ import annotations

import argparse
from typing import Any

import numpy as np

from .options import robot_of, robot_options
from .output import emit_json


def _program(args: argparse.Namespace, rate: float | None = None) -> tuple[Any, Any]:
    """The program and its plan; with ``rate``, its samples at that rate bounded before it is planned."""
    from ..robot.plan import check_sample_count, plan_program
    from ..robot.program import load_program
    program = load_program(args.program)
    if rate is not None:
        check_sample_count(program, rate)
    return program, plan_program(robot_of(args, program.robot), program)


def _summary(plan: Any) -> dict[str, Any]:
    v, a = plan.timing.usage()
    err = np.linalg.norm(plan.naive_wafer_error, axis=1)
    i = int(np.argmax(err))
    return {'program': plan.program.source, 'robot': plan.robot.name, 'stations': len(plan.program.stations),
            'steps': len(plan.program.steps), 'waypoints': len(plan.waypoints), 'duration': plan.timing.total,
            'joint_names': list(plan.joint_names), 'velocity_usage': v, 'acceleration_usage': a,
            'max_naive_wafer_error': err[i], 'max_naive_wafer_error_at': plan.labels[i]}


def _print_summary(s: dict[str, Any]) -> None:
    print(f'program {s["program"]} on robot {s["robot"]}: {s["stations"]} stations, {s["steps"]} steps, '
          f'{s["waypoints"]} waypoints, {s["duration"]:.3f} s; every waypoint reachable, every move within the limits')
    for what in ('velocity', 'acceleration'):
        usage = zip(s['joint_names'], s[f'{what}_usage'], strict=True)
        print(f'  peak {what} / limit: ' + ', '.join(f'{n} {u:.2f}' for n, u in usage))
    print(f'  the naive model would miss the wafer by up to {s["max_naive_wafer_error"] * 1e6:.3f} um '
          f'(at {s["max_naive_wafer_error_at"]})')


def _cmd_check(args: argparse.Namespace) -> int:
    _, plan = _program(args)
    if args.json:
        emit_json(_summary(plan))
    else:
        _print_summary(_summary(plan))
    return 0


def _cmd_export(args: argparse.Namespace) -> int:
    from ..errors import InputError
    from ..robot.export import check_table_path, sample_table, waypoint_table, write_table
    from ..robot.plan import sample_plan
    from ..robot.timing import check_rate
    if args.waypoints is None and args.samples is None:
        raise InputError('nothing to export: give --waypoints FILE and/or --samples FILE (.csv or .json)')
    for path in (args.waypoints, args.samples):
        if path is not None:  # refused before the program is planned
            check_table_path(path)
    if args.samples is not None:
        check_rate(args.rate)
    _, plan = _program(args, args.rate if args.samples is not None else None)
    meta = {'robot': plan.robot.name, 'program': plan.program.source}
    written: dict[str, Any] = {}  # the paths written, under keys of their own (the summary counts 'waypoints')
    if args.waypoints is not None:
        written['waypoints_file'] = str(write_table(args.waypoints, *waypoint_table(plan), meta))
    if args.samples is not None:
        sampled = sample_plan(plan, args.rate)
        written['samples_file'] = str(write_table(args.samples, *sample_table(plan, sampled),
                                                  meta | {'rate': args.rate}))
        written['sample_count'] = len(sampled)
    if args.json:
        emit_json(_summary(plan) | written)
    else:
        _print_summary(_summary(plan))
        for key in ('waypoints', 'samples'):
            if f'{key}_file' in written:
                print(f'  {key} written to {written[f"{key}_file"]}')
    return 0


def register(sub: Any) -> None:
    """Add ``gpr program`` to the ``gpr`` parser."""
    program = sub.add_parser('program', help='offline programs of the whole robot: check, export the joint table',
                             description='Robot programs (docs/robot.md#programs).')
    psub = program.add_subparsers(dest='program_command', metavar='SUBCOMMAND', parser_class=type(program))
    psub.required = True
    p = psub.add_parser('check', help='solve every waypoint and time every move within the limits')
    p.add_argument('program', metavar='PROGRAM', help='robot program YAML file')
    robot_options(p)
    p.set_defaults(handler=_cmd_check)
    p = psub.add_parser('export', help='the joint table per waypoint and per sample, as CSV or JSON')
    p.add_argument('program', metavar='PROGRAM', help='robot program YAML file')
    p.add_argument('--waypoints', metavar='FILE', help='write the waypoint table (.csv or .json)')
    p.add_argument('--samples', metavar='FILE', help='write the sample table (.csv or .json)')
    p.add_argument('--rate', type=float, default=100.0, help='sample rate [Hz] (default 100; 0.1 to 5000)')
    robot_options(p)
    p.set_defaults(handler=_cmd_export)
