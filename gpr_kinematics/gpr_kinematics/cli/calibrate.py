"""``gpr calibrate``: identify the geometry from measured poses or points, or plan the measurements; with ``--robot``,
the arms.

Examples::

    gpr calibrate config/calibration/synthetic_measurements.csv --output calibrated.yaml
    gpr calibrate MEASUREMENTS --output calibrated.yaml --free rod_offsets rod_directions kappa
    gpr calibrate TRACKER.csv --frame tracker --output calibrated.yaml      # the tracker where it stands
    gpr calibrate POINTS.csv --frame tracker --target 0.1 0 0.05 --fit-target --output calibrated.yaml
    gpr calibrate --plan 12 --output plan.csv --json
    gpr calibrate --plan 40 --points --frame tracker --target 0.1 0 0.05 --fit-target
    gpr calibrate --robot robot.yaml ARM1.csv --output robot_calibrated.yaml
    gpr calibrate MEASUREMENTS --output calibrated.yaml --plot residuals.png     # residuals before and after

A fit that fails its gate (not at a minimum, chi-square or cross-validation: docs/calibration.md) exits with status 1,
the report on stdout and the reason on stderr, and writes no calibrated file unless ``--force`` (then the file, still
status 1); a ``--plot`` is drawn either way.
The measurement file formats, the identification, registration, the gate and the plan: docs/calibration.md.
Plugin of :mod:`gpr_kinematics.cli.main` (``register(subparsers)``).
"""
from __future__ import annotations

import argparse
import contextlib
import math
import re
from collections.abc import Sequence
from dataclasses import replace
from datetime import datetime, timezone
from functools import partial
from typing import TYPE_CHECKING

from ..core.config import MODELS
from ..errors import InputError
from ..inputs.resources import MEASUREMENTS, ROBOTS, TOLERANCES
from ..inputs.units import as_typed, both_units
from .calibrate_options import (
    EXIT_GATE,
    base_option,
    config,
    declared,
    fixed_frame,
    free_names,
    gate_outcome,
    pose,
    priors,
    refuse_unused_sigmas,
    sigmas,
    table_of,
    with_given_poses,
)
from .options import number, png_plot, shipped, whole
from .output import emit_json
from .progress import add_no_progress, progress_line

#: The tracker's frame name (``--frame``).
_FRAME = re.compile(r'[A-Za-z0-9_]{1,64}')

if TYPE_CHECKING:
    from ..calibration.identifiability import Combination
    from ..calibration.model import PoseModel
    from ..core.geometry_covariance import GeometryCovariance
    from .main import Subparsers


def _calibrate(args: argparse.Namespace) -> int:
    from ..calibration.core_model import (
        CoreModel,
        beyond_budget,
        check_limits,
        fitted_covariance,
        measured_forward,
        refused_rows,
        write_calibrated_config,
    )
    from ..calibration.frames import FramedModel, measuring_model
    from ..calibration.identification import identify
    from ..calibration.measurements import read_measurements
    from ..calibration.registration import registration
    from ..calibration.report import format_calibration
    if args.output is None:
        raise InputError('--output FILE is required: the calibrated geometry is written there')
    if len(args.measurements) != 1:
        raise InputError(f'give one MEASUREMENTS file of the GPR (got {len(args.measurements)}); several files are '
                         'for the arms, with --robot')
    cfg = config(args)
    line = progress_line(args.no_progress)   # 70,000 rows took 2 min of CPU time
    try:
        meas = read_measurements(args.measurements[0], line)
        refuse_unused_sigmas(args, meas, args.measurements[0])
        check_limits(meas, cfg)
        core = CoreModel(cfg, args.model)
        model = measuring_model(core, meas, args.frame, pose(args.base, args, '--base', (6,)),
                                pose(args.target, args, '--target', (3, 6)), args.fit_target, args.free)
        table = table_of(args)
        sp, sa = sigmas(args, table)
        prior, bound = priors(table, model)
        res = with_given_poses(args, partial(identify, model, meas, free=free_names(args, model), sigma_position=sp,
                                             sigma_angle=sa, threshold=args.threshold, prior=prior, bound=bound,
                                             frame=args.frame, declared=declared(args), progress=line))
    finally:
        line.close()
    reg = None
    if isinstance(model, FramedModel):
        reg = registration(model, res.estimate, res.standard_error, res.fitted, res.covariance, args.frame,
                           res.bias)
        calibrated = core.config_for(model.inner_theta(res.estimate[None])[0])
    else:
        calibrated = core.config_for(res.estimate)
    fk = measured_forward(calibrated, meas.q)   # once for both warnings
    res = replace(res, warnings=res.warnings + beyond_budget(calibrated, meas.q, fk)
                  + refused_rows(calibrated, meas, fk))
    write = gate_outcome(res.gate.passed, res.gate.message(), args)
    plotted: dict[str, str] = {}
    if args.plot is not None:   # also when the gate fails: the picture helps most then
        from ..calibration.plot import plot_residuals
        from ..calibration.residual_plot import residual_plot
        plotted['plot_file'] = str(plot_residuals(args.plot, residual_plot(model, meas, res, sp, sa, declared(args))))
    path = None
    if write:
        cov = fitted_covariance(model, res, args.frame)
        stamp = datetime.now(timezone.utc).strftime('%Y-%m-%dT%H:%M:%SZ')
        comments = (f'GPR geometry calibrated by `gpr calibrate` from {args.measurements[0]} ({res.rows} rows, '
                    f'measured in {args.frame}), {stamp}',
                    f'fitted: {", ".join(res.parameters[j].name for j in res.fitted) or "none"}; '
                    f'{_held_where(res.identifiability.combinations)}',
                    f'pose residuals RMS before {res.before.rms_position:.3e} m, {res.before.rms_angle:.3e} rad; after '
                    f'{res.after.rms_position:.3e} m, {res.after.rms_angle:.3e} rad; gate '
                    f'{"passed" if res.gate.passed else "FAILED (written with --force)"}',
                    *(f'registration: {line}' for line in (reg.lines() if reg else [])),
                    *(_covariance_words(cov) if cov else ()),
                    'SI units; use with any command: --config THIS_FILE')
        path = write_calibrated_config(args.output, calibrated, comments, cov)
    if args.json:
        emit_json(res.as_dict() | {'model': calibrated.model, 'output': str(path) if path else None,
                                   'registration': reg.as_dict() if reg else None} | plotted)
    else:
        print(format_calibration(res))
        if reg:
            print('\n'.join(f'registration: {line}' for line in reg.lines()))
        if path:
            print(f'calibrated geometry written to {path} (use it with --config {path})')
        if plotted:
            print(f'plot written to {plotted["plot_file"]}')
    return 0 if res.gate.passed else EXIT_GATE


def _covariance_words(cov: GeometryCovariance) -> tuple[str, ...]:
    """The comment that says what the file's covariance block is."""
    words = (f'covariance: of the {len(cov.geometry().names)} fitted parameters (SI; kappaK as its anisotropy '
             "(kappa - 1) / (kappa + 1)), for the arms' standard errors: gpr calibrate --robot ROBOT --config "
             'THIS_FILE',)
    if cov.base is None:
        return words
    return words + (f'its base: the registration of gpr_base in {cov.base.frame} with the geometry, for an arm '
                    f'measured there: --frame {cov.base.frame} --base THIS_FILE --config THIS_FILE',)


def _held_where(combinations: Sequence[Combination]) -> str:
    """``held at nominal: a, b; held at its rod's place: c``: the held parameters by where they are held (``held at
    nominal: none`` without any)."""
    where: dict[str, list[str]] = {}
    for c in combinations:
        where.setdefault(c.held_at, []).append(c.held)
    return '; '.join(f'held at {at}: {", ".join(names)}' for at, names in where.items()) or 'held at nominal: none'


def _plan(args: argparse.Namespace) -> int:
    from ..calibration.core_model import CoreModel
    from ..calibration.files import comment_lines, write_text
    from ..calibration.frames import FramedModel, Transform
    from ..calibration.monte_carlo import drawn_from
    from ..calibration.plan import plan_measurements
    from ..calibration.report import format_plan
    from ..calibration.tolerances import centre_of
    cfg = config(args)
    core = CoreModel(cfg, args.model)
    model: PoseModel = core
    target = pose(args.target, args, '--target', (3, 6))
    fit_target = args.fit_target or (None if target is not None or (args.frame == 'gpr_base' and not args.points)
                                     else 'position' if args.points else 'pose')
    if args.frame != 'gpr_base' or fit_target or args.points or target is not None:
        base = pose(args.base, args, '--base', (6,))
        model = FramedModel(core, base or Transform.identity(), target or Transform.identity(),
                            args.frame != 'gpr_base' and base is None, fit_target, args.points, args.free)
    table = table_of(args)
    sp, sa = sigmas(args, table)
    prior, _ = priors(table, model)
    with contextlib.nullcontext() if table is None else drawn_from(table):   # planned at the table's centre
        plan = plan_measurements(model, cfg, args.plan, index=args.index or 'product', free=free_names(args, model),
                                 sigma_position=sp, sigma_angle=sa, threshold=args.threshold, prior=prior,
                                 theta=centre_of(table, model.parameters) if table is not None else None,
                                 points=args.points)
    path = None
    if args.output is not None:
        measure = 'x,y,z' if args.points else 'x,y,z,qx,qy,qz,qw'
        text = (comment_lines([f'measurement plan of `gpr calibrate --plan {args.plan}`: observability index '
                               f'({plan.index_name}) {plan.index:.6g}',
                               f'measure the target at each row in {args.frame} and add the columns {measure} '
                               '(docs/calibration.md)', 'units: m rad'])
                + 'q1,q2,q3\n' + ''.join(','.join(repr(float(v)) for v in row) + '\n' for row in plan.q))
        path = write_text(args.output, text, 'plan')
    if args.json:
        emit_json(plan.as_dict() | ({'output': str(path)} if path else {}))
        return 0
    print(format_plan(plan, sp, sa))
    if path:
        print(f'configurations written to {path}')
    return 0


def _check_outputs(args: argparse.Namespace) -> None:
    """Refuse, before any fit, an ``--output`` named unlike what is written (``--output x.csv`` got the calibrated
    geometry's YAML) or that cannot be written (a folder was refused only after the fit); and ``--plot``
    (:func:`_check_plot`)."""
    from ..inputs.files import check_output, check_suffix
    if args.output is not None:
        what, suffixes = ('plan', ('.csv',)) if args.plan is not None else (
            'calibrated robot' if args.robot is not None else 'calibrated geometry', ('.yaml', '.yml'))
        check_output(args.output, what)
        check_suffix(args.output, '--output', suffixes, f' (the {what} is written as {suffixes[0][1:].upper()})')
    if args.plot is not None:
        _check_plot(args)


def _check_plot(args: argparse.Namespace) -> None:
    """Refuse, before any fit, a ``--plot`` with ``--plan`` (it draws a fit's residuals), and what
    :func:`~.options.png_plot` refuses."""
    if args.plan is not None:
        raise InputError('--plot draws the residuals of a fit, and --plan fits nothing; allowed: --plot with '
                         'MEASUREMENTS files (of the GPR, or with --robot of the arms)')
    png_plot(args.plot)


def _check_plan_options(args: argparse.Namespace) -> None:
    """Refuse the options of a plan without ``--plan``, and those of a fit with it (each was accepted and did
    nothing)."""
    if args.robot is not None and args.plan is not None:
        raise InputError('--plan is for the GPR; the arms are calibrated from measured files (--robot FILE CSV...)')
    if args.points and args.plan is None:   # the arms' files too
        raise InputError('--points goes with --plan (a measurement file says itself whether it has orientations)')
    if args.index is not None and args.plan is None:
        raise InputError('--index goes with --plan (the observability index a plan maximises)')
    if args.force and args.plan is not None:
        raise InputError('--force writes a fit that failed its gate, and --plan fits nothing; allowed: --force with '
                         'a MEASUREMENTS file')


def _handler(args: argparse.Namespace) -> int:
    if bool(args.measurements) == (args.plan is not None):
        raise InputError('give a MEASUREMENTS file to calibrate from, or --plan N for a measurement plan '
                         + ('(not both)' if args.measurements else '(neither was given)'))
    if not (math.isfinite(args.threshold) and args.threshold > 0):
        raise InputError(f'--threshold = {args.threshold!r}; allowed: a finite number > 0')
    from ..calibration.measurements import SIGMA_RANGE
    lo, hi = SIGMA_RANGE
    sp, sa = sigmas(args)
    for flag, typed, si, unit, own in (('--sigma-position', args.sigma_position, sp, 'm', 'mm' if args.mm else 'm'),
                                       ('--sigma-angle', args.sigma_angle, sa, 'rad', 'deg' if args.deg else 'rad')):
        if not lo <= si <= hi:   # named as typed (20 deg), the bounds in both units: it said '0.349... (SI)'
            raise InputError(f'{flag} = {as_typed(typed, si, unit, own)}; allowed: a standard deviation from '
                             f'{both_units(lo, hi, unit, own)}')
    args.base, args.base_file = base_option(args.base, args.robot is not None)
    if not _FRAME.fullmatch(args.frame):   # isalnum took any script's letters and digits
        raise InputError(f'--frame {args.frame[:64]!r}; allowed: a frame name of 1 to 64 ASCII letters, digits and _')
    if args.robot is None:
        from ..core.config import GprConfig
        from ..robot.urdf import gpr_urdf
        fixed_frame(args.frame, gpr_urdf(GprConfig()))   # the frames' names: any geometry's
    # --base in gpr_base was applied: 0.5 mm moved the rod offsets by 0.5 mm
    if (args.base is not None or args.base_file is not None) and args.frame == 'gpr_base':
        raise InputError('--base gives the pose of gpr_base in --frame, which is gpr_base itself (the default): the '
                         'identity; allowed: --base with --frame naming the frame the measurements are in (tracker)')
    _check_plan_options(args)
    _check_outputs(args)
    if args.robot is not None:
        from .calibrate_robot import calibrate_robot
        return calibrate_robot(args)
    return _plan(args) if args.plan is not None else _calibrate(args)


def register(sub: Subparsers) -> None:
    """Add ``gpr calibrate`` to the ``gpr`` parser."""
    p = sub.add_parser('calibrate', help='identify the geometry (or the arms) from measured poses or points, or plan '
                                         'the measurements',
                       description='Identify the geometric parameters from measured platform poses or points '
                                   '(weighted least squares, standard errors, the bias of what is held, '
                                   'cross-validation, identifiability, the frames of the tracker and the target) and '
                                   'write the calibrated geometry; or, with --plan N, propose N measurement '
                                   'configurations; or, with --robot, calibrate the arms.')
    p.add_argument('measurements', nargs='*', metavar='MEASUREMENTS', type=shipped(MEASUREMENTS),
                   help='measurement CSV: q1,q2,q3,x,y,z[,qx,qy,qz,qw][,sigma_position[,sigma_angle]] '
                        '(docs/calibration.md); with --robot: one or more files of an arm\'s measured points')
    p.add_argument('--plan', type=whole, metavar='N', help='propose N measurement configurations instead')
    p.add_argument('--output', metavar='FILE',
                   help='calibrated geometry YAML (a robot description with --robot; required when calibrating); '
                        'with --plan: the configurations as CSV')
    p.add_argument('--plot', metavar='FILE.png',
                   help='the residuals of every measurement before and after, against the noise, and the fitted '
                        'parameters\' change in standard errors (each arm\'s with --robot; needs matplotlib; written '
                        'also when the gate fails)')
    p.add_argument('--force', action='store_true', help='write the calibrated file even when the fit fails its gate '
                                                        '(the status is still 1)')
    p.add_argument('--free', nargs='+', action='extend', metavar='NAME',
                   help='parameters to identify (repeatable, the names add up): names (rod2_offset, rod1_ux, '
                        'joint3_y, kappa1, arm1_elbow_length, ...) or whole keys (rod_positions, rod_offsets, '
                        'rod_directions, platform_joints, kappa; length, zero_offset, wafer_centre); default: all')
    p.add_argument('--frame', default='gpr_base', metavar='NAME',
                   help='the fixed frame the measurements are in (default gpr_base; not one that moves with the '
                        'machine, gpr_platform ...); another (tracker): the pose of gpr_base in it is identified with '
                        'the geometry, unless --base gives it')
    p.add_argument('--base', nargs='+', metavar='V',
                   help='the known pose of gpr_base in --frame, X Y Z ROLL PITCH YAW [m, rad; --mm, --deg]; with '
                        '--robot also FILE, a geometry gpr calibrate --frame wrote: its registration, whose '
                        'uncertainty enters the arms\' standard errors and gate (with --config FILE)')
    p.add_argument('--target', nargs='+', type=number, metavar='V',
                   help='the target\'s pose in gpr_platform, X Y Z [ROLL PITCH YAW] [m, rad; --mm, --deg]: known, or '
                        'the start of --fit-target; default: gpr_platform itself (poses in gpr_base), else identified')
    p.add_argument('--fit-target', nargs='?', const='pose', choices=('pose', 'position'),
                   help='identify the target on the platform (position: its orientation is --target\'s)')
    p.add_argument('--points', action='store_true',
                   help='with --plan: the configurations will be measured as points (a reflector, no orientation)')
    p.add_argument('--robot', metavar='FILE', type=shipped(ROBOTS),
                   help='calibrate the arms of this robot description from the files')
    p.add_argument('--sigma-position', type=number, metavar='S',
                   help='standard deviation of a measured coordinate for rows without sigma columns '
                        '[m, or mm with --mm]: their noise (without it 5e-6 m, a laser tracker\'s, or the '
                        '--tolerances table\'s, is assumed: the gate fails residuals well beyond it)')
    p.add_argument('--sigma-angle', type=number, metavar='S',
                   help='standard deviation of a measured rotation component [rad, or deg with --deg]: their '
                        'noise (assumed without it: 2e-5 rad, or the --tolerances table\'s)')
    p.add_argument('--tolerances', metavar='TABLE', type=shipped(TOLERANCES),
                   help='tolerance table (YAML, docs/calibration.md): its standard deviations are the a-priori '
                        'uncertainties the measurements must beat and its bounds those of the held parameters\' bias, '
                        'its measurement_noise the default sigmas; a plan is made where its tolerances are')
    p.add_argument('--threshold', type=number, default=1.0,
                   help='scaled singular value a parameter combination must reach to be fitted (default 1: the '
                        'measurements must determine it better than its a-priori uncertainty)')
    p.add_argument('--index', choices=('product', 'smallest'),
                   help='with --plan: the observability index the plan maximises (default product: D-optimal)')
    p.add_argument('--model', choices=MODELS,
                   help='virtual-joint model of the identification (default compliant: kappa acts only there); the '
                        'calibrated file selects it')
    p.add_argument('--config', metavar='FILE', help='nominal geometry (YAML overriding config/gpr.yaml)')
    p.add_argument('--mm', action='store_true', help='--sigma-position, --base and --target are in millimetres')
    p.add_argument('--deg', action='store_true', help='--sigma-angle and the angles of --base and --target in degrees')
    p.add_argument('--json', action='store_true', help='print one JSON object on stdout')
    add_no_progress(p)
    p.set_defaults(handler=_handler)
