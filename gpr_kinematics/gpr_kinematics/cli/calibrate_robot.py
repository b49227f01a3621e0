"""``gpr calibrate --robot FILE ARM.csv ...``: each arm's link lengths, joint zero offsets and wafer centre from
measured points of its blade (:mod:`gpr_kinematics.calibration.arm`), the report of each, and the calibrated robot
description for ``--robot``. Part of :mod:`gpr_kinematics.cli.calibrate`."""
from __future__ import annotations

import argparse
import dataclasses
from datetime import datetime, timezone
from functools import partial
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from ..errors import InputError
from .calibrate_options import (
    EXIT_GATE,
    declared,
    fixed_frame,
    gate_outcome,
    pose,
    refuse_unused_sigmas,
    registered_base,
    sigmas,
    table_of,
    with_given_poses,
)
from .output import emit_json
from .progress import progress_line

if TYPE_CHECKING:
    from ..calibration.arm import ArmMeasurements, ArmModel
    from ..calibration.model import PoseModel
    from ..calibration.registration import Registration
    from ..calibration.results import CalibrationResult
    from ..core.geometry_covariance import GeometryCovariance
    from ..robot.description import RobotDescription



def _free(args: argparse.Namespace, models: dict[str, PoseModel]) -> dict[str, list[str] | None]:
    """``--free`` per arm: the names and keys of that arm's parameters (with an identified frame, its parameters)."""
    if args.free is None:
        return {arm: None for arm in models}
    known = {n for m in models.values() for n in m.parameters.names + m.parameters.groups}
    unknown = [n for n in args.free if n not in known]
    if unknown:
        allowed = ', '.join(sorted(known - {n for n in known if n.startswith(('base_', 'target_'))}))
        raise InputError(f'--free: unknown parameter(s) {", ".join(unknown)}; allowed: {allowed}')
    out: dict[str, list[str] | None] = {}
    for arm, m in models.items():
        mine = [n for n in args.free if n in m.parameters.names or n in m.parameters.groups]
        out[arm] = mine + [n for n in m.parameters.names if n.startswith(('base_', 'target_'))]
    return out


def _check(args: argparse.Namespace) -> None:
    if args.output is None:
        raise InputError('--output FILE is required: the calibrated robot description is written there')
    if not args.measurements:
        raise InputError('--robot needs one or more files of measured points of its arms')
    if args.target is not None or args.fit_target is not None:
        raise InputError('--target and --fit-target are for the GPR; an arm\'s measured point is its wafer centre, '
                         'or the blade point of the columns bx, by, bz')


def _models(args: argparse.Namespace, robot: RobotDescription,
            registered: GeometryCovariance | None) -> tuple[dict[str, PoseModel], dict[str, ArmModel]]:
    """Per arm with files: its pose model in ``--frame`` and its :class:`~gpr_kinematics.calibration.arm.ArmModel`
    (whose measurements it holds); ``registered``: ``--base FILE``'s block, whose base is the known one."""
    from ..calibration.arm import ArmModel, merge, read_arm_measurements
    from ..calibration.frames import Transform, measuring_model
    parts: dict[str, list[ArmMeasurements]] = {}
    for path in args.measurements:
        m = read_arm_measurements(path, robot)
        parts.setdefault(m.arm, []).append(m)
    base = None
    given = args.base is not None or args.base_file is not None
    if given and args.frame == robot.world_frame:  # it replaced the description's base unsaid
        raise InputError(f'--base gives the pose of gpr_base in --frame, which is {args.frame}, the world frame where '
                         'the robot description places gpr_base (its base); allowed: --base with --frame naming '
                         'another frame (the tracker\'s), or the description\'s base edited')
    if registered is not None and registered.base is not None:
        base = Transform.from_xyz_rpy(registered.base.pose)
    elif args.base is not None:
        base = pose(args.base, args, '--base', (6,))
    elif args.frame == robot.world_frame:
        base = Transform(np.asarray(robot.base_position, dtype=float), robot.base_rotation)
    models: dict[str, PoseModel] = {}
    inners: dict[str, ArmModel] = {}
    for arm, rows in parts.items():
        inner = ArmModel(robot, merge(rows))
        models[arm] = measuring_model(inner, inner.meas.points, args.frame, base, Transform.identity(), None)
        inners[arm] = inner
    return models, inners


#: What the arms' standard errors leave out without a GPR covariance (a GPR calibrated from its own noisy poses put a
#: shoulder's zero offset 4 standard errors off in 3 runs of 4, the heading it gives the platform a few urad off).
GEOMETRY_NOTE = ("the arms' standard errors take the GPR's geometry (--config, else the robot's) as exact: its own "
                 "calibration's uncertainty (the platform's heading, a few urad) adds to the zero offsets and the "
                 'mount, beyond them; a geometry file gpr calibrate wrote with its covariance block (--config, or '
                 "the robot's gpr section naming it) adds it to them")


def covariance_note(cov: GeometryCovariance) -> str:
    """The ``note:`` when the arms' standard errors include the GPR's covariance ``cov`` (and its registration's)."""
    base = '' if cov.base is None else f" and the 6 of its registration of gpr_base in {cov.base.frame} (--base)"
    return (f"the arms' standard errors include the GPR's calibration uncertainty: the covariance of its "
            f"{len(cov.geometry().names)} calibrated parameters (fitted, or derived from them by a registration's "
            f'datum){base} in {cov.origin}, propagated to first order (K Sigma_g K^T, docs/calibration.md)')


def _without(res: CalibrationResult, plain: np.ndarray) -> str:
    """``gpr covariance: ...``: the standard errors without the GPR's covariance, beside the report's (with it)."""
    from ..calibration.report import micro
    parts = [f'{res.parameters[int(j)].name} {micro(float(plain[j]), res.parameters[int(j)].unit).lstrip("+")}'
             for j in res.fitted]
    return ("gpr covariance: every standard error above includes the GPR's calibration covariance; without it: "
            + ', '.join(parts))


def _write(args: argparse.Namespace, robot: RobotDescription, results: list[tuple[str, CalibrationResult]],
           values: dict[str, np.ndarray], regs: dict[str, Registration | None]) -> Path:
    """The calibrated robot file, headed by what was fitted and the registrations."""
    from ..calibration.arm import calibrated_robot, write_robot
    stamp = datetime.now(timezone.utc).strftime('%Y-%m-%dT%H:%M:%SZ')
    comments = [f'robot {robot.name} with its arms calibrated by `gpr calibrate --robot` from '
                f'{", ".join(args.measurements)} (measured in {args.frame}), {stamp}']
    comments += [f'arm {a}: fitted {", ".join(r.parameters[j].name for j in r.fitted) or "none"}; held '
                 f'{", ".join(r.identifiability.held) or "none"}; residual RMS {r.after.rms_position:.3e} m; gate '
                 f'{"passed" if r.gate.passed else "FAILED (written with --force)"}' for a, r in results]
    comments += [f'registration of arm {a}: {line}' for a, reg in regs.items() if reg for line in reg.lines()]
    comments.append('SI units; use with any command: --robot THIS_FILE')
    return write_robot(args.output, calibrated_robot(robot, values), comments)


def _as_dict(reg: Registration | None) -> dict[str, object] | None:
    return None if reg is None else reg.as_dict()


def _gpr_dict(cov: GeometryCovariance | None, plain: dict[str, float]) -> dict[str, object] | None:
    """The JSON's ``gpr_covariance`` of an arm: the file, the GPR's parameters and the standard errors without them
    (``null``: the standard errors take the GPR as exact)."""
    if cov is None:
        return None
    return {'file': cov.source, 'section': cov.section or None, 'parameters': list(cov.names),
            'standard_error_without': plain}


def _gpr_covariance(args: argparse.Namespace, robot: RobotDescription) -> GeometryCovariance | None:
    """The GPR's calibration covariance: ``--config``'s block, else the robot's gpr section's
    (:mod:`~gpr_kinematics.robot.gpr_section`); its registration's base with it only for ``--base FILE``
    (:func:`~.calibrate_options.registered_base`), else the geometry's parameters alone."""
    from ..core.geometry_covariance import load_covariance
    cov = load_covariance(args.config) if args.config is not None else robot.gpr_covariance
    if args.base_file is not None:
        return registered_base(args.base_file, args.frame, cov)
    return cov.geometry() if cov is not None else None


def calibrate_robot(args: argparse.Namespace) -> int:
    """Identify every arm with measurement files (module docstring); status 0, or 1 when a fit fails its gate."""
    from ..calibration.arm_gpr import ResidualShare, gain, weighted_jacobians, weighted_residuals, with_gpr_covariance
    from ..calibration.frames import FramedModel
    from ..calibration.identification import identify, weights
    from ..calibration.registration import registration
    from ..calibration.report import format_calibration
    from ..robot.description import load_robot
    from ..robot.gpr_section import GprSection
    from ..robot.urdf import robot_urdf
    _check(args)
    robot = load_robot(args.robot, geometry=args.config, model=args.model)
    urdf = robot_urdf(robot)
    fixed_frame(args.frame, urdf)
    if args.frame == 'world' and urdf.root != 'world':   # the docs' name for it, not this robot's: a user's mistake
        raise InputError(f'--frame world: the world frame of robot {robot.name} is {urdf.root} (its description\'s '
                         f'base frame); allowed: --frame {urdf.root} for measurements in it, gpr_base, or a tracker\'s '
                         'frame under a name of its own (it would be fitted: world would read as a tracker here)')
    gpr_cov = _gpr_covariance(args, robot)
    models, inners = _models(args, robot, gpr_cov)
    left = robot.gpr.left if args.config is None else ''
    robot = dataclasses.replace(robot, gpr=GprSection(gpr_cov.geometry() if gpr_cov is not None else None))
    sp, sa = sigmas(args, table_of(args))
    free = _free(args, models)
    results, texts, values = [], [], {}
    without: dict[str, dict[str, float]] = {}
    regs: dict[str, Registration | None] = {}
    shares: dict[str, np.ndarray] = {}   # the GPR's share of each arm's residuals, for its plot
    shown = progress_line(args.no_progress)
    for arm, model in models.items():
        inner = inners[arm]
        refuse_unused_sigmas(args, inner.meas.points, f'arm {arm}\'s measurements')

        def told(stage: str, share: float, arm: str = arm) -> None:
            shown(f'arm {arm}: {stage}', share)

        try:
            res = with_given_poses(args, partial(identify, model, inner.meas.points, free=free[arm], sigma_position=sp,
                                                 sigma_angle=sa, threshold=args.threshold, frame=args.frame,
                                                 declared=declared(args), progress=told))
        finally:
            shown.close()
        plain = res.standard_error
        if gpr_cov is not None:   # the GPR's calibration uncertainty in the arm's (calibration.arm_gpr)
            w = weights(inner.meas.points, sp, sa, declared(args))[0]
            A, B = weighted_jacobians(model, inner, res, gpr_cov, w)   # and its gate with the GPR's error
            share = ResidualShare.of(A, B, gpr_cov)
            gate = share.gate(res, weighted_residuals(model, inner, res, w), inner.meas.points.row_names)
            shares[arm] = share.gpr
            res = with_gpr_covariance(res, gain(A, B), gpr_cov, gate)
        reg: Registration | None = None
        if isinstance(model, FramedModel):
            values[arm] = inner.parameters.values(model.inner_theta(res.estimate[None])[0])
            if model.fit_base:
                reg = registration(model, res.estimate, res.standard_error, res.fitted, res.covariance, args.frame,
                                   res.bias)
        else:
            values[arm] = res.values
        results.append((arm, res))
        regs[arm] = reg
        without[arm] = {res.parameters[int(j)].name: float(plain[j]) for j in res.fitted}
        texts.append(f'== arm {arm}\n{format_calibration(res)}'
                     + (f'\n{_without(res, plain)}' if gpr_cov is not None else '')
                     + ''.join(f'\nregistration: {line}' for line in (reg.lines() if reg else [])))
    passed = all(r.gate.passed for _, r in results)
    message = ' '.join(f'arm {a}: {r.gate.message()}' for a, r in results if not r.gate.passed)
    write = gate_outcome(passed, message, args)
    plotted: dict[str, str] = {}
    if args.plot is not None:   # each arm's residuals, also when a gate fails
        from ..calibration.plot import plot_residuals
        from ..calibration.residual_plot import residual_plot
        plotted['plot_file'] = str(plot_residuals(args.plot, [
            residual_plot(models[a], inners[a].meas.points, r, sp, sa, declared(args), f'arm {a}', shares.get(a))
            for a, r in results]))
    path = _write(args, robot, results, values, regs) if write else None
    note = covariance_note(gpr_cov) if gpr_cov is not None else f'{GEOMETRY_NOTE}; {left}' if left else GEOMETRY_NOTE
    if args.json:
        emit_json({'robot': robot.name, 'arms': [r.as_dict() | {'arm': a, 'registration': _as_dict(regs[a]),
                                                                'gpr_covariance': _gpr_dict(gpr_cov, without[a])}
                                                 for a, r in results],
                   'output': str(path) if path else None, 'note': note} | plotted)
    else:
        print('\n'.join(texts))
        print(f'note: {note}')
        if path:
            print(f'calibrated robot written to {path} (use it with --robot {path})')
        if plotted:
            print(f'plot written to {plotted["plot_file"]}')
    return 0 if passed else EXIT_GATE
