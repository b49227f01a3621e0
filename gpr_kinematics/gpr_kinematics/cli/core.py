"""Core subcommands of ``gpr``: fk, ik, compensate, mobility, sweep.

Inputs are SI (metres, radians) unless ``--mm`` (lengths in millimetres) or ``--deg`` (angles in
degrees) is given; outputs are always SI. ``--json`` prints one JSON object on stdout.
"""
from __future__ import annotations

import argparse
import csv
import math
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from ..core.config import MODELS, GprConfig, load_config
from ..core.virtual_joints import EDGE_NAMES
from ..errors import InputError, apart, brief
from ..inputs.units import metres
from .options import direction, number, rod_lengths, tool_point, typed_tilt, vec, whole
from .output import emit_json, json_object

if TYPE_CHECKING:
    from ..core import ForwardResult
    from ..core.sweep import SweepResult
    from .main import Subparsers


def _config(args: argparse.Namespace) -> GprConfig:
    return load_config(args.config)


def _length(args: argparse.Namespace, value: float) -> float:
    return metres(value, bool(getattr(args, 'mm', False)))


#: Lengths typed under ``--mm`` all this small [mm] and not 0: metres typed (``gpr fk 0.5 0.503 0.498 --mm`` ran on
#: rods of half a millimetre without a word; ``gpr robot ik`` hints the same).
METRES_UNDER_MM = 1.0


def _typed_lengths(args: argparse.Namespace, values: list[float], option: str) -> list[float]:
    """``values`` typed as ``option`` in metres (``--mm`` converted), with a warning on stderr where under ``--mm``
    every one is below :data:`METRES_UNDER_MM` and not all are 0: metres typed under ``--mm``?"""
    if getattr(args, 'mm', False) and any(values) and all(abs(v) < METRES_UNDER_MM for v in values):
        import sys
        typed = ' '.join(f'{v:g}' for v in values)
        print(f'gpr {args.command}: warning: {option} = {typed} mm (under --mm): metres typed under --mm? (as metres '
              f'{typed} m)', file=sys.stderr)
    return [_length(args, v) for v in values]


def _angle(args: argparse.Namespace, value: float) -> float:
    return math.radians(value) if getattr(args, 'deg', False) else value


def _common(p: argparse.ArgumentParser, lengths: bool = True, angles: bool = False,
            model: bool = True) -> None:
    if model:
        p.add_argument('--model', choices=MODELS, help='virtual-joint model (default: from the config)')
    p.add_argument('--config', metavar='FILE', help='YAML file overriding the package config (config/gpr.yaml)')
    if lengths:
        p.add_argument('--mm', action='store_true', help='input lengths are in millimetres (output stays SI)')
        p.set_defaults(mm_converts_all=True)   # every length the command is given: no mm hint under --mm (main)
    if angles:
        p.add_argument('--deg', action='store_true', help='input angles are in degrees (output stays SI)')
    p.add_argument('--json', action='store_true', help='print one JSON object on stdout')


def _print_pose(fk: ForwardResult) -> None:
    print(f'  position      {vec(fk.position)} m')
    print(f'  quaternion    {vec(fk.quaternion, fmt="{:.12f}")} (x, y, z, w)')
    print(f'  tilt          {fk.tilt:.12g} rad ({math.degrees(fk.tilt):.9g} deg), azimuth '
          f'{fk.tilt_azimuth:.9g} rad ({math.degrees(fk.tilt_azimuth):.6g} deg), twist {fk.twist:.3e} rad')


def _cmd_fk(args: argparse.Namespace) -> int:
    from ..core import forward
    cfg = _config(args)
    fk = forward(_typed_lengths(args, list(args.q), 'q'), config=cfg, model=args.model)
    if args.json:
        emit_json(fk)
        return 0
    print(f'forward kinematics, model {fk.model}: q = {vec(fk.q)} m')
    _print_pose(fk)
    from ..core.virtual_joints import make_model
    names = ', '.join(f'{n} = {v:.9g}' for n, v in zip(fk.virtual_joint_names, fk.virtual_joints, strict=True))
    print(f'  virtual joints {names} ({"m, rad" if make_model(cfg, fk.model).angular.any() else "m"})')
    print(f'  side lengths  {", ".join(EDGE_NAMES)} = {vec(fk.side_lengths)} m')
    print(f'  centre shift  {vec(fk.centre_shift, 1e6, "{:.3f}")} um (versus the naive model)')
    print(f'  joint displacement {vec(fk.joint_displacement, 1e6, "{:.3f}")} um, '
          f'{"within" if fk.within_budget else "BEYOND"} the imperfection budget '
          f'{cfg.imperfection_budget * 1e6:.1f} um')
    print(f'  Newton: {fk.iterations} iterations, closure residual {fk.residual:.2e} m, '
          f'rigid fit {fk.fit_residual:.2e} m')
    return 0


def _add_target(p: argparse.ArgumentParser, command: bool = False) -> None:
    """The target of ``ik``, or (``command``) the naively commanded pose of ``compensate``, whose --height is the
    platform origin's and whose tool point keeps the height that command gives it (as ``compensate`` does)."""
    p.add_argument('--height', type=number, required=True,
                   help='commanded height of the platform origin (the naive model\'s pose) [m, or mm with --mm]'
                   if command else 'height of the platform point [m, or mm with --mm]')
    p.add_argument('--tilt', type=number, required=True, help='tilt angle [rad, or deg with --deg]; signed')
    p.add_argument('--azimuth', type=number, required=True,
                   help='azimuth of the tilt axis in gpr_base [rad, or deg with --deg]')
    p.add_argument('--tool', type=number, nargs=3, metavar=('X', 'Y', 'Z'), default=(0.0, 0.0, 0.0),
                   help='tool point (in gpr_platform) that reaches the height the commanded pose gives it [m, or mm]; '
                   'default origin' if command else
                   'platform point (in gpr_platform) whose height is prescribed [m, or mm]; default origin')


def _cmd_ik(args: argparse.Namespace) -> int:
    from ..core import inverse
    cfg = _config(args)
    tool = tool_point(args)
    tilt = _angle(args, args.tilt)
    typed_tilt(args, '--tilt', tilt, args.tilt, cfg)   # named as the option, with the hint of degrees as radians
    ik = inverse(_typed_lengths(args, [args.height], '--height')[0], tilt, direction(args, args.azimuth, '--azimuth'),
                 config=cfg, model=args.model, tool=tool)
    if args.json:
        emit_json(ik)
        return 0
    print(f'inverse kinematics, model {ik.achieved.model}: q = {vec(ik.q)} m ({ik.iterations} iterations)')
    print('achieved pose:')
    _print_pose(ik.achieved)
    print(f'  centre shift  {vec(ik.achieved.centre_shift, 1e6, "{:.3f}")} um')
    return 0


def _cmd_compensate(args: argparse.Namespace) -> int:
    from ..core.compensation import compensate
    from ..core.rotations import quaternion_from_matrix, rotation_z, tilt_rotation
    cfg = _config(args)
    # The command is built from the typed angles: check them by name before they become a quaternion.
    tilt = direction(args, args.tilt, '--tilt')   # 2pi - 0.02 is -0.02 once a rotation: within a turn
    azimuth, heading = (direction(args, getattr(args, n), f'--{n}') for n in ('azimuth', 'heading'))
    # the tilt of the command's normal, as compensation checks it (2pi - 0.02 rad tilts it 0.02 rad)
    typed_tilt(args, '--tilt', tilt, args.tilt, cfg, tilt=abs(math.remainder(tilt, 2.0 * math.pi)))
    R = tilt_rotation(tilt, azimuth) @ rotation_z(heading)
    res = compensate([0.0, 0.0, _length(args, args.height)], quaternion_from_matrix(R), tool_point(args), config=cfg,
                     model=args.model)
    if args.json:
        emit_json(res)
        return 0
    print(f'compensation, model {res.achieved.model}: command q = {vec(res.q)} m')
    print('platform pose reached:')
    _print_pose(res.achieved)
    print(f'  tool point    commanded {vec(res.tool_commanded)} m, reached {vec(res.tool_achieved)} m')
    print(f'  tool shift    {vec(res.tool_shift, 1e6, "{:.3f}")} um')
    print(f'  height solved for the platform point {vec(res.platform_point)} m (gpr_platform: the tool turned '
          f'by the heading)')
    print(f'  arm correction (apply to targets in the platform frame): translation '
          f'{vec(res.arm_correction_translation, 1e6, "{:.3f}")} um, quaternion '
          f'{vec(res.arm_correction_quaternion, fmt="{:.12f}")}')
    return 0


def _cmd_mobility(args: argparse.Namespace) -> int:
    from ..core.mobility import analyze_mobility, rod_change
    cfg = _config(args)
    res = analyze_mobility([_length(args, v) for v in args.q], config=cfg, model=args.model)
    change = None if args.dq is None else rod_change(res, [_length(args, v) for v in args.dq], cfg)
    if args.json:
        out = json_object(res)
        bounds = out['bounds']
        if change is not None and isinstance(bounds, dict):  # the bounds of eqs. (4), (5), and those for dq
            bounds['for_dq'] = json_object(change)
        emit_json(out)
        return 0
    print(f'mobility analysis (paper §IV-A), model {res.model}, q = {vec(res.q)} m')
    print(f'  rank dPhi/dP = {res.rank_dphi_dp} (mobility h = {res.mobility}); '
          f'rank [dPhi/dP dPhi/dX] = {res.rank_augmented}; singular configuration: '
          + ('yes (h > 1: the rigid mechanism gains instantaneous freedoms)' if res.singular else 'no'))
    print(f'  non-zero singular values of dX/dP: {vec(res.singular_values, fmt="{:.6g}")}')
    print(f'  |dX| / |projected dP| in [{res.bounds["eq4"][0]:.6g}, {res.bounds["eq4"][1]:.6g}] (eq. 4), '
          f'[{res.bounds["eq5"][0]:.6g}, {res.bounds["eq5"][1]:.6g}] (eq. 5)')
    if change is not None:
        from ..core.virtual_joints import make_model
        full = change.norm_dx_full
        u = 'm|rad' if make_model(cfg, res.model).angular.any() else 'm'  # |dX| of lengths and angles: mixed
        print(f'  for dq = {vec(change.dq, fmt="{:.3e}")} m: first order |dX/dP dP| = {change.norm_dx:.6e} {u} '
              f'(eq. 3), eq. 4 [{change.lower_eq4:.6e}, {change.upper_eq4:.6e}] {u}, eq. 5 [{change.lower_eq5:.6e}, '
              f'{change.upper_eq5:.6e}] {u}; '
              + (f'full solve |X(q + dq) - X(q)| = {full:.6e} {u}' if full is not None
                 else f'no full solve ({change.full_solve_refused})')
              + (' (at the singular configuration the first order of a rod change vanishes)' if res.singular else ''))
    return 0


def _write_csv(path: str, s: SweepResult) -> Path:
    """Every sample of the sweep ``s`` as CSV (SI units, floats to round-trip), atomically; the path written."""
    from ..inputs.files import atomic_output
    fk = s.forward
    names = list(fk.virtual_joint_names)
    header = (['sample', 'pass', 'gamma', 'alpha', 'q1', 'q2', 'q3', 'x', 'y', 'z', 'qx', 'qy', 'qz', 'qw',
               'tilt', 'tilt_azimuth', 'twist', 'centre_shift_x', 'centre_shift_y', 'centre_shift_z']
              + names + [*EDGE_NAMES, 'iterations', 'residual'])
    cols = np.column_stack([np.arange(len(s)), s.pass_index, s.gamma, s.alpha, s.q, fk.position, fk.quaternion,
                            fk.tilt, fk.tilt_azimuth, fk.twist, fk.centre_shift, fk.virtual_joints,
                            fk.side_lengths, fk.iterations, fk.residual])
    with atomic_output(path, 'CSV') as fh:
        w = csv.writer(fh)
        w.writerow(header)
        for row in cols:
            w.writerow([int(row[0]), int(row[1])] + [repr(float(v)) for v in row[2:-2]]
                       + [int(row[-2]), repr(float(row[-1]))])
    return Path(path)


def _check_sweep_options(args: argparse.Namespace, cfg: GprConfig) -> None:
    """``gpr sweep``'s steps and passes against the core's bounds, named as typed and in the unit typed."""
    from ..core import sweep
    unit = 'deg' if args.deg else 'rad'
    for option, value in (('--max-tilt', args.max_tilt), ('--tilt-step', args.tilt_step),
                          ('--azimuth-step', args.azimuth_step)):   # named as typed, not as the radians they become
        if value is not None and not 0.0 < value < math.inf:   # inf and nan named alike, as typed
            raise InputError(f'{option} = {value:g} {unit}; allowed: a positive finite angle')
        least = sweep.LEAST_STEPS.get(option[2:].replace('-', '_'), 0.0)
        if value is not None and _angle(args, value) < least:   # the core's bound, named as typed
            shown = f'{math.degrees(least):g} deg' if args.deg else f'{least:g} rad'
            raise InputError(f'{option} = {value:g} {unit}; allowed: a step of at least {shown}')
    if not 1 <= args.passes <= sweep.MAX_PASSES:
        raise InputError(f'--passes = {brief(args.passes)}; allowed: an integer from 1 to {sweep.MAX_PASSES}')
    if args.azimuth_step is not None:   # beyond a turn: degrees typed as radians, as a typed direction
        direction(args, args.azimuth_step, '--azimuth-step')
        _divides_a_turn(args, args.azimuth_step)
    if args.tilt_step is not None and not args.deg and args.tilt_step > cfg.tilt_limit:   # 0.2 meant 0.2 deg
        shown, limit = apart(args.tilt_step, cfg.tilt_limit)
        raise InputError(f'--tilt-step = {shown} rad is more than the tilt limit {limit} rad '
                         f'({math.degrees(cfg.tilt_limit):g} deg); allowed: a step within it (give --deg for degrees)')


def _divides_a_turn(args: argparse.Namespace, typed: float) -> None:
    """Refuse an ``--azimuth-step`` that is not a whole part of a turn, within the tilt step's tolerance (1e-9 of the
    count; :func:`~gpr_kinematics.core.sweep.sweep_grid`): 7 deg swept 52 azimuths, 0 to 357 deg, and left a gap of
    3 deg before 360 without a word. Named as typed, with the nearest steps that divide a turn (each taken as typed:
    within the tolerance, and not below the least step)."""
    from ..core.sweep import LEAST_STEPS, azimuth_count
    unit, turn = ('deg', 360.0) if args.deg else ('rad', 2.0 * math.pi)
    count = turn / typed   # at least 1: a step beyond a turn was refused
    if azimuth_count(count) is not None:
        return
    more = math.ceil(count)   # the azimuths the sweep makes
    last = (more - 1) * typed
    least = math.degrees(LEAST_STEPS['azimuth_step']) if args.deg else LEAST_STEPS['azimuth_step']
    nearest = [f'{turn / n:.12g} {unit} ({n} azimuth{"s" if n > 1 else ""})' for n in (more, more - 1)
               if n >= 1 and turn / n >= least]
    raise InputError(f'--azimuth-step = {typed:g} {unit} does not divide a turn: its {more} azimuths from 0 to '
                     f'{last:.6g} {unit} leave {turn - last:.6g} {unit} before {"360 deg" if args.deg else "2pi rad"}; '
                     f'allowed: a step that divides a turn a whole number of times, the nearest {" or ".join(nearest)}')


def _cmd_sweep(args: argparse.Namespace) -> int:
    from ..core import sweep
    from ..inputs.files import check_output, check_suffix
    if args.csv is not None:   # a .csv (it overwrote a YAML file), before the work, not after it
        check_output(args.csv, 'CSV')
        check_suffix(args.csv, '--csv', ('.csv',))
    cfg = _config(args)

    def given(value: float | None, convert: Callable[[argparse.Namespace, float], float], default: float) -> float:
        # Defaults are SI already: --mm/--deg convert only what the user typed.
        return default if value is None else convert(args, value)

    _check_sweep_options(args, cfg)
    max_tilt, tilt_step = (given(args.max_tilt, _angle, sweep.DEFAULT_MAX_TILT),
                           given(args.tilt_step, _angle, sweep.DEFAULT_TILT_STEP))
    if args.max_tilt is not None:   # named as the option, with the hint of degrees typed as radians
        typed_tilt(args, '--max-tilt', max_tilt, args.max_tilt, cfg, allowed='--max-tilt')
    # named as typed, in the unit typed (the core's messages name its parameters in radians)
    unit = 'deg' if args.deg else 'rad'
    typed = [v if v is not None else (math.degrees(d) if args.deg else d) for v, d in
             ((args.tilt_step, sweep.DEFAULT_TILT_STEP), (args.max_tilt, sweep.DEFAULT_MAX_TILT))]
    if tilt_step > max_tilt:
        raise InputError(f'--tilt-step = {typed[0]:g} {unit} is more than --max-tilt = {typed[1]:g} {unit}; allowed: '
                         'a step that divides --max-tilt a whole number (>= 1) of times')
    try:
        s = sweep.paper_sweep(height=given(args.height, _length, sweep.DEFAULT_HEIGHT),
                              max_tilt=max_tilt, tilt_step=tilt_step,
                              azimuth_step=given(args.azimuth_step, _angle, sweep.DEFAULT_AZIMUTH_STEP),
                              passes=args.passes, config=cfg, model=args.model, serpentine=not args.paper_order)
    except sweep.TiltStepsError:   # --max-tilt 0.5 --deg was named as 0.00872664625997 rad of 0.00349065850399 rad
        raise InputError(f'--max-tilt = {typed[1]:.15g} {unit} is not a whole number (>= 1) of --tilt-step = '
                         f'{typed[0]:.15g} {unit}; allowed: a --tilt-step that divides --max-tilt a whole number of '
                         'times (every pass then crosses alpha = 0)') from None
    written = None if args.csv is None else str(_write_csv(args.csv, s))
    summary = s.summary
    if args.json:
        emit_json(summary, **({'csv': written} if written else {}))
        return 0
    print(f'paper sweep (§VI), model {summary.model}, height {summary.height:.6g} m: '
          f'{summary.samples} samples, {summary.singular_crossings} crossings of the singular configuration')
    print(f'  max centre shift        {summary.max_centre_shift * 1e6:10.3f} um (versus the naive model)')
    print(f'  max joint displacement  {summary.max_joint_displacement * 1e6:10.3f} um '
          f'({"within" if summary.within_budget else "BEYOND"} the budget '
          f'{cfg.imperfection_budget * 1e6:.0f} um)')
    print(f'  max closure residual    {summary.max_residual:10.2e} m, rigid fit {summary.max_fit_residual:.2e} m')
    print(f'  Newton iterations       forward <= {summary.max_fk_iterations}, '
          f'inverse <= {summary.max_ik_iterations}')
    if written:
        print(f'  samples written to {written}')
    return 0


def register(sub: Subparsers) -> None:
    """Add the core subcommands to the ``gpr`` parser."""
    p = sub.add_parser('fk', help='forward kinematics: rod lengths -> platform pose',
                       description='Forward kinematics under the virtual-joint model (paper §IV-V).')
    rod_lengths(p)
    _common(p)
    p.set_defaults(handler=_cmd_fk)

    p = sub.add_parser('ik', help='inverse kinematics: height and tilt -> rod lengths',
                       description='Inverse kinematics: the rod lengths whose forward kinematics gives the tilt '
                                   '(angle about the horizontal axis at the azimuth) and the height.')
    _add_target(p)
    _common(p, angles=True)
    p.set_defaults(handler=_cmd_ik)

    p = sub.add_parser('compensate', help='compensation of a naively commanded pose for offline programming',
                       description='Rod commands, pose reached, tool shift and arm correction for a platform '
                                   'pose commanded with the naive model (rotation about the centre).')
    _add_target(p, command=True)
    p.add_argument('--heading', type=number, default=0.0,
                   help='commanded rotation about the platform normal [rad, or deg]; the GPR cannot realise '
                        'it, the arm correction takes it up')
    _common(p, angles=True)
    p.set_defaults(handler=_cmd_compensate)

    p = sub.add_parser('mobility', help='mobility and sensitivity analysis (ranks, eqs. 4, 5)',
                       description='Ranks of dPhi/dP and [dPhi/dP dPhi/dX], singular values and bounds of dX '
                                   '(paper §IV-A).')
    rod_lengths(p)
    p.add_argument('--dq', type=number, nargs=3, metavar=('D1', 'D2', 'D3'),
                   help='a change of the rod lengths: also print |dX| and its bounds for it [m, or mm]')
    _common(p)
    p.set_defaults(handler=_cmd_mobility)

    p = sub.add_parser('sweep', help="the paper's singular-tilt sweep with a summary",
                       description='For each azimuth over 0..360 deg, the tilt from -max to +max in steps, at a '
                                   'height (paper §VI): inverse and forward kinematics of every sample.')
    p.add_argument('--height', type=number, help='platform height [m, or mm] (default 0.5 m)')
    p.add_argument('--max-tilt', type=number, help='largest tilt [rad, or deg] (default 2 deg)')
    p.add_argument('--tilt-step', type=number, help='tilt step [rad, or deg] (default 0.2 deg)')
    p.add_argument('--azimuth-step', type=number, help='azimuth step [rad, or deg] (default 10 deg)')
    p.add_argument('--passes', type=whole, default=1, help='repeat the azimuth sweep this many times (default 1)')
    p.add_argument('--paper-order', action='store_true',
                   help='every pass from -max to +max (default alternates direction so the stream is continuous)')
    p.add_argument('--csv', metavar='FILE', help='write every sample to a CSV file (SI units)')
    _common(p, angles=True)
    p.set_defaults(handler=_cmd_sweep)
