"""``gpr mechanism``, ``gpr accuracy`` and ``gpr dexterity``: the mechanism analyses on the command line.

Plugin of :mod:`gpr_kinematics.cli` (``register(subparsers)``). A FILE is a mechanism YAML
(``config/mechanisms/*.yaml``; a bare packaged name such as ``upu3.yaml`` also works). Poses are
``X Y Z A B C`` in metres and radians (``--mm`` and ``--deg`` convert the input), with the Euler
convention of the mechanism:

- ``gsp``: R = Rz(C) Ry(B) Rx(A), scipy ``from_euler('xyz', [A, B, C])`` (or the file's ``euler``);
- ``stewart_6sps`` (Alwan): Z-X-Z intrinsic, A, B, C = psi, theta, phi, scipy ``from_euler('ZXZ', ...)``;
- ``upu3``: translation only, A B C must be 0 (ignored);
- ``tripod_3rps``: A, B = theta (about y), psi (about x), R = Ry(theta) Rx(psi) Rz(phi); X, Y and C = phi
  are the parasitic motions (outcomes, ignored on input);
- ``gpr``: A, B = tilt rotation vector (tilt_x, tilt_y); X, Y and C = twist are outcomes.

Outputs are SI. Bad input (unknown constraint type, degenerate line, pose outside the joint limits,
singular pose where an inverse is needed) exits with status 2 and a one-line message.
"""
from __future__ import annotations

import argparse
from typing import Any

import numpy as np

from .errors import InputError, SingularityError, brief
from .mechanisms import load_mechanism
from .mechanisms.base import ANGULAR_JOINTS, Mechanism, as_poses
from .validation import MAX_COORDINATE

CONVENTIONS = """pose convention (X Y Z A B C, m and rad unless --mm/--deg):
  gsp           R = Rz(C) Ry(B) Rx(A) = scipy from_euler('xyz', [A, B, C]) (or the file's 'euler')
  stewart_6sps  Z-X-Z intrinsic Euler angles (psi, theta, phi) = scipy from_euler('ZXZ', [A, B, C])
  upu3          translation only: A B C must be 0
  tripod_3rps   A = theta (about y), B = psi (about x); R = Ry(theta) Rx(psi) Rz(phi); X, Y, C = phi are
                parasitic motions computed by the mechanism (ignored on input)
  gpr           A, B = tilt rotation vector (tilt_x, tilt_y) = tilt (cos azimuth, sin azimuth); X, Y and
                C = twist are outcomes of the virtual-joint model (ignored on input)
angular velocities and inverse-Jacobian columns: v_x v_y v_z w_x w_y w_z, w in the base frame"""


def _finite(text: str) -> float:
    try:
        val = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f'{brief(text)} is not a number') from None
    if not np.isfinite(val):
        raise argparse.ArgumentTypeError(f'{brief(text)} is not a finite number')
    return val


def _pose(args: argparse.Namespace, mech: Mechanism) -> np.ndarray:
    pose = np.array(args.pose, dtype=float)
    if args.mm:
        pose[:3] *= 1e-3
    if args.deg:
        pose[3:] = np.radians(pose[3:])
    as_poses(pose, '--pose')  # the position's bound, named as the option
    if mech.kind == 'upu3' and np.any(pose[3:] != 0):
        raise InputError(f'{mech.name} only translates: the angles A B C must be 0; got {pose[3:].tolist()}')
    return pose


def _joints(mech: Mechanism, q: np.ndarray) -> list[dict[str, Any]]:
    labels = getattr(mech, 'types', None)
    out = []
    for k, name in enumerate(mech.joint_names):
        jt = mech.joint_types[k]
        out.append({'name': name,
                     'type': str(labels[k]) if labels is not None else jt,
                     'joint_type': jt,
                     'value': float(q[k]),
                     'unit': 'rad' if jt in ANGULAR_JOINTS else 'm'})
    return out


def _finite_or_none(x: float) -> float | None:
    return float(x) if np.isfinite(x) else None


def _mechanism(args: argparse.Namespace) -> int:
    from .cli import emit_json
    mech = load_mechanism(args.file)
    pose = _pose(args, mech)
    full = mech.complete_pose(pose)
    q = mech.inverse_kinematics(full)
    mech.check_limits(q)
    rep = mech.report(full)
    if not (np.all(np.isfinite(rep.inverse_jacobian)) and np.all(np.isfinite(rep.task_jacobian))):
        raise SingularityError(f'{mech.name}: the inverse Jacobian is not defined at pose {full.tolist()} '
                               '(a constraint row divides by zero: zero distance, parallel lines, theta = 0)')
    result: dict[str, Any] = {
        'mechanism': mech.name, 'type': mech.kind, 'file': str(args.file),
        'euler_convention': mech.euler_convention,
        'pose': dict(zip(mech.pose_names, full.tolist(), strict=True)),
        'pose_variables': list(mech.pose_variables),
        'joints': _joints(mech, q),
        'inverse_jacobian': rep.inverse_jacobian,
        'homogenized_inverse_jacobian': rep.homogenized_inverse_jacobian,
        'characteristic_length': mech.characteristic_length,
        'homogenized_task_jacobian': rep.task_jacobian,
        'condition_number': _finite_or_none(rep.condition_number),
        'dexterity': rep.dexterity,
        'singular': rep.singular,
        'singularity': rep.singularity or None,
        'within_limits': rep.within_limits,
    }
    if hasattr(mech, 'plane_residuals'):
        result['plane_residuals'] = mech.plane_residuals(full)[0]
    if args.json:
        emit_json(result)
        return 0
    print(f'{mech.name} ({mech.kind}), pose ' + ', '.join(
        f'{k} = {v:.9g}' for k, v in result['pose'].items()))
    for j in result['joints']:
        print(f'  {j["name"]:>8} [{j["type"]}] = {j["value"]:.9g} {j["unit"]}')
    print('inverse Jacobian (columns v_x v_y v_z w_x w_y w_z, w in the base frame):')
    for row in rep.inverse_jacobian:
        print('  ' + ' '.join(f'{v:11.6f}' for v in row))
    print(f'homogenized inverse Jacobian (characteristic length {mech.characteristic_length:g} m):')
    for row in rep.homogenized_inverse_jacobian:
        print('  ' + ' '.join(f'{v:11.6f}' for v in row))
    print(f'condition number {rep.condition_number:.6g}, dexterity {rep.dexterity:.6g}, '
          f'singular: {"yes" if rep.singular else "no"}' + (f' ({rep.singularity})' if rep.singularity else ''))
    return 0


def _joint_errors(args: argparse.Namespace, mech: Mechanism) -> np.ndarray:
    """``--errors`` in SI (``--mm``/``--deg`` converted), else the file's leg deformations, else zeros."""
    if args.errors is None:
        deformations = getattr(mech, 'leg_deformations', None)
        return np.zeros(mech.n_joints) if deformations is None else np.asarray(deformations, dtype=float)
    errors = np.array(args.errors, dtype=float)
    if errors.size != mech.n_joints:
        raise InputError(f'--errors takes {mech.n_joints} values ({", ".join(mech.joint_names)}); '
                         f'got {errors.size}')
    ang = np.array([t in ANGULAR_JOINTS for t in mech.joint_types])
    if args.mm:
        errors[~ang] *= 1e-3
    if args.deg:
        errors[ang] = np.radians(errors[ang])
    return errors


def _parameter_errors(args: argparse.Namespace, mech: Mechanism) -> dict[str, np.ndarray]:
    """``--parameter-error NAME V...`` items as arrays of the parameters' shapes (m, ``--mm`` converted)."""
    params: dict[str, np.ndarray] = {}
    nominal = mech.parameters()
    for item in args.parameter_error or []:
        name, values = item[0], item[1:]
        if name not in nominal:
            raise InputError(f'{mech.name}: unknown parameter {brief(name)} for --parameter-error; allowed: '
                             + (', '.join(sorted(nominal)) or 'none'))
        try:
            vals = np.array([float(v) for v in values])
        except ValueError:
            raise InputError(f'--parameter-error {name}: values must be numbers; got {values}') from None
        size = np.asarray(nominal[name]).size
        if vals.size != size:
            raise InputError(f'--parameter-error {name} takes {size} values (shape '
                             f'{np.shape(nominal[name])}, m); got {vals.size}')
        params[name] = (vals * (1e-3 if args.mm else 1.0)).reshape(np.shape(nominal[name]))
    return params


def _accuracy(args: argparse.Namespace) -> int:
    if args.tolerances is not None:
        from .cli_accuracy import budget_command
        return budget_command(args)
    from .accuracy import accuracy_analysis
    from .cli import emit_json
    from .cli_accuracy import check_budget_options
    check_budget_options(args, budget=False)
    mech = load_mechanism(args.file)
    trajectory = getattr(mech, 'trajectory', None)
    if args.pose is not None:
        poses = _pose(args, mech)[None, :]
    elif trajectory is not None:
        poses = np.asarray(trajectory, dtype=float)
    else:
        raise InputError(f'{mech.name}: give --pose X Y Z A B C (the file has no trajectory)')
    errors = _joint_errors(args, mech)
    params = _parameter_errors(args, mech)
    full = mech.complete_pose(poses)
    mech.check_limits(mech.inverse_kinematics(full))
    res = accuracy_analysis(mech, full, errors, params)
    # The text and the JSON print the same numbers: both from these dicts.
    results = [res.as_dict(i) for i in range(res.poses.shape[0])]
    if args.json:
        emit_json({'mechanism': mech.name, 'type': mech.kind, 'variables': list(res.variables), 'results': results})
        return 0
    print(f'{mech.name}: pose deviation for joint errors {np.asarray(errors).tolist()} (SI)'
          + (f' and parameter errors {sorted(params)}' if params else ''))
    head = ' '.join(f'{v:>12}' for v in res.variables)
    print(f'{"":>6} {"":>11} {head}')
    for i, r in enumerate(results):
        for label in ('linearized', 'exact', 'difference'):
            print(f'{i + 1 if label == "linearized" else "":>6} {label:>11} '
                  + ' '.join(f'{r[label][v]:12.4e}' for v in res.variables))
    print('rigid motion of the platform, parasitic components included (x y z [m], rotation vector rx ry rz [rad], '
          'base frame):')
    print(f'{"":>6} {"":>11} ' + ' '.join(f'{v:>12}' for v in ('x', 'y', 'z', 'rx', 'ry', 'rz')))
    for i, r in enumerate(results):
        for label in ('linearized', 'exact'):
            print(f'{i + 1 if label == "linearized" else "":>6} {label:>11} '
                  + ' '.join(f'{v:12.4e}' for v in np.asarray(r[f'{label}_twist']).tolist()))
    return 0


def _vary(args: argparse.Namespace, mech: Mechanism, base: np.ndarray, values: list[str] | None,
          default_var: str) -> tuple[str, np.ndarray]:
    """The variable and its values of ``--vary NAME MIN MAX COUNT`` (SI; ``--mm``/``--deg`` converted), or
    51 values over the default range of ``default_var``."""
    if values is None:
        lo, hi = _default_range(mech, base, default_var)
        return default_var, np.linspace(lo, hi, 51)
    from .dexterity import MAX_POINTS
    name = values[0]
    try:
        lo, hi, n = float(values[1]), float(values[2]), int(values[3])
    except ValueError:
        raise InputError(f'--vary takes NAME MIN MAX COUNT (numbers, COUNT an integer from 2 to {MAX_POINTS}); '
                         f'got {brief(values)}') from None
    if not 2 <= n <= MAX_POINTS:
        raise InputError(f'--vary {brief(name)}: COUNT = {n}; allowed: an integer from 2 to {MAX_POINTS} (poses per '
                         'map)')
    if not (abs(lo) <= MAX_COORDINATE and abs(hi) <= MAX_COORDINATE) or not lo < hi:  # NaN fails both
        raise InputError(f'--vary {brief(name)}: need MIN < MAX, both finite and of magnitude at most '
                         f'{MAX_COORDINATE:g}; got {brief(values[1:])}')
    idx = mech.pose_names.index(name) if name in mech.pose_names else -1
    scale = 1.0
    if 0 <= idx < 3 and args.mm:
        scale = 1e-3
    if idx >= 3 and args.deg:
        scale = np.pi / 180
    return name, np.linspace(lo, hi, n) * scale


def _dexterity(args: argparse.Namespace) -> int:
    from .cli import emit_json
    from .dexterity import check_plot_path, dexterity_grid, dexterity_sweep, plot_dexterity
    if args.plot is not None:
        check_plot_path(args.plot)  # before the work, not after it
    mech = load_mechanism(args.file)
    base = _pose(args, mech) if args.pose is not None else np.asarray(mech.home_pose, dtype=float)
    sweep = getattr(mech, 'default_sweep', None)
    default_var = sweep[0] if sweep is not None else 'z'
    var, vals = _vary(args, mech, base, args.vary, default_var)
    if args.vary2 is not None:
        var2, vals2 = _vary(args, mech, base, args.vary2, default_var)
        dmap = dexterity_grid(mech, base, var, vals, var2, vals2)
    else:
        dmap = dexterity_sweep(mech, base, var, vals)
    plot = None if args.plot is None else str(plot_dexterity(dmap, args.plot))
    if args.json:
        emit_json(dmap.as_dict() | {'type': mech.kind, 'plot': plot})
        return 0
    if dmap.variable2 is None:
        print(f'{mech.name}: dexterity (inverse condition number) against {var}')
        for v, d, ok in zip(dmap.values, dmap.dexterity, dmap.within_limits, strict=True):
            print(f'  {var} = {v:12.6g}   dexterity {d:.6f}' + ('' if ok else '   (joints outside limits)'))
    else:
        inside = dmap.dexterity[dmap.within_limits]
        print(f'{mech.name}: dexterity on a {vals.size} x {vals2.size} grid of {var} x {var2}; within joint '
              f'limits: {inside.size} points' + (f', dexterity {inside.min():.4f} .. {inside.max():.4f}'
                                                  if inside.size else ''))
    if plot is not None:
        print(f'plot written to {plot}')
    return 0


def _default_range(mech: Mechanism, base: np.ndarray, var: str) -> tuple[float, float]:
    """The range of ``var`` (default z) over which ``base`` stays within the joint limits, by a scan."""
    if var not in mech.pose_variables:
        raise InputError(f'{mech.name}: cannot vary {brief(var)}; its pose variables are '
                         + ', '.join(mech.pose_variables) + ' (use --vary NAME MIN MAX COUNT)')
    sweep = getattr(mech, 'default_sweep', None)
    if sweep is not None and sweep[0] == var:
        return float(sweep[1]), float(sweep[2])
    lim = np.asarray(mech.joint_limits, dtype=float)
    finite = lim[np.isfinite(lim)]
    top = 4.0 * mech.characteristic_length
    if finite.size and np.max(finite) > 0:
        top = 2.0 * float(np.max(finite))
    grid = np.linspace(0.0, top, 801)
    poses = np.repeat(base[None, :], grid.size, axis=0)
    poses[:, mech.pose_names.index(var)] = grid
    try:
        ok = mech.within_limits(mech.inverse_kinematics(poses))
    except InputError:
        ok = np.zeros(grid.size, dtype=bool)
    if not ok.any():
        raise InputError(f'{mech.name}: no {var} in [0, {top:g}] keeps the joints within limits at this '
                         'pose; give --vary NAME MIN MAX COUNT')
    return float(grid[ok][0]), float(grid[ok][-1])


def register(subparsers: Any) -> None:
    """Add ``mechanism``, ``accuracy`` and ``dexterity`` to the ``gpr`` command."""
    fmt = argparse.RawDescriptionHelpFormatter

    def common(p: argparse.ArgumentParser, pose_required: bool) -> None:
        p.add_argument('file', metavar='FILE', help='mechanism YAML (config/mechanisms/*.yaml)')
        p.add_argument('--pose', nargs=6, type=_finite, metavar=('X', 'Y', 'Z', 'A', 'B', 'C'),
                       required=pose_required, help='platform pose (m, rad; see the convention below)')
        p.add_argument('--mm', action='store_true', help='lengths given in mm (outputs stay SI)')
        p.add_argument('--deg', action='store_true', help='angles given in degrees (outputs stay SI)')
        p.add_argument('--json', action='store_true', help='print one JSON object')

    p = subparsers.add_parser('mechanism', help='joint values, inverse Jacobian and conditioning at a pose',
                              description='Inverse kinematics, inverse Jacobian (plain and homogenised), '
                              'condition number and singularity of a mechanism at one pose.',
                              epilog=CONVENTIONS, formatter_class=fmt)
    common(p, True)
    p.set_defaults(handler=_mechanism)

    p = subparsers.add_parser('accuracy', help='platform pose deviation from joint and geometry errors; the accuracy '
                              'budget of the GPR and the whole robot from a tolerance table',
                              description='Pose deviation caused by joint errors (leg deformations, '
                              'actuator errors) and geometric errors: linearised (Alwan eq. 7) and exact '
                              '(perturbed closure solved by Newton). Without --pose/--errors the file\'s '
                              'trajectory and leg_deformations are used (stewart_alwan.yaml). With --tolerances: '
                              'the accuracy budget (docs/calibration.md) of the GPR (FILE of type gpr with --pose, '
                              'or a platform program) or of the whole robot at the wafer (FILE a robot program): '
                              'linearised RSS, worst case and shares, and Monte Carlo percentiles.',
                              epilog=CONVENTIONS, formatter_class=fmt)
    common(p, False)
    p.add_argument('--errors', nargs='+', type=_finite, metavar='E',
                   help='one error per joint in file order (m, rad for angular joints)')
    p.add_argument('--parameter-error', nargs='+', action='append', metavar='NAME V',
                   help='geometric error: parameter name and its values, e.g. A_i (18 values, m) for a '
                   'Stewart platform, joint_imperfections (9 values, m) for the GPR; repeatable')
    from .cli_accuracy import add_budget_options
    add_budget_options(p, _finite)
    p.set_defaults(handler=_accuracy)

    p = subparsers.add_parser('dexterity', help='dexterity (inverse condition number) maps',
                              description='Dexterity = inverse condition number of the homogenised '
                              'Jacobian along one pose variable (default: z over the range within the joint '
                              'limits, as the 3-UPU paper\'s Fig. 6) or on a grid of two.',
                              epilog=CONVENTIONS, formatter_class=fmt)
    common(p, False)
    p.add_argument('--vary', nargs=4, metavar=('NAME', 'MIN', 'MAX', 'COUNT'),
                   help='pose variable to vary (units as --pose, with --mm/--deg)')
    p.add_argument('--vary2', nargs=4, metavar=('NAME', 'MIN', 'MAX', 'COUNT'),
                   help='second variable: a grid map')
    p.add_argument('--plot', metavar='FILE', help='write a plot (.png, .pdf or .svg)')
    p.set_defaults(handler=_dexterity)
