"""Workspace approximation by nonuniform covering (certified) and by the grid methods.

The covering method of Posypkin, Rybak, Malyshev and Gaponenko ("Approximation of the parallel robot
working area using the method of nonuniform covering", docs/references.md) keeps a list of boxes, starting from one box
``Q`` that contains the working area ``W = {x in Q : lower_j <= g_j(x) <= upper_j}``; for each box it
bounds every constraint by interval arithmetic (:mod:`gpr_kinematics.workspace.interval`, outward rounding): a box
with some ``[g_j]`` outside ``[lower_j, upper_j]`` is dropped (outside), a box with every ``[g_j]`` inside
is inner, any other box is bisected along its longest edge, or, once its diameter is below ``delta``,
becomes a boundary box. Here the whole list is processed level by level as numpy arrays, cut into chunks
of a fixed size (:mod:`.scheduler` runs the chunks here or on a Dask cluster; the result is the same).

Diameter. Variables may mix metres and radians. Each variable has a ``scale`` (metres per unit: 1 for
lengths, a characteristic length for angles, e.g. the platform radius, so that an angle edge is measured by
the displacement it causes at the platform joints). The diameter of a box is its longest scaled edge (the
infinity-norm diameter, the same measure as codac's SIVIA ``eps``); the longest scaled edge is the one
bisected.

Models given by closure equations (:class:`~.equations.EquationModel`) are covered the same way over their
output variables, each output box carrying the boxes of its passive variables (:mod:`.projection`).

The **grid method** (the paper's alternative for expressions with repeated variables) classifies a box by
evaluating the constraints at the nodes of a small grid inside it; the **uniform grid** is the plain
discretisation (:mod:`.grid`). Neither is certified. Volumes are in the variables' own units.
"""

from __future__ import annotations

import re
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, TextIO

import numpy as np

from ..errors import InputError, brief
from .base import (
    WorkspaceModel,
    WorkspaceResult,
    check_delta,
    check_initial_box,
    check_max_boxes,
    check_max_seconds,
    most_boxes,
)
from .boxes import bisect, box_volume, closed_faces, scaled_diameter, touches
from .grid import check_grid_nodes, grid_classify, uniform
from .levels import PARTS, LocalContext, Outcome, cover_part, decided_volume, distribute_at, run_levels
from .progress import Progress, StopFlag
from .scheduler import Executor

METHODS = ('covering', 'grid', 'uniform')
#: Pending boxes per chunk (the unit of work of one process or Dask task) for constraint models.
CHUNK_BOXES = 32768


@dataclass
class Step:
    """What classifying one chunk gives: decided boxes (over the output variables) and the next level."""

    inner: np.ndarray
    boundary: np.ndarray
    outside: np.ndarray
    children: Any
    evaluations: int


@dataclass
class BoxFrontier:
    """Pending boxes of a constraint model, (n, d, 2)."""

    boxes: np.ndarray

    @property
    def size(self) -> int:
        return int(self.boxes.shape[0])

    def split(self, chunk: int) -> list[BoxFrontier]:
        return [BoxFrontier(self.boxes[s : s + chunk]) for s in range(0, self.size, chunk)]

    def parts(self, n: int) -> list[BoxFrontier]:
        """``n`` contiguous parts of about equal size (fewer when there are fewer boxes)."""
        return [BoxFrontier(b) for b in np.array_split(self.boxes, min(n, self.size)) if b.shape[0]]

    def join(self, parts: list[BoxFrontier]) -> BoxFrontier:
        arrays = [p.boxes for p in parts if p.size]
        return BoxFrontier(np.concatenate(arrays) if arrays else self.boxes[:0])

    def output_boxes(self) -> np.ndarray:
        return self.boxes

    def diameter(self, scale: np.ndarray) -> float:
        return float(scaled_diameter(self.boxes, scale).max()) if self.size else 0.0


def constraint_step(model: WorkspaceModel, frontier: BoxFrontier, delta: float, method: str, nodes: int) -> Step:
    """Classify one chunk of boxes of a constraint model: inner, outside, boundary or bisected."""
    chunk = frontier.boxes
    if method == 'covering':
        glo, ghi = model.bounds(chunk)
        is_out = np.any((ghi < model.lower) | (glo > model.upper), axis=1)
        is_in = np.all((glo >= model.lower) & (ghi <= model.upper), axis=1) & ~is_out
    else:
        is_in, is_out = grid_classify(model, chunk, nodes)
        is_in &= ~is_out
    undecided = ~(is_in | is_out)
    small = undecided & (scaled_diameter(chunk, model.scale) < delta)
    split = undecided & ~small
    return Step(chunk[is_in], chunk[small], chunk[is_out], BoxFrontier(bisect(chunk[split], model.scale)),
                chunk.shape[0])


@dataclass(frozen=True)
class CoveringTask:
    """How to cover one model: the first frontier (with ``size``, ``split(chunk)``, ``parts(n)``,
    ``join(frontiers)``, ``output_boxes()``, ``diameter(scale)``), the chunk step ``step(model, chunk, delta,
    *args)`` (a module-level function: it is sent to cluster workers), the initial box and scale of the
    output variables, and the chunk size."""

    frontier: Any
    step: Callable[..., Step]
    args: tuple[Any, ...]
    box: np.ndarray
    scale: np.ndarray
    chunk: int


def _constraint_task(model: WorkspaceModel, box: np.ndarray, method: str, nodes: int) -> CoveringTask:
    if method == 'grid':
        check_grid_nodes(nodes, box.shape[0])
    return CoveringTask(BoxFrontier(box[None].copy()), constraint_step, (method, nodes), box,
                        np.asarray(model.scale, dtype=float), CHUNK_BOXES)


def approximate(
    model: Any,
    delta: float,
    method: str = 'covering',
    box: np.ndarray | None = None,
    grid_nodes: int = 3,
    progress: bool | None = None,
    progress_stream: TextIO | None = None,
    progress_after: float = 2.0,
    max_seconds: float | None = None,
    max_boxes: int | None = None,
    chunk_size: int | None = None,
    scheduler: str | Executor = 'none',
    workers: int | None = None,
    keep_outside: bool = False,
    parts: int = PARTS,
) -> WorkspaceResult:
    """Approximate the working area of ``model`` to accuracy ``delta`` (metres, scaled diameter).

    Args:
        model: a constraint model (:class:`~.base.WorkspaceModel`) or an equation model
            (:class:`~.equations.EquationModel`, covering only; its boxes are over its outputs).
        delta: accuracy: undecided boxes are bisected until their scaled diameter is below ``delta`` [m].
        method: ``covering`` (certified interval bounds), ``grid`` (the paper's grid method: node sampling
            inside each box, with bisection; not certified) or ``uniform`` (plain grid of cells).
        box: initial box (d, 2) of a constraint model; default ``model.box``. It must contain the
            workspace (reported: ``touches_initial_box`` is true when the boxes reach its faces).
        grid_nodes: nodes per edge for the grid method's classification.
        progress: progress bar on stderr after ``progress_after`` s; ``None`` shows it on a terminal.
        max_seconds: stop like an interruption after this wall time [s] (None: the default limit,
            :data:`~.base.DEFAULT_MAX_SECONDS`; every method has one).
        max_boxes: stop like an interruption before the boxes kept could exceed this count (None: the boxes of
            about 0.5 GB, :func:`~.base.default_max_boxes`: 10 million up to 3 variables, fewer beyond); a count
            whose boxes take more than a quarter of the machine's memory is refused (:func:`~.base.check_max_boxes`).
        chunk_size: pending boxes per chunk (default per model); results do not depend on where chunks run.
        scheduler: ``'none'`` (this process), ``'local'`` (a Dask local cluster, ``workers`` processes,
            default one per core), a Dask scheduler address ``'tcp://HOST:PORT'``, or an :class:`Executor`
            to reuse (the caller closes it).
        parts: once a level holds enough work, the pending boxes are cut into this many parts, each covered
            to the end on its own (the unit of work of a cluster: see :mod:`.levels`).
        keep_outside: also return the boxes proved outside (``result.outside``; with inner and boundary boxes
            they tile the initial box).

    Returns:
        :class:`WorkspaceResult`. Ctrl-C (SIGINT) during the run stops it cleanly between chunks: the
        result is returned with ``interrupted=True`` and the unexamined boxes counted as boundary.
    """
    if not isinstance(model, WorkspaceModel) and not hasattr(model, 'covering_task'):   # 'upu3.yaml': AttributeError
        raise InputError(f'model = {brief(model)}; allowed: a WorkspaceModel (or an equation model), as '
                         'load_workspace_model(path) returns it')
    chunk_size, parts = _check_run_options(method, chunk_size, parts)
    max_boxes = check_max_boxes(max_boxes, model)
    max_seconds = check_max_seconds(max_seconds)
    t0 = time.perf_counter()  # the run's time and time limit include the coverings a model builds on
    own = not isinstance(scheduler, Executor)
    executor = Executor(scheduler, workers) if isinstance(scheduler, str) else scheduler
    if hasattr(model, 'covering_task'):
        if method != 'covering' or box is not None:
            raise InputError(f'{model.name}: this model is covered with method covering on its own box only')
        check_delta(delta, model.box[model.output_index], model.scale[model.output_index])

        def part(sub_model: Any, sub_delta: float, keep: bool = False) -> WorkspaceResult:
            # a mechanism the model builds on, covered by the same scheduler (its own progress off), in the time
            # left of this run
            left = max(max_seconds - (time.perf_counter() - t0), 1e-6)
            # with the run's box limit (a mechanism of wider boxes than the model's, at most what the machine gives)
            return approximate(sub_model, sub_delta, progress=False, max_seconds=left,
                               max_boxes=min(max_boxes, most_boxes(sub_model)), scheduler=executor, keep_outside=keep)

        try:
            task = model.covering_task(delta, part)
        except (KeyboardInterrupt, SubCoveringStoppedError) as exc:
            if own:
                executor.close()
            reason = exc.reason if isinstance(exc, SubCoveringStoppedError) else 'interrupted'
            # the sub-covering had the time left of this run's limit (its reasons may be several, '; '-joined)
            reason = re.sub(r'time limit \([^)]*\)', f'time limit ({max_seconds:g} s)', reason)
            return _nothing_proved(model, delta, reason, time.perf_counter() - t0)
        except BaseException:  # a cluster the sub-coverings started is not left running
            if own:
                executor.close()
            raise
    else:
        box = check_initial_box(model.box if box is None else box, model.variables)
        model.check_box(box)
        task = _constraint_task(model, box, method, grid_nodes)
    check_delta(delta, task.box, task.scale)
    if method == 'uniform':
        return uniform(model, delta, task.box, max_seconds, t0, max_boxes)
    executor.forget_model()
    stream = progress_stream
    if progress is None:
        progress = bool(getattr(stream or sys.stderr, 'isatty', lambda: False)())
    bar = Progress(progress, stream, progress_after, '*'.join(model.units[i] for i in _output_index(model)))
    try:
        return _run(model, task, float(delta), method, executor, bar, max_seconds, max_boxes,
                    chunk_size or task.chunk, keep_outside, parts, t0)
    finally:
        bar.close()
        if own:
            executor.close()


def _check_run_options(method: str, chunk_size: int | None, parts: int) -> tuple[int | None, int]:
    """``chunk_size`` and ``parts`` as Python ints (numpy's too; a bool is no count), else InputError naming the
    first option of :func:`approximate` out of its range, and the range (``max_boxes``:
    :func:`~.base.check_max_boxes`)."""
    if method not in METHODS:
        raise InputError(f'unknown workspace method {method!r}; allowed: {", ".join(METHODS)}')
    if chunk_size is not None and not (_is_count(chunk_size) and chunk_size >= 1):
        raise InputError(f'chunk_size must be a positive integer, got {brief(chunk_size)}')
    if not (_is_count(parts) and 1 <= parts <= 100_000):
        raise InputError(f'parts must be an integer from 1 to 100000, got {brief(parts)}')
    return (None if chunk_size is None else int(chunk_size)), int(parts)


def _is_count(value: Any) -> bool:
    return isinstance(value, (int, np.integer)) and not isinstance(value, (bool, np.bool_))


class SubCoveringStoppedError(Exception):
    """Raised by a model's ``covering_task`` when a covering it builds on stopped early (``reason``: that covering's
    ``stopped``, e.g. ``box limit (10000000 boxes)``): the run stops with that reason."""

    def __init__(self, reason: str) -> None:
        super().__init__(reason)
        self.reason = reason or 'interrupted'


def _nothing_proved(model: Any, delta: float, stopped: str = 'interrupted', seconds: float = 0.0) -> WorkspaceResult:
    """The result of a run stopped (``stopped`` says why, after ``seconds``) before its covering started: the whole
    box is a boundary box."""
    outputs = _output_index(model)
    box = model.box[outputs]
    return WorkspaceResult('covering', tuple(model.variables[i] for i in outputs),
                           tuple(model.units[i] for i in outputs), float(delta), np.empty((0, box.shape[0], 2)),
                           box[None].copy(), 0, seconds, 0, 0, interrupted=True, touches_initial_box=True,
                           stopped=stopped)


def _output_index(model: Any) -> list[int]:
    outputs = getattr(model, 'outputs', model.variables)
    return [list(model.variables).index(v) for v in outputs]


class _Monitor:
    """A run's tally (evaluations, decided volumes, boxes kept) shown on the progress bar, and its stop rule:
    Ctrl-C (``flag``), the wall-time limit, the box limit."""

    def __init__(self, bar: Progress, delta: float, total_volume: float, flag: StopFlag, t0: float,
                 max_seconds: float, max_boxes: int) -> None:
        self.bar, self.delta, self.total_volume, self.flag = bar, delta, total_volume, flag
        self.t0, self.max_seconds, self.max_boxes = t0, max_seconds, max_boxes
        self.evaluations = 0
        self.inner = self.boundary = self.outside = 0.0
        self.kept = 0

    def stop(self) -> str:
        """Why the run must stop now ('' to go on)."""
        if self.flag.raised:
            return 'interrupted'
        if time.perf_counter() - self.t0 > self.max_seconds:
            return f'time limit ({self.max_seconds:g} s)'
        return f'box limit ({self.max_boxes} boxes)' if self.kept > self.max_boxes else ''

    def count(self, level: int, diameter: float, evaluations: int, inner: float, boundary: float, outside: float,
              kept: int) -> None:
        self.evaluations += evaluations
        self.inner += inner
        self.boundary += boundary
        self.outside += outside
        self.kept += kept
        decided = self.inner + self.boundary + self.outside
        self.bar.update(level, diameter, self.delta, self.evaluations, self.inner, self.boundary,
                        decided / self.total_volume)

    def report(self, level: int, diameter: float, r: Step) -> None:
        """One chunk, classified in this process."""
        self.count(level, diameter, r.evaluations, box_volume(r.inner), box_volume(r.boundary),
                   box_volume(r.outside), r.inner.shape[0] + r.boundary.shape[0])

    def done(self, i: int, o: Outcome) -> None:
        """One part, covered by a cluster worker (counted here unless its chunks were reported already)."""
        if not o.reported:
            inner, boundary = decided_volume(o)
            self.count(o.levels, o.diameter, o.evaluations, inner, boundary, o.outside_volume,
                       sum(a.shape[0] for a in o.inner) + sum(a.shape[0] for a in o.boundary))


def _run(
    model: Any,
    task: CoveringTask,
    delta: float,
    method: str,
    executor: Executor,
    bar: Progress,
    max_seconds: float,
    max_boxes: int,
    chunk: int,
    keep_outside: bool,
    parts: int,
    t0: float,
) -> WorkspaceResult:
    box = task.box
    flag = StopFlag()
    mon = _Monitor(bar, delta, float(np.prod(box[:, 1] - box[:, 0])), flag, t0, max_seconds, max_boxes)
    try:
        with LocalContext(mon.stop, mon.report):
            out = run_levels(model, task.step, task.args, task.frontier, delta, chunk, keep_outside, max_boxes,
                             mon.stop, mon.report, until=distribute_at(chunk, parts))
            if out.frontier.size and not out.stopped:
                pieces = out.frontier.parts(parts)
                results: list[Outcome | None] = [None] * len(pieces)
                deadline = time.time() + max_seconds - (time.perf_counter() - t0)
                # each part may keep its own boxes plus an equal share of what the limit leaves: the parts' boxes
                # then add up to at most max_boxes (each part once had the whole limit: 16 parts kept 8 times it)
                kept = sum(a.shape[0] for a in (*out.inner, *out.boundary, *(out.outside if keep_outside else ())))
                spare = max(0, max_boxes - kept - out.frontier.size) // len(pieces)
                args = (delta, task.step, task.args, chunk, keep_outside, max_boxes, deadline, out.levels, spare)
                try:
                    executor.run(cover_part, model, pieces, args, results, lambda: bool(mon.stop()), mon.done,
                                 bar.refresh)
                except KeyboardInterrupt:
                    flag.raised = True
                for piece, o in zip(pieces, results, strict=True):
                    if o is None:                    # not run (stopped): its boxes count as boundary
                        out.boundary.append(piece.output_boxes())
                        out.stop(mon.stop() or 'interrupted')
                    else:
                        if o.stopped == 'time limit':   # a cluster's part (its deadline), named as the driver's
                            o.stopped = f'time limit ({max_seconds:g} s)'
                        out.merge(o, keep_outside)
            elif out.frontier.size:
                out.boundary.append(out.frontier.output_boxes())
    finally:
        flag.restore()
    return _result(model, method, delta, box, out, time.perf_counter() - t0, executor.describe(), keep_outside)


def _result(model: Any, method: str, delta: float, box: np.ndarray, out: Outcome, seconds: float, extra: Any,
            keep_outside: bool) -> WorkspaceResult:
    """The run's :class:`WorkspaceResult` from what its levels and parts decided (``out``)."""
    k = box.shape[0]
    inner_arr = np.concatenate(out.inner) if out.inner else np.empty((0, k, 2))
    bnd_arr = np.concatenate(out.boundary) if out.boundary else np.empty((0, k, 2))
    outputs = _output_index(model)
    return WorkspaceResult(
        method=method,
        variables=tuple(model.variables[i] for i in outputs),
        units=tuple(model.units[i] for i in outputs),
        delta=delta,
        inner=inner_arr,
        boundary=bnd_arr,
        outside_boxes=out.outside_count,
        seconds=seconds,
        evaluations=out.evaluations,
        levels=out.levels,
        interrupted=bool(out.stopped),
        certified=(method == 'covering'),
        touches_initial_box=touches(box, inner_arr, bnd_arr, closed=closed_faces(model, box))
        and not getattr(model, 'box_contains_workspace', False),
        stopped=out.stopped,
        extra=extra,
        outside=(np.concatenate(out.outside) if out.outside else np.empty((0, k, 2))) if keep_outside else None,
    )
