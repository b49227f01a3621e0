"""``gpr program check|export|send``: offline programs of the whole robot (docs/robot.md#programs).

``gpr program check`` exits 0 when the program is safe (clearance at least ``--margin`` for every pair of bodies,
certified between samples, no wafer slip, and every sample of a stream at ``--rate`` within the geometry's
imperfection budget, as ``gpr verify`` judges its recording), 1 when it is not (a table names the first collision,
or the steps beyond the budget), 2 on bad input. ``--robot FILE`` names the robot description (default: the
program's ``robot``, else the shipped example), ``--config FILE`` a GPR geometry replacing the description's,
``--json`` prints one JSON object on stdout. Bad input exits with status 2 and one line on stderr.

``export --trajectory FILE.yaml`` writes the program as a ``trajectory_msgs/JointTrajectory`` (one point per sample at
``--rate``, timed as ``--samples``); ``send`` (the ``ros`` extra, in a ROS environment) sends that trajectory, from
where the robot is (``joint_states``), to a ``control_msgs/action/FollowJointTrajectory`` server and reports its
progress and result: exit 0 when it succeeded, 1 when the server refused, aborted or never answered, 2 on bad input.
Both refuse a program ``check`` finds not safe with status 1, as ``check`` (one line on stderr, nothing written or
sent); a ``--rate`` at which the trajectory is refused and a higher one helps is bad input, status 2.
"""
from __future__ import annotations

import argparse
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

from ..bags.results import json_number
from ..errors import InputError
from ..inputs.resources import CELLS, PROGRAMS
from ..robot.plan import ProgramSummary, program_summary
from ..safety.margin import STREAM_RATE
from .options import named_file, number, png_plot, program_plan, robot_options, sample_rate, shipped
from .output import JsonValue, emit_json
from .program_send import send_parser
from .program_trajectory import SLIP_HELPS, add_margin, as_a_controller_takes_it, margin_of, the_program_is_safe
from .progress import ProgressLine, add_no_progress, progress_line

if TYPE_CHECKING:
    from ..safety.check import SafetyReport


def _print_summary(s: ProgramSummary) -> None:
    print(f'program {s.program} on robot {s.robot}: {s.stations} stations, {s.steps} steps, {s.waypoints} waypoints, '
          f'{s.duration:.3f} s; every waypoint reachable, every move within the limits')
    for what, values in (('velocity', s.velocity_usage), ('acceleration', s.acceleration_usage)):
        usage = zip(s.joint_names, values, strict=True)
        print(f'  peak {what} / limit: ' + ', '.join(f'{n} {u:.2f}' for n, u in usage))
    print(f'  the naive model would miss the wafer by up to {s.max_naive_wafer_error * 1e6:.3f} um '
          f'(at {s.max_naive_wafer_error_at})')


@dataclass(frozen=True)
class ProgramCheck:
    """``gpr program check --json``: the program's summary and its safety report, their keys side by side."""

    summary: ProgramSummary = field(metadata={'json': 'inline'})
    safety: SafetyReport = field(metadata={'json': 'inline'})


def _cmd_check(args: argparse.Namespace) -> int:
    from ..safety.cell import load_cell
    from ..safety.check import check_program
    if args.plot is not None:
        png_plot(args.plot)
    margin = margin_of(args, warn=True)
    sample_rate(args.rate)   # before the program is planned
    program, plan = program_plan(args)
    path = named_file(program, 'cell', args.cell)
    cell = None if path is None else load_cell(path)
    line = progress_line(args.no_progress)
    try:
        report, clear, slip = check_program(plan, cell, margin, progress=line, rate=args.rate)
    finally:
        line.close()
    written: dict[str, str] = {}
    if args.plot is not None:
        from ..safety.plan_view import plan_view
        from ..safety.plot import plot_check
        view = plan_view(plan, cell)
        written['plot_file'] = str(plot_check(args.plot, clear, slip, report, args.program, view))
    if args.json:
        emit_json(ProgramCheck(program_summary(plan), report), **written)
    else:
        _print_summary(program_summary(plan))
        _print_safety(report, plan)
        if written:
            print(f'  plot written to {written["plot_file"]}')
    return 0 if report.safe else 1


def _print_safety(r: Any, plan: Any) -> None:
    where = f'in cell {r.cell}' if r.cell else 'against itself (no cell)'
    slip = (f'max slip ratio {r.max_slip_ratio:.3f} ({r.bound} over the motion; {r.max_slip_evaluated:.3f} evaluated '
            f'at {r.max_slip_at:.3f} s, {r.slip_label})') if r.wafer_carried else 'no wafer carried: no slip checked'
    print(f'  clearance {where}: minimum {r.min_clearance * 1e3:.3f} mm (margin {r.margin * 1e3:g} mm, '
          f'{r.between_samples}; {r.evaluations} distance calls); {slip}')
    if not r.slip_certified:
        from ..safety.slip_bound import SLIP_TOLERANCE
        print(f'  the slip bound was not refined to within {SLIP_TOLERANCE:g} of the evaluated ratios (too many '
              'instants): it is looser, still a bound')
    carried = [m for m in r.moves if m.max_slip_ratio > 0.0]
    if carried:
        head = 'waypoint (the move into it and its hold)'
        print(f'    {head:<48} {"from [s]":>9} {"to [s]":>9} {"max slip ratio":>15}')
        for m in carried:
            print(f'    {m.label:<48} {m.start:>9.3f} {m.end:>9.3f} {m.max_slip_ratio:>15.3f}')
    if r.collisions:
        print(f'  UNSAFE: {len(r.collisions)} pair(s) below the margin:')
        print(f'    {"step":>5}  {"station":<16} {"first below [s]":>15}  {"bodies":<40} {"min distance [mm]":>17} '
              f'{"min at [s]":>10}')
        for c in r.collisions:
            below = f'{c.time:>15.3f}' if c.measured_below else f'{"-":>15}'
            print(f'    {c.step:>5}  {c.station:<16} {below}  {" / ".join(c.bodies):<40} '
                  f'{c.distance * 1e3:>17.3f} {_least_at(r, c):>10.3f}')
        print('    (first below: when the pair first comes closer than the margin, to 1 us, in that step at that '
              'station; -: none,\n     the bounds between samples could not show the pair the margin apart; min '
              "distance: the pair's least certified\n     distance over the whole program; min at: the instant of its "
              'smallest measured distance)')
        for c in r.collisions:
            if not c.measured_below:
                print(f'    {c.not_shown(r.margin)}')
        _print_least_elsewhere(r, plan)
    _print_budget(r.budget)
    if r.max_slip_evaluated == float('inf'):  # the blade pulls away faster than gravity and the vacuum hold
        print(f'  UNSAFE: the wafer lifts off the blade (ratio inf: the paddle accelerates away from it faster than '
              f'gravity and the vacuum hold it down) at {r.max_slip_at:.3f} s, {r.slip_label}')
    elif r.max_slip_evaluated >= 1.0:
        print(f'  UNSAFE: the wafer slips on the blade (ratio {r.max_slip_evaluated:.3f} >= 1) at {r.max_slip_at:.3f} '
              f's, {r.slip_label}; {SLIP_HELPS}')
    elif r.max_slip_ratio >= 1.0:
        print(f'  UNSAFE: the slip ratio is not bounded below 1 (its bound {r.max_slip_ratio:.3f}; evaluated at most '
              f'{r.max_slip_evaluated:.3f}, at {r.max_slip_at:.3f} s, {r.slip_label})')
    shown = [c for c in r.collisions if not c.measured_below]
    verdict = ('safe' if r.cell else 'safe against itself only: no cell was checked (a cell: key in the program or '
               '--cell FILE checks one)') if r.safe else 'NOT safe'
    print(f'  {verdict}' + (f' ({len(shown)} pair(s) could not be shown the margin apart, '
                                                      'none measured closer)' if shown == list(r.collisions) and
                                                      shown and r.max_slip_ratio < 1.0 and not r.budget.beyond
                                                      else ''))


def _print_budget(b: Any) -> None:
    print(f'  largest joint displacement {b.max_displacement * 1e6:.3f} um at {b.max_at:.3f} s, {b.max_label} '
          f'(imperfection budget {b.budget * 1e6:g} um; the samples of a stream at {b.rate:g} Hz)')
    if b.beyond:
        print(f'  BEYOND the imperfection budget: {sum(f.samples for f in b.beyond)} sample(s) in {len(b.beyond)} '
              "waypoint(s) (gpr verify fails the recording's state.imperfection_budget there):")
        head = 'waypoint (the move into it and its hold)'
        print(f'    {head:<48} {"first [s]":>9} {"samples":>8} {"max [um]":>10} {"at [s]":>9}')
        for f in b.beyond:
            print(f'    {f.label:<48} {f.first:>9.3f} {f.samples:>8} {f.displacement * 1e6:>10.3f} {f.at:>9.3f}')


def _print_least_elsewhere(r: Any, plan: Any) -> None:
    """For each pair below the margin whose least distance lies in another step than its first instant below it
    (the table's row names the first: a wafer into a chamber's jamb at a place and again at a later pick), that step."""
    from ..safety.check import label_at
    for c in r.collisions:
        least = _least_at(r, c)
        if least == least and label_at(plan, least) != c.label:
            print(f'    {" / ".join(c.bodies)}: least at {least:.3f} s, {label_at(plan, least)} (another step than '
                  f'its first below the margin, {c.label})')


def _least_at(r: Any, c: Any) -> float:
    """When the collision ``c``'s pair is at its least distance: the time of its entry in the report's pairs (the
    same bodies and distance; the collision itself carries the first instant below the margin)."""
    for p in r.pairs:
        if tuple(p['bodies']) == tuple(c.bodies) and p['distance'] == c.distance:
            return float(p['time'])
    return float('nan')


def _cmd_export(args: argparse.Namespace) -> int:
    from ..robot.export import check_table_path, sample_table, waypoint_table, write_table
    from ..robot.plan import sample_plan
    if args.waypoints is None and args.samples is None and args.trajectory is None:
        raise InputError('nothing to export: give --waypoints FILE and/or --samples FILE (.csv or .json), or '
                         '--trajectory FILE.yaml')
    if args.force and args.trajectory is not None:
        raise InputError('--force writes the joint tables of a program that is not safe, and a trajectory is never '
                         'written for one; allowed: --force with --waypoints and/or --samples only')
    for option, path in (('--waypoints', args.waypoints), ('--samples', args.samples)):
        if path is not None:  # refused before the program is planned, named by its option
            check_table_path(path, option)
    margin = margin_of(args, warn=True)
    at_rate = args.samples is not None or args.trajectory is not None
    sample_rate(args.rate)  # with --waypoints alone too: a rate of 99999 Hz is a slip wherever it goes (docs/robot.md)
    _check_trajectory_output(args)
    _, plan = program_plan(args, args.rate if at_rate else None)
    _outputs_read_nowhere(args, plan)
    if args.trajectory is not None:   # before any file is written
        from ..robot.trajectory import within_a_day
        within_a_day(plan.timing.total + args.lead_in, f'{plan.program.source}: the trajectory'
                     + (f' with its --lead-in of {args.lead_in:g} s' if args.lead_in else ''))
    line = progress_line(args.no_progress)
    try:
        unsafe, report = _tables_of_a_safe_program(args, plan, margin, line)
        checked, report = _export_trajectory(args, plan, margin, line, report)   # before any file is written
    finally:
        line.close()
    meta = {'robot': plan.robot.name, 'program': plan.program.source}
    written: dict[str, JsonValue] = {}  # the paths written, under keys of their own (the summary counts 'waypoints')
    if args.waypoints is not None:
        written['waypoints_file'] = str(write_table(args.waypoints, *waypoint_table(plan), meta))
    if args.samples is not None:
        sampled = sample_plan(plan, args.rate)
        written['samples_file'] = str(write_table(args.samples, *sample_table(plan, sampled),
                                                  meta | {'rate': args.rate}))
        written['sample_count'] = len(sampled)
    written |= checked
    written |= _checked(report)
    if args.json:
        emit_json(program_summary(plan), **written)
    else:
        _print_summary(program_summary(plan))
        _print_checked(report)
        for key in ('waypoints', 'samples', 'trajectory'):
            if f'{key}_file' in written:
                print(f'  {key} written to {written[f"{key}_file"]}')
    if unsafe:
        import sys
        print(f'gpr program export: warning: {unsafe}; the tables were written as --force asks, for analysis, not '
              'for a controller', file=sys.stderr)
        return 1
    return 0


def _outputs_read_nowhere(args: argparse.Namespace, plan: Any) -> None:
    """The outputs checked again once the program, its robot and stations are read, its cell noted (its check reads
    it): a trajectory written over the cell was refused only after the check's work."""
    import contextlib
    import os

    from ..inputs.files import check_output, note_read
    with contextlib.suppress(OSError, TypeError):   # no cell (None), or none there: its reader says so
        note_read(os.stat(plan.program.cell))
    for path, what in ((args.waypoints, 'joint table'), (args.samples, 'joint table'), (args.trajectory, 'trajectory')):
        if path is not None:
            check_output(path, what)


def _checked(report: SafetyReport | None) -> dict[str, JsonValue]:
    """``checked``, what the outputs were checked against (``--json``; an engineer had no record of the cell,
    margin and verdict of the tables written): {} when they were not (``--force``)."""
    if report is None:
        return {}
    return {'checked': {'safe': report.safe, 'cell': report.cell, 'margin': report.margin,
                        'min_clearance': json_number(report.min_clearance),
                        'max_slip_ratio': json_number(report.max_slip_ratio), 'wafer_carried': report.wafer_carried}}


def _print_checked(report: SafetyReport | None) -> None:
    """The text of :func:`_checked`: ``checked safe in cell ...: minimum clearance ... (margin ...), ...``."""
    if report is not None:
        where = f'in cell {report.cell}' if report.cell else 'against itself (no cell)'
        slip = (f'max slip ratio {report.max_slip_ratio:.3f}' if report.wafer_carried else
                'no wafer carried: no slip checked')
        print(f'  checked safe {where}: minimum clearance {report.min_clearance * 1e3:.3f} mm (margin '
              f'{report.margin * 1e3:g} mm), {slip}')


def _tables_of_a_safe_program(args: argparse.Namespace, plan: Any, margin: float, line: ProgressLine
                              ) -> tuple[str, SafetyReport | None]:
    """Refuse (:class:`~gpr_kinematics.errors.UnsafeError`, status 1) the joint tables of a program ``gpr program
    check`` finds not safe, as the trajectory is (they drive a controller as it does: a colliding program's and a
    slipping one's were written with exit 0); with ``--force`` the reason, the tables then written (status 1). With
    ``--trajectory`` the check is the trajectory's (:func:`.program_trajectory.as_a_controller_takes_it`). The
    reason with ``--force`` ('' when safe) and the check's report (None when forced or with ``--trajectory``)."""
    from ..errors import UnsafeError
    if args.trajectory is not None:
        return '', None
    try:
        return '', the_program_is_safe(plan, args.rate, 'export', margin, line)[1]
    except UnsafeError as exc:
        if not args.force:
            raise UnsafeError(f'{exc}; --force writes the tables anyway, for analysis (status 1)') from None
        return str(exc).rsplit('; allowed: ', 1)[0], None   # the reason: what is allowed is the refusal's


# -- the program as a joint trajectory: export --trajectory, send ------------------------------------------------
def _check_trajectory_output(args: argparse.Namespace) -> None:
    """Refuse a bad ``--trajectory`` path or ``--lead-in`` before any work."""
    from ..inputs.files import check_output, check_suffix
    if args.trajectory is not None:
        check_suffix(args.trajectory, '--trajectory', ('.yaml', '.yml'))
        check_output(args.trajectory, 'trajectory')
    if not 0.0 <= args.lead_in <= 3600.0:
        raise InputError(f'--lead-in = {args.lead_in:.12g} s; allowed: 0 to 3600 s')
    if args.lead_in and args.trajectory is None:
        raise InputError('--lead-in applies to --trajectory FILE.yaml, which is not given')


def _export_trajectory(args: argparse.Namespace, plan: Any, margin: float, line: ProgressLine,
                       report: SafetyReport | None) -> tuple[dict[str, Any], SafetyReport | None]:
    """``--trajectory``: the program's trajectory at ``--rate``, its points ``--lead-in`` seconds later, checked at
    ``margin`` [m] as a controller takes it (its check's progress on ``line``); its output keys and the check's
    report (``report`` without ``--trajectory``)."""
    if args.trajectory is None:
        return {}, report
    from ..robot.trajectory import program_trajectory, write_trajectory
    traj = program_trajectory(plan, args.rate)
    # in the program's time (its wafers' windows)
    report = as_a_controller_takes_it(plan, traj, args.rate, 'export', margin, line)
    traj = traj.shifted(args.lead_in)
    return {'trajectory_file': write_trajectory(args.trajectory, traj), 'trajectory_points': len(traj),
            'trajectory_duration': traj.duration}, report


def register(sub: Any) -> None:
    """Add ``gpr program`` to the ``gpr`` parser."""
    program = sub.add_parser('program', help='offline programs of the whole robot: check, export the joint tables and '
                             'trajectory, send to a controller',
                             description='Robot programs (docs/robot.md#programs).')
    psub = program.add_subparsers(dest='program_command', metavar='SUBCOMMAND', parser_class=type(program))
    psub.required = True
    p = psub.add_parser('check', help='solve every waypoint, time every move, check clearance and wafer slip')
    p.add_argument('program', metavar='PROGRAM', type=shipped(PROGRAMS), help='robot program YAML file')
    p.add_argument('--cell', metavar='FILE', type=shipped(CELLS),
                   help='the process cell (default: the program\'s cell, else none)')
    add_margin(p, 'the cell and against the robot itself')
    p.add_argument('--plot', metavar='FILE.png', help='clearance and slip ratio against time, the cell from above '
                   '(needs matplotlib)')
    p.add_argument('--rate', type=number, default=STREAM_RATE, help='the rate of the stream whose samples the '
                   f'imperfection budget is judged at [Hz] (trajectory_node\'s rate; default {STREAM_RATE:g}; 0.1 to '
                   '5000)')
    add_no_progress(p)
    robot_options(p, program=True)
    p.set_defaults(handler=_cmd_check)
    p = psub.add_parser('export', help='the joint table per waypoint and per sample, as CSV or JSON; the joint '
                        'trajectory as YAML')
    p.add_argument('program', metavar='PROGRAM', type=shipped(PROGRAMS), help='robot program YAML file')
    p.add_argument('--waypoints', metavar='FILE', help='write the waypoint table (.csv or .json)')
    p.add_argument('--samples', metavar='FILE', help='write the sample table (.csv or .json)')
    p.add_argument('--trajectory', metavar='FILE', help='write the trajectory_msgs/JointTrajectory YAML (.yaml) that '
                   'ros2 action send_goal reads: "{trajectory: $(cat FILE)}"')
    p.add_argument('--lead-in', type=number, default=0.0, metavar='SECONDS', help='--trajectory: the first point this '
                   'much after the start [s] (a controller moves there from where the robot is; 0 to 3600); '
                   'default 0')
    p.add_argument('--rate', type=number, default=100.0, help='sample rate [Hz] (default 100; 0.1 to 5000)')
    p.add_argument('--force', action='store_true', help='write the tables (not a trajectory) of a program check '
                   'finds not safe, for analysis (status 1)')
    add_margin(p, 'the program and its trajectory')
    add_no_progress(p)
    robot_options(p, program=True, cell=True)
    p.set_defaults(handler=_cmd_export)
    send_parser(psub)
