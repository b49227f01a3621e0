"""``gpr accuracy FILE``: the pose accuracy of a mechanism, and the accuracy budget of the GPR and the whole robot.

Without ``--tolerances``: the pose deviation of a mechanism from joint and geometry errors (Alwan, eq. (7),
linearised and exact; poses as ``gpr mechanism``). With ``--tolerances TABLE`` the accuracy budget, where FILE is

* a mechanism file of ``type: gpr`` (e.g. the packaged ``gpr.yaml``) with ``--pose X Y Z A B C`` (the GPR's
  convention: Z the height, A B the tilt vector; X, Y, C are outcomes and ignored): the budget of that platform
  pose, with ``--tool`` a point of the platform;
* a platform program of ``trajectory_node`` (stations with height, tilt and azimuth): the budget of each station;
* a whole-robot program (``format: gpr_robot_program``, docs/robot.md): the budget of each station it visits, at
  the wafer, in the world's axes (``--robot`` names the description, else the program's or the shipped example).

Examples (bare names: the packaged files, :func:`~gpr_kinematics.inputs.resources.packaged_file`)::

    gpr accuracy gpr.yaml --tolerances tolerances_example.yaml --pose 0 0 0.5 0.0349 0 0
    gpr accuracy example_robot_program.yaml --tolerances tolerances_example.yaml
    gpr accuracy gpr.yaml --tolerances TABLE --pose 0 0 0.3 1.5 0 0 --deg --tool 0.3 0 0.1 --calibration-plan 40

``--config FILE`` replaces the GPR geometry (e.g. a calibrated file; for a robot, the description's ``gpr``
section), ``--model`` the virtual-joint model (default ``compliant``), ``--samples``/``--seed`` the Monte Carlo
draws (0: linearised only), ``--calibration-plan N`` makes the budget after a calibration from the ``N``
configurations of ``gpr calibrate --plan N`` measured with the table's ``measurement_noise`` (the parameters the
plan holds compensated through the calibrated ones by the plan's alias: ``compensated`` in the JSON),
``--plot FILE.png`` draws the Monte Carlo's samples of the first 4 stations against the budget's numbers
(:func:`~gpr_kinematics.calibration.budget_plot.budget_plot`).
"""
from __future__ import annotations

import argparse
import math
import sys
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from ..calibration.core_model import MODEL
from ..calibration.tolerances import MAX_TOLERANCE
from ..callbacks import StageProgress
from ..core.stroke import typed_in_millimetres
from ..errors import InputError, apart, brief
from ..inputs.resources import MECHANISMS_AND_PROGRAMS, ROBOTS, TOLERANCES, packaged_file
from ..inputs.safe_yaml import YamlValue
from ..inputs.units import metres
from ..mechanisms.base import ANGULAR_JOINTS, Mechanism
from .mechanism import mechanism_options
from .options import (
    CONVENTIONS,
    finite,
    mechanism_of,
    mechanism_pose,
    named_file,
    number,
    png_plot,
    pose_tilt,
    shipped,
    tool_point,
    whole,
)
from .output import emit_json
from .progress import add_no_progress, progress_line

if TYPE_CHECKING:
    from ..calibration.budget import Budget
    from ..core.config import GprConfig
    from .main import Subparsers

#: The options that only a budget takes (their defaults are None, so that their use without --tolerances shows).
BUDGET_OPTIONS = ('tool', 'samples', 'seed', 'config', 'robot', 'model', 'calibration_plan', 'plot')
DEFAULT_SAMPLES = 10_000


def add_budget_options(p: argparse.ArgumentParser, finite: Callable[[str], float]) -> None:
    """The budget's options of ``gpr accuracy`` (module docstring)."""
    from ..calibration.budget import MAX_POSES, MAX_SAMPLES
    from ..core.config import MODELS
    g = p.add_argument_group('accuracy budget (docs/calibration.md)')
    g.add_argument('--tolerances', metavar='TABLE', type=shipped(TOLERANCES),
                   help='tolerance table (YAML): make the accuracy budget')
    g.add_argument('--tool', nargs=3, type=finite, metavar=('X', 'Y', 'Z'),
                   help='tool point in gpr_platform [m, or mm with --mm] (default the origin; a robot program: the '
                        'wafer centre)')
    g.add_argument('--samples', type=whole, metavar='N',
                   help=f'Monte Carlo samples (default {DEFAULT_SAMPLES}; 0: linearised only; at most {MAX_SAMPLES}, '
                        f'and samples x stations at most {MAX_POSES} for a program)')
    g.add_argument('--seed', type=whole, metavar='S', help='seed of the Monte Carlo draws (default 0)')
    g.add_argument('--config', metavar='FILE', help='GPR geometry (e.g. a calibrated file) instead of the default')
    g.add_argument('--robot', metavar='FILE', type=shipped(ROBOTS),
                   help='robot description for a robot program (default: the program\'s robot, else the packaged '
                        'example_robot.yaml)')
    g.add_argument('--model', choices=MODELS, help='virtual-joint model of the budget (default compliant)')
    g.add_argument('--calibration-plan', type=whole, metavar='N',
                   help='the budget after calibrating from N planned configurations (gpr calibrate --plan N) '
                        'measured with the table\'s measurement_noise (the parameters the plan holds compensated '
                        'through the calibrated ones)')
    g.add_argument('--plot', metavar='FILE.png',
                   help='the Monte Carlo\'s distribution of each error of the first 4 stations against the worst '
                        'case, the RSS and the percentiles (needs matplotlib and samples)')


def check_budget_options(args: argparse.Namespace, budget: bool) -> None:
    """Refuse options of the other mode: budget options without ``--tolerances``, the mechanism analysis's errors
    with it."""
    if not budget:
        used = [name for name in BUDGET_OPTIONS if getattr(args, name, None) is not None]
        if used:
            flags = ', '.join('--' + name.replace('_', '-') for name in used)
            raise InputError(f'{flags} {"belongs" if len(used) == 1 else "belong"} to the accuracy budget: give '
                             '--tolerances TABLE as well (without it gpr accuracy analyses --errors and '
                             '--parameter-error, Alwan eq. 7)')
        return
    if args.errors is not None or args.parameter_error:
        raise InputError('--errors and --parameter-error belong to the mechanism analysis; with --tolerances the '
                         'table gives the errors (rod_length, parameters, joint_clearance)')
    from ..calibration.budget import MAX_SAMPLES
    if args.samples is not None and not 0 <= args.samples <= MAX_SAMPLES:   # the whole range, as the budget's
        raise InputError(f'--samples = {brief(args.samples)}; allowed: an integer from 0 to {MAX_SAMPLES}')
    if args.seed is not None and not 0 <= args.seed <= 2 ** 63 - 1:
        raise InputError(f'--seed = {brief(args.seed)}; allowed: an integer from 0 to 2**63 - 1')
    if args.calibration_plan is not None and args.calibration_plan < 1:
        raise InputError(f'--calibration-plan = {brief(args.calibration_plan)}; allowed: a positive number of '
                         'configurations, enough to identify the parameters (the plan names the least)')
    if args.plot is not None:
        _check_plot(args)


def _check_plot(args: argparse.Namespace) -> None:
    """Refuse, before any budget, a ``--plot`` without Monte Carlo samples (it draws them), and what
    :func:`~.options.png_plot` refuses."""
    if args.samples == 0:
        raise InputError('--plot draws the Monte Carlo\'s samples, and --samples 0 draws none; allowed: --plot with '
                         f'--samples N >= 1 (default {DEFAULT_SAMPLES})')
    png_plot(args.plot)


def _kind(data: YamlValue) -> str:
    """``robot`` (a whole-robot program), ``platform`` (a platform program) or ``mechanism``."""
    if isinstance(data, Mapping):
        if data.get('format') == 'gpr_robot_program':
            return 'robot'
        if 'type' not in data and isinstance(data.get('stations'), list):
            return 'platform'
    return 'mechanism'


def _gpr_config(args: argparse.Namespace, overrides: Mapping[str, YamlValue] | None = None) -> GprConfig:
    from ..core.config import load_config
    return load_config(args.config, overrides=overrides or None)


def _budget(args: argparse.Namespace, data: YamlValue, path: Path, progress: StageProgress | None = None
            ) -> tuple[Budget, str]:
    """The budget of FILE (module docstring) and a line saying what was computed; ``progress`` hears the Monte
    Carlo's share done."""
    from ..calibration.budget_plot import MAX_STATIONS
    from ..calibration.stations import BudgetOptions, platform_budget, robot_budget
    from ..calibration.tolerances import load_tolerances
    table = load_tolerances(args.tolerances)
    options = BudgetOptions(samples=DEFAULT_SAMPLES if args.samples is None else args.samples,
                            seed=args.seed or 0, model=args.model, plan=args.calibration_plan or 0,
                            progress=progress, keep_samples=MAX_STATIONS if args.plot is not None else 0)
    kind = _kind(data)
    if kind != 'mechanism' and args.pose is not None:
        raise InputError(f'{path}: a program gives its stations; --pose goes with a mechanism file of type gpr')
    if kind != 'mechanism':  # they were accepted and did nothing: a program says its own units
        unused = [flag for flag, on in (('--mm', args.mm and (kind == 'robot' or args.tool is None)),
                                        ('--deg', args.deg)) if on]
        if unused:
            raise InputError(f'{" and ".join(unused)} with a program: it says its own units; allowed: --mm with a '
                             'platform program\'s --tool, --mm and --deg with --pose of a mechanism file')
    if kind == 'robot':
        from ..robot.description import load_robot
        from ..robot.program import parse_program
        if args.tool is not None:
            raise InputError('--tool: a robot program\'s tool point is the wafer centre of each station\'s arm')
        program = parse_program(data, str(path), path.parent)
        # the stations solved under the budget's own model, as for a platform program
        robot = load_robot(named_file(program, 'robot', args.robot), geometry=args.config, model=options.model or MODEL)
        return robot_budget(robot, program, table, options), (f'robot {robot.name}: tool point = the wafer centre of '
                                                              f'each station\'s arm, errors in the axes of '
                                                              f'{robot.world_frame}')
    if args.robot is not None:
        raise InputError('--robot goes with a robot program (format: gpr_robot_program)')
    if kind == 'platform':
        from ..robot.platform_program import parse_platform_program
        st = parse_platform_program(data, str(path)).stations
        return (platform_budget(_gpr_config(args), table, [s.height for s in st], [s.tilt for s in st],
                                [s.azimuth for s in st], tool_point(args), [s.name for s in st], options),
                f'platform program {path.name}: {len(st)} station(s)')
    from ..mechanisms import mechanism_from_dict
    from ..mechanisms.gpr import GprMechanism
    mech = mechanism_from_dict(data, str(path))
    if not isinstance(mech, GprMechanism):
        raise InputError(f'{mech.name} ({mech.kind}): the accuracy budget is made for the GPR (a file of type gpr), '
                         'a platform program or a robot program; for this mechanism use --errors and '
                         '--parameter-error')
    if args.pose is None:
        raise InputError(f'{mech.name}: give --pose X Y Z A B C (Z the height, A B the tilt vector) or a program')
    pose = [metres(v, args.mm and i < 3) for i, v in enumerate(args.pose)]
    if args.deg:
        pose[3:] = [math.radians(v) for v in pose[3:]]
    config = _gpr_config(args, data.get('overrides')) if args.config is not None else mech.config
    pose_tilt(args, pose[3], pose[4], config)   # named as typed, with the hint of degrees typed as radians
    tilt, azimuth = math.hypot(pose[3], pose[4]), math.atan2(pose[4], pose[3])
    tool = tool_point(args)
    with typed_in_millimetres(args.mm):   # the pose's height in mm: named so, not "millimetres given as metres?"
        budget = platform_budget(config, table, pose[2], tilt, azimuth, tool, None, options)
    return budget, f'{mech.name}: height {pose[2]:g} m, tilt {tilt:.6g} rad about the axis at azimuth {azimuth:.6g} rad'


def budget_command(args: argparse.Namespace) -> int:
    """``gpr accuracy FILE --tolerances TABLE ...`` (module docstring)."""
    from ..mechanisms import read_mechanism_file
    check_budget_options(args, budget=True)
    # FILE may be a program too: a bare name is also one of the packaged programs
    data, path = read_mechanism_file(packaged_file(args.file, MECHANISMS_AND_PROGRAMS) if args.file else args.file)
    line = progress_line(args.no_progress)   # 5,000,000 poses: about 35 s of CPU time
    try:
        budget, what = _budget(args, data, path, line)
    finally:
        line.close()
    plotted: dict[str, str] = {}
    if args.plot is not None:
        from ..calibration.budget_plot import budget_plot
        from ..calibration.plot import plot_budget
        plotted['plot_file'] = str(plot_budget(args.plot, budget_plot(budget)))
    model = args.model or MODEL
    plan = f', after a calibration from {args.calibration_plan} planned configurations' if args.calibration_plan \
        else ''
    config = None if args.config is None else str(args.config)   # a calibrated geometry: budgets told apart
    if args.json:
        emit_json({'file': str(path), 'config': config, 'tolerances': str(args.tolerances), 'model': model,
                   'calibration_plan': args.calibration_plan, 'description': what} | budget.as_dict() | plotted)
        return 0
    from ..calibration.report import format_budget
    geometry = '' if config is None else f'; geometry {config}'
    print(f'{what}{geometry}; tolerances {args.tolerances}, model {model}{plan}')
    print(format_budget(budget))
    if plotted:
        print(f'plot written to {plotted["plot_file"]}')
    return 0


def _joint_errors(args: argparse.Namespace, mech: Mechanism) -> np.ndarray:
    """``--errors`` in SI (``--mm``/``--deg`` converted), else the file's leg deformations, else zeros; bounded as
    :func:`~..mechanisms.accuracy.check_joint_errors` bounds them, a unit's hint added."""
    from ..mechanisms.accuracy import check_joint_errors
    if args.errors is None:
        deformations = getattr(mech, 'leg_deformations', None)
        return np.zeros(mech.n_joints) if deformations is None else np.asarray(deformations, dtype=float)
    errors = np.array(args.errors, dtype=float)
    if errors.size != mech.n_joints:
        raise InputError(f'--errors has {errors.size} values in all; allowed: {mech.n_joints} '
                         f'({", ".join(mech.joint_names)}), one per joint (the values of every --errors joined in '
                         'order)')
    ang = np.array([t in ANGULAR_JOINTS for t in mech.joint_types])
    if args.mm:
        errors[~ang] = metres(errors[~ang], True)
    if args.deg:
        errors[ang] = np.radians(errors[ang])
    hints = ('' if args.mm else ' (millimetres given as metres? give --mm)',
             '' if args.deg else ' (degrees given as radians? give --deg)')
    return np.asarray(check_joint_errors(mech, errors, 1, hints)[0], dtype=np.float64)


def _parameter_errors(args: argparse.Namespace, mech: Mechanism) -> dict[str, np.ndarray]:
    """``--parameter-error NAME V...`` items as arrays of the parameters' shapes (m, ``--mm`` converted)."""
    params: dict[str, np.ndarray] = {}
    nominal = mech.parameters()
    for item in args.parameter_error or []:
        name, values = item[0], item[1:]
        if name not in nominal:
            raise InputError(f'{mech.name}: unknown parameter {brief(name)} for --parameter-error; allowed: '
                             + (', '.join(sorted(nominal)) or 'none'))
        if name in params:  # the second would silently replace the first
            raise InputError(f'--parameter-error {name} is given twice; allowed: each parameter once')
        try:
            vals = np.array([number(v) for v in values])
        except ValueError:
            raise InputError(f'--parameter-error {name}: values must be numbers; got {brief(values)}') from None
        size = np.asarray(nominal[name]).size
        if vals.size != size:
            raise InputError(f'--parameter-error {name} takes {size} values (shape '
                             f'{np.shape(nominal[name])}, m); got {vals.size}')
        si = metres(vals, args.mm)
        big = np.flatnonzero(np.abs(si) > MAX_TOLERANCE['m'])
        if big.size:   # a point's error of 1e6 m passed: nonsense printed as a result (0.05 with --mm left off)
            hint = '' if args.mm else ' (millimetres given as metres? give --mm)'
            typed = float(vals[big[0]])
            shown = apart(abs(typed), MAX_TOLERANCE['m'] * (1000.0 if args.mm else 1.0))[0]   # 0.01000001 read 0.01
            raise InputError(f'--parameter-error {name}: value {big[0] + 1} = {"-" if typed < 0 else ""}{shown} '
                             f'{"mm" if args.mm else "m"} is beyond {MAX_TOLERANCE["m"]:g} m; allowed: errors of at '
                             f'most {MAX_TOLERANCE["m"]:g} m, as a tolerance table\'s{hint}')
        params[name] = si.reshape(np.shape(nominal[name]))
    return params


def _refuse_program(file: str) -> None:
    """A program without ``--tolerances`` (``gpr accuracy example_robot_program.yaml``): refused as such, where it
    read 'mechanism file ... not found' (a packaged program's bare name) or 'type = None is not a mechanism type'."""
    from ..errors import GprError
    from ..mechanisms import read_mechanism_file
    try:
        data, path = read_mechanism_file(packaged_file(file, MECHANISMS_AND_PROGRAMS) if file else file)
    except GprError:
        return  # the mechanism's own reading says what is wrong
    kind = _kind(data)
    if kind != 'mechanism':
        raise InputError(f'{path}: a {"whole-robot" if kind == "robot" else "platform"} program: its accuracy budget '
                         'needs --tolerances TABLE (e.g. tolerances_example.yaml); allowed without it: a mechanism '
                         'file (config/mechanisms/*.yaml) with its trajectory or --pose and --errors')


def _accuracy(args: argparse.Namespace) -> int:
    if args.tolerances is not None:
        return budget_command(args)
    from ..mechanisms.accuracy import accuracy_analysis
    check_budget_options(args, budget=False)
    _refuse_program(args.file)
    mech = mechanism_of(args.file)
    trajectory = getattr(mech, 'trajectory', None)
    if args.pose is not None:
        poses = mechanism_pose(args, mech)[None, :]
    elif trajectory is not None:
        poses = np.asarray(trajectory, dtype=float)
    else:
        raise InputError(f'{mech.name}: give --pose X Y Z A B C (the file has no trajectory)')
    errors = _joint_errors(args, mech)
    params = _parameter_errors(args, mech)
    with typed_in_millimetres(args.mm and args.pose is not None):   # a --pose in mm is named so (not a trajectory)
        full = mech.complete_pose(poses)
        mech.check_limits(mech.inverse_kinematics(full))
    # The text and the JSON print the same numbers: both from this report.
    report = accuracy_analysis(mech, full, errors, params).report(mech.kind)
    for warning in report.warnings:          # the JSON holds them too
        sys.stderr.write(f'gpr accuracy: warning: {warning}\n')
    if args.json:
        emit_json(report)
        return 0
    print(f'{mech.name}: pose deviation for joint errors {np.asarray(errors).tolist()} (SI)'
          + (f' and parameter errors {sorted(params)}' if params else ''))
    head = ' '.join(f'{v:>12}' for v in report.variables)
    print(f'{"":>6} {"":>11} {head}')
    for i, r in enumerate(report.results):
        for label, values in (('linearized', r.linearized), ('exact', r.exact), ('difference', r.difference)):
            print(f'{i + 1 if label == "linearized" else "":>6} {label:>11} '
                  + ' '.join(f'{values[v]:12.4e}' for v in report.variables))
    print('rigid motion of the platform, parasitic components included (x y z [m], rotation vector rx ry rz [rad], '
          'base frame):')
    print(f'{"":>6} {"":>11} ' + ' '.join(f'{v:>12}' for v in ('x', 'y', 'z', 'rx', 'ry', 'rz')))
    for i, r in enumerate(report.results):
        for label, twist in (('linearized', r.linearized_twist), ('exact', r.exact_twist)):
            print(f'{i + 1 if label == "linearized" else "":>6} {label:>11} '
                  + ' '.join(f'{v:12.4e}' for v in np.asarray(twist).tolist()))
    return 0


def register(subparsers: Subparsers) -> None:
    """Add ``accuracy`` to the ``gpr`` command."""
    p = subparsers.add_parser('accuracy', help='platform pose deviation from joint and geometry errors; the accuracy '
                              'budget of the GPR and the whole robot from a tolerance table',
                              description='Pose deviation caused by joint errors (leg deformations, '
                              'actuator errors) and geometric errors: linearised (Alwan eq. 7) and exact '
                              '(perturbed closure solved by Newton). Without --pose/--errors the file\'s '
                              'trajectory and leg_deformations are used (stewart_alwan.yaml). With --tolerances: '
                              'the accuracy budget (docs/calibration.md) of the GPR (FILE of type gpr with --pose, '
                              'or a platform program) or of the whole robot at the wafer (FILE a robot program): '
                              'linearised RSS, worst case and shares, and Monte Carlo percentiles.',
                              epilog=CONVENTIONS, formatter_class=argparse.RawDescriptionHelpFormatter)
    mechanism_options(p, False, 'mechanism YAML (config/mechanisms/*.yaml); with --tolerances also a platform or '
                      'robot program')
    p.add_argument('--errors', nargs='+', action='extend', type=finite, metavar='E',
                   help='one error per joint in file order (m, rad for angular joints); repeatable: the values of '
                        'every --errors are joined in order (--errors E1 E2 E3 --errors E4 E5 E6), one per joint in '
                        'all, as --free of gpr calibrate joins its names')
    p.add_argument('--parameter-error', nargs='+', action='append', metavar='NAME V',
                   help='geometric error: parameter name and its values, e.g. A_i (18 values, m) for a '
                   'Stewart platform, joint_imperfections (9 values, m) for the GPR; repeatable')
    add_budget_options(p, finite)
    add_no_progress(p)
    p.set_defaults(handler=_accuracy)
