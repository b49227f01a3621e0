"""``gpr program check|export``: offline programs of the whole robot (docs/robot.md#programs).

``gpr program check`` exits 0 when the program is safe (clearance at least ``--margin`` for every pair of bodies,
certified between samples, and no wafer slip), 1 when it is not (a table names the first collision), 2 on bad
input. ``--robot FILE`` names the robot description (default: the program's ``robot``, else the shipped example),
``--config FILE`` a GPR geometry replacing the description's, ``--json`` prints one JSON object on stdout. Bad input
exits with status 2 and one line on stderr.
"""
from __future__ import annotations

import argparse
from typing import Any

import numpy as np

from .options import robot_of, robot_options
from .output import emit_json, jsonable


def _program(args: argparse.Namespace) -> tuple[Any, Any]:
    from ..robot.plan import plan_program
    from ..robot.program import load_program
    program = load_program(args.program)
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
    from ..errors import InputError
    from ..safety.cell import load_cell
    from ..safety.check import check_program
    from ..safety.clearance import MARGIN
    if args.plot is not None:
        from ..inputs.files import check_output
        if not str(args.plot).lower().endswith('.png'):
            raise InputError(f'--plot {args.plot!r}: allowed: a .png file')
        check_output(args.plot, 'plot')
    margin = MARGIN if args.margin is None else args.margin
    program, plan = _program(args)
    path = args.cell if args.cell is not None else program.cell
    cell = None if path is None else load_cell(path)
    report, clear, slip = check_program(plan, cell, margin)
    written: dict[str, str] = {}
    if args.plot is not None:
        from ..safety.plot import plot_check
        written['plot_file'] = str(plot_check(args.plot, clear, slip, report))
    if args.json:
        emit_json(_summary(plan) | jsonable(report) | written)
    else:
        _print_summary(_summary(plan))
        _print_safety(report)
        if written:
            print(f'  plot written to {written["plot_file"]}')
    return 0 if report.safe else 1


def _print_safety(r: Any) -> None:
    where = f'in cell {r.cell}' if r.cell else 'against itself (no cell)'
    print(f'  clearance {where}: minimum {r.min_clearance * 1e3:.3f} mm (margin {r.margin * 1e3:g} mm, certified '
          f'between samples; {r.evaluations} distance calls); max slip ratio {r.max_slip_ratio:.3f} at '
          f'{r.max_slip_at:.3f} s ({r.slip_label})')
    carried = [m for m in r.moves if m.max_slip_ratio > 0.0]
    if carried:
        head = 'waypoint (the move into it and its hold)'
        print(f'    {head:<48} {"from [s]":>9} {"to [s]":>9} {"max slip ratio":>15}')
        for m in carried:
            print(f'    {m.label:<48} {m.start:>9.3f} {m.end:>9.3f} {m.max_slip_ratio:>15.3f}')
    if r.collisions:
        c = r.collisions[0]
        print(f'  UNSAFE: {len(r.collisions)} pair(s) below the margin; the first:')
        print(f'    {"step":>5}  {"station":<16} {"time [s]":>9}  {"bodies":<40} {"distance [mm]":>13}')
        print(f'    {c.step:>5}  {c.station:<16} {c.time:>9.3f}  {" / ".join(c.bodies):<40} {c.distance * 1e3:>13.3f}')
    if r.max_slip_ratio >= 1.0:
        print(f'  UNSAFE: the wafer slips on the blade (ratio {r.max_slip_ratio:.3f} >= 1) at {r.max_slip_at:.3f} s, '
              f'{r.slip_label}')
    print(f'  {"safe" if r.safe else "NOT safe"}')


def _cmd_export(args: argparse.Namespace) -> int:
    from ..errors import InputError
    from ..robot.export import check_table_path, sample_table, waypoint_table, write_table
    from ..robot.plan import sample_plan
    if args.waypoints is None and args.samples is None:
        raise InputError('nothing to export: give --waypoints FILE and/or --samples FILE (.csv or .json)')
    for path in (args.waypoints, args.samples):
        if path is not None:  # refused before the program is planned
            check_table_path(path)
    _, plan = _program(args)
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
    p = psub.add_parser('check', help='solve every waypoint, time every move, check clearance and wafer slip')
    p.add_argument('program', metavar='PROGRAM', help='robot program YAML file')
    p.add_argument('--cell', metavar='FILE', help='the process cell (default: the program\'s cell, else none)')
    p.add_argument('--margin', type=float, default=None, metavar='M',
                   help='clearance below which a pair collides [m] (default 0.002)')
    p.add_argument('--plot', metavar='FILE.png', help='clearance and slip ratio against time (needs matplotlib)')
    robot_options(p)
    p.set_defaults(handler=_cmd_check)
    p = psub.add_parser('export', help='the joint table per waypoint and per sample, as CSV or JSON')
    p.add_argument('program', metavar='PROGRAM', help='robot program YAML file')
    p.add_argument('--waypoints', metavar='FILE', help='write the waypoint table (.csv or .json)')
    p.add_argument('--samples', metavar='FILE', help='write the sample table (.csv or .json)')
    p.add_argument('--rate', type=float, default=100.0, help='sample rate [Hz] (default 100)')
    robot_options(p)
    p.set_defaults(handler=_cmd_export)
