"""Numeric views of decoded message columns (:class:`~gpr_kinematics.bags.cdr.Columns`) for the checks.

Field names are the dotted paths of :mod:`.cdr` (``pose.position.x``, ``markers[1].points[5].z``); a field
that is a message (``pose.position``) is the stack of its numeric sub-fields in definition order.
"""
from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..core.messages import NS_PER_S
from ..core.rotations import quaternion_multiply, wrap_angle
from .cdr import Columns


def field_matrix(c: Columns, name: str, width: int | None = None) -> NDArray[np.float64]:
    """Field ``name`` as a float matrix ``(n, k)``: a numeric column (ragged sequences padded with NaN to
    ``width`` or the longest), or the stack of a message field's numeric sub-fields."""
    if name in c.numeric:
        return matrix(c.numeric[name], width)
    parts = [k for k in c.numeric if k.startswith(name + '.')]
    if not parts:
        raise KeyError(f'no numeric field {name!r} in the decoded messages')
    return np.stack([np.asarray(c.numeric[k], dtype=float) for k in parts], axis=-1)


def matrix(col: NDArray[Any], width: int | None = None) -> NDArray[np.float64]:
    """A numeric column as a float matrix (ragged object columns padded with NaN)."""
    if col.dtype != object:
        return np.asarray(col, dtype=float).reshape(len(col), -1)
    w = width if width is not None else max((len(r) for r in col), default=0)
    out = np.full((len(col), w), np.nan)
    for i, r in enumerate(col):
        r = np.asarray(r, dtype=float)[:w]
        out[i, :r.size] = r
    return out


def row_sizes(col: NDArray[Any]) -> NDArray[np.int64]:
    """Each row's number of values of a numeric column (a ragged object column's own lengths; :func:`matrix` pads
    the shorter rows with NaN)."""
    if col.dtype != object:
        return np.full(len(col), np.asarray(col, dtype=float).reshape(len(col), -1).shape[1], dtype=np.int64)
    return np.array([len(r) for r in col], dtype=np.int64)


def vec(c: Columns, prefix: str, keys: str = 'xyz') -> NDArray[np.float64]:
    """``(n, len(keys))`` of the fields ``prefix.k`` (a Point/Vector3: xyz; a Quaternion: xyzw)."""
    return np.stack([np.asarray(c[f'{prefix}.{k}'], dtype=float) for k in keys], axis=-1)


def stamp_ns(c: Columns, prefix: str = 'header.stamp') -> NDArray[np.int64]:
    """Header stamps [ns since the epoch]."""
    return (np.asarray(c[f'{prefix}.sec'], dtype=np.int64) * NS_PER_S
            + np.asarray(c[f'{prefix}.nanosec'], dtype=np.int64))


def quaternion_angle(a: NDArray[np.float64], b: NDArray[np.float64]) -> NDArray[np.float64]:
    """Rotation angle [rad] between unit quaternions ``a`` and ``b`` (x, y, z, w; ``(N, 4)``), computed as
    ``2 atan2(|v|, |w|)`` of ``conj(a) b`` (accurate for small angles).

    >>> turn = np.array([[0, 0, np.sin(0.05), np.cos(0.05)]])  # 0.1 rad about z
    >>> round(float(quaternion_angle(np.array([[0, 0, 0, 1.0]]), turn)[0]), 12)
    0.1
    """
    x, y, z, w = np.moveaxis(quaternion_multiply(a * np.array([-1.0, -1.0, -1.0, 1.0]), b), -1, 0)
    out: NDArray[np.float64] = 2.0 * np.arctan2(np.sqrt(x * x + y * y + z * z), np.abs(w))
    return out


def wrapped(a: NDArray[np.float64]) -> NDArray[np.float64]:
    """``|a|`` wrapped to [0, pi] (angle differences)."""
    out: NDArray[np.float64] = np.abs(wrap_angle(a))
    return out
