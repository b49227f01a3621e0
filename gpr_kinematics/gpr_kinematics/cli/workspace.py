"""``gpr workspace``: workspace approximation of a mechanism file by nonuniform covering or grid.

Examples::

    gpr workspace config/mechanisms/tripod_3rps.yaml --delta 0.001 --json
    gpr workspace tripod_3rps.yaml --delta 1 --mm --boxes tripod.npz --plot out/
    gpr workspace dextar_6d.yaml --delta 6 --mm --scheduler local --workers 2
    gpr workspace joint_working_area.yaml --delta 6 --mm --plot out/ --scheduler tcp://10.0.0.5:8786

``--delta`` is the accuracy in metres (``--mm``: millimetres); angle edges count as ``angle_scale`` times the
angle (the mechanism's characteristic length), see docs/workspace.md. A progress bar appears on stderr after
2 s; Ctrl-C (or SIGTERM) stops the run and keeps (and saves) what was proved, marked ``interrupted`` (its
``stopped``: ``interrupted``, or ``terminated`` after SIGTERM), exiting with status 130 (143), as does the time limit
(``--max-seconds``, default 600 s), exiting 0.
"""

from __future__ import annotations

import argparse
import importlib.util
import math
import signal
import sys
import textwrap
from pathlib import Path
from types import ModuleType
from typing import TYPE_CHECKING

import numpy as np

from ..errors import ConfigError, InputError, brief
from ..inputs.files import atomic_output, check_output, check_suffix, output_folder
from ..inputs.safe_yaml import YamlValue, load_text
from ..inputs.units import metres
from ..workspace import MAX_BOXES, METHODS, WorkspaceResult, approximate, load_workspace_model
from ..workspace.base import DEFAULT_MAX_SECONDS, check_delta, check_max_boxes, check_max_seconds, workspace_report
from ..workspace.boxes import closed_faces, reached_faces
from ..workspace.levels import PARTS, SIGNALLED
from ..workspace.progress import StopFlag
from ..workspace.scheduler import MAX_WORKERS, check_scheduler
from .options import number, whole
from .output import JsonValue, description, emit_json, json_object

if TYPE_CHECKING:
    from matplotlib.figure import Figure

    from .main import Subparsers


def register(subparsers: Subparsers) -> None:
    """Add the ``workspace`` subcommand (plugin interface of :mod:`gpr_kinematics.cli.main`)."""
    p = subparsers.add_parser(
        'workspace',
        help='workspace approximation (nonuniform covering / grid)',
        description=description(__doc__),
    )
    p.add_argument('file', help='mechanism YAML file with a type key (e.g. config/mechanisms/tripod_3rps.yaml)')
    p.add_argument('--delta', type=number, required=True,
                   help='accuracy: largest scaled edge of a boundary box, m (mm with --mm)')
    p.add_argument('--mm', action='store_true', help='--delta is in millimetres')
    p.add_argument('--method', choices=METHODS, default='covering',
                   help="covering (certified interval bounds), grid (node sampling per box, the paper's grid "
                   'method) or uniform (plain grid); default covering')
    p.add_argument('--grid-nodes', type=whole, default=None, help='grid method: nodes per box edge (default 3)')
    p.add_argument('--boxes', metavar='OUT.npz', help='save the boxes: arrays inner, boundary (n, d, 2), variables')
    p.add_argument('--plot', metavar='DIR', help='write PNG projections on the coordinate planes into DIR')
    p.add_argument('--json', action='store_true', help='print the summary as one JSON object')
    p.add_argument('--set', action='append', default=[], metavar='KEY=VALUE',
                   help='override a top-level mechanism parameter (SI, YAML syntax), e.g. --set b=0.25')
    p.add_argument('--scheduler', default='local', metavar='none|local|tcp://HOST:PORT',
                   help='where the covering runs: local (default; a Dask local cluster, one worker per core, '
                   'started only when a run is large enough), none (this process) or the address of a Dask '
                   'scheduler; the boxes are the same')
    p.add_argument('--workers', type=whole, default=None,
                   help=f'worker processes of --scheduler local (1 to {MAX_WORKERS}; default: the cores)')
    p.add_argument('--parts', type=whole, default=None,
                   help=f'parts a large run is cut into for the workers (default {PARTS}); changes the order '
                   'of the boxes, not the boxes')
    p.add_argument('--max-boxes', type=whole, default=None,
                   help='stop (like Ctrl-C) before keeping more boxes than this (default: the boxes of about 0.5 GB, '
                   f'16 bytes per variable each: {MAX_BOXES} up to 3 variables, 1875000 for 16; at most the boxes '
                   "of a quarter of the physical memory, or of a container's lower memory limit)")
    p.add_argument('--max-seconds', type=number, default=None,
                   help=f'stop (like Ctrl-C) after this many seconds (default {DEFAULT_MAX_SECONDS:g}; every method '
                   'has a limit)')
    p.add_argument('--no-progress', action='store_true', help='no progress bar on stderr')
    p.set_defaults(handler=run)


#: Longest --set value (characters).
MAX_SET = 2000
#: Characters of a projection's title line before it wraps (at fontsize 8 a 5.5 in figure holds about 90).
TITLE_WIDTH = 80
#: A plane of two lengths is drawn with equal axes where its sides' ratio is at most this (a 2 m by 0.03 m frame
#: would be 7 pixels tall).
EQUAL_AXES = 4.0


def _overrides(items: list[str]) -> dict[str, YamlValue]:
    out: dict[str, YamlValue] = {}
    for item in items:
        key, sep, value = item.partition('=')
        if not sep or not key.strip():
            raise InputError(f'--set expects KEY=VALUE, got {item[:60]!r}')
        if len(value) > MAX_SET:
            raise InputError(f'--set {key[:40]}: the value has {len(value)} characters; allowed: at most {MAX_SET}')
        if key.strip() in out:  # the last one won silently
            raise InputError(f'--set {key.strip()[:40]} is given twice; allowed: each key once')
        try:  # the package's one YAML reader: no aliases (a value cannot expand), bounded depth and size
            out[key.strip()] = load_text(value, f'--set {key[:40]}')
        except ConfigError as exc:   # the reader's reason (it said "(no aliases)" of any error)
            reason = str(exc).removeprefix(f'--set {key[:40]}: ')
            raise InputError(f'--set {key[:40]}: value {value[:60]!r} is not valid YAML: {reason}') from None
    return out


def _scheduler(args: argparse.Namespace) -> str:
    """The scheduler to use: ``local`` falls back to ``none`` (with a note) when dask.distributed is absent."""
    if args.scheduler == 'local' and importlib.util.find_spec('distributed') is None:
        if args.workers is not None:
            raise InputError("--workers needs dask.distributed (pip install '.[cluster]': dask and distributed)")
        sys.stderr.write('gpr workspace: dask.distributed is not installed; running in this process '
                         '(--scheduler none)\n')
        return 'none'
    return str(args.scheduler)


def _check_args(args: argparse.Namespace) -> float:
    delta = metres(float(args.delta), args.mm)
    if 0 < float(args.delta) < math.inf and delta == 0:   # '--delta 5e-324 --mm' was said not to be positive
        raise InputError(f'--delta = {args.delta:g} mm is 0 m in floating point; allowed: a positive number of mm '
                         f'whose metres are a float above 0 (at least {1e3 * 5e-324:.3g} mm)')
    if not math.isfinite(delta) or delta <= 0:
        raise InputError(f'--delta = {args.delta:g} is invalid; allowed: a positive number (m, or mm with --mm)')
    # options of another method or scheduler were run without a word (--grid-nodes 5 under the covering)
    if args.grid_nodes is not None and args.method != 'grid':
        raise InputError(f'--grid-nodes belongs to --method grid; allowed with --method {args.method}: no --grid-nodes')
    if args.parts is not None and args.scheduler == 'none':
        raise InputError('--parts cuts a run for the workers of a Dask scheduler; allowed with --scheduler none: no '
                         '--parts')
    check_scheduler(args.scheduler, args.workers, ('--workers', '--scheduler'))   # named as options ('workers must')
    args.grid_nodes = 3 if args.grid_nodes is None else args.grid_nodes
    args.parts = PARTS if args.parts is None else args.parts
    if args.grid_nodes < 2:
        raise InputError(f'--grid-nodes = {brief(args.grid_nodes)} is invalid; allowed: an integer of at least 2 '
                         '(nodes per box edge)')
    check_max_seconds(args.max_seconds, '--max-seconds')
    if not 1 <= args.parts <= 100_000:
        raise InputError(f'--parts = {brief(args.parts)} is invalid; allowed: an integer from 1 to 100000')
    if args.boxes is not None:  # an empty name is refused, not ignored; a .npz (it overwrote a measurement CSV)
        check_output(args.boxes, '--boxes')
        if Path(args.boxes).suffix:   # a name without one is written as given
            check_suffix(args.boxes, '--boxes', ('.npz',), ' (or a name without a suffix, written as given)')
    if args.plot is not None:
        output_directory(args.plot)
        _matplotlib()
    return delta


def _matplotlib() -> ModuleType:
    """matplotlib (Agg), or a one-line error when it is not installed."""
    try:
        import matplotlib
    except ImportError:
        raise InputError('--plot needs matplotlib (pip install matplotlib)') from None
    matplotlib.use('Agg')
    return matplotlib


def run(args: argparse.Namespace) -> int:
    delta = _check_args(args)
    overrides = _overrides(args.set)
    model = load_workspace_model(args.file, overrides)
    check_max_boxes(args.max_boxes, model, '--max-boxes')   # named as the option (approximate checks it again)
    out = getattr(model, 'output_index', slice(None))
    outputs = [str(v) for v in np.asarray(model.variables)[out]]
    if args.plot is not None and len(outputs) < 2:   # exit 0 with "0 projections written" before
        raise InputError(f'--plot draws the boxes on pairs of output variables; {args.file} has one ({outputs[0]}); '
                         'allowed: --plot for models of 2 or more outputs (--boxes keeps the boxes)')
    check_delta(delta, model.box[out], model.scale[out])   # refused before the warning below, one line
    edge = float(np.max((model.box[out, 1] - model.box[out, 0]) * model.scale[out]))
    if delta >= edge:  # allowed (docs/workspace.md), but --delta 1 for 1 mm ran one box without a word
        mm = '; millimetres? give --mm' if not args.mm and delta / 1000.0 < edge else ''
        sys.stderr.write(f'gpr workspace: warning: --delta {delta:g} m is at least the initial box\'s largest scaled '
                         f'edge ({edge:.6g} m): the box is not divided{mm}\n')
    result = approximate(model, delta, method=args.method, grid_nodes=args.grid_nodes,
                         progress=not args.no_progress, max_seconds=args.max_seconds,
                         max_boxes=args.max_boxes, scheduler=_scheduler(args), workers=args.workers,
                         parts=args.parts)
    terminated(result)
    report = workspace_report(model, result)
    name = Path(args.file).stem   # the summary's heading and the plots' names (a model's type is in --json)
    written: dict[str, JsonValue] = {}
    notes = []
    if args.boxes is not None:
        written['boxes_file'] = path = str(save_boxes(args.boxes, result, report.box, report.scale))
        notes.append(f'boxes written to {path}')
    if args.plot is not None:
        plots = plot_projections(result, args.plot, name, report.box)
        written['plots'] = [str(p) for p in plots]
        notes.append(f'{len(plots)} projections written to {args.plot}')
    if args.method != 'covering' and result.inner_boxes + result.boundary_boxes == 0 and not result.interrupted:
        nodes, more = ('the grid nodes of its boxes', '--grid-nodes') if args.method == 'grid' else \
            ("the cells' corners", 'a smaller --delta')   # the shipped 3-UPU's was "0 inner, 0 boundary", no word
        sys.stderr.write(f'gpr workspace: warning: no feasible point among {nodes}: the workspace may lie between '
                         f'them (method {args.method}, not certified; {more}, or --method covering)\n')
    if result.interrupted:
        reasons = result.stopped.split('; ')
        said = 'terminated' if 'terminated' in reasons else 'interrupted'
        others = '; '.join(r for r in reasons if r not in ('', said))   # a signal's stop: the parts' limits beside
        why = '' if not others else f' (also stopped by: {others})' if said in reasons else f' ({result.stopped})'
        sys.stderr.write(f'gpr workspace: {said}{why} after {result.seconds:.1f} s; the unexamined boxes '
                         'count as boundary boxes\n')
    # stopped by a signal: what was proved is kept, and the status says so (a time or box limit is a result: 0)
    signalled = StopFlag.caught is not None or bool(set(SIGNALLED) & set(result.stopped.split('; ')))
    status = 128 + (StopFlag.caught or signal.SIGINT) if signalled else 0
    if args.json:
        emit_json(report, file=str(args.file), overrides=json_object(overrides), **written)
        return status
    print(f'{name}: {result.inner_boxes} inner and {result.boundary_boxes} boundary boxes '
          f'({result.outside_boxes} outside), method {result.method}'
          f'{"" if result.certified else " (sampled, not certified)"}, delta {delta:g} m')
    print(f'inner volume {result.inner_volume:.6g} {report.volume_units}, outer volume '
          f'{result.outer_volume:.6g} {report.volume_units}, {result.seconds:.2f} s'
          + (' (interrupted)' if result.interrupted else ''))
    if result.touches_initial_box:
        faces = ', '.join(result.variables[k] for k in reached_faces(report.box, result.inner, result.boundary,
                                                                     closed=closed_faces(model, report.box)))
        print(f'note: the approximation reaches the faces of the initial box (workspace.box) in {faces}; the '
              'workspace may extend beyond it')
    for note in notes:
        print(note)
    return status


def terminated(result: WorkspaceResult) -> None:
    """A run stopped by SIGTERM says ``terminated`` where it said ``interrupted`` (its ``stopped``, the stderr line,
    the plots' titles), as every command stopped by SIGTERM does (Ctrl-C: ``interrupted``); the parts' other reasons
    kept."""
    if StopFlag.caught == signal.SIGTERM and result.interrupted:
        result.stopped = '; '.join('terminated' if r == 'interrupted' else r for r in result.stopped.split('; '))


def output_directory(path: str | Path) -> Path:
    """An output directory: an existing directory or a path that can be created (not a file)."""
    if str(path) == '':
        raise InputError('--plot: the folder path is empty; allowed: a folder to write the projections into')
    p = Path(path)
    if p.exists() and not p.is_dir():
        raise InputError(f'--plot {str(p)!r} exists and is not a directory; allowed: a directory')
    return p


def save_boxes(path: str | Path, result: WorkspaceResult, box: np.ndarray, scale: np.ndarray) -> Path:
    """Write ``inner``, ``boundary`` (n, d, 2), ``variables``, ``units``, ``box``, ``scale``, ``delta``,
    ``method``, ``certified`` (false for the sampled methods), ``interrupted`` to exactly ``path`` (no suffix
    added), atomically (:func:`~.files.atomic_output`)."""
    with atomic_output(path, '--boxes', binary=True) as f:
        np.savez_compressed(f, inner=result.inner, boundary=result.boundary, variables=np.array(result.variables),
                            units=np.array(result.units), box=box, scale=scale, delta=result.delta,
                            method=result.method, certified=result.certified, interrupted=result.interrupted)
    return Path(path)


def _unique_rects(boxes: np.ndarray, i: int, j: int) -> np.ndarray:
    if boxes.shape[0] == 0:
        return np.empty((0, 4))
    rects = np.stack([boxes[:, i, 0], boxes[:, i, 1], boxes[:, j, 0], boxes[:, j, 1]], axis=1)
    return np.unique(rects, axis=0)


def projection_figure(result: WorkspaceResult, i: int, j: int, name: str, box: np.ndarray | None = None) -> Figure:
    """The projection of the inner (dark) and outer (light) approximations on the plane of variables ``i``, ``j``
    (a matplotlib Figure), framed by ``box``; the title says when the boxes reach the box's faces and which (the
    workspace may extend beyond them) and when the run stopped early (the unexamined boxes drawn as boundary)."""
    _matplotlib()
    import matplotlib.pyplot as plt
    from matplotlib.collections import PolyCollection

    fig, ax = plt.subplots(figsize=(5.5, 5.0), dpi=110)
    for arr, colour in ((result.boundary, '#f4a582'), (result.inner, '#2166ac')):
        r = _unique_rects(arr, i, j)
        verts = list(np.stack([r[:, [0, 2]], r[:, [1, 2]], r[:, [1, 3]], r[:, [0, 3]]], axis=1))
        ax.add_collection(PolyCollection(verts, facecolors=colour, edgecolors='none', linewidths=0))
    if box is not None:
        ax.set_xlim(box[i])
        ax.set_ylim(box[j])
    else:
        ax.autoscale()
    ax.set_xlabel(f'{result.variables[i]} [{result.units[i]}]')
    ax.set_ylabel(f'{result.variables[j]} [{result.units[j]}]')
    (x0, x1), (y0, y1) = ax.get_xlim(), ax.get_ylim()
    if result.units[i] == result.units[j] == 'm' and max(x1 - x0, y1 - y0) <= EQUAL_AXES * min(x1 - x0, y1 - y0):
        ax.set_aspect('equal', adjustable='box')   # a plane of lengths at its true shape (a dome was 1.8x as tall)
    notes = []
    if result.touches_initial_box:   # which faces: a frame the boxes stop well inside was said to be reached
        faces = reached_faces(box, result.inner, result.boundary) if box is not None else (i, j)
        drawn = [result.variables[k] for k in faces if k in (i, j)]
        others = [result.variables[k] for k in faces if k not in (i, j)]
        if drawn:
            notes.append(f'the boxes reach the frame ({", ".join(drawn)}): the workspace may extend beyond it')
        elif others:
            notes.append(f'the boxes reach the initial box in {", ".join(others)} (not drawn here): the workspace '
                         'may extend beyond it')
    if result.interrupted:
        notes.append(f'stopped early ({result.stopped or "interrupted"}): unexamined boxes drawn as boundary')
    lines = [f'{name}: projection on {result.variables[i]}-{result.variables[j]}',
             f'inner (blue) and boundary (orange), delta = {result.delta:g} m', *notes]
    if not result.certified:   # a grid's picture was titled as the covering's, "inner" with no word
        lines.insert(1, f'method {result.method} (sampled, not certified): its "inner" and "outside" boxes are '
                        'guesses from nodes')
    ax.set_title('\n'.join(textwrap.fill(line, TITLE_WIDTH) for line in lines), fontsize=8)   # none cut at the edge
    fig.tight_layout()
    return fig


def plot_projections(
    result: WorkspaceResult, directory: str | Path, name: str, box: np.ndarray | None = None
) -> list[Path]:
    """PNG projections (:func:`projection_figure`) on every coordinate plane, written into ``directory``."""
    _matplotlib()
    import matplotlib.pyplot as plt

    out_dir = output_directory(directory)
    try:
        output_folder(out_dir)
    except OSError as exc:
        raise InputError(f'cannot create --plot directory {str(out_dir)!r}: {exc.strerror}; allowed: a directory '
                         'that exists or can be created (its parent directories writable)') from None
    d = len(result.variables)
    pairs = [(0, 1)] if d == 2 else [(i, j) for i in range(d) for j in range(i + 1, d)]
    files = []
    for i, j in pairs:
        fig = projection_figure(result, i, j, name, box)
        path = out_dir / f'workspace_{name}_{result.variables[i]}_{result.variables[j]}.png'
        try:  # never through a link, into a FIFO or device, or over the model file (savefig wrote through them)
            with atomic_output(path, '--plot', binary=True) as fh:
                fig.savefig(fh, format='png')
        finally:
            plt.close(fig)
        files.append(path)
    return files


__all__ = ['register', 'run', 'save_boxes', 'plot_projections', 'projection_figure']
