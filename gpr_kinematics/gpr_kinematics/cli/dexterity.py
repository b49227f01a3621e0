"""``gpr dexterity FILE``: dexterity (inverse condition number) maps of a mechanism (Toz & Kucuk; Aboulissane et
al., Fig. 6). Poses as ``gpr mechanism`` (:data:`gpr_kinematics.cli.options.CONVENTIONS`)."""
from __future__ import annotations

import argparse
import math
from typing import TYPE_CHECKING

import numpy as np

from ..errors import InputError, brief
from ..inputs.units import metres
from ..inputs.validation import MAX_COORDINATE
from ..mechanisms.base import Mechanism
from .mechanism import mechanism_options
from .options import CONVENTIONS, mechanism_of, mechanism_pose, number, whole
from .output import emit_json

if TYPE_CHECKING:
    from .main import Subparsers


def _vary(args: argparse.Namespace, mech: Mechanism, base: np.ndarray, values: list[str] | None,
          default_var: str) -> tuple[str, np.ndarray]:
    """The variable and its values of ``--vary NAME MIN MAX COUNT`` (SI; ``--mm``/``--deg`` converted), or
    51 values over the default range of ``default_var``."""
    if values is None:
        lo, hi = _default_range(mech, base, default_var)
        return default_var, np.linspace(lo, hi, 51)
    from ..mechanisms.dexterity import MAX_POINTS
    name = values[0]
    try:
        lo, hi, n = number(values[1]), number(values[2]), whole(values[3])
    except ValueError:
        raise InputError(f'--vary takes NAME MIN MAX COUNT (numbers, COUNT an integer from 2 to {MAX_POINTS}); '
                         f'got {brief(values)}') from None
    if not 2 <= n <= MAX_POINTS:
        raise InputError(f'--vary {brief(name)}: COUNT = {brief(n)}; allowed: an integer from 2 to {MAX_POINTS} '
                         '(poses per map)')
    if not (abs(lo) <= MAX_COORDINATE and abs(hi) <= MAX_COORDINATE) or not lo < hi:  # NaN fails both
        raise InputError(f'--vary {brief(name)}: need MIN < MAX, both finite and of magnitude at most '
                         f'{MAX_COORDINATE:g}; got {brief(values[1:])}')
    idx = mech.pose_names.index(name) if name in mech.pose_names else -1
    if idx >= 3 and args.deg:   # the ends in SI, then the grid: as the same grid typed in SI
        lo, hi = math.radians(lo), math.radians(hi)
    elif 0 <= idx < 3:
        lo, hi = metres(lo, args.mm), metres(hi, args.mm)
    return name, np.linspace(lo, hi, n)


def _dexterity(args: argparse.Namespace) -> int:
    from ..mechanisms.dexterity import check_plot_path, dexterity_grid, dexterity_sweep, plot_dexterity
    if args.plot is not None:
        check_plot_path(args.plot)  # before the work, not after it
    mech = mechanism_of(args.file)
    base = mechanism_pose(args, mech) if args.pose is not None else np.asarray(mech.home_pose, dtype=float)
    sweep = getattr(mech, 'default_sweep', None)
    default_var = sweep[0] if sweep is not None else 'z'
    var, vals = _vary(args, mech, base, args.vary, default_var)
    if args.vary2 is not None:
        var2, vals2 = _vary(args, mech, base, args.vary2, default_var)
        if var2 == var and args.vary is None:   # "got z twice", z given once: the first is the default's
            raise InputError(f'--vary2 {var2}: the first varied variable is {var} too (the default without --vary); '
                             f'allowed: --vary NAME MIN MAX COUNT with another variable than --vary2\'s')
        dmap = dexterity_grid(mech, base, var, vals, var2, vals2)
    else:
        dmap = dexterity_sweep(mech, base, var, vals)
    plot = None if args.plot is None else str(plot_dexterity(dmap, args.plot))
    if args.json:
        emit_json(dmap.record(mech.kind), plot=plot)
        return 0
    if dmap.variable2 is None:
        print(f'{mech.name}: dexterity (inverse condition number) against {var}')
        for v, d, ok, sing in zip(dmap.values, dmap.dexterity, dmap.within_limits, dmap.singular, strict=True):
            print(f'  {var} = {v:12.6g}   dexterity {d:.6f}' + ('' if ok else '   (outside the limits: joints or pose)')
                  + ('   (singular)' if sing else ''))
    else:
        inside = dmap.dexterity[dmap.within_limits]
        print(f'{mech.name}: dexterity on a {vals.size} x {vals2.size} grid of {var} x {var2}; within joint '
              f'limits: {inside.size} points' + (f', dexterity {inside.min():.4f} .. {inside.max():.4f}'
                                                  if inside.size else ''))
    if plot is not None:
        print(f'plot written to {plot}')
    return 0


def _span(mech: Mechanism) -> float:
    """The mechanism's size: the largest distance between two of its points (base and platform, m); 4 times its
    characteristic length where it has none."""
    names = [k for k in ('A_i', 'A_j', 'B_i', 'B_j', 'base_points', 'platform_points') if hasattr(mech, k)]
    pts = np.concatenate([np.empty((0, 3)), *(np.reshape(getattr(mech, k), (-1, 3)) for k in names)])
    pts = pts[np.isfinite(pts).all(axis=1)]
    if len(pts) < 2:
        return 4.0 * mech.characteristic_length
    return float(np.max(np.linalg.norm(pts[:, None] - pts[None], axis=-1)))


def _default_range(mech: Mechanism, base: np.ndarray, var: str) -> tuple[float, float]:
    """The range of ``var`` (default z) over which ``base`` stays within the joint limits, by a scan from 0 to twice
    the largest finite length limit (an angle's, pi rad, swept a 0.3 m GSP to 6.28 m), else to :func:`_span`."""
    if var not in mech.pose_variables:
        raise InputError(f'{mech.name}: cannot vary {brief(var)}; its pose variables are '
                         + ', '.join(mech.pose_variables) + ' (use --vary NAME MIN MAX COUNT)')
    sweep = getattr(mech, 'default_sweep', None)
    if sweep is not None and sweep[0] == var:
        return float(sweep[1]), float(sweep[2])
    lim = np.asarray(mech.joint_limits, dtype=float)[np.array(mech.joint_types) == 'prismatic']
    finite = lim[np.isfinite(lim)]
    top = 2.0 * float(np.max(finite)) if finite.size and np.max(finite) > 0 else _span(mech)
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


def register(subparsers: Subparsers) -> None:
    """Add ``dexterity`` to the ``gpr`` command."""
    p = subparsers.add_parser('dexterity', help='dexterity (inverse condition number) maps',
                              description='Dexterity = inverse condition number of the homogenised '
                              'Jacobian along one pose variable (default: z over the range within the joint '
                              'limits, as the 3-UPU paper\'s Fig. 6) or on a grid of two.',
                              epilog=CONVENTIONS, formatter_class=argparse.RawDescriptionHelpFormatter)
    mechanism_options(p, False)
    p.add_argument('--vary', nargs=4, metavar=('NAME', 'MIN', 'MAX', 'COUNT'),
                   help='pose variable to vary (units as --pose, with --mm/--deg)')
    p.add_argument('--vary2', nargs=4, metavar=('NAME', 'MIN', 'MAX', 'COUNT'),
                   help='second variable: a grid map')
    p.add_argument('--plot', metavar='FILE', help='write a plot (.png, .pdf or .svg)')
    p.set_defaults(handler=_dexterity)
