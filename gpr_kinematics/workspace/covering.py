"""Workspace approximation by nonuniform covering (certified) and by the grid methods.

The covering method of Posypkin, Rybak, Malyshev and Gaponenko ("Approximation of the parallel robot
working area using the method of nonuniform covering", 2019) keeps a list of boxes, starting from one box
``Q`` that contains the working area ``W = {x in Q : lower_j <= g_j(x) <= upper_j}``; for each box it
bounds every constraint by interval arithmetic (:mod:`gpr_kinematics.interval`, outward rounding): a box
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

import sys
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, TextIO

import numpy as np

from ..errors import InputError
from .base import WorkspaceModel, WorkspaceResult, check_delta, check_initial_box
from .boxes import bisect, box_volume, scaled_diameter, touches
from .grid import check_grid_nodes, grid_classify, uniform
from .progress import Progress, StopFlag
from .scheduler import Executor

METHODS = ('covering', 'grid', 'uniform')
#: Most boxes a run keeps (inner + boundary + pending, counted before a level doubles them); beyond it
#: the run stops like an interruption (``stopped = 'box limit'``) instead of exhausting memory.
MAX_BOXES = 10_000_000
#: Pending boxes per chunk (the unit of work of one process or Dask task) for constraint models.
CHUNK_BOXES = 32768


@dataclass
class Step:
    """What classifying one chunk gives: decided boxes (over the output variables) and the next level."""

    inner: np.ndarray
    boundary: np.ndarray
    outside: int
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

    @staticmethod
    def concat(parts: list[BoxFrontier], d: int) -> BoxFrontier:
        arrays = [p.boxes for p in parts if p.size]
        return BoxFrontier(np.concatenate(arrays) if arrays else np.empty((0, d, 2)))

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
    return Step(chunk[is_in], chunk[small], int(np.count_nonzero(is_out)),
                BoxFrontier(bisect(chunk[split], model.scale)), chunk.shape[0])


@dataclass(frozen=True)
class CoveringTask:
    """How to cover one model: the first frontier, the chunk step ``step(model, chunk, delta, *args)``,
    how frontiers are joined, and the initial box and scale of the output variables."""

    frontier: Any
    step: Callable[..., Step]
    args: tuple[Any, ...]
    concat: Callable[[list[Any]], Any]
    box: np.ndarray
    scale: np.ndarray
    chunk: int


def _constraint_task(model: WorkspaceModel, box: np.ndarray, method: str, nodes: int) -> CoveringTask:
    if method == 'grid':
        check_grid_nodes(nodes, box.shape[0])
    d = box.shape[0]
    return CoveringTask(BoxFrontier(box[None].copy()), constraint_step, (method, nodes),
                        lambda parts: BoxFrontier.concat(parts, d), box, np.asarray(model.scale, dtype=float),
                        CHUNK_BOXES)


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
    max_boxes: int = MAX_BOXES,
    chunk_size: int | None = None,
    scheduler: str | Executor = 'none',
    workers: int | None = None,
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
        max_seconds: stop like an interruption after this wall time (None: no limit).
        max_boxes: stop like an interruption before the boxes kept could exceed this count.
        chunk_size: pending boxes per chunk (default per model); results do not depend on where chunks run.
        scheduler: ``'none'`` (this process), ``'local'`` (a Dask local cluster, ``workers`` processes,
            default one per core), a Dask scheduler address ``'tcp://HOST:PORT'``, or an :class:`Executor`
            to reuse (the caller closes it).

    Returns:
        :class:`WorkspaceResult`. Ctrl-C (SIGINT) during the run stops it cleanly between chunks: the
        result is returned with ``interrupted=True`` and the unexamined boxes counted as boundary.
    """
    if method not in METHODS:
        raise InputError(f'unknown workspace method {method!r}; allowed: {", ".join(METHODS)}')
    if not (isinstance(max_boxes, int) and max_boxes >= 1):
        raise InputError(f'max_boxes must be a positive integer, got {max_boxes!r}')
    if chunk_size is not None and not (isinstance(chunk_size, int) and chunk_size >= 1):
        raise InputError(f'chunk_size must be a positive integer, got {chunk_size!r}')
    if hasattr(model, 'covering_task'):
        if method != 'covering' or box is not None:
            raise InputError(f'{model.name}: a model given by equations is covered with method covering on '
                             'its own variable box only')
        task = model.covering_task()
    else:
        box = check_initial_box(model.box if box is None else box, model.variables)
        model.check_box(box)
        task = _constraint_task(model, box, method, grid_nodes)
    check_delta(delta, task.box, task.scale)
    if method == 'uniform':
        return uniform(model, delta, task.box)
    own = not isinstance(scheduler, Executor)
    executor = Executor(scheduler, workers) if isinstance(scheduler, str) else scheduler
    stream = progress_stream
    if progress is None:
        progress = bool(getattr(stream or sys.stderr, 'isatty', lambda: False)())
    bar = Progress(progress, stream, progress_after, '*'.join(model.units[i] for i in _output_index(model)))
    try:
        return _run(model, task, float(delta), method, executor, bar, max_seconds, max_boxes,
                    chunk_size or task.chunk)
    finally:
        bar.close()
        if own:
            executor.close()


def _output_index(model: Any) -> list[int]:
    outputs = getattr(model, 'outputs', model.variables)
    return [list(model.variables).index(v) for v in outputs]


def _run(
    model: Any,
    task: CoveringTask,
    delta: float,
    method: str,
    executor: Executor,
    bar: Progress,
    max_seconds: float | None,
    max_boxes: int,
    chunk: int,
) -> WorkspaceResult:
    t0 = time.perf_counter()
    box, scale = task.box, task.scale
    total_volume = float(np.prod(box[:, 1] - box[:, 0]))
    frontier = task.frontier
    inner: list[np.ndarray] = []
    boundary: list[np.ndarray] = []
    tally = {'outside': 0, 'evaluations': 0, 'kept': 0, 'inner_volume': 0.0, 'boundary_volume': 0.0,
             'outside_volume': 0.0}
    level = 0
    stopped = ''
    flag = StopFlag()

    def late() -> bool:
        return max_seconds is not None and time.perf_counter() - t0 > max_seconds

    def should_stop() -> bool:
        return flag.raised or late()

    try:
        while frontier.size and not stopped:
            level += 1
            if tally['kept'] + 2 * frontier.size > max_boxes:
                stopped = f'box limit ({max_boxes} boxes)'
                break
            chunks = frontier.split(chunk)
            diameter = frontier.diameter(scale)

            def done(i: int, r: Step, level: int = level, diameter: float = diameter,
                     chunks: list[Any] = chunks) -> None:
                tally['evaluations'] += r.evaluations
                tally['outside'] += r.outside
                tally['kept'] += r.inner.shape[0] + r.boundary.shape[0]
                tally['inner_volume'] += box_volume(r.inner)
                tally['boundary_volume'] += box_volume(r.boundary)
                tally['outside_volume'] += box_volume(chunks[i].output_boxes()) - box_volume(
                    r.children.output_boxes()) - box_volume(r.inner) - box_volume(r.boundary)
                decided = tally['inner_volume'] + tally['boundary_volume'] + tally['outside_volume']
                bar.update(level, diameter, delta, tally['evaluations'], tally['inner_volume'],
                           tally['boundary_volume'], decided / total_volume)

            results: list[Step | None] = [None] * len(chunks)
            try:
                executor.run(task.step, model, chunks, (delta, *task.args), results, should_stop, done)
            except KeyboardInterrupt:
                # raised inside a model's evaluation (or outside the main thread): keep what is recorded
                flag.raised = True
            frontier = task.concat([c if r is None else r.children for c, r in zip(chunks, results, strict=True)])
            for r in results:
                if r is not None:
                    inner.append(r.inner)
                    boundary.append(r.boundary)
            if flag.raised:
                stopped = 'interrupted'
            elif late():
                stopped = f'time limit ({max_seconds:g} s)'
        if stopped and frontier.size:
            boundary.append(frontier.output_boxes())
    finally:
        flag.restore()
    k = box.shape[0]
    inner_arr = np.concatenate(inner) if inner else np.empty((0, k, 2))
    bnd_arr = np.concatenate(boundary) if boundary else np.empty((0, k, 2))
    outputs = _output_index(model)
    return WorkspaceResult(
        method=method,
        variables=tuple(model.variables[i] for i in outputs),
        units=tuple(model.units[i] for i in outputs),
        delta=delta,
        inner=inner_arr,
        boundary=bnd_arr,
        outside_boxes=tally['outside'],
        seconds=time.perf_counter() - t0,
        evaluations=tally['evaluations'],
        levels=level,
        interrupted=bool(stopped),
        certified=(method == 'covering'),
        touches_initial_box=touches(box, inner_arr, bnd_arr),
        stopped=stopped,
        extra=executor.describe(),
    )
