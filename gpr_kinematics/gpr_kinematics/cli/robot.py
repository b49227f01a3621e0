"""``gpr robot fk|ik|teach``: the whole robot on the GPR (docs/robot.md); programs are ``gpr program``.

Inputs are SI (metres, radians) unless ``--mm`` (lengths: positions, rods, heights) or ``--deg`` (angles: tilt,
azimuth, heading, arm joints); outputs are always SI. ``--robot FILE`` names the robot description (default: the
shipped example ``config/robots/example_robot.yaml``), ``--config FILE`` a GPR geometry replacing the description's,
``--json`` prints one JSON object on stdout. Bad input exits with status 2 and one line on stderr.
"""
from __future__ import annotations

import argparse
from typing import TYPE_CHECKING

import numpy as np

from .options import angles, direction, lengths, number, robot_of, robot_options, typed_point, unit_options, vec
from .output import emit_json

if TYPE_CHECKING:
    from ..robot.description import Arm
    from ..robot.forward import RobotForward
    from ..robot.stations import Stations
    from .main import Subparsers


def _print_poses(fk: RobotForward, i: int = 0) -> None:
    for name, pose in (('wafer', fk.wafer), ('blade', fk.blade), ('platform', fk.platform)):
        print(f'  {name:<9} position {vec(pose.position[i])} m, quaternion {vec(pose.quaternion[i], fmt="{:.12f}")}')
    print(f'  naive model: the wafer {fk.naive_wafer_error_norm[i] * 1e6:.3f} um '
          f'{vec(fk.naive_wafer_error[i], 1e6, "{:.3f}")} and {fk.naive_wafer_angle_error[i]:.3e} rad away from '
          'where the old tool places it')


def _typed_joints(args: argparse.Namespace, arm: Arm, limits: bool = True) -> list[float]:
    """``--joints`` [rad]: one value per joint of ``arm`` (the core's words are the array's: shape (N, 3)); under
    ``--deg`` with ``limits`` a value beyond its joint's limits named as typed, the radians beside (the core named the
    radians alone: ``2.96705973 rad`` for a typed 170)."""
    import math

    from ..errors import InputError
    from ..robot.arm_chain import LIMIT_SLACK
    joints = args.joints
    if len(joints) != len(arm.joints):
        raise InputError(f'--joints: {len(joints)} value{"s" if len(joints) != 1 else ""} for arm {arm.name}, which '
                         f'has {len(arm.joints)} joints ({", ".join(arm.joint_names)}); allowed: one value per joint, '
                         'shoulder first')
    values = angles(args, joints)
    for typed, v, j in zip(joints, values, arm.joints, strict=True):
        if args.deg and limits and not j.lower - LIMIT_SLACK <= v <= j.upper + LIMIT_SLACK:
            side, limit = ('lower', j.lower) if v < j.lower else ('upper', j.upper)
            deg = math.degrees
            raise InputError(f'--joints: {j.name} = {typed:.9g} deg ({v:.9g} rad) is beyond its {side} limit '
                             f'{deg(limit):.9g} deg ({limit:.9g} rad) by {abs(deg(v - limit)):.3g} deg; allowed: '
                             f'[{deg(j.lower):.9g}, {deg(j.upper):.9g}] deg')
    return values


def _cmd_fk(args: argparse.Namespace) -> int:
    from ..robot.forward import robot_forward
    from ..robot.stations import stations_from_poses
    robot = robot_of(args)
    arm = robot.arm(args.arm)
    fk = robot_forward(robot, [lengths(args, args.rods)], [_typed_joints(args, arm)], arm.name)
    if args.json:
        emit_json(fk.record(0))
        return 0
    station = stations_from_poses(fk.wafer.position, fk.wafer.rotation)
    print(f'robot {robot.name}, arm {fk.arm}, model {fk.gpr.model}: rods {vec(fk.rods[0])} m, joints '
          f'{vec(fk.joints[0])} rad')
    _print_poses(fk)
    print(f'  station   tilt {station.tilt[0]:.12g} rad, azimuth {station.azimuth[0]:.9g} rad, heading '
          f'{station.heading[0]:.9g} rad')
    return 0


def _station_args(args: argparse.Namespace) -> Stations:
    from ..errors import InputError
    from ..robot.fields import check_world_position
    from ..robot.stations import Stations
    tilt = direction(args, args.tilt, '--tilt')   # a tilt of more than a turn is a slip, as a direction's
    azimuth = direction(args, args.azimuth, '--azimuth')
    heading = None if args.heading is None else [direction(args, args.heading, '--heading')]
    position = lengths(args, args.position)
    check_world_position(position, '--position', '' if args.mm else ' (millimetres? give --mm)', InputError,
                         typed_point(args, args.position, position))   # as typed: --mm named the metres
    return Stations.of([position], tilt, azimuth, heading)


#: A ``--position`` typed under ``--mm`` with every coordinate below this [mm] that no arm reaches: metres typed?
MM_AS_METRES = 10.0


def _cmd_ik(args: argparse.Namespace) -> int:
    from ..errors import GprError
    from ..robot.inverse import solve_stations
    robot = robot_of(args)
    value = None if args.redundancy is None else direction(args, args.redundancy, '--redundancy')
    stations, arm = _station_args(args), robot.arm(args.arm)
    if args.heading is None and len(arm.joints) > 2:   # the core's 'station 0: ...' named no station given
        from ..errors import InputError
        raise InputError(f'--heading is missing: arm {arm.name} has {len(arm.joints)} joints and needs the blade '
                         'heading; allowed: --heading H [rad, or deg with --deg] (free only for a 2-joint arm)')
    red = arm.redundancy
    if value is not None and red is not None and red.rule == 'fixed_joint':   # named as typed, in the unit typed
        from ..errors import InputError
        from ..robot.inverse import held_refusal
        refusal = held_refusal(arm.joints[red.joint], value, '--redundancy = {}', args.deg)
        if refusal:
            raise InputError(refusal)
    try:
        sol = solve_stations(robot, stations, args.arm, args.branch, redundancy_value=value)
    except GprError as exc:   # metres typed under --mm: a station within 10 mm of the world's origin, out of reach
        if not (args.mm and max(abs(v) for v in args.position) < MM_AS_METRES):
            raise
        from ..robot.fields import without_origin_hint
        point = typed_point(args, args.position, [v / 1000.0 for v in args.position])
        said = without_origin_hint(str(exc))   # one hint: the core's (for a station file) said the same
        raise type(exc)(f'{said} (metres typed under --mm? --position {point} lies within {MM_AS_METRES:g} mm of '
                        'the world\'s origin)') from None
    if args.json:
        emit_json(sol.record(0))
        return 0
    a = robot.arm(sol.arm)
    print(f'station inverse kinematics, robot {robot.name}, arm {a.name} (branch {sol.branch[0]}), model '
          f'{sol.forward.gpr.model}:')
    print(f'  rods      {vec(sol.rods[0])} m')
    print('  joints    ' + ', '.join(f'{n} = {v:.9f}' for n, v in zip(a.joint_names, sol.joints[0], strict=True))
          + ' rad')
    _print_poses(sol.forward)
    print(f'  reached to {sol.position_error[0]:.1e} m and {sol.angle_error[0]:.1e} rad; the naive model\'s joints '
          f'would miss the station by {sol.naive_wafer_error_norm[0] * 1e6:.3f} um '
          f'{vec(sol.naive_wafer_error[0], 1e6, "{:.3f}")} and {sol.naive_wafer_angle_error[0]:.3e} rad')
    return 0


def _cmd_teach(args: argparse.Namespace) -> int:
    from ..robot.teach import MOVED_JOINT, RetaughtRecord, TeachReport, read_joint_table, reteach, teach
    robot = robot_of(args)
    if args.table is not None:  # an empty name is refused, not ignored
        from ..errors import InputError
        if args.rods or args.joints:
            raise InputError('give either --table FILE or --rods and --joints, not both')
        if args.mm or args.deg:  # they were ignored: a table's columns without a unit were read as SI all the same
            rod, joint = robot.rods.names[0], robot.arm(args.arm).joints[-1].name   # this robot's names
            raise InputError(f'{"--mm" if args.mm else "--deg"} converts --rods and --joints; a --table gives its '
                             f'units in its header ("{rod} [mm]", "{joint} [deg]") or a "# units: mm deg" line')
        names, rods, joints = read_joint_table(args.table, robot, args.arm, check_limits=not args.naive)
    elif args.rods and args.joints:
        typed = _typed_joints(args, robot.arm(args.arm), limits=not args.naive)
        # no names: one configuration typed, no table's row to name (its station is '0')
        names, rods, joints = None, np.array([lengths(args, args.rods)]), np.array([typed])
    else:
        from ..errors import InputError
        raise InputError('give the joints: --rods Q1 Q2 Q3 and --joints J1 J2 [J3 J4], or --table FILE')
    if args.naive:
        from ..errors import LimitError
        try:
            report = TeachReport(robot.name, True, reteach(robot, rods, joints, args.arm, names).records())
        except LimitError as exc:   # a table's row: named by its file too, as without --naive
            if args.table is None:
                raise
            raise LimitError(f'{args.table}: {exc}') from None
    else:
        report = TeachReport(robot.name, False, teach(robot, rods, joints, args.arm, names).records())
    if args.json:
        emit_json(report)
        return 0
    for row in report.stations:
        if isinstance(row, RetaughtRecord):
            print(f'{row.name}: meant {vec(row.intended.position)} m; new rods {vec(row.rods)} m, joints '
                  + ', '.join(f'{k} = {v:.9f}' for k, v in row.arm.items())
                  + f' rad; the old joints missed by {row.avoided_error * 1e6:.3f} um')
            if row.moved:   # another posture, not a correction (nearest: hi_j3 0.89 rad away for 3.6 um, unsaid)
                # a warning: on stderr, as every command's; the stations' lines stay on stdout
                import sys
                print(f'gpr robot teach: warning: {row.name}: the posture changed: '
                      + ', '.join(f'{k} moved {v:+.3f} rad' for k, v in row.moved.items())
                      + f' from the old joints (more than {MOVED_JOINT:g} rad){_why_moved(robot.arm(args.arm))}',
                      file=sys.stderr)
        else:
            st = row.station
            print(f'{row.name}: station {vec(st.position)} m, tilt {st.tilt:.9g}, azimuth {st.azimuth:.9g}, heading '
                  f'{st.heading:.9g} rad; the naive model would record it {row.naive_error * 1e6:.3f} um away')
    return 0


def _why_moved(arm: Arm) -> str:
    """Why re-teach moved a joint far, for the warning: a 4-joint arm under ``nearest`` keeps no old posture."""
    if arm.redundancy is None or arm.redundancy.rule != 'nearest':
        return ''
    return (f'; arm {arm.name} takes the posture nearest its reference (redundancy rule nearest), not the old one: '
            'under the rule fixed_joint re-teach keeps its held joint\'s old value')


def register(sub: Subparsers) -> None:
    """Add ``gpr robot`` to the ``gpr`` parser."""
    robot = sub.add_parser('robot', help='the whole robot: forward and station inverse kinematics, teach',
                           description='The arm and the wafer on the GPR (docs/robot.md).')
    rsub = robot.add_subparsers(dest='robot_command', metavar='SUBCOMMAND', parser_class=type(robot))
    rsub.required = True
    p = rsub.add_parser('fk', help='rods and arm joints -> wafer, blade and platform in the world',
                        description='Forward kinematics of the whole robot: the platform from the rods (the '
                                    "description's virtual-joint model), then the arm on it; prints the wafer "
                                    'centre, the blade and the platform in the world frame [m, rad] '
                                    '(docs/robot.md).')
    p.add_argument('--rods', type=number, nargs=3, required=True, metavar='Q', help='rod lengths [m, or mm]')
    p.add_argument('--joints', type=number, nargs='+', required=True, metavar='J', help='arm joints [rad, or deg]')
    p.add_argument('--arm', help='arm name (default: the first arm)')
    unit_options(p)
    robot_options(p)
    p.set_defaults(handler=_cmd_fk)

    p = rsub.add_parser('ik', help='a station (wafer pose in the world) -> rods and arm joints',
                        description='Station inverse kinematics: the rods and arm joints that put the wafer centre '
                                    'at --position on a station plane of --tilt and --azimuth, the blade along '
                                    '--heading; every limit checked (docs/robot.md).')
    p.add_argument('--position', type=number, nargs=3, required=True, metavar=('X', 'Y', 'Z'),
                   help='wafer centre in the world [m, or mm]')
    p.add_argument('--tilt', type=number, default=0.0, help='station plane tilt [rad, or deg] (default 0)')
    p.add_argument('--azimuth', type=number, default=0.0, help='azimuth of the tilt axis [rad, or deg] (default 0)')
    p.add_argument('--heading', type=number, help='blade heading in the station plane [rad, or deg]; required for '
                                                   'arms of 3 or 4 joints, free when omitted for a 2-joint arm')
    p.add_argument('--arm', help='arm name (default: the first arm)')
    p.add_argument('--branch', choices=('left', 'right'), help="elbow branch (default: the arm's)")
    p.add_argument('--redundancy', type=number, metavar='VALUE',
                   help='4-joint arm under fixed_joint: the held joint value [rad, or deg]')
    unit_options(p)
    robot_options(p)
    p.set_defaults(handler=_cmd_ik)

    p = rsub.add_parser('teach', help='joints -> stations; with --naive: re-teach joints of the old naive model',
                        description='Teach stations from joints read on the robot (--rods/--joints, or a --table '
                                    'of them): the station each puts the wafer at; with --naive the joints came '
                                    'from a tool that ignored the platform\'s tilt and centre shift, and the joints '
                                    'that put the wafer where it meant are printed (docs/robot.md).')
    p.add_argument('--rods', type=number, nargs=3, metavar='Q', help='rod lengths [m, or mm]')
    p.add_argument('--joints', type=number, nargs='+', metavar='J', help='arm joints [rad, or deg]')
    p.add_argument('--table', metavar='CSV', help='many: a CSV with a header naming the rods and joints (units in '
                                                  'brackets, e.g. "rod_1 [mm]") and an optional name column')
    p.add_argument('--naive', action='store_true', help='the joints came from the naive model (the old tool): '
                                                        'print the joints that put the wafer where it meant')
    p.add_argument('--arm', help='arm name (default: the first arm)')
    unit_options(p)
    robot_options(p)
    p.set_defaults(handler=_cmd_teach)
