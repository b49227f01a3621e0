"""The naive model of the GPR: the platform of the old offline tool, rotated about its centre.

Bratovanov & Sotirov, Fig. 2 (``docs/references.md``): the old offline-programming tool commands the
platform as if it rotated by a pure tilt about its centre ``(0, 0, z)``. Its rod lengths follow from the
heights of the joint centres alone: with ``n' = Rot^T e3`` (``Rot`` the pure tilt, ``n = Rot e3`` the
platform normal, ``n' = (-n_x, -n_y, n_z)``),

    (q_k + o_k) u_kz = z + n' . p_k                                        (three linear equations)

On the nominal machine (``o_k = 0``, ``u_k = e3``, ``p_k = R (cos theta_k, sin theta_k)``) that is the paper's
``q_k = z + (Rot r_k)_z``. **On an imperfect machine** the naive model uses the machine's own platform
joints, zero offsets and rod directions for the joint heights, and ignores, like the old tool, every
horizontal effect (the centre shift of the virtual joints, the base positions, the rods' tilts): it is "the
old tool, given the calibrated geometry", so the centre shift it is compared with is the error of that tool.

>>> import math
>>> q = naive_inverse(0.5, math.radians(2.0), 0.0)  # 2 deg about x: rod 1 sits on the axis
>>> [round(v, 6) for v in q.tolist()]
[0.5, 0.502817, 0.497183]
"""
from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..errors import InputError, NoPoseError
from ..inputs.validation import bounded, empty_beside_one, rows_of
from .config import GprConfig, resolve_config
from .machine import MachineGeometry
from .ops import ARRAY, Ops, Value
from .rotations import AZIMUTH_UNDEFINED_BELOW, tilt_normal, tilt_of_normal, tilt_rotation
from .stroke import millimetres_within

Array = NDArray[np.float64]


#: What :func:`naive_state` returns: ``(z, h2, nx, ny, nz)``, floats for one pose or columns for a batch.
NaiveState = tuple[Value, Value, Value, Value, Value]


def naive_state(ops: Ops, geo: MachineGeometry, q: Sequence[Value]) -> NaiveState:
    """Naive model for rod lengths ``q``: solve ``(q_k + o_k) u_kz = z + n' . p_k`` for ``z`` and ``n'_x, n'_y``.

    Returns ``(z, h2, nx, ny, nz)`` with the platform normal ``n = (-n'_x, -n'_y, n'_z)`` and
    ``h2 = n'_x^2 + n'_y^2`` (>= 1: no orientation exists).
    """
    m = geo.naive_inv
    off, uz = geo.offsets, geo.uz
    h0, h1, h2_ = (q[0] + off[0]) * uz[0], (q[1] + off[1]) * uz[1], (q[2] + off[2]) * uz[2]
    z = m[0][0] * h0 + m[0][1] * h1 + m[0][2] * h2_
    px = m[1][0] * h0 + m[1][1] * h1 + m[1][2] * h2_
    py = m[2][0] * h0 + m[2][1] * h1 + m[2][2] * h2_
    h2 = px * px + py * py
    return z, h2, -px, -py, ops.sqrt(ops.maximum(1.0 - h2, 0.0))


def leaning(geo: MachineGeometry) -> bool:
    """Whether a rod leans (``u_kx`` or ``u_ky`` not 0): its joint centre travels sideways as it extends, which the
    naive model's heights leave out."""
    return any(bool(np.any(np.asarray(u) != 0.0)) for u in (*geo.ux, *geo.uy))


def centres_tilt(ops: Ops, geo: MachineGeometry, q: Sequence[Value]) -> Value:
    """The tilt [rad] of the plane through the joint centres ``P_k`` of rods ``q`` (eq. (1)), its normal oriented as
    the base joints' triangle: the naive tilt's stand-in on leaning rods, whose joints' sideways travel the naive
    model leaves out (2.125 deg naive against a real 1.995 at leans of 0.01-0.02 rad and a stroke of 0.34 m)."""
    (x0, x1, x2), (y0, y1, y2), (z0, z1, z2) = geo.joint_centres(q)
    ax, ay, az, bx, by, bz = x1 - x0, y1 - y0, z1 - z0, x2 - x0, y2 - y0, z2 - z0
    nz = ax * by - ay * bx
    (c0, c1, c2), (d0, d1, d2) = geo.bx, geo.by
    up = (c1 - c0) * (d2 - d0) - (d1 - d0) * (c2 - c0)
    return ops.atan2(ops.hypot(ay * bz - az * by, az * bx - ax * bz), ops.where(up < 0.0, -nz, nz))


def naive_rods(geo: MachineGeometry, h: Value, n: Sequence[Value], tool: Sequence[Value]) -> list[Value]:
    """Naive inverse for a platform point ``tool`` at height ``h`` and platform normal ``n``:
    ``q_k = (h + n' . (p_k - tool)) / u_kz - o_k`` with ``n' = (-n_x, -n_y, n_z)``."""
    return [(h - n[0] * (geo.px[k] - tool[0]) - n[1] * (geo.py[k] - tool[1]) - n[2] * tool[2]) / geo.uz[k]
            - geo.offsets[k] for k in range(3)]


def tilt_matrix_of_normal(ops: Ops, nx: Value, ny: Value, nz: Value) -> list[list[Value]]:
    """The pure tilt ``exp(t [a]x)`` taking ``e3`` to the unit normal ``n``, without trigonometry:
    ``sin t = |n_xy|``, ``cos t = n_z``, ``a = (-n_y, n_x) / |n_xy|`` (``a = e1`` when ``n = e3``)."""
    s = ops.hypot(nx, ny)
    flat = s < AZIMUTH_UNDEFINED_BELOW
    inv = 1.0 / ops.where(flat, 1.0, s)
    ax, ay = ops.where(flat, 1.0, -ny * inv), ops.where(flat, 0.0, nx * inv)
    v = 1.0 - nz
    vxy = v * ax * ay
    return [[nz + v * ax * ax, vxy, s * ay], [vxy, nz + v * ay * ay, -s * ax], [-s * ay, s * ax, nz]]


def naive_forward(q: ArrayLike, config: GprConfig | None = None) -> tuple[Array, Array]:
    """Naive pose of rod lengths ``q (N, 3)`` (paper Fig. 2): centre ``(0, 0, z)`` and tilt rotation.

    Returns ``(position (N, 3), rotation (N, 3, 3))``.
    """
    geo = MachineGeometry.of(resolve_config(config))
    Q = rows_of(q, 'q', 3)
    z, h2, nx, ny, nz = naive_state(ARRAY, geo, [Q[:, 0], Q[:, 1], Q[:, 2]])
    if np.any(h2 >= 1.0):
        i = int(np.argmax(h2))
        cfg = resolve_config(config)   # as forward kinematics says it, with the millimetres' hint of the rods
        mm = '; millimetres given as metres?' if all(millimetres_within(float(v), cfg) for v in Q[i]) else ''
        raise NoPoseError(f'q = {Q[i].tolist()} m imply no platform orientation (their differences are more than the '
                          f'joints\' spread can make at any tilt); allowed: rods whose differences a tilt makes{mm}')
    tilt, az = tilt_of_normal(ARRAY, nx, ny, nz)
    pos = np.zeros((Q.shape[0], 3))
    pos[:, 2] = z
    return pos, tilt_rotation(tilt, az)


def _naive_targets(height: ArrayLike, tilt: ArrayLike, azimuth: ArrayLike) -> list[Array]:
    """``height`` [m], ``tilt``, ``azimuth`` [rad] as finite float arrays broadcast together."""
    values = [bounded(v, n) for v, n in ((height, 'height'), (tilt, 'tilt'), (azimuth, 'azimuth'))]
    try:
        empty_beside_one((height, tilt, azimuth))
        return list(np.broadcast_arrays(*values))
    except ValueError:
        raise InputError('height, tilt and azimuth must broadcast together (one value or one per target), got shapes '
                         + ', '.join(str(v.shape) for v in values)) from None


def naive_pose(height: ArrayLike, tilt: ArrayLike, azimuth: ArrayLike) -> tuple[Array, Array]:
    """Naive commanded pose (paper Fig. 2): centre ``(0, 0, height)`` and ``tilt_rotation(tilt, azimuth)``.

    Raises:
        InputError: a value that is not a finite number within +-1e6 (m, rad), shapes that do not broadcast.
    """
    h, t, g = _naive_targets(height, tilt, azimuth)
    pos = np.stack([np.zeros_like(h), np.zeros_like(h), h], axis=-1)
    return pos, tilt_rotation(t, g)


def naive_inverse(height: ArrayLike, tilt: ArrayLike, azimuth: ArrayLike,
                  config: GprConfig | None = None) -> Array:
    """Rod lengths of the naive model for the platform origin at ``height`` [m] and the tilt, shape ``(..., 3)``: what
    an offline tool without virtual joints commands, so no limit is checked (the rods may leave the stroke).

    Raises:
        InputError: a value that is not a finite number within +-1e6 (m, rad), shapes that do not broadcast.
    """
    geo = MachineGeometry.of(resolve_config(config))
    h, t, g = _naive_targets(height, tilt, azimuth)
    n = tilt_normal(t, g)
    return np.stack(naive_rods(geo, h, [n[..., 0], n[..., 1], n[..., 2]], (0.0, 0.0, 0.0)), axis=-1)
