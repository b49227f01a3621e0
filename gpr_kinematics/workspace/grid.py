"""The two grid methods, neither certified: the grid classification of a box (Posypkin et al.
2019: the constraints at the nodes of a small grid inside the box) and the plain uniform grid of cells
(Aboulissane and El Bakkali's discretisation of the 3-UPU workspace)."""

from __future__ import annotations

import time

import numpy as np

from ..errors import InputError
from .base import WorkspaceModel, WorkspaceResult
from .boxes import touches

#: Most grid nodes inside one box for the grid method (``grid_nodes ** d``).
MAX_NODES_PER_BOX = 4096
#: Most nodes of the uniform grid (its boolean node array and one chunk of points stay below ~4 GB).
MAX_UNIFORM_NODES = 5e8
_POINT_CHUNK = 200_000


def check_grid_nodes(nodes: int, d: int) -> None:
    """``nodes`` per edge (>= 2) with ``nodes ** d`` at most :data:`MAX_NODES_PER_BOX`."""
    if nodes < 2 or float(nodes) ** d > MAX_NODES_PER_BOX:
        raise InputError(
            f'grid method: {nodes} nodes per edge in {d} dimensions gives {float(nodes) ** d:.3g} nodes per box; '
            f'allowed: at least 2 per edge and at most {MAX_NODES_PER_BOX} per box'
        )


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


def uniform(model: WorkspaceModel, delta: float, box: np.ndarray) -> WorkspaceResult:
    """Plain grid: cells of scaled edge < delta, classified by their 2**d corner nodes (not certified)."""
    t0 = time.perf_counter()
    scale = np.asarray(model.scale, dtype=float)
    d = box.shape[0]
    counts = np.maximum(np.ceil((box[:, 1] - box[:, 0]) * scale / delta * (1 + 1e-12)), 1)
    if float(np.prod(counts + 1)) > MAX_UNIFORM_NODES:
        raise InputError(
            f'uniform grid with {counts.astype(int).tolist()} cells ({float(np.prod(counts + 1)):.3g} nodes) is too '
            f'large for delta {delta:g}; allowed: at most {MAX_UNIFORM_NODES:.0e} nodes (use a larger delta or the '
            'covering method)'
        )
    cells = counts.astype(int)
    axes = [np.linspace(box[i, 0], box[i, 1], cells[i] + 1) for i in range(d)]
    nodes = np.stack(np.meshgrid(*axes, indexing='ij'), axis=-1).reshape(-1, d)
    ok = np.concatenate(
        [model.feasible(nodes[i : i + _POINT_CHUNK]) for i in range(0, nodes.shape[0], _POINT_CHUNK)]
    ).reshape(tuple(cells + 1))
    # a cell is inner if all its corners are feasible, outside if none is
    corner_slices = []
    for corner in range(2**d):
        sl = tuple(slice(1, None) if (corner >> i) & 1 else slice(0, -1) for i in range(d))
        corner_slices.append(ok[sl])
    all_ok = np.logical_and.reduce(corner_slices)
    any_ok = np.logical_or.reduce(corner_slices)
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
        evaluations=int(nodes.shape[0]),
        levels=1,
        certified=False,
        touches_initial_box=touches(box, inner, bnd),
        extra={'grid_cells': cells.tolist()},
    )
