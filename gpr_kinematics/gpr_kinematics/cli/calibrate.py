"""``gpr calibrate``: identify the geometry from measured platform poses, or plan the measurements.

Examples::

    gpr calibrate config/calibration/synthetic_measurements.csv --output calibrated.yaml
    gpr calibrate MEASUREMENTS --output calibrated.yaml --free rod_offsets rod_directions kappa
    gpr fk 0.3 0.301 0.299 --config calibrated.yaml        # every command takes the calibrated geometry
    gpr calibrate --plan 12 --output plan.csv --json
    gpr calibrate MEASUREMENTS --output calibrated.yaml --tolerances config/calibration/tolerances_example.yaml

The measurement file format, the identification, the identifiability report and the plan are described in
docs/calibration.md. Plugin of :mod:`gpr_kinematics.cli.main` (``register(subparsers)``).
"""
from __future__ import annotations

import argparse
import math
from datetime import datetime, timezone
from typing import Any

from ..core.config import MODELS, GprConfig, load_config
from ..errors import InputError
from .output import emit_json


def _config(args: argparse.Namespace) -> GprConfig:
    return load_config(args.config) if args.config is not None else load_config()


def _table(args: argparse.Namespace) -> Any:
    from ..calibration.tolerances import load_tolerances
    return load_tolerances(args.tolerances) if args.tolerances is not None else None


def _sigmas(args: argparse.Namespace, table: Any = None) -> tuple[float, float]:
    """The options' sigmas (SI), else the tolerance table's measurement noise, else the defaults."""
    from ..calibration.identification import DEFAULT_SIGMA_ANGLE, DEFAULT_SIGMA_POSITION
    sp = table.sigma_position if table is not None and table.sigma_position is not None else DEFAULT_SIGMA_POSITION
    sa = table.sigma_angle if table is not None and table.sigma_angle is not None else DEFAULT_SIGMA_ANGLE
    if args.sigma_position is not None:
        sp = args.sigma_position * (1e-3 if args.mm else 1.0)
    if args.sigma_angle is not None:
        sa = math.radians(args.sigma_angle) if args.deg else args.sigma_angle
    return sp, sa


def _prior(table: Any, model: Any) -> Any:
    from ..calibration.tolerances import prior_of
    return prior_of(table, model.parameters) if table is not None else None


def _calibrate(args: argparse.Namespace) -> int:
    from ..calibration.core_model import CoreModel, check_limits, write_calibrated_config
    from ..calibration.identification import identify
    from ..calibration.measurements import read_measurements
    from ..calibration.report import format_calibration
    if args.output is None:
        raise InputError('--output FILE is required: the calibrated geometry is written there')
    cfg = _config(args)
    meas = read_measurements(args.measurements)
    check_limits(meas, cfg)
    model = CoreModel(cfg, args.model)
    table = _table(args)
    sp, sa = _sigmas(args, table)
    res = identify(model, meas, free=args.free, sigma_position=sp, sigma_angle=sa, threshold=args.threshold,
                   prior=_prior(table, model))
    calibrated = model.config_for(res.estimate)
    stamp = datetime.now(timezone.utc).strftime('%Y-%m-%dT%H:%M:%SZ')
    comments = (f'GPR geometry calibrated by `gpr calibrate` from {args.measurements} ({res.rows} rows), {stamp}',
                f'fitted: {", ".join(res.parameters[j].name for j in res.fitted) or "none"}; held at nominal: '
                f'{", ".join(res.identifiability.held) or "none"}',
                f'pose residuals RMS before {res.before.rms_position:.3e} m, {res.before.rms_angle:.3e} rad; after '
                f'{res.after.rms_position:.3e} m, {res.after.rms_angle:.3e} rad',
                'SI units; use with any command: --config THIS_FILE')
    path = write_calibrated_config(args.output, calibrated, comments)
    if args.json:
        emit_json(res.as_dict() | {'model': calibrated.model, 'output': str(path)})
        return 0
    print(format_calibration(res))
    print(f'calibrated geometry written to {path} (use it with --config {path})')
    return 0


def _plan(args: argparse.Namespace) -> int:
    from ..calibration.core_model import CoreModel
    from ..calibration.files import comment_lines, write_text
    from ..calibration.plan import plan_measurements
    from ..calibration.report import format_plan
    cfg = _config(args)
    model = CoreModel(cfg, args.model)
    table = _table(args)
    sp, sa = _sigmas(args, table)
    plan = plan_measurements(model, cfg, args.plan, index=args.index, free=args.free, sigma_position=sp,
                             sigma_angle=sa, threshold=args.threshold, prior=_prior(table, model))
    path = None
    if args.output is not None:
        text = (comment_lines([f'measurement plan of `gpr calibrate --plan {args.plan}`: observability index '
                               f'({plan.index_name}) {plan.index:.6g}',
                               'measure the pose of gpr_platform at each row and add the columns x,y,z,qx,qy,qz,qw '
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


def _handler(args: argparse.Namespace) -> int:
    if (args.measurements is None) == (args.plan is None):
        raise InputError('give a MEASUREMENTS file to calibrate from, or --plan N for a measurement plan '
                         '(not both)')
    if not (math.isfinite(args.threshold) and args.threshold > 0):
        raise InputError(f'--threshold = {args.threshold!r}; allowed: a finite number > 0')
    from ..calibration.measurements import SIGMA_RANGE
    lo, hi = SIGMA_RANGE
    for flag, value in zip(('--sigma-position', '--sigma-angle'), _sigmas(args), strict=True):
        if not lo <= value <= hi:
            raise InputError(f'{flag} = {value!r} (SI); allowed: a standard deviation from {lo:g} to {hi:g} (m, rad)')
    return _plan(args) if args.plan is not None else _calibrate(args)


def register(sub: Any) -> None:
    """Add ``gpr calibrate`` to the ``gpr`` parser."""
    p = sub.add_parser('calibrate', help='identify the geometry from measured poses, or plan the measurements',
                       description='Identify the geometric parameters from measured platform poses (weighted '
                                   'least squares, standard errors, identifiability) and write the calibrated '
                                   'geometry; or, with --plan N, propose N measurement configurations.')
    p.add_argument('measurements', nargs='?', metavar='MEASUREMENTS',
                   help='measurement CSV: q1,q2,q3,x,y,z,qx,qy,qz,qw[,sigma_position,sigma_angle] '
                        '(docs/calibration.md)')
    p.add_argument('--plan', type=int, metavar='N', help='propose N measurement configurations instead')
    p.add_argument('--output', metavar='FILE',
                   help='calibrated geometry YAML (required when calibrating); with --plan: the configurations as CSV')
    p.add_argument('--free', nargs='+', metavar='NAME',
                   help='parameters to identify: names (rod2_offset, rod1_ux, joint3_y, kappa1, ...) or whole keys '
                        '(rod_positions, rod_offsets, rod_directions, platform_joints, kappa); default: all 24')
    p.add_argument('--sigma-position', type=float, metavar='S',
                   help='standard deviation of a measured coordinate for rows without sigma columns '
                        '[m, or mm with --mm] (default 5e-6 m)')
    p.add_argument('--sigma-angle', type=float, metavar='S',
                   help='standard deviation of a measured rotation component [rad, or deg with --deg] '
                        '(default 2e-5 rad)')
    p.add_argument('--tolerances', metavar='TABLE',
                   help='tolerance table (YAML, docs/calibration.md): its standard deviations are the a-priori '
                        'uncertainties the measurements must beat, its measurement_noise the default sigmas')
    p.add_argument('--threshold', type=float, default=1.0,
                   help='scaled singular value a parameter combination must reach to be fitted (default 1: the '
                        'measurements must determine it better than its a-priori uncertainty)')
    p.add_argument('--index', choices=('product', 'smallest'), default='product',
                   help='observability index the plan maximises (default product: D-optimal)')
    p.add_argument('--model', choices=MODELS,
                   help='virtual-joint model of the identification (default compliant: kappa acts only there); the '
                        'calibrated file selects it')
    p.add_argument('--config', metavar='FILE', help='nominal geometry (YAML overriding config/gpr.yaml)')
    p.add_argument('--mm', action='store_true', help='--sigma-position is in millimetres')
    p.add_argument('--deg', action='store_true', help='--sigma-angle is in degrees')
    p.add_argument('--json', action='store_true', help='print one JSON object on stdout')
    p.set_defaults(handler=_handler)
