"""Workspace approximation by nonuniform covering (certified) and by the grid method.

Seed ``workspace-nonuniform-covering-posypkin.txt`` (Posypkin, Rybak, Malyshev, Gaponenko): a working area
``W = {x in Q : lower_j <= g_j(x) <= upper_j for all j}`` is approximated by two unions of boxes,

* the **inner** approximation: boxes on which every constraint certainly holds (``W`` contains them), and
* the **outer** approximation: inner boxes plus **boundary** boxes (undecided boxes whose diameter fell below
  the accuracy ``delta``); it contains ``W``.

The covering method keeps a list of boxes, starting from one box ``Q`` that contains ``W``; for each box it
bounds every constraint by interval arithmetic (:mod:`gpr_kinematics.interval`, outward rounding): a box with
some ``[g_j]`` outside ``[lower_j, upper_j]`` is dropped (outside), a box with every ``[g_j]`` inside is
inner, any other box is bisected along its longest edge, or, once its diameter is below ``delta``, becomes a
boundary box. Here the whole list is processed at once, level by level, as numpy arrays (one interval
evaluation per level for all boxes), instead of one box at a time.

Diameter. Variables may mix metres and radians. Each variable has a ``scale`` (metres per unit: 1 for
lengths, a characteristic length for angles, e.g. the platform radius, so that an angle edge is measured by
the displacement it causes at the platform joints). The diameter of a box is its longest scaled edge (the
infinity-norm diameter, the same measure as codac's SIVIA ``eps``); the longest scaled edge is the one
bisected.

The **grid method** (the seed's alternative for expressions with repeated variables) classifies a box by
evaluating the constraints at the nodes of a small grid inside it (all nodes feasible: inner; none: outside;
else bisect): cheaper and tighter where interval bounds overestimate, but not certified. The **uniform
grid** is the plain discretisation of seed ``3upu-aboulissane.txt``: cells of edge below ``delta``
classified by their corner nodes, no bisection.

Volumes are in the variables' own units (e.g. m·rad² for ``z, psi, theta``).
"""

from __future__ import annotations

import signal
import sys
import threading
import time
from abc import ABC, abstractmethod
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import TextIO

import numpy as np

from .errors import InputError
from .interval import Interval

METHODS = ('covering', 'grid', 'uniform')


class WorkspaceModel(ABC):
    """Constraint model of a mechanism's working area: ``lower_j <= g_j(x) <= upper_j``.

    Subclasses set :attr:`variables`, :attr:`units`, :attr:`scale` (metres per unit of each variable),
    :attr:`box` ((d, 2) initial box that contains the workspace), :attr:`constraint_names`, :attr:`lower`,
    :attr:`upper` (bounds, may be +-inf) and implement :meth:`enclose` (certified interval bounds over boxes)
    and :meth:`evaluate` (exact point values, used by tests and by the grid methods).
    """

    name: str = 'model'
    variables: tuple[str, ...] = ()
    units: tuple[str, ...] = ()
    scale: np.ndarray
    box: np.ndarray
    constraint_names: tuple[str, ...] = ()
    lower: np.ndarray
    upper: np.ndarray

    @abstractmethod
    def enclose(self, x: Sequence[Interval]) -> list[Interval]:
        """Interval enclosures of every ``g_j`` over boxes; ``x[i]`` holds variable i over n boxes."""

    @abstractmethod
    def evaluate(self, points: np.ndarray) -> np.ndarray:
        """Point values ``g(x)`` for ``points`` (N, d) -> (N, m) (NaN where undefined = infeasible)."""

    def feasible(self, points: np.ndarray) -> np.ndarray:
        """Boolean (N,): every constraint satisfied at the point (NaN counts as violated)."""
        g = self.evaluate(np.atleast_2d(np.asarray(points, dtype=float)))
        return np.all((g >= self.lower) & (g <= self.upper), axis=1)

    def bounds(self, boxes: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Interval bounds of all constraints over ``boxes`` (n, d, 2) -> (lo, hi), each (n, m)."""
        xs = [Interval(boxes[:, i, 0], boxes[:, i, 1]) for i in range(boxes.shape[1])]
        g = self.enclose(xs)
        n = boxes.shape[0]
        lo = np.stack([np.broadcast_to(gi.lo, (n,)) for gi in g], axis=1)
        hi = np.stack([np.broadcast_to(gi.hi, (n,)) for gi in g], axis=1)
        return lo, hi

    def check_box(self, box: np.ndarray) -> None:  # noqa: B027 - optional hook, valid everywhere by default
        """Raise :class:`InputError` if the model's enclosures are not valid on ``box``."""

    def describe(self) -> dict:
        return {
            'type': self.name,
            'variables': list(self.variables),
            'units': list(self.units),
            'scale': self.scale.tolist(),
            'box': self.box.tolist(),
            'constraints': list(self.constraint_names),
        }


@dataclass
class WorkspaceResult:
    """Inner and boundary boxes of a workspace approximation.

    ``inner`` and ``boundary`` are (n, d, 2) arrays of lower/upper bounds; the outer approximation is their
    union. After an interruption (Ctrl-C) the boxes not yet examined are appended to ``boundary``, so the
    outer approximation still contains the workspace and ``inner`` is still inside it.
    """

    method: str
    variables: tuple[str, ...]
    units: tuple[str, ...]
    delta: float
    inner: np.ndarray
    boundary: np.ndarray
    outside_boxes: int
    seconds: float
    evaluations: int
    levels: int
    interrupted: bool = False
    certified: bool = True
    touches_initial_box: bool = False
    extra: dict = field(default_factory=dict)

    @property
    def inner_boxes(self) -> int:
        return int(self.inner.shape[0])

    @property
    def boundary_boxes(self) -> int:
        return int(self.boundary.shape[0])

    @property
    def inner_volume(self) -> float:
        return box_volume(self.inner)

    @property
    def outer_volume(self) -> float:
        return self.inner_volume + box_volume(self.boundary)

    def summary(self) -> dict:
        return {
            'method': self.method,
            'variables': list(self.variables),
            'units': list(self.units),
            'delta': self.delta,
            'inner_boxes': self.inner_boxes,
            'boundary_boxes': self.boundary_boxes,
            'outside_boxes': self.outside_boxes,
            'inner_volume': self.inner_volume,
            'outer_volume': self.outer_volume,
            'seconds': self.seconds,
            'evaluations': self.evaluations,
            'levels': self.levels,
            'interrupted': self.interrupted,
            'certified': self.certified,
            'touches_initial_box': self.touches_initial_box,
            **self.extra,
        }


def box_volume(boxes: np.ndarray) -> float:
    """Sum of the volumes of (n, d, 2) boxes (in the variables' units)."""
    if boxes.shape[0] == 0:
        return 0.0
    return float(np.sum(np.prod(boxes[..., 1] - boxes[..., 0], axis=1)))


class _Progress:
    """One-line progress display on stderr, shown only once a run has lasted ``after`` seconds."""

    def __init__(self, enabled: bool, stream: TextIO | None = None, after: float = 2.0) -> None:
        self.enabled = enabled
        self.stream = stream or sys.stderr
        self.after = after
        self.start = time.perf_counter()
        self.shown = False

    def update(self, level: int, pending: int, inner: int, boundary: int, done_frac: float) -> None:
        if not self.enabled:
            return
        elapsed = time.perf_counter() - self.start
        if elapsed < self.after:
            return
        width = 30
        fill = int(round(width * min(max(done_frac, 0.0), 1.0)))
        self.stream.write(
            f'\r[{"#" * fill}{"." * (width - fill)}] {100 * done_frac:5.1f}% of volume decided, '
            f'level {level}, {pending} pending, {inner} inner, {boundary} boundary, '
            f'{elapsed:.1f} s '
        )
        self.stream.flush()
        self.shown = True

    def close(self) -> None:
        if self.shown:
            self.stream.write('\n')
            self.stream.flush()


class _StopFlag:
    """While alive, SIGINT (Ctrl-C) sets :attr:`raised` instead of raising KeyboardInterrupt (main thread)."""

    def __init__(self) -> None:
        self.raised = False
        self._old = None
        if threading.current_thread() is threading.main_thread():
            try:
                self._old = signal.signal(signal.SIGINT, self._handler)
            except (ValueError, OSError):  # pragma: no cover - embedded interpreters
                self._old = None

    def _handler(self, signum: int, frame: object) -> None:
        self.raised = True

    def restore(self) -> None:
        if self._old is not None:
            signal.signal(signal.SIGINT, self._old)
            self._old = None


def _check(model: WorkspaceModel, delta: float, box: np.ndarray | None) -> np.ndarray:
    box = np.array(model.box if box is None else box, dtype=float)
    if box.ndim != 2 or box.shape != (len(model.variables), 2):
        raise InputError(f'initial box must have shape ({len(model.variables)}, 2), got {box.shape}')
    if not np.all(np.isfinite(box)) or np.any(box[:, 1] <= box[:, 0]):
        raise InputError(f'initial box needs finite bounds with lower < upper, got {box.tolist()}')
    if not np.isfinite(delta) or delta <= 0:
        raise InputError(f'delta must be a positive length in metres, got {delta!r}')
    model.check_box(box)
    diam = float(np.max((box[:, 1] - box[:, 0]) * model.scale))
    if delta < diam * 2.0**-40:
        raise InputError(
            f'delta {delta:g} m is too small for the initial box (diameter {diam:g} m): '
            f'allowed delta >= {diam * 2.0**-40:.3g} m'
        )
    return box


def _touches(box: np.ndarray, *arrays: np.ndarray) -> bool:
    for a in arrays:
        if a.shape[0] and (np.any(a[:, :, 0] <= box[:, 0]) or np.any(a[:, :, 1] >= box[:, 1])):
            return True
    return False


def _bisect(boxes: np.ndarray, scale: np.ndarray) -> np.ndarray:
    """Split each (d, 2) box in two halves across its longest scaled edge -> (2n, d, 2)."""
    n = boxes.shape[0]
    widths = (boxes[:, :, 1] - boxes[:, :, 0]) * scale
    axis = np.argmax(widths, axis=1)
    rows = np.arange(n)
    mid = 0.5 * (boxes[rows, axis, 0] + boxes[rows, axis, 1])
    left = boxes.copy()
    right = boxes.copy()
    left[rows, axis, 1] = mid
    right[rows, axis, 0] = mid
    return np.concatenate([left, right], axis=0)


def _grid_classify(model: WorkspaceModel, boxes: np.ndarray, nodes: int) -> tuple[np.ndarray, np.ndarray]:
    """Grid-method test: feasibility at the ``nodes**d`` grid nodes of each box -> (all ok, none ok)."""
    n, d, _ = boxes.shape
    t = np.linspace(0.0, 1.0, nodes)
    grids = np.stack(np.meshgrid(*([t] * d), indexing='ij'), axis=-1).reshape(-1, d)  # (k, d)
    lo = boxes[:, None, :, 0]
    hi = boxes[:, None, :, 1]
    pts = lo + (hi - lo) * grids[None]  # (n, k, d)
    ok = model.feasible(pts.reshape(-1, d)).reshape(n, -1)
    return ok.all(axis=1), ~ok.any(axis=1)


def approximate(
    model: WorkspaceModel,
    delta: float,
    method: str = 'covering',
    box: np.ndarray | None = None,
    grid_nodes: int = 3,
    max_batch: int = 200_000,
    progress: bool | None = None,
    progress_stream: TextIO | None = None,
    max_seconds: float | None = None,
) -> WorkspaceResult:
    """Approximate the working area of ``model`` to accuracy ``delta`` (metres, scaled diameter).

    Args:
        model: the constraint model (see :class:`WorkspaceModel`).
        delta: accuracy: undecided boxes are bisected until their scaled diameter is below ``delta`` [m].
        method: ``covering`` (certified interval bounds), ``grid`` (the seed's grid method: node sampling
            inside each box, with bisection; not certified) or ``uniform`` (plain grid of cells).
        box: initial box (d, 2); default ``model.box``. It must contain the workspace (reported:
            ``touches_initial_box`` is true when inner or boundary boxes reach its faces).
        grid_nodes: nodes per edge for the grid method's classification.
        max_batch: most boxes evaluated in one numpy call (bounds memory).
        progress: progress bar on stderr after 2 s; ``None`` shows it when stderr is a terminal.
        max_seconds: stop like an interruption after this wall time (None: no limit).

    Returns:
        :class:`WorkspaceResult`. Ctrl-C (KeyboardInterrupt) during the run stops it cleanly: the result
        is returned with ``interrupted=True`` and the unexamined boxes counted as boundary.
    """
    if method not in METHODS:
        raise InputError(f'unknown workspace method {method!r}; allowed: {", ".join(METHODS)}')
    box = _check(model, delta, box)
    if method == 'uniform':
        return _uniform(model, delta, box)
    scale = np.asarray(model.scale, dtype=float)
    stream = progress_stream or sys.stderr
    if progress is None:
        progress = bool(getattr(stream, 'isatty', lambda: False)())
    bar = _Progress(progress, stream)
    total_volume = float(np.prod(box[:, 1] - box[:, 0]))
    lower = np.asarray(model.lower, dtype=float)
    upper = np.asarray(model.upper, dtype=float)

    t0 = time.perf_counter()
    pending = [box[None].copy()]
    inner: list[np.ndarray] = []
    boundary: list[np.ndarray] = []
    outside = 0
    evaluations = 0
    level = 0
    decided_volume = 0.0
    interrupted = False
    # Ctrl-C sets a flag that is checked between chunks, so a chunk is never half recorded; a
    # KeyboardInterrupt raised inside a model's evaluation (or outside the main thread) is handled too.
    stop = _StopFlag()
    try:
        while pending and not interrupted:
            level += 1
            current = np.concatenate(pending, axis=0)
            pending = []
            for start in range(0, current.shape[0], max_batch):
                chunk = current[start : start + max_batch]
                try:
                    if method == 'covering':
                        glo, ghi = model.bounds(chunk)
                        is_out = np.any((ghi < lower) | (glo > upper), axis=1)
                        is_in = np.all((glo >= lower) & (ghi <= upper), axis=1) & ~is_out
                    else:
                        is_in, is_out = _grid_classify(model, chunk, grid_nodes)
                        is_in &= ~is_out
                except KeyboardInterrupt:
                    interrupted = True
                    pending.append(current[start:])
                    break
                evaluations += chunk.shape[0]
                undecided = ~(is_in | is_out)
                diam = np.max((chunk[:, :, 1] - chunk[:, :, 0]) * scale, axis=1)
                small = undecided & (diam < delta)
                split = undecided & ~small
                inner.append(chunk[is_in])
                boundary.append(chunk[small])
                outside += int(np.count_nonzero(is_out))
                decided_volume += box_volume(chunk[is_in | is_out]) + box_volume(chunk[small])
                if np.any(split):
                    pending.append(_bisect(chunk[split], scale))
                bar.update(
                    level,
                    sum(p.shape[0] for p in pending) + current.shape[0] - start - chunk.shape[0],
                    sum(a.shape[0] for a in inner),
                    sum(a.shape[0] for a in boundary),
                    decided_volume / total_volume,
                )
                late = max_seconds is not None and time.perf_counter() - t0 > max_seconds
                if stop.raised or late:
                    interrupted = True
                    pending.append(current[start + max_batch :])
                    break
        if interrupted:
            boundary.extend(p for p in pending if p.shape[0])
    finally:
        stop.restore()
        bar.close()
    seconds = time.perf_counter() - t0
    d = box.shape[0]
    inner_arr = np.concatenate(inner, axis=0) if inner else np.empty((0, d, 2))
    bnd_arr = np.concatenate(boundary, axis=0) if boundary else np.empty((0, d, 2))
    return WorkspaceResult(
        method=method,
        variables=tuple(model.variables),
        units=tuple(model.units),
        delta=float(delta),
        inner=inner_arr,
        boundary=bnd_arr,
        outside_boxes=outside,
        seconds=seconds,
        evaluations=evaluations,
        levels=level,
        interrupted=interrupted,
        certified=(method == 'covering'),
        touches_initial_box=_touches(box, inner_arr, bnd_arr),
    )


def _uniform(model: WorkspaceModel, delta: float, box: np.ndarray) -> WorkspaceResult:
    """Plain grid: cells of scaled edge < delta, classified by their 2**d corner nodes (not certified)."""
    t0 = time.perf_counter()
    scale = np.asarray(model.scale, dtype=float)
    d = box.shape[0]
    counts = np.maximum(np.ceil((box[:, 1] - box[:, 0]) * scale / delta * (1 + 1e-12)), 1).astype(int)
    if float(np.prod(counts.astype(float) + 1)) > 5e8:
        raise InputError(
            f'uniform grid with {counts.tolist()} cells is too large for delta {delta:g}; '
            'use a larger delta or the covering method'
        )
    axes = [np.linspace(box[i, 0], box[i, 1], counts[i] + 1) for i in range(d)]
    nodes = np.stack(np.meshgrid(*axes, indexing='ij'), axis=-1).reshape(-1, d)
    ok = np.concatenate([model.feasible(nodes[i:i + 200_000]) for i in range(0, nodes.shape[0], 200_000)])
    ok = ok.reshape(tuple(counts + 1))
    # a cell is inner if all its corners are feasible, outside if none is
    corner_slices = []
    for corner in range(2**d):
        sl = tuple(slice(1, None) if (corner >> i) & 1 else slice(0, -1) for i in range(d))
        corner_slices.append(ok[sl])
    all_ok = np.logical_and.reduce(corner_slices)
    any_ok = np.logical_or.reduce(corner_slices)
    idx_in = np.argwhere(all_ok)
    idx_bd = np.argwhere(any_ok & ~all_ok)

    def cells(idx: np.ndarray) -> np.ndarray:
        out = np.empty((idx.shape[0], d, 2))
        for i in range(d):
            out[:, i, 0] = axes[i][idx[:, i]]
            out[:, i, 1] = axes[i][idx[:, i] + 1]
        return out

    inner = cells(idx_in)
    bnd = cells(idx_bd)
    return WorkspaceResult(
        method='uniform',
        variables=tuple(model.variables),
        units=tuple(model.units),
        delta=float(delta),
        inner=inner,
        boundary=bnd,
        outside_boxes=int(all_ok.size - idx_in.shape[0] - idx_bd.shape[0]),
        seconds=time.perf_counter() - t0,
        evaluations=int(nodes.shape[0]),
        levels=1,
        certified=False,
        touches_initial_box=_touches(box, inner, bnd),
        extra={'grid_cells': counts.tolist()},
    )


def contains_points(boxes: np.ndarray, points: np.ndarray) -> np.ndarray:
    """Boolean (N,): point i lies in at least one of ``boxes`` (n, d, 2) (closed boxes).

    A bucket grid over the boxes' hull: every box is registered in the cells it overlaps, every point is
    tested against the boxes of its own cell only (cell indices from the same monotone floor, so a point of
    a box always falls in one of the box's cells).
    """
    points = np.atleast_2d(np.asarray(points, dtype=float))
    npts = points.shape[0]
    out = np.zeros(npts, dtype=bool)
    n = boxes.shape[0]
    if n == 0 or npts == 0:
        return out
    d = boxes.shape[1]
    lo = boxes[:, :, 0].min(axis=0)
    hi = boxes[:, :, 1].max(axis=0)
    cells = int(np.clip(round(2.0 * n ** (1.0 / d)), 1, 256))
    size = np.where(hi > lo, (hi - lo) / cells, 1.0)

    def cell_of(x: np.ndarray) -> np.ndarray:
        return np.clip(np.floor((x - lo) / size), 0, cells - 1).astype(np.int64)

    i0 = cell_of(boxes[:, :, 0])
    span = cell_of(boxes[:, :, 1]) - i0 + 1
    counts = np.prod(span, axis=1)
    box_id = np.repeat(np.arange(n), counts)
    k = np.arange(box_id.shape[0]) - np.repeat(np.cumsum(counts) - counts, counts)
    cell = np.zeros_like(k)
    for dim in range(d):
        r = span[box_id, dim]
        cell = cell * cells + i0[box_id, dim] + k % r
        k = k // r
    order = np.argsort(cell, kind='stable')
    cell_sorted = cell[order]
    box_sorted = box_id[order]
    pc = cell_of(points)
    pcell = np.zeros(npts, dtype=np.int64)
    for dim in range(d):
        pcell = pcell * cells + pc[:, dim]
    start = np.searchsorted(cell_sorted, pcell, side='left')
    cnt = np.searchsorted(cell_sorted, pcell, side='right') - start
    for s0 in range(0, npts, 20000):
        sl = slice(s0, s0 + 20000)
        c = cnt[sl]
        pid = np.repeat(np.arange(s0, s0 + c.shape[0]), c)
        j = np.arange(pid.shape[0]) - np.repeat(np.cumsum(c) - c, c) + np.repeat(start[sl], c)
        b = box_sorted[j]
        inside = np.all((boxes[b, :, 0] <= points[pid]) & (points[pid] <= boxes[b, :, 1]), axis=1)
        out[pid[inside]] = True
    return out
