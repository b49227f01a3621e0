"""``gpr mechanism``: joint values, inverse Jacobians and conditioning of a mechanism at one pose.

``gpr accuracy`` (:mod:`.accuracy`) and ``gpr dexterity`` (:mod:`.dexterity`) take the same FILE and poses.

Plugin of :mod:`gpr_kinematics.cli.main` (``register(subparsers)``). A FILE is a mechanism YAML
(``config/mechanisms/*.yaml``; a bare packaged name such as ``upu3.yaml`` also works). Poses are
``X Y Z A B C`` in metres and radians (``--mm`` and ``--deg`` convert the input), with the Euler
convention of the mechanism:

- ``gsp``: R = Rz(C) Ry(B) Rx(A), scipy ``from_euler('xyz', [A, B, C])`` (or the file's ``euler``);
- ``stewart_6sps`` (Alwan): Z-X-Z intrinsic, A, B, C = psi, theta, phi, scipy ``from_euler('ZXZ', ...)``;
- ``upu3``: translation only, A B C must be 0 (ignored);
- ``tripod_3rps``: A, B = theta (about y), psi (about x), R = Ry(theta) Rx(psi) Rz(phi); X, Y and C = phi
  are the parasitic motions (outcomes: 0 or their values on input, others refused);
- ``gpr``: A, B = tilt rotation vector (tilt_x, tilt_y); X, Y and C = twist are outcomes.

Outputs are SI. Bad input (unknown constraint type, degenerate line, pose outside the joint limits,
singular pose where an inverse is needed) exits with status 2 and a one-line message.
"""
from __future__ import annotations

import argparse
from typing import TYPE_CHECKING

from ..core.stroke import typed_in_millimetres
from ..mechanisms.pose_analysis import analyse_pose
from .options import CONVENTIONS, finite, mechanism_of, mechanism_pose
from .output import emit_json, number_text

if TYPE_CHECKING:
    from .main import Subparsers


def _mechanism(args: argparse.Namespace) -> int:
    mech = mechanism_of(args.file)
    pose = mechanism_pose(args, mech)
    with typed_in_millimetres(args.mm):   # --pose in mm (the file was read): named so, not "millimetres as metres?"
        res = analyse_pose(mech, pose)
    if args.json:
        emit_json(res, file=str(args.file))
        return 0
    print(f'{mech.name} ({mech.kind}), pose '
          + ', '.join(f'{k} = {number_text(v, ".9g")}' for k, v in res.pose.items()))   # tilt_x = -0 read so
    for j in res.joints:
        print(f'  {j.name:>8} [{j.type}] = {number_text(j.value, ".9g")} {j.unit}')
    print('inverse Jacobian (columns v_x v_y v_z w_x w_y w_z, w in the base frame):')
    for row in res.inverse_jacobian:
        print('  ' + ' '.join(number_text(v, '11.6f') for v in row))
    print(f'homogenized inverse Jacobian (characteristic length {mech.characteristic_length:g} m):')
    for row in res.homogenized_inverse_jacobian:
        print('  ' + ' '.join(number_text(v, '11.6f') for v in row))
    print(f'condition number {res.condition_number:.6g}, dexterity {res.dexterity:.6g}, '
          f'singular: {"yes" if res.singular else "no"}' + (f' ({res.singularity})' if res.singularity else ''))
    return 0


MECHANISM_FILE = 'mechanism YAML (config/mechanisms/*.yaml)'


def mechanism_options(p: argparse.ArgumentParser, pose_required: bool, file_help: str = MECHANISM_FILE) -> None:
    """FILE (described by ``file_help``), ``--pose``, ``--mm``, ``--deg`` and ``--json``: the options of every
    mechanism subcommand."""
    p.add_argument('file', metavar='FILE', help=file_help)
    p.add_argument('--pose', nargs=6, type=finite, metavar=('X', 'Y', 'Z', 'A', 'B', 'C'),
                   required=pose_required, help='platform pose (m, rad; see the convention below)')
    p.add_argument('--mm', action='store_true', help='lengths given in mm (outputs stay SI)')
    p.add_argument('--deg', action='store_true', help='angles given in degrees (outputs stay SI)')
    p.add_argument('--json', action='store_true', help='print one JSON object')


def register(subparsers: Subparsers) -> None:
    """Add ``mechanism`` to the ``gpr`` command."""
    p = subparsers.add_parser('mechanism', help='joint values, inverse Jacobian and conditioning at a pose',
                              description='Inverse kinematics, inverse Jacobian (plain and homogenised), '
                              'condition number and singularity of a mechanism at one pose.',
                              epilog=CONVENTIONS, formatter_class=argparse.RawDescriptionHelpFormatter)
    mechanism_options(p, True)
    p.set_defaults(handler=_mechanism)
