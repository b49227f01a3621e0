"""``gpr accuracy FILE --tolerances TABLE``: the accuracy budget of the GPR and of the whole robot.

The ``accuracy`` subcommand itself (its parser and the mechanism analysis of Alwan, eq. (7)) is in
:mod:`gpr_kinematics.cli_mechanisms`; with ``--tolerances`` it comes here. FILE is

* a mechanism file of ``type: gpr`` (e.g. the packaged ``gpr.yaml``) with ``--pose X Y Z A B C`` (the GPR's
  convention: Z the height, A B the tilt vector; X, Y, C are outcomes and ignored): the budget of that platform
  pose, with ``--tool`` a point of the platform;
* a platform program of ``trajectory_node`` (stations with height, tilt and azimuth): the budget of each station;
* a whole-robot program (``format: gpr_robot_program``, docs/robot.md): the budget of each station it visits, at
  the wafer, in the world's axes (``--robot`` names the description, else the program's or the shipped example).

Examples::

    gpr accuracy gpr.yaml --tolerances config/calibration/tolerances_example.yaml --pose 0 0 0.5 0.0349 0 0
    gpr accuracy config/programs/example_robot_program.yaml --tolerances config/calibration/tolerances_example.yaml
    gpr accuracy gpr.yaml --tolerances TABLE --pose 0 0 0.3 1.5 0 0 --deg --tool 0.3 0 0.1 --calibration-plan 40

``--config FILE`` replaces the GPR geometry (e.g. a calibrated file; for a robot, the description's ``gpr``
section), ``--model`` the virtual-joint model (default ``compliant``), ``--samples``/``--seed`` the Monte Carlo
draws (0: linearised only), ``--calibration-plan N`` makes the budget after a calibration from the ``N``
configurations of ``gpr calibrate --plan N`` measured with the table's ``measurement_noise``.
"""
from __future__ import annotations

import argparse
import math
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any

from .calibration.core_model import MODEL
from .errors import InputError

#: The options that only a budget takes (their defaults are None, so that their use without --tolerances shows).
BUDGET_OPTIONS = ('tool', 'samples', 'seed', 'config', 'robot', 'model', 'calibration_plan')
DEFAULT_SAMPLES = 10_000


def add_budget_options(p: argparse.ArgumentParser, finite: Callable[[str], float]) -> None:
    """The budget's options of ``gpr accuracy`` (module docstring)."""
    from .calibration.budget import MAX_SAMPLES
    from .config import MODELS
    g = p.add_argument_group('accuracy budget (docs/calibration.md)')
    g.add_argument('--tolerances', metavar='TABLE', help='tolerance table (YAML): make the accuracy budget')
    g.add_argument('--tool', nargs=3, type=finite, metavar=('X', 'Y', 'Z'),
                   help='tool point in gpr_platform [m, or mm with --mm] (default the origin; a robot program: the '
                        'wafer centre)')
    g.add_argument('--samples', type=int, metavar='N',
                   help=f'Monte Carlo samples (default {DEFAULT_SAMPLES}; 0: linearised only; at most {MAX_SAMPLES})')
    g.add_argument('--seed', type=int, metavar='S', help='seed of the Monte Carlo draws (default 0)')
    g.add_argument('--config', metavar='FILE', help='GPR geometry (e.g. a calibrated file) instead of the default')
    g.add_argument('--robot', metavar='FILE', help='robot description for a robot program (default: the program\'s '
                                                    'robot, else config/robots/example_robot.yaml)')
    g.add_argument('--model', choices=MODELS, help='virtual-joint model of the budget (default compliant)')
    g.add_argument('--calibration-plan', type=int, metavar='N',
                   help='the budget after calibrating from N planned configurations (gpr calibrate --plan N) '
                        'measured with the table\'s measurement_noise')


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
    if args.samples is not None and args.samples < 0:
        raise InputError(f'--samples = {args.samples}; allowed: an integer >= 0')
    if args.seed is not None and args.seed < 0:
        raise InputError(f'--seed = {args.seed}; allowed: an integer >= 0')
    if args.calibration_plan is not None and args.calibration_plan < 1:
        raise InputError(f'--calibration-plan = {args.calibration_plan}; allowed: an integer >= 1 (configurations)')


def _kind(data: Any) -> str:
    """``robot`` (a whole-robot program), ``platform`` (a platform program) or ``mechanism``."""
    if isinstance(data, Mapping):
        if data.get('format') == 'gpr_robot_program':
            return 'robot'
        if 'type' not in data and isinstance(data.get('stations'), list):
            return 'platform'
    return 'mechanism'


def _tool(args: argparse.Namespace) -> tuple[float, float, float]:
    if args.tool is None:
        return (0.0, 0.0, 0.0)
    f = 1e-3 if args.mm else 1.0
    return (args.tool[0] * f, args.tool[1] * f, args.tool[2] * f)


def _gpr_config(args: argparse.Namespace, overrides: Any = None) -> Any:
    from .config import load_config
    return load_config(args.config, overrides=overrides or None)


def _budget(args: argparse.Namespace, data: Any, path: Path) -> tuple[Any, str]:
    """The budget of FILE (module docstring) and a line saying what was computed."""
    from .calibration.stations import BudgetOptions, platform_budget, robot_budget
    from .calibration.tolerances import load_tolerances
    table = load_tolerances(args.tolerances)
    options = BudgetOptions(samples=DEFAULT_SAMPLES if args.samples is None else args.samples,
                            seed=args.seed or 0, model=args.model, plan=args.calibration_plan or 0)
    kind = _kind(data)
    if kind != 'mechanism' and args.pose is not None:
        raise InputError(f'{path}: a program gives its stations; --pose goes with a mechanism file of type gpr')
    if kind == 'robot':
        from .robot.description import load_robot
        from .robot.program import parse_program
        if args.tool is not None:
            raise InputError('--tool: a robot program\'s tool point is the wafer centre of each station\'s arm')
        program = parse_program(data, str(path), path.parent)
        # the stations solved under the budget's own model, as for a platform program
        robot = load_robot(args.robot or program.robot, geometry=args.config, model=options.model or MODEL)
        return robot_budget(robot, program, table, options), (f'robot {robot.name}: tool point = the wafer centre of '
                                                              f'each station\'s arm, errors in the axes of '
                                                              f'{robot.world_frame}')
    if args.robot is not None:
        raise InputError('--robot goes with a robot program (format: gpr_robot_program)')
    if kind == 'platform':
        from .nodes.program import parse_program as parse_platform_program
        st = parse_platform_program(data, str(path)).stations
        return (platform_budget(_gpr_config(args), table, [s.height for s in st], [s.tilt for s in st],
                                [s.azimuth for s in st], _tool(args), [s.name for s in st], options),
                f'platform program {path.name}: {len(st)} station(s)')
    from .mechanisms import mechanism_from_dict
    from .mechanisms.gpr import GprMechanism
    mech = mechanism_from_dict(data, str(path))
    if not isinstance(mech, GprMechanism):
        raise InputError(f'{mech.name} ({mech.kind}): the accuracy budget is made for the GPR (a file of type gpr), '
                         'a platform program or a robot program; for this mechanism use --errors and '
                         '--parameter-error')
    if args.pose is None:
        raise InputError(f'{mech.name}: give --pose X Y Z A B C (Z the height, A B the tilt vector) or a program')
    pose = [v * (1e-3 if args.mm and i < 3 else 1.0) for i, v in enumerate(args.pose)]
    if args.deg:
        pose[3:] = [math.radians(v) for v in pose[3:]]
    config = _gpr_config(args, data.get('overrides')) if args.config is not None else mech.config
    tilt, azimuth = math.hypot(pose[3], pose[4]), math.atan2(pose[4], pose[3])
    return (platform_budget(config, table, pose[2], tilt, azimuth, _tool(args), None, options),
            f'{mech.name}: height {pose[2]:g} m, tilt {tilt:.6g} rad about the axis at azimuth {azimuth:.6g} rad')


def budget_command(args: argparse.Namespace) -> int:
    """``gpr accuracy FILE --tolerances TABLE ...`` (module docstring)."""
    from .cli import emit_json
    from .mechanisms import read_mechanism_file
    check_budget_options(args, budget=True)
    data, path = read_mechanism_file(args.file)
    budget, what = _budget(args, data, path)
    model = args.model or MODEL
    plan = f', after a calibration from {args.calibration_plan} planned configurations' if args.calibration_plan \
        else ''
    if args.json:
        emit_json({'file': str(path), 'tolerances': str(args.tolerances), 'model': model,
                   'calibration_plan': args.calibration_plan, 'description': what} | budget.as_dict())
        return 0
    from .calibration.report import format_budget
    print(f'{what}; tolerances {args.tolerances}, model {model}{plan}')
    print(format_budget(budget))
    return 0
