"""The two grid methods, neither certified: the grid classification of a box (Posypkin et al., docs/references.md:
the constraints at the nodes of a small grid inside the box) and the plain uniform grid of cells (Aboulissane and
El Bakkali's discretisation of the 3-UPU workspace, CPI 2015)."""

from __future__ import annotations

import math
import time

import numpy as np

from ..errors import InputError, brief
from .base import DEFAULT_MAX_SECONDS, WorkspaceModel, WorkspaceResult, default_max_boxes
from .boxes import closed_faces, touches
from .progress import StopFlag

#: Most grid nodes inside one box for the grid method (``grid_nodes ** d``).
MAX_NODES_PER_BOX = 4096
_POINT_CHUNK = 200_000


def check_grid_nodes(nodes: int, d: int) -> None:
    """``nodes`` per edge (>= 2) with ``nodes ** d`` at most :data:`MAX_NODES_PER_BOX` (integer arithmetic: an
    integer of 500 digits has no float)."""
    if isinstance(nodes, bool) or not isinstance(nodes, (int, np.integer)):   # 'a' and 2.5 were TypeErrors
        raise InputError(f'grid method: nodes per edge = {brief(nodes)}; allowed: an integer, at least 2')
    if 2 <= nodes <= MAX_NODES_PER_BOX and nodes ** d <= MAX_NODES_PER_BOX:
        return
    allowed = f'allowed: at least 2 per edge and at most {MAX_NODES_PER_BOX} per box'
    if nodes < 2:
        raise InputError(f'grid method: {brief(nodes)} nodes per edge; {allowed}')
    exponent = d * math.log10(nodes)
    per_box = f'{10.0 ** exponent:.3g}' if exponent < 300 else f'10^{exponent:.0f}'
    raise InputError(f'grid method: {brief(nodes)} nodes per edge in {d} dimensions gives {per_box} nodes per box; '
                     f'{allowed}')


def grid_classify(model: WorkspaceModel, boxes: np.ndarray, nodes: int) -> tuple[np.ndarray, np.ndarray]:
    """Grid-method test: feasibility at the ``nodes**d`` grid nodes of each box -> (all ok, none ok)."""
    n, d, _ = boxes.shape
    t = np.linspace(0.0, 1.0, nodes)
    grids = np.stack(np.meshgrid(*([t] * d), indexing='ij'), axis=-1).reshape(-1, d)  # (k, d)
    k = grids.shape[0]
    all_ok = np.empty(n, dtype=bool)
    none_ok = np.empty(n, dtype=bool)
    step = max(1, _POINT_CHUNK // k)
    for s in range(0, n, step):
        lo = boxes[s : s + step, None, :, 0]
        hi = boxes[s : s + step, None, :, 1]
        pts = lo + (hi - lo) * grids[None]  # (m, k, d)
        ok = model.feasible(pts.reshape(-1, d)).reshape(pts.shape[0], k)
        all_ok[s : s + step] = ok.all(axis=1)
        none_ok[s : s + step] = ~ok.any(axis=1)
    return all_ok, none_ok


def _feasible_nodes(model: WorkspaceModel, axes: list[np.ndarray], deadline: float) -> tuple[np.ndarray, np.ndarray]:
    """Feasibility at every node of the grid ``axes`` (shape ``len(axes[i])`` per axis), the nodes made chunk by
    chunk from their flat index (C order, as ``meshgrid(indexing='ij')``): memory of one chunk, not of the grid.
    Chunks after ``deadline`` (``time.perf_counter()``) or Ctrl-C are not evaluated: the second array says which
    nodes were."""
    shape = tuple(a.size for a in axes)
    total = int(np.prod(shape))
    ok = np.zeros(total, dtype=bool)
    known = np.zeros(total, dtype=bool)
    flag = StopFlag()
    try:
        for s in range(0, total, _POINT_CHUNK):
            if flag.raised or time.perf_counter() > deadline:
                break
            idx = np.unravel_index(np.arange(s, min(s + _POINT_CHUNK, total)), shape)
            ok[s : s + _POINT_CHUNK] = model.feasible(np.stack([a[i] for a, i in zip(axes, idx, strict=True)],
                                                               axis=1))
            known[s : s + _POINT_CHUNK] = True
    finally:
        flag.restore()
    return ok.reshape(shape), known.reshape(shape)


def uniform(model: WorkspaceModel, delta: float, box: np.ndarray, max_seconds: float = DEFAULT_MAX_SECONDS,
            t0: float | None = None, max_boxes: int | None = None) -> WorkspaceResult:
    """Plain grid: cells of scaled edge < delta, classified by their 2**d corner nodes (not certified). Stopped
    after ``max_seconds`` from ``t0`` (``time.perf_counter()``, default now) or by Ctrl-C, a cell with a corner not
    evaluated is a boundary cell (it may be either), and the result says ``interrupted`` and why. More cells than
    ``max_boxes`` (default :func:`default_max_boxes`; each cell may come back as a box) are refused before the
    run: a ``--max-boxes 1000`` was ignored (3,167,172 cells came back as boxes at delta 0.33 mm on DexTAR)."""
    t0 = time.perf_counter() if t0 is None else t0
    deadline = t0 + max_seconds
    scale = np.asarray(model.scale, dtype=float)
    d = box.shape[0]
    counts = np.maximum(np.ceil((box[:, 1] - box[:, 0]) * scale / delta * (1 + 1e-12)), 1)
    # every cell may come back as a box (16 bytes per variable): the covering's default bound on the boxes kept
    limit = default_max_boxes(model) if max_boxes is None else max_boxes
    if float(np.prod(counts)) > limit:
        raise InputError(
            f'uniform grid with {counts.astype(int).tolist()} cells ({float(np.prod(counts)):.3g}) is too large for '
            f'delta {delta:g}; allowed: at most {limit:.4g} cells (the box limit, max_boxes or --max-boxes: each '
            'cell may come back as a box); use a larger delta, a larger box limit or the covering method'
        )
    cells = counts.astype(int)
    axes = [np.linspace(box[i, 0], box[i, 1], cells[i] + 1) for i in range(d)]
    ok, known = _feasible_nodes(model, axes, deadline)
    # a cell is inner if all its corners are feasible, outside if none is (a corner not evaluated may be either)
    corners = [tuple(slice(1, None) if (corner >> i) & 1 else slice(0, -1) for i in range(d))
               for corner in range(2**d)]
    all_ok = np.logical_and.reduce([ok[sl] & known[sl] for sl in corners])
    any_ok = np.logical_or.reduce([ok[sl] | ~known[sl] for sl in corners])
    stopped = '' if known.all() else ('interrupted' if time.perf_counter() <= deadline else
                                      f'time limit ({max_seconds:g} s)')
    idx_in = np.argwhere(all_ok)
    idx_bd = np.argwhere(any_ok & ~all_ok)

    def cell_boxes(idx: np.ndarray) -> np.ndarray:
        out = np.empty((idx.shape[0], d, 2))
        for i in range(d):
            out[:, i, 0] = axes[i][idx[:, i]]
            out[:, i, 1] = axes[i][idx[:, i] + 1]
        return out

    inner = cell_boxes(idx_in)
    bnd = cell_boxes(idx_bd)
    return WorkspaceResult(
        method='uniform',
        variables=tuple(model.variables),
        units=tuple(model.units),
        delta=float(delta),
        inner=inner,
        boundary=bnd,
        outside_boxes=int(all_ok.size - idx_in.shape[0] - idx_bd.shape[0]),
        seconds=time.perf_counter() - t0,
        evaluations=int(ok.size),
        levels=1,
        interrupted=bool(stopped),
        stopped=stopped,
        certified=False,
        touches_initial_box=touches(box, inner, bnd, closed=closed_faces(model, box)),
        extra={'grid_cells': cells.tolist()},
    )
