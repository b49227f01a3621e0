"""A union of boxes as a voxel grid, for a constant-time certified query: does a box meet the union?

The grid has a power-of-two spacing per axis and an origin on that spacing, so voxel faces are exact floats;
marking and queries moreover keep a one-voxel margin on the safe side: every voxel that meets one of the
boxes is marked, and one voxel around it; a query counts the marked voxels that meet the query box, and one
voxel around it, in a summed-volume table (``2^d`` lookups). So ``any == False`` proves that the query box
misses every box, whatever the rounding of the index arithmetic.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass

import numpy as np

from ..errors import InputError

#: Most voxels of one grid (its table is 4 bytes per voxel).
MAX_VOXELS = 16_000_000


def hull_of(boxes: np.ndarray) -> np.ndarray:
    """The hull (d, 2) of (n, d, 2) boxes (zeros for none)."""
    if not len(boxes):
        return np.zeros((boxes.shape[1], 2))
    return np.stack([boxes[:, :, 0].min(axis=0), boxes[:, :, 1].max(axis=0)], axis=1)


def dyadic(step: float) -> float:
    """The largest power of two not above ``step`` (> 0)."""
    return float(2.0 ** math.floor(math.log2(step)))


def _up(x: float) -> str:
    """``x`` > 0 rounded up at three significant digits (rounded to nearest, 0.001953125 read 0.00195: a delta
    refused again)."""
    e = math.floor(math.log10(x)) - 2
    return f'{float(f"{math.ceil(x / 10.0 ** e - 1e-9)}e{e}"):g}'


def _cells(hull: np.ndarray, s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The origin and the cells per axis of the grid of spacing ``s`` over ``hull`` with a two-voxel margin."""
    origin = (np.floor(hull[:, 0] / s) - 2) * s
    return origin, (np.floor((hull[:, 1] - origin) / s) + 3).astype(np.int64)


def grid(hull: np.ndarray, spacing: np.ndarray, delta: float | None = None) -> tuple[np.ndarray, np.ndarray,
                                                                                  np.ndarray]:
    """The dyadic spacing, the origin and the cells per axis of a grid of (rounded down) ``spacing`` over ``hull``
    (d, 2) with a two-voxel margin; :class:`InputError` beyond :data:`MAX_VOXELS` cells, naming the delta ``delta``
    [SI] of the covering it serves and about the finest one allowed (the cells go as 1 / delta^d)."""
    s = np.array([dyadic(float(v)) for v in spacing])
    origin, shape = _cells(hull, s)
    cells = float(np.prod(shape.astype(float)))
    if cells > MAX_VOXELS:
        # the spacing is a power of two: the fewest doublings whose grid fits (each divides the cells by about 2^d,
        # the margins and the floors aside: the estimate named a delta refused again)
        doublings = math.ceil(math.log2(cells / MAX_VOXELS) / len(shape))
        while doublings < 1100 and float(np.prod(_cells(hull, s * 2.0 ** doublings)[1].astype(float))) > MAX_VOXELS:
            doublings += 1
        coarser = 0.0 if delta is None else delta * float(np.max(s * 2.0 ** doublings / np.asarray(spacing)))
        finer = '' if delta is None else f' (delta {delta:g} here; {_up(coarser)} or more)'
        raise InputError(f'a voxel grid of {shape.tolist()} cells exceeds the limit of {MAX_VOXELS} voxels; '
                         f'allowed: a coarser delta{finer}')
    return s, origin, shape


@dataclass(frozen=True)
class VoxelSet:
    """Marked voxels of a grid: ``origin`` (d,), ``spacing`` (d,) powers of two, ``table`` the summed counts
    (shape + 1 per axis, a leading zero plane on each axis)."""

    origin: np.ndarray
    spacing: np.ndarray
    table: np.ndarray

    @property
    def shape(self) -> tuple[int, ...]:
        return tuple(int(n) - 1 for n in self.table.shape)

    @classmethod
    def from_boxes(cls, boxes: np.ndarray, spacing: np.ndarray, hull: np.ndarray | None = None,
                   delta: float | None = None) -> VoxelSet:
        """Voxelise (n, d, 2) boxes on a grid of (rounded down to dyadic) ``spacing`` over ``hull`` (d, 2)
        (default: the boxes' hull, :func:`hull_of`; the parts of boxes beyond it are left out); ``delta``: the
        covering's, for the message of a grid beyond :data:`MAX_VOXELS` (:func:`grid`)."""
        d = boxes.shape[1]
        s, origin, shape = grid(hull_of(boxes) if hull is None else hull, spacing, delta)
        marks = np.zeros(tuple(int(n) + 1 for n in shape), dtype=np.int32)
        if len(boxes):
            i0 = np.floor((boxes[:, :, 0] - origin) / s).astype(np.int64) - 1
            i1 = np.floor((boxes[:, :, 1] - origin) / s).astype(np.int64) + 1
            i0 = np.clip(i0, 0, shape - 1)
            i1 = np.clip(i1, -1, shape - 1)
            ok = np.all(i1 >= i0, axis=1)
            i0, i1 = i0[ok], i1[ok] + 1
            # inclusion-exclusion at the 2^d corners of each index range, then prefix sums: box counts
            for corner in itertools.product((0, 1), repeat=d):
                idx = tuple(np.where(c, i1[:, k], i0[:, k]) for k, c in enumerate(corner))
                np.add.at(marks, idx, -1 if sum(corner) % 2 else 1)
            for k in range(d):
                np.cumsum(marks, axis=k, out=marks)
        occupied = (marks[tuple(slice(0, int(n)) for n in shape)] > 0).astype(np.int32)
        table = np.zeros(tuple(int(n) + 1 for n in shape), dtype=np.int32)
        table[tuple(slice(1, None) for _ in range(d))] = occupied
        for k in range(d):
            np.cumsum(table, axis=k, out=table)
        return cls(origin, s, table)

    def _range(self, lo: np.ndarray, hi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Voxel index ranges [i0, i1) meeting the boxes, widened by one voxel on each side (not clipped)."""
        with np.errstate(invalid='ignore', over='ignore'):
            i0 = np.floor((lo - self.origin) / self.spacing) - 1
            i1 = np.floor((hi - self.origin) / self.spacing) + 2
        i0 = np.where(np.isfinite(i0), i0, -1e18)
        i1 = np.where(np.isfinite(i1), i1, 1e18)
        return i0, i1

    def _count(self, i0: np.ndarray, i1: np.ndarray) -> np.ndarray:
        d = len(self.shape)
        total = np.zeros(i0.shape[0], dtype=np.int64)
        for corner in itertools.product((0, 1), repeat=d):
            idx = tuple(np.where(c, i1[:, k], i0[:, k]).astype(np.int64) for k, c in enumerate(corner))
            sign = -1 if (d - sum(corner)) % 2 else 1
            total += sign * self.table[idx]
        return total

    def any(self, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
        """(M,) mask: some marked voxel meets the box ``[lo, hi]`` (M, d) (or lies within a voxel of it)."""
        i0, i1 = self._range(lo, hi)
        top = np.array(self.shape)
        i0 = np.clip(i0, 0, top)
        i1 = np.clip(i1, 0, top)
        empty = np.any(i1 <= i0, axis=1)
        return np.asarray(~empty & (self._count(i0, np.maximum(i1, i0)) > 0))
