"""The options ``gpr calibrate`` and ``gpr calibrate --robot`` share (:mod:`gpr_kinematics.cli.calibrate`): the
geometry, the tolerance table and the sigmas, the frames' poses, ``--free``, and the gate's outcome."""
from __future__ import annotations

import argparse
import math
import sys
from collections.abc import Callable
from typing import TYPE_CHECKING, TypeVar

import numpy as np

from ..core.config import GprConfig, load_config
from ..errors import InputError, brief, one_line
from ..inputs.units import metres
from ..inputs.validation import MAX_COORDINATE, decimal
from .options import number

T = TypeVar('T')

if TYPE_CHECKING:
    from numpy.typing import NDArray

    from ..calibration.frames import Transform
    from ..calibration.measurements import Measurements
    from ..calibration.model import PoseModel
    from ..calibration.tolerances import ToleranceTable
    from ..core.geometry_covariance import GeometryCovariance
    from ..robot.urdf import RobotUrdf

#: Exit status of a fit that failed its gate.
EXIT_GATE = 1


def config(args: argparse.Namespace) -> GprConfig:
    return load_config(args.config) if args.config is not None else load_config()


def table_of(args: argparse.Namespace) -> ToleranceTable | None:
    """The tolerance table of ``--tolerances`` (``None`` without it)."""
    from ..calibration.tolerances import load_tolerances
    return load_tolerances(args.tolerances) if args.tolerances is not None else None


def sigmas(args: argparse.Namespace, table: ToleranceTable | None = None) -> tuple[float, float]:
    """The options' sigmas (SI), else the tolerance table's measurement noise, else the defaults."""
    from ..calibration.identification import DEFAULT_SIGMA_ANGLE, DEFAULT_SIGMA_POSITION
    sp = table.sigma_position if table is not None and table.sigma_position is not None else DEFAULT_SIGMA_POSITION
    sa = table.sigma_angle if table is not None and table.sigma_angle is not None else DEFAULT_SIGMA_ANGLE
    if args.sigma_position is not None:
        sp = metres(args.sigma_position, args.mm)
    if args.sigma_angle is not None:
        sa = math.radians(args.sigma_angle) if args.deg else args.sigma_angle
    return sp, sa


def declared(args: argparse.Namespace) -> tuple[bool, bool]:
    """Whether ``--sigma-position`` and ``--sigma-angle`` were given: then they are the declared measurement noise of
    rows without sigma columns (the whole gate applies), not a noise assumed (the gate's chi-square against it and
    outliers by the residuals' robust scale)."""
    return args.sigma_position is not None, args.sigma_angle is not None


def refuse_unused_sigmas(args: argparse.Namespace, meas: Measurements, source: str) -> None:
    """Refuse ``--sigma-position`` / ``--sigma-angle`` for measurements ``meas`` whose file has that sigma column
    (every row its own sigma, which the fit takes): the option did nothing, exit 0 and the same fit."""
    for flag, column in (('--sigma-position', 'sigma_position'), ('--sigma-angle', 'sigma_angle')):
        if getattr(args, column) is not None and getattr(meas, column) is not None:
            raise InputError(f'{flag} {getattr(args, column):g}: the rows of {source} have their own {column} column, '
                             f'which the fit takes; allowed: {flag} for a file without that column (leave it out, or '
                             'the column)')


def base_option(values: list[str] | None, robot: bool) -> tuple[list[float] | None, str | None]:
    """``--base`` as typed: six numbers (the pose), or with ``robot`` one file (a calibrated geometry whose covariance
    block has the registration: :func:`registered_base`); ``(numbers, file)``, either ``None``."""
    if values is None:
        return None, None
    if len(values) == 1 and robot and not _reads_as_number(values[0]):
        return None, values[0]
    if len(values) != 6:
        also = ' or, with --robot, one FILE (a geometry gpr calibrate --frame wrote, with its registration)'
        raise InputError(f'--base takes 6 numbers (x y z roll pitch yaw){also if robot else ""}, got '
                         f'{len(values)}: {brief(" ".join(values))}' + ('' if robot else f'; allowed: 6 numbers{also}'))
    try:
        return [number(v) for v in values], None
    except ValueError as exc:
        raise InputError(f'--base: {exc}') from None


def _reads_as_number(text: str) -> bool:
    try:
        decimal(text)
    except ValueError:
        return False
    return True


def registered_base(path: str, frame: str, gpr: GeometryCovariance | None) -> GeometryCovariance:
    """The covariance block of ``path`` with its registration of ``gpr_base`` in ``frame`` (``--base FILE``), whose
    geometry is ``gpr``'s (the GPR the arms are calibrated with: ``--config FILE``, or the robot's section naming
    it); else :class:`InputError` naming what is wrong and what is allowed."""
    from pathlib import Path

    from ..core.geometry_covariance import load_covariance
    block = load_covariance(path)
    allowed = ("allowed: a geometry gpr calibrate --frame NAME wrote (its covariance block with the registration's "
               'base), or X Y Z ROLL PITCH YAW')
    if block is None or block.base is None:
        raise InputError(f'--base {path}: no registration of gpr_base with its covariance in that file; {allowed}')
    if block.base.frame != frame:
        raise InputError(f'--base {path}: its registration is of gpr_base in {block.base.frame}, and --frame is '
                         f'{frame}; allowed: --frame {block.base.frame} (the frame it was registered in)')
    if gpr is None or gpr.section or Path(gpr.source).resolve() != Path(path).resolve():
        used = 'a geometry without a covariance block' if gpr is None else gpr.origin
        raise InputError(f'--base {path}: its registration was identified with the geometry of that file, and the '
                         f'GPR here is {used}; allowed: --config {path} with it (both, and their covariance, from '
                         'one calibration)')
    return block


def pose(values: list[float] | None, args: argparse.Namespace, flag: str,
         sizes: tuple[int, ...]) -> Transform | None:
    """``--base`` / ``--target`` as a :class:`~gpr_kinematics.calibration.frames.Transform` (``--mm``, ``--deg``)."""
    from ..calibration.frames import Transform
    if values is None:
        return None
    names = ('x', 'y', 'z', 'roll', 'pitch', 'yaw')
    if len(values) not in sizes:
        shape = 'x y z roll pitch yaw' if sizes == (6,) else 'x y z [roll pitch yaw]'
        raise InputError(f'{flag} takes {" or ".join(map(str, sizes))} finite numbers ({shape}), got {len(values)}')
    for name, value in zip(names, values, strict=False):   # a NaN was refused as 'takes 6 finite numbers, got 6'
        if not math.isfinite(value):
            raise InputError(f'{flag} {name} = {value:g} is not a finite number; allowed: finite numbers')
    if max(abs(v) for v in values) > MAX_COORDINATE:  # 1e308 overflowed into the measurements' check
        raise InputError(f'{flag} {brief(values)}: allowed: each value within +-{MAX_COORDINATE:g} (m or mm, rad or '
                         'deg)')
    v = [metres(x, args.mm and i < 3) for i, x in enumerate(values)]
    v[3:] = [math.radians(x) if args.deg else x for x in v[3:]]
    return Transform.from_xyz_rpy(v)


def fixed_frame(frame: str, model: RobotUrdf) -> None:
    """Refuse a ``--frame`` of ``model`` (the GPR's or the robot's URDF) other than one whose pose is known: its root
    and ``gpr_base``. A frame that moves with the machine (``--frame gpr_platform`` passed as a tracker's name) is
    refused since measurements are taken in a fixed frame; a fixed one placed by the geometry being calibrated (a rod
    guide, at its rod's position and direction) since its pose would be fitted as a tracker's, apart from the
    geometry that places it."""
    known = tuple(dict.fromkeys((model.root, 'gpr_base')))
    fixed = model.fixed_frames()
    moving = [link.name for link in model.links if link.name not in fixed]
    allowed = (f'allowed: the frame the measurements are in: one whose pose is known ({", ".join(known)}) or one of '
               "the tracker's own name")
    if frame in moving:
        raise InputError(f'--frame {frame} moves with the machine; {allowed} (not one of the {len(moving)} frames of '
                         f'{model.name} that move)')
    if frame in fixed and frame not in known:
        raise InputError(f'--frame {frame} is a frame of {model.name} placed by its geometry (a rod\'s guide, at '
                         f'the rod\'s foot and direction), not a known pose: it would be fitted as a tracker\'s, '
                         f'apart from that geometry; {allowed}')


def with_given_poses(args: argparse.Namespace, run: Callable[[], T]) -> T:
    """``run()``; a measured pose far from the nominal model's
    (:class:`~gpr_kinematics.calibration.plausibility.ImplausiblePoseError`) also names ``--base``/``--target``
    when they were given without ``--mm``/``--deg`` (their units are the options', not the file's)."""
    from ..calibration.plausibility import ImplausiblePoseError
    try:
        return run()
    except ImplausiblePoseError as exc:
        if getattr(args, 'robot', None) is not None and exc.angle != 'rad' and not exc.units:   # an arm's joints
            said = f"{exc}; or its '# units:' line's angle unit ({exc.angle}) not the joints'"
            exc = ImplausiblePoseError(said)   # its frame hint below, if any, comes after it
        flags = ' and '.join(f for f in ('--base', '--target') if getattr(args, f[2:], None) is not None)
        units = [u for u, on in (('--mm for millimetres', not args.mm), ('--deg for degrees', not args.deg)) if on]
        gpr = getattr(args, 'robot', None) is None and hasattr(args, 'fit_target')   # not an arm's: its wafer centre
        if gpr and not flags and not exc.target_fitted and not exc.units:   # the GPR's target: a probe off the origin?
            unit = 'mm' if args.mm else 'm'
            raise ImplausiblePoseError(f'{exc}; or a target (a probe, a reflector) away from the origin of '
                                       f'gpr_platform: give its place with --target X Y Z [{unit}], or --fit-target'
                                       ) from None
        if not flags or not units:
            raise exc from None
        raise ImplausiblePoseError(f'{exc}; or {flags} in other units than m and rad ({", ".join(units)})?') from None


def priors(table: ToleranceTable | None,
           model: PoseModel) -> tuple[NDArray[np.float64] | None, NDArray[np.float64] | None]:
    """The tolerance table's standard deviations and bounds for the model's parameters (``None``: no table)."""
    from ..calibration.tolerances import bound_of, prior_of
    return (prior_of(table, model.parameters), bound_of(table, model.parameters)) if table is not None else (None,
                                                                                                          None)


def free_names(args: argparse.Namespace, model: PoseModel) -> list[str] | None:
    """``--free`` and, with an identified frame, its parameters (``None``: all)."""
    if args.free is None:
        return None
    twice = sorted({n for n in args.free if args.free.count(n) > 1})
    if twice:
        raise InputError(f'--free names {brief(twice[0])} twice; allowed: each parameter once')
    params = model.parameters
    for key in set(args.free) & set(params.groups):   # a key and one of its own parameters: the parameter twice
        inner = [p.name for p in params if p.key == key and p.name in args.free]
        if inner:
            raise InputError(f'--free names {inner[0]} twice, on its own and in {key}; allowed: each parameter once '
                             '(a key selects all of its parameters)')
    frames = [n for n in model.parameters.names if n.startswith(('base_', 'target_'))]
    return list(args.free) + frames


def gate_outcome(passed: bool, message: str, args: argparse.Namespace) -> bool:
    """Whether to write the file; a failed gate's reason on stderr (one line)."""
    if passed:
        return True
    what = 'written anyway (--force)' if args.force else 'no file written (--force writes it anyway)'
    sys.stderr.write(f'gpr calibrate: the fit failed its gate: {one_line(message)} {what}\n')
    return bool(args.force)
