"""Operations on arrays of boxes: (n, d, 2) float arrays of lower and upper bounds; boxes read from YAML."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from ..errors import ConfigError, InputError, brief
from ..inputs.schema import number_key
from ..inputs.validation import float_array


def box_volume(boxes: np.ndarray) -> float:
    """Sum of the volumes of (n, d, 2) boxes (in the variables' units)."""
    if boxes.shape[0] == 0:
        return 0.0
    return float(np.sum(np.prod(boxes[..., 1] - boxes[..., 0], axis=1)))


def scaled_diameter(boxes: np.ndarray, scale: np.ndarray) -> np.ndarray:
    """Infinity-norm diameter of (n, d, 2) boxes in metres: the longest edge times its variable's scale."""
    return np.asarray(np.max((boxes[:, :, 1] - boxes[:, :, 0]) * scale, axis=1))


def bisect(boxes: np.ndarray, scale: np.ndarray) -> np.ndarray:
    """Split each (d, 2) box in two halves across its longest scaled edge -> (2n, d, 2), halves
    ``[left_0, right_0, left_1, right_1, ...]`` (each box's two halves side by side)."""
    n = boxes.shape[0]
    axis = np.argmax((boxes[:, :, 1] - boxes[:, :, 0]) * scale, axis=1)
    rows = np.arange(n)
    mid = 0.5 * (boxes[rows, axis, 0] + boxes[rows, axis, 1])
    out = np.repeat(boxes, 2, axis=0)
    out[2 * rows, axis, 1] = mid
    out[2 * rows + 1, axis, 0] = mid
    return out


def closed_faces(model: Any, box: np.ndarray) -> np.ndarray | None:
    """The faces of ``box`` (d, 2) beyond which ``model`` has no workspace (its ``closed_faces(box)``; None: a model
    without)."""
    faces = getattr(model, 'closed_faces', None)
    return None if faces is None else np.asarray(faces(box), dtype=bool)


def touches(box: np.ndarray, *arrays: np.ndarray, closed: np.ndarray | None = None) -> bool:
    """True when some of the (n, d, 2) boxes reach a face of the initial ``box`` (d, 2) not ``closed``."""
    return bool(reached_faces(box, *arrays, closed=closed))


def reached_faces(box: np.ndarray, *arrays: np.ndarray, closed: np.ndarray | None = None) -> tuple[int, ...]:
    """The variables (indices) at whose faces of the initial ``box`` (d, 2) some of the (n, d, 2) boxes lie, but for
    the faces ``closed`` (d, 2) marks: the model's own bounds there, beyond which no workspace lies (the GPR's height
    within the stroke, its box's z: "the workspace may extend beyond it" was said of it)."""
    lo, hi = np.zeros(box.shape[0], dtype=bool), np.zeros(box.shape[0], dtype=bool)
    for a in arrays:
        if a.shape[0]:
            lo |= np.any(a[:, :, 0] <= box[:, 0], axis=0)
            hi |= np.any(a[:, :, 1] >= box[:, 1], axis=0)
    if closed is not None:
        lo, hi = lo & ~closed[:, 0], hi & ~closed[:, 1]
    return tuple(int(k) for k in np.flatnonzero(lo | hi))


#: At most this many (box, cell) registrations of :func:`contains_points`' bucket grid (coarser cells beyond: many
#: large boxes overlapping everywhere registered ``n^2 2^d`` times), and (point, box) candidate pairs tested at once.
MAX_REGISTRATIONS = 4_000_000
MAX_PAIRS = 2_000_000


def contains_points(boxes: np.ndarray, points: np.ndarray) -> np.ndarray:
    """Boolean (N,): point i lies in at least one of ``boxes`` (n, d, 2) (closed boxes).

    A bucket grid over the boxes' hull: every box is registered in the cells it overlaps, every point is
    tested against the boxes of its own cell only (cell indices from the same monotone floor, so a point of
    a box always falls in one of the box's cells). Memory is bounded whatever the boxes: the grid is made coarser
    until it holds at most :data:`MAX_REGISTRATIONS` registrations (one cell, ``n``, at the coarsest), and the
    points are tested in runs of at most :data:`MAX_PAIRS` candidate pairs (one point and its cell's boxes at
    least).
    """
    B, P = _numbers(boxes), _numbers(points)
    P = None if P is None else np.atleast_2d(P)
    if B is None or P is None or B.ndim != 3 or B.shape[2] != 2 or P.ndim != 2 or P.shape[1] != B.shape[1]:
        raise InputError(f'boxes {_shown(boxes, B)} and points {_shown(points, P)}; allowed: boxes (n, d, 2) and '
                         'points (N, d) of the same d')   # numpy's ValueError or IndexError before ('abc' too)
    boxes, points = B, P
    npts = points.shape[0]
    out = np.zeros(npts, dtype=bool)
    n = boxes.shape[0]
    if n == 0 or npts == 0:
        return out
    d = boxes.shape[1]
    lo = boxes[:, :, 0].min(axis=0)
    hi = boxes[:, :, 1].max(axis=0)
    cells = int(np.clip(round(2.0 * n ** (1.0 / d)), 1, 256))
    while True:
        size = np.where(hi > lo, (hi - lo) / cells, 1.0)

        def cell_of(x: np.ndarray, size: np.ndarray = size, cells: int = cells) -> np.ndarray:
            # NaN (a NaN point, or inf - inf of infinite bounds) to cell 0: its cast to int64 warned and is undefined
            with np.errstate(invalid='ignore'):
                f = np.nan_to_num(np.floor((x - lo) / size), nan=0.0, posinf=cells - 1, neginf=0.0)
            return np.asarray(np.clip(f, 0, cells - 1).astype(np.int64))

        i0 = cell_of(boxes[:, :, 0])
        span = cell_of(boxes[:, :, 1]) - i0 + 1
        counts = np.prod(span, axis=1)
        if cells == 1 or int(counts.sum()) <= MAX_REGISTRATIONS:
            break
        cells //= 2
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
    total = np.cumsum(cnt)
    s0 = 0
    while s0 < npts:
        before = int(total[s0 - 1]) if s0 else 0
        s1 = max(s0 + 1, int(np.searchsorted(total, before + MAX_PAIRS, side='right')))
        sl = slice(s0, s1)
        c = cnt[sl]
        pid = np.repeat(np.arange(s0, s1), c)
        j = np.arange(pid.shape[0]) - np.repeat(np.cumsum(c) - c, c) + np.repeat(start[sl], c)
        b = box_sorted[j]
        inside = np.all((boxes[b, :, 0] <= points[pid]) & (points[pid] <= boxes[b, :, 1]), axis=1)
        out[pid[inside]] = True
        s0 = s1
    return out


def _numbers(values: Any) -> np.ndarray | None:
    """``values`` as a float array, or None where they are no numbers (text, truth values, a ragged list)."""
    try:
        return float_array(values, 'values')
    except InputError:
        return None


def _shown(values: Any, array: np.ndarray | None) -> str:
    """How a refusal of :func:`contains_points` names an argument: its shape, or the value that is no numbers."""
    return f'of shape {array.shape}' if array is not None else f'{brief(values)} (not numbers)'


def number(value: Any, key: str, source: str, positive: bool = False, unit: str = 'm') -> float:
    """One YAML value as a number by the package's rule (:func:`~gpr_kinematics.inputs.schema.number_key`)."""
    return number_key({key: value}, key, source, positive=positive, unit=unit)


def box_from(ws: Mapping[str, Any], variables: Sequence[str], default: np.ndarray, source: str) -> np.ndarray:
    """``workspace.box``: variable name -> ``[lower, upper]`` over the model's ``default`` box."""
    spec = ws.get('box')
    box = np.array(default, dtype=float)
    if spec is None:
        return box
    if not isinstance(spec, Mapping):
        raise ConfigError(f'{source}: workspace.box must map variable names {list(variables)} to [lower, upper]')
    for name, bounds in spec.items():
        if name not in variables:
            raise ConfigError(f'{source}: workspace.box has unknown variable {str(name)[:40]!r}; '
                              f'allowed: {list(variables)}')
        box[list(variables).index(name)] = bounds_pair(bounds, f'workspace.box.{name}', source)
    return box


def bounds_pair(bounds: Any, where: str, source: str) -> tuple[float, float]:
    """``[lower, upper]``: two numbers with lower < upper."""
    if not isinstance(bounds, (list, tuple)) or len(bounds) != 2:
        raise ConfigError(f'{source}: {where} must be [lower, upper], got {str(bounds)[:80]}')
    lo, hi = (number(b, where, source, unit='SI units') for b in bounds)
    if not lo < hi:
        raise ConfigError(f'{source}: {where} needs lower < upper, got [{lo:g}, {hi:g}]')
    return lo, hi
