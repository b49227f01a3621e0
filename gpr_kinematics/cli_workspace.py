"""``gpr workspace``: workspace approximation of a mechanism file by nonuniform covering or grid.

Examples::

    gpr workspace config/mechanisms/tripod_3rps.yaml --delta 0.001 --json
    gpr workspace tripod_3rps.yaml --delta 1 --mm --boxes tripod.npz --plot out/
    gpr workspace upu3.yaml --delta 0.005 --set b=0.25 --set limb_max=0.3 --plot out/

``--delta`` is the accuracy in metres (``--mm``: millimetres); angle edges count as ``angle_scale`` times the
angle (the mechanism's characteristic length), see docs/workspace.md. A progress bar appears on stderr after
2 s; Ctrl-C stops the run and keeps (and saves) what was computed, marked ``interrupted``.
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from .errors import InputError
from .workspace import METHODS, WorkspaceResult, approximate
from .workspace_models import load_workspace_model


def register(subparsers: Any) -> None:
    """Add the ``workspace`` subcommand (plugin interface of :mod:`gpr_kinematics.cli`)."""
    p = subparsers.add_parser(
        'workspace',
        help='workspace approximation (nonuniform covering / grid)',
        description=__doc__.split('\n\n')[0],
    )
    p.add_argument(
        'file', help='mechanism YAML file with a type key (e.g. config/mechanisms/tripod_3rps.yaml)'
    )
    p.add_argument(
        '--delta',
        type=float,
        required=True,
        help='accuracy: largest scaled edge of a boundary box, m (mm with --mm)',
    )
    p.add_argument('--mm', action='store_true', help='--delta is in millimetres')
    p.add_argument(
        '--method',
        choices=METHODS,
        default='covering',
        help="covering (certified interval bounds), grid (node sampling per box, the seed's grid "
        'method) or uniform (plain grid); default covering',
    )
    p.add_argument('--grid-nodes', type=int, default=3, help='grid method: nodes per box edge (default 3)')
    p.add_argument(
        '--boxes', metavar='OUT.npz', help='save the boxes: arrays inner, boundary (n, d, 2), variables'
    )
    p.add_argument('--plot', metavar='DIR', help='write PNG projections on the coordinate planes into DIR')
    p.add_argument('--json', action='store_true', help='print the summary as one JSON object')
    p.add_argument(
        '--set',
        action='append',
        default=[],
        metavar='KEY=VALUE',
        help='override a top-level mechanism parameter (SI, YAML syntax), e.g. --set b=0.25',
    )
    p.add_argument(
        '--max-seconds', type=float, default=None, help='stop (like Ctrl-C) after this many seconds'
    )
    p.add_argument('--no-progress', action='store_true', help='no progress bar on stderr')
    p.set_defaults(handler=run)


def _overrides(items: list[str]) -> dict[str, Any]:
    out: dict[str, Any] = {}
    for item in items:
        key, sep, value = item.partition('=')
        if not sep or not key.strip():
            raise InputError(f'--set expects KEY=VALUE, got {item!r}')
        try:
            out[key.strip()] = yaml.safe_load(value)
        except yaml.YAMLError:
            raise InputError(f'--set {key}: value {value!r} is not valid YAML') from None
    return out


def run(args: argparse.Namespace) -> int:
    delta = float(args.delta) * (1e-3 if args.mm else 1.0)
    if not math.isfinite(delta) or delta <= 0:
        raise InputError(f'--delta must be a positive number (m, or mm with --mm), got {args.delta}')
    if args.grid_nodes < 2:
        raise InputError(f'--grid-nodes must be at least 2, got {args.grid_nodes}')
    if args.max_seconds is not None and not args.max_seconds > 0:
        raise InputError(f'--max-seconds must be positive, got {args.max_seconds}')
    model = load_workspace_model(args.file, _overrides(args.set))
    result = approximate(
        model,
        delta,
        method=args.method,
        grid_nodes=args.grid_nodes,
        progress=not args.no_progress,
        max_seconds=args.max_seconds,
    )
    summary = result.summary()
    summary.update(
        {
            'file': str(args.file),
            'type': model.name,
            'box': model.box.tolist(),
            'scale': model.scale.tolist(),
            'volume_units': '*'.join(model.units),
            'overrides': _overrides(args.set),
        }
    )
    if args.boxes:
        save_boxes(args.boxes, result, model.box, model.scale)
        summary['boxes_file'] = str(args.boxes)
    if args.plot:
        summary['plots'] = [str(p) for p in plot_projections(result, args.plot, model.name, model.box)]
    if result.interrupted:
        sys.stderr.write(
            f'gpr workspace: interrupted after {result.seconds:.1f} s; the unexamined boxes count '
            'as boundary boxes\n'
        )
    if args.json:
        from .cli import emit_json

        emit_json(summary)
    else:
        print(
            f'{model.name}: {result.inner_boxes} inner and {result.boundary_boxes} boundary boxes '
            f'({result.outside_boxes} outside), method {result.method}, delta {delta:g} m'
        )
        print(
            f'inner volume {result.inner_volume:.6g} {summary["volume_units"]}, '
            f'outer volume {result.outer_volume:.6g} {summary["volume_units"]}, {result.seconds:.2f} s'
            + (' (interrupted)' if result.interrupted else '')
        )
        if result.touches_initial_box:
            print(
                'note: the approximation reaches the faces of the initial box (workspace.box); '
                'the workspace may extend beyond it'
            )
    return 0


def save_boxes(path: str | Path, result: WorkspaceResult, box: np.ndarray, scale: np.ndarray) -> None:
    """Write ``inner``, ``boundary`` (n, d, 2), ``variables``, ``units``, ``box``, ``scale``, ``delta``."""
    try:
        np.savez_compressed(
            path,
            inner=result.inner,
            boundary=result.boundary,
            variables=np.array(result.variables),
            units=np.array(result.units),
            box=box,
            scale=scale,
            delta=result.delta,
            method=result.method,
            interrupted=result.interrupted,
        )
    except OSError as exc:
        raise InputError(f'cannot write --boxes file {str(path)!r}: {exc.strerror}') from None


def _unique_rects(boxes: np.ndarray, i: int, j: int) -> np.ndarray:
    if boxes.shape[0] == 0:
        return np.empty((0, 4))
    rects = np.stack([boxes[:, i, 0], boxes[:, i, 1], boxes[:, j, 0], boxes[:, j, 1]], axis=1)
    return np.unique(rects, axis=0)


def plot_projections(
    result: WorkspaceResult, directory: str | Path, name: str, box: np.ndarray | None = None
) -> list[Path]:
    """PNG projections of the inner (dark) and outer (light) approximations on every coordinate plane."""
    import matplotlib

    matplotlib.use('Agg')
    import matplotlib.pyplot as plt
    from matplotlib.collections import PolyCollection

    out_dir = Path(directory)
    try:
        out_dir.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise InputError(f'cannot create --plot directory {str(out_dir)!r}: {exc.strerror}') from None
    d = len(result.variables)
    pairs = [(0, 1)] if d == 2 else [(i, j) for i in range(d) for j in range(i + 1, d)]
    files = []
    for i, j in pairs:
        fig, ax = plt.subplots(figsize=(5.5, 5.0), dpi=110)
        for arr, colour in ((result.boundary, '#f4a582'), (result.inner, '#2166ac')):
            r = _unique_rects(arr, i, j)
            verts = np.stack([r[:, [0, 2]], r[:, [1, 2]], r[:, [1, 3]], r[:, [0, 3]]], axis=1)
            ax.add_collection(PolyCollection(verts, facecolors=colour, edgecolors='none', linewidths=0))
        if box is not None:
            ax.set_xlim(box[i])
            ax.set_ylim(box[j])
        else:
            ax.autoscale()
        ax.set_xlabel(f'{result.variables[i]} [{result.units[i]}]')
        ax.set_ylabel(f'{result.variables[j]} [{result.units[j]}]')
        ax.set_title(
            f'{name}: projection on {result.variables[i]}-{result.variables[j]}\n'
            f'inner (blue) and boundary (orange), delta = {result.delta:g} m',
            fontsize=9,
        )
        fig.tight_layout()
        path = out_dir / f'workspace_{name}_{result.variables[i]}_{result.variables[j]}.png'
        fig.savefig(path)
        plt.close(fig)
        files.append(path)
    return files


__all__ = ['register', 'run', 'save_boxes', 'plot_projections']
