"""Forward and inverse kinematics of the GPR under a virtual-joint model, and the naive model.

Seed: Bratovanov & Sotirov (``gpr-virtual-joints-bratovanov-sotirov.txt``) §IV-VI; meanings in
design.md §4. Frames (design.md §2): base frame ``gpr_base`` with rod ``k`` at
``B_k = R (cos theta_k, sin theta_k, 0)`` and joint centre ``P_k = B_k + q_k e3`` (paper eq. 1, first
row); platform frame ``gpr_platform`` with origin at the centre of the nominal joint triangle.

Forward kinematics ``q -> pose``:

1. side lengths ``L_ij = |P_j - P_i|`` (``= sqrt(3 R^2 + (q_j - q_i)^2)`` for rods 120 deg apart);
2. virtual joints ``X`` from the closure ``F(X) = 0`` (:mod:`gpr_kinematics.virtual_joints`);
3. the rigid transform ``(Rot, t)`` with ``P_k = Rot r_k(X) + t``: it exists because the side lengths
   now agree; it is built from the orthonormal frames of the two congruent triangles and its fit
   residual ``max |Rot r_k + t - P_k|`` is reported (~1e-16 m);
4. the naive pose (paper Fig. 2, the old offline tool): the platform rotated by a pure tilt about its
   centre ``(0, 0, z)``, with ``q_k = z + (Rot_n r_k^nom)_z``; the *centre shift* is ``t - (0, 0, z)``.

Inverse kinematics ``(height, tilt, azimuth) -> q`` solves ``FK(q) = target`` for the height of a
point of the platform (its origin by default) and the platform normal, by a Newton iteration whose
Jacobian is that of the naive model (exact up to the virtual-joint corrections, so it converges in
3-4 steps from the naive inverse).
"""
from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, fields
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ._ops import ARRAY, SCALAR, Ops
from .config import GprConfig, load_config
from .errors import ConvergenceError, InputError, LimitError
from .geometry import AZIMUTH_UNDEFINED_BELOW, tilt_normal, tilt_of_normal, tilt_rotation
from .virtual_joints import (
    EDGES,
    VirtualJointModel,
    make_model,
    solve_virtual_joints,
    solve_virtual_joints_scalar,
)

Array = NDArray[np.float64]

#: Margin [rad] by which a solved tilt may exceed ``tilt_limit`` (rounding of targets at the limit).
TILT_LIMIT_SLACK = 1e-9
#: Margin [m] by which a rod length may leave the stroke (rounding).
STROKE_SLACK = 1e-12
#: Inverse kinematics stops when height [m] and normal errors are both below this.
IK_TOLERANCE = 1e-14

_DEFAULT_CONFIG: GprConfig | None = None


def resolve_config(config: GprConfig | None) -> GprConfig:
    """``config``, or the package default (loaded once)."""
    global _DEFAULT_CONFIG
    if config is not None:
        return config
    if _DEFAULT_CONFIG is None:
        _DEFAULT_CONFIG = load_config()
    return _DEFAULT_CONFIG


@dataclass(frozen=True)
class ForwardResult:
    """Forward kinematics of one configuration (SI units; quaternions x, y, z, w).

    Attributes:
        q: rod lengths [m]. model: virtual-joint model name.
        virtual_joints: ``X`` [m and rad], named by ``virtual_joint_names``.
        side_lengths: ``L12, L23, L31`` [m].
        position: platform origin in ``gpr_base`` [m]; rotation, quaternion: platform orientation.
        tilt: angle between platform normal and base z [rad], >= 0; tilt_azimuth: direction of the tilt
            axis ``e3 x n`` in (-pi, pi] [rad]; twist: remaining rotation about the normal [rad].
        nominal_position, nominal_rotation, nominal_quaternion: naive model for the same ``q``.
        centre_shift: ``position - nominal_position`` [m].
        joint_displacement: distance of each joint centre from its nominal place on the platform [m].
        within_budget: every ``joint_displacement`` <= the imperfection budget.
        iterations: Newton steps; residual: closure side-length error [m]; fit_residual: rigid fit [m].
    """

    q: Array
    model: str
    virtual_joints: Array
    virtual_joint_names: tuple[str, ...]
    side_lengths: Array
    position: Array
    rotation: Array
    quaternion: Array
    tilt: float
    tilt_azimuth: float
    twist: float
    nominal_position: Array
    nominal_rotation: Array
    nominal_quaternion: Array
    centre_shift: Array
    joint_displacement: Array
    within_budget: bool
    iterations: int
    residual: float
    fit_residual: float

    @property
    def normal(self) -> Array:
        """Platform normal ``Rot e3`` in ``gpr_base``."""
        return self.rotation[:, 2]


@dataclass(frozen=True)
class ForwardBatch:
    """Forward kinematics of ``N`` configurations: the fields of :class:`ForwardResult` with a leading
    axis of length ``N`` (``model`` and ``virtual_joint_names`` are shared)."""

    q: Array
    model: str
    virtual_joints: Array
    virtual_joint_names: tuple[str, ...]
    side_lengths: Array
    position: Array
    rotation: Array
    quaternion: Array
    tilt: Array
    tilt_azimuth: Array
    twist: Array
    nominal_position: Array
    nominal_rotation: Array
    nominal_quaternion: Array
    centre_shift: Array
    joint_displacement: Array
    within_budget: NDArray[np.bool_]
    iterations: NDArray[np.int64]
    residual: Array
    fit_residual: Array

    def __len__(self) -> int:
        return self.q.shape[0]

    def __getitem__(self, i: int) -> ForwardResult:
        out = {name: getattr(self, name) for name in _SHARED_FIELDS}
        for name in _ROW_FIELDS:
            out[name] = getattr(self, name)[i]
        for name in _SCALAR_FIELDS:
            out[name] = getattr(self, name)[i].item()
        return ForwardResult(**out)

    @property
    def normal(self) -> Array:
        """Platform normals ``(N, 3)``."""
        return self.rotation[:, :, 2]


#: Fields of :class:`ForwardBatch` shared by all rows, with one array row per sample, and one scalar per sample.
_SHARED_FIELDS = ('model', 'virtual_joint_names')
_SCALAR_FIELDS = ('tilt', 'tilt_azimuth', 'twist', 'within_budget', 'iterations', 'residual', 'fit_residual')
_ROW_FIELDS = tuple(f.name for f in fields(ForwardResult) if f.name not in _SHARED_FIELDS + _SCALAR_FIELDS)


def _as_rows(values: ArrayLike, name: str, width: int) -> Array:
    try:
        a = np.asarray(values, dtype=float)
    except (TypeError, ValueError):
        raise InputError(f'{name} must be numbers, got {values!r}') from None
    if a.ndim == 1:
        a = a[None, :]
    if a.ndim != 2 or a.shape[1] != width:
        raise InputError(f'{name} must have {width} values per sample (shape (N, {width})), '
                         f'got shape {np.shape(values)}')
    bad = ~np.isfinite(a)
    if bad.any():
        i, j = np.argwhere(bad)[0]
        # Rods are numbered 1..3 in messages, like the paper's q1, q2, q3.
        label = f'{name}{j + 1}' if name == 'q' else f'{name}[{j}]'
        where = f' (sample {i})' if a.shape[0] > 1 else ''
        raise InputError(f'{label} = {a[i, j]}{where} is not a finite number')
    return a


def _check_stroke(Q: Array, config: GprConfig, what: str = 'q') -> None:
    lo, hi = config.stroke_min - STROKE_SLACK, config.stroke_max + STROKE_SLACK
    bad = (Q < lo) | (Q > hi)
    if bad.any():
        i, k = np.argwhere(bad)[0]
        where = f' (sample {i})' if Q.shape[0] > 1 else ''
        raise LimitError(f'{what}{k + 1} = {Q[i, k]:.9g} m{where} is outside the stroke '
                         f'[{config.stroke_min:g}, {config.stroke_max:g}] m')


def base_points(Q: Array, config: GprConfig) -> Array:
    """Joint centres ``P_k = B_k + q_k e3`` in ``gpr_base``, ``(N, 3, 3)`` (paper eq. 1)."""
    th = np.asarray(config.rod_azimuths)
    P = np.empty(Q.shape + (3,))
    P[..., 0] = config.radius * np.cos(th)
    P[..., 1] = config.radius * np.sin(th)
    P[..., 2] = Q
    return P


@dataclass(frozen=True)
class _Geometry:
    """Constants of one configuration used by the kernels (floats, not arrays)."""

    bx: tuple[float, float, float]
    by: tuple[float, float, float]
    naive_inv: tuple[tuple[float, ...], ...]  # inverse of rows (1, R cos th_k, R sin th_k)

    @staticmethod
    def of(config: GprConfig) -> _Geometry:
        th = config.rod_azimuths
        bx = tuple(config.radius * math.cos(t) for t in th)
        by = tuple(config.radius * math.sin(t) for t in th)
        A = np.array([[1.0, bx[k], by[k]] for k in range(3)])
        inv = tuple(tuple(float(v) for v in row) for row in np.linalg.inv(A))
        return _Geometry(bx, by, inv)


_GEOMETRY_CACHE: dict[GprConfig, _Geometry] = {}


def _geometry(config: GprConfig) -> _Geometry:
    geo = _GEOMETRY_CACHE.get(config)
    if geo is None:
        geo = _GEOMETRY_CACHE[config] = _Geometry.of(config)
    return geo


def _side_lengths(ops: Ops, geo: _Geometry, q: Sequence[Any]) -> list[Any]:
    """``L_ij = |P_j - P_i|`` with ``P_k = (B_k, q_k)`` (paper eq. 1)."""
    out = []
    for a, b in EDGES:
        dx, dy, dz = geo.bx[b] - geo.bx[a], geo.by[b] - geo.by[a], q[b] - q[a]
        out.append(ops.sqrt(dx * dx + dy * dy + dz * dz))
    return out


def _tilt_matrix_of_normal(ops: Ops, nx: Any, ny: Any, nz: Any) -> list[list[Any]]:
    """The pure tilt ``exp(t [a]x)`` taking ``e3`` to the unit normal ``n``, without trigonometry:
    ``sin t = |n_xy|``, ``cos t = n_z``, ``a = (-n_y, n_x) / |n_xy|`` (``a = e1`` when ``n = e3``)."""
    s = ops.hypot(nx, ny)
    flat = s < AZIMUTH_UNDEFINED_BELOW
    inv = 1.0 / ops.where(flat, 1.0, s)
    ax, ay = ops.where(flat, 1.0, -ny * inv), ops.where(flat, 0.0, nx * inv)
    v = 1.0 - nz
    vxy = v * ax * ay
    return [[nz + v * ax * ax, vxy, s * ay], [vxy, nz + v * ay * ay, -s * ax], [-s * ay, s * ax, nz]]


def _naive(ops: Ops, geo: _Geometry, q: Sequence[Any]) -> tuple[Any, ...]:
    """Naive model for rod lengths ``q``: solve ``q_k = z + n' . r_k^nom`` for ``z`` and ``n'_x, n'_y``
    (``n' = Rot^T e3``); the platform normal is ``n = (-n'_x, -n'_y, n'_z)``.

    Returns ``(z, h2, nx, ny, nz)`` with ``h2 = n'_x^2 + n'_y^2`` (>= 1: no orientation exists).
    """
    m = geo.naive_inv
    z = m[0][0] * q[0] + m[0][1] * q[1] + m[0][2] * q[2]
    px = m[1][0] * q[0] + m[1][1] * q[1] + m[1][2] * q[2]
    py = m[2][0] * q[0] + m[2][1] * q[1] + m[2][2] * q[2]
    h2 = px * px + py * py
    return z, h2, -px, -py, ops.sqrt(ops.maximum(1.0 - h2, 0.0))


def naive_forward(q: ArrayLike, config: GprConfig | None = None) -> tuple[Array, Array]:
    """Naive pose of rod lengths ``q (N, 3)`` (paper Fig. 2): centre ``(0, 0, z)`` and tilt rotation.

    Solves ``q_k = z + (Rot r_k^nom)_z`` (three linear equations in ``z`` and ``Rot^T e3``).
    Returns ``(position (N, 3), rotation (N, 3, 3))``.
    """
    cfg = resolve_config(config)
    Q = _as_rows(q, 'q', 3)
    z, h2, nx, ny, nz = _naive(ARRAY, _geometry(cfg), [Q[:, 0], Q[:, 1], Q[:, 2]])
    if (h2 >= 1.0).any():
        i = int(np.argmax(h2))
        raise LimitError(f'q = {Q[i].tolist()} m implies no platform orientation')
    tilt, az = tilt_of_normal(ARRAY, nx, ny, nz)
    pos = np.zeros((Q.shape[0], 3))
    pos[:, 2] = z
    return pos, tilt_rotation(tilt, az)


def naive_pose(height: ArrayLike, tilt: ArrayLike, azimuth: ArrayLike) -> tuple[Array, Array]:
    """Naive commanded pose (paper Fig. 2): centre ``(0, 0, height)`` and ``tilt_rotation(tilt, azimuth)``."""
    h, t, g = np.broadcast_arrays(*(np.asarray(v, dtype=float) for v in (height, tilt, azimuth)))
    pos = np.stack([np.zeros_like(h), np.zeros_like(h), h], axis=-1)
    return pos, tilt_rotation(t, g)


def _naive_q(geo: _Geometry, h: Any, n: Sequence[Any], tool: Sequence[Any]) -> list[Any]:
    """Naive inverse for a platform point ``tool`` at height ``h`` and platform normal ``n``:
    ``q_k = h + n' . (r_k^nom - tool)``, ``n' = Rot^T e3 = (-n_x, -n_y, n_z)`` (design.md §4)."""
    return [h - n[0] * (geo.bx[k] - tool[0]) - n[1] * (geo.by[k] - tool[1]) - n[2] * tool[2]
            for k in range(3)]


def naive_inverse(height: ArrayLike, tilt: ArrayLike, azimuth: ArrayLike,
                  config: GprConfig | None = None) -> Array:
    """Rod lengths of the naive model, ``q_k = z + (Rot r_k)_z`` (design.md §4), shape ``(..., 3)``."""
    cfg = resolve_config(config)
    h, t, g = np.broadcast_arrays(*(np.asarray(v, dtype=float) for v in (height, tilt, azimuth)))
    n = tilt_normal(t, g)
    return np.stack(_naive_q(_geometry(cfg), h, [n[..., 0], n[..., 1], n[..., 2]], (0.0, 0.0, 0.0)), axis=-1)


def _pose(ops: Ops, geo: _Geometry, q: Sequence[Any], comps: tuple[list, ...]) -> dict:
    """Platform pose from rod lengths ``q`` and the :func:`joint_components` of the solved ``X``.

    The rigid transform ``P_k = Rot r_k(X) + t`` is ``Rot = F_P F_r^T`` with ``F`` the orthonormal frame
    (edge 1-2 direction, in-plane normal, triangle normal) of each triangle; ``t`` maps the centroid of
    the ``r_k`` to that of the ``P_k``. The quaternion uses the trace formula (rotations of the platform
    are far below 90 deg, so ``w >= 0.7``). Written with scalar locals: it runs on floats or arrays.
    """
    sqrt = ops.sqrt
    (rx0, rx1, rx2), (ry0, ry1, ry2) = comps[0], comps[1]
    bx0, bx1, bx2 = geo.bx
    by0, by1, by2 = geo.by
    q0, q1, q2 = q[0], q[1], q[2]
    # Base triangle P_k = (bx_k, by_k, q_k): frame (e1, e2, e3).
    ux, uy, uz = bx1 - bx0, by1 - by0, q1 - q0
    vx, vy, vz = bx2 - bx0, by2 - by0, q2 - q0
    inv = 1.0 / sqrt(ux * ux + uy * uy + uz * uz)
    e1x, e1y, e1z = ux * inv, uy * inv, uz * inv
    cx, cy, cz = uy * vz - uz * vy, uz * vx - ux * vz, ux * vy - uy * vx
    inv = 1.0 / sqrt(cx * cx + cy * cy + cz * cz)
    e3x, e3y, e3z = cx * inv, cy * inv, cz * inv
    e2x, e2y, e2z = e3y * e1z - e3z * e1y, e3z * e1x - e3x * e1z, e3x * e1y - e3y * e1x
    # Platform triangle r_k (z = 0): frame (f, sigma (-f_y, f_x, 0), (0, 0, sigma)).
    wx, wy = rx1 - rx0, ry1 - ry0
    inv = 1.0 / sqrt(wx * wx + wy * wy)
    fx, fy = wx * inv, wy * inv
    sg = ops.where(wx * (ry2 - ry0) - wy * (rx2 - rx0) >= 0.0, 1.0, -1.0)
    sfx, sfy = sg * fx, sg * fy
    r00, r01, r02 = e1x * fx - e2x * sfy, e1x * fy + e2x * sfx, sg * e3x
    r10, r11, r12 = e1y * fx - e2y * sfy, e1y * fy + e2y * sfx, sg * e3y
    r20, r21, r22 = e1z * fx - e2z * sfy, e1z * fy + e2z * sfx, sg * e3z
    rcx, rcy = (rx0 + rx1 + rx2) / 3.0, (ry0 + ry1 + ry2) / 3.0
    tx = (bx0 + bx1 + bx2) / 3.0 - (r00 * rcx + r01 * rcy)
    ty = (by0 + by1 + by2) / 3.0 - (r10 * rcx + r11 * rcy)
    tz = (q0 + q1 + q2) / 3.0 - (r20 * rcx + r21 * rcy)
    fit = None
    for rxk, ryk, bxk, byk, qk in ((rx0, ry0, bx0, by0, q0), (rx1, ry1, bx1, by1, q1),
                                   (rx2, ry2, bx2, by2, q2)):
        dx = r00 * rxk + r01 * ryk + tx - bxk
        dy = r10 * rxk + r11 * ryk + ty - byk
        dz = r20 * rxk + r21 * ryk + tz - qk
        dk = sqrt(dx * dx + dy * dy + dz * dz)
        fit = dk if fit is None else ops.maximum(fit, dk)
    tilt, az = tilt_of_normal(ops, r02, r12, r22)
    T = _tilt_matrix_of_normal(ops, r02, r12, r22)
    m00 = T[0][0] * r00 + T[1][0] * r10 + T[2][0] * r20
    m10 = T[0][1] * r00 + T[1][1] * r10 + T[2][1] * r20
    twist = ops.atan2(m10, m00)
    w4 = 2.0 * sqrt(1.0 + r00 + r11 + r22)
    qx, qy, qz, qw = (r21 - r12) / w4, (r02 - r20) / w4, (r10 - r01) / w4, 0.25 * w4
    inv = 1.0 / sqrt(qx * qx + qy * qy + qz * qz + qw * qw)
    # Naive model and centre shift.
    z0, _, nnx, nny, nnz = _naive(ops, geo, q)
    NR = _tilt_matrix_of_normal(ops, nnx, nny, nnz)
    # quaternion of a pure tilt: (a sin(t/2), 0, cos(t/2)); cos(t/2) = sqrt((1 + n_z) / 2)
    cw = sqrt(0.5 * (1.0 + nnz))
    half = 0.5 / cw
    nquat = [-(NR[1][2]) * half, NR[0][2] * half, 0.0 * cw, cw]
    d0x, d0y, d1x, d1y, d2x, d2y = rx0 - bx0, ry0 - by0, rx1 - bx1, ry1 - by1, rx2 - bx2, ry2 - by2
    return dict(position=[tx, ty, tz], rotation=[[r00, r01, r02], [r10, r11, r12], [r20, r21, r22]],
                quaternion=[qx * inv, qy * inv, qz * inv, qw * inv], tilt=tilt, tilt_azimuth=az,
                twist=twist, nominal_z=z0, nominal_rotation=NR, nominal_quaternion=nquat,
                joint_displacement=[sqrt(d0x * d0x + d0y * d0y), sqrt(d1x * d1x + d1y * d1y),
                                    sqrt(d2x * d2x + d2y * d2y)],
                fit_residual=fit)


def _check_naive_tilt(Q: Array, config: GprConfig) -> None:
    """Refuse ``q`` whose naive tilt exceeds the limit by 5 % (the real tilt differs by < 0.1 %;
    the margin keeps Newton inside its basin; the exact check follows the solve)."""
    z, h2, nx, ny, nz = _naive(ARRAY, _geometry(config), [Q[:, 0], Q[:, 1], Q[:, 2]])
    n_tilt = np.arctan2(np.sqrt(np.minimum(h2, 1.0)), nz)
    too = (h2 >= 1.0) | (n_tilt > 1.05 * config.tilt_limit)
    if too.any():
        i = int(np.argmax(np.where(too, n_tilt, -1.0)))
        raise LimitError(f'q = {Q[i].tolist()} m tilts the platform by about {np.degrees(n_tilt[i]):.4g} '
                         f'deg, beyond the tilt limit {np.degrees(config.tilt_limit):.4g} deg')


def _tilt_limit_error(q: Any, tilt: float, config: GprConfig) -> LimitError:
    return LimitError(f'q = {list(map(float, q))} m tilts the platform by {np.degrees(tilt):.6g} deg, '
                      f'beyond the tilt limit {np.degrees(config.tilt_limit):.6g} deg')


def _forward(Q: Array, cfg: GprConfig, vjm: VirtualJointModel, check_limits: bool) -> ForwardBatch:
    if check_limits:
        _check_stroke(Q, cfg)
        _check_naive_tilt(Q, cfg)
    geo = _geometry(cfg)
    qc = [np.ascontiguousarray(Q[:, k]) for k in range(3)]
    L = _side_lengths(ARRAY, geo, qc)
    sol = solve_virtual_joints(np.stack(L, axis=-1), vjm, cfg)
    p = _pose(ARRAY, geo, qc, sol.components)
    tilt = p['tilt']
    if check_limits and (tilt > cfg.tilt_limit + TILT_LIMIT_SLACK).any():
        i = int(np.argmax(tilt))
        raise _tilt_limit_error(Q[i], float(tilt[i]), cfg)
    n = Q.shape[0]
    position = np.stack(p['position'], axis=-1)
    rotation = np.array(p['rotation']).transpose(2, 0, 1)
    nominal_position = np.zeros((n, 3))
    nominal_position[:, 2] = p['nominal_z']
    disp = np.stack(p['joint_displacement'], axis=-1)
    return ForwardBatch(
        q=Q, model=vjm.name, virtual_joints=sol.X, virtual_joint_names=vjm.names,
        side_lengths=np.stack(L, axis=-1), position=position, rotation=rotation,
        quaternion=np.stack(p['quaternion'], axis=-1), tilt=tilt, tilt_azimuth=p['tilt_azimuth'],
        twist=p['twist'], nominal_position=nominal_position,
        nominal_rotation=np.array([[np.broadcast_to(c, (n,)) for c in row] for row in p['nominal_rotation']])
        .transpose(2, 0, 1),
        nominal_quaternion=np.stack([np.broadcast_to(c, (n,)) for c in p['nominal_quaternion']], axis=-1),
        centre_shift=position - nominal_position, joint_displacement=disp,
        within_budget=np.all(disp <= cfg.imperfection_budget, axis=-1),
        iterations=sol.iterations, residual=sol.residual, fit_residual=p['fit_residual'])


def _forward_scalar(qc: list[float], cfg: GprConfig, vjm: VirtualJointModel,
                    check_limits: bool) -> ForwardResult:
    """:func:`_forward` of one configuration in float arithmetic (same kernels)."""
    geo = _geometry(cfg)
    if check_limits:
        lo, hi = cfg.stroke_min - STROKE_SLACK, cfg.stroke_max + STROKE_SLACK
        if not all(lo <= v <= hi for v in qc):
            _check_stroke(np.array([qc]), cfg)
        _, h2, _, _, nz = _naive(SCALAR, geo, qc)
        if h2 >= 1.0 or math.atan2(math.sqrt(h2), nz) > 1.05 * cfg.tilt_limit:
            _check_naive_tilt(np.array([qc]), cfg)
    L = _side_lengths(SCALAR, geo, qc)
    X, _, iterations, residual, comps = solve_virtual_joints_scalar(L, vjm, cfg)
    p = _pose(SCALAR, geo, qc, comps)
    if check_limits and p['tilt'] > cfg.tilt_limit + TILT_LIMIT_SLACK:
        raise _tilt_limit_error(qc, p['tilt'], cfg)
    position = np.array(p['position'])
    nominal_position = np.array([0.0, 0.0, p['nominal_z']])
    disp = np.array(p['joint_displacement'])
    return ForwardResult(
        q=np.array(qc), model=vjm.name, virtual_joints=np.array(X), virtual_joint_names=vjm.names,
        side_lengths=np.array(L), position=position, rotation=np.array(p['rotation']),
        quaternion=np.array(p['quaternion']), tilt=p['tilt'], tilt_azimuth=p['tilt_azimuth'],
        twist=p['twist'], nominal_position=nominal_position, nominal_rotation=np.array(p['nominal_rotation']),
        nominal_quaternion=np.array(p['nominal_quaternion']), centre_shift=position - nominal_position,
        joint_displacement=disp, within_budget=max(p['joint_displacement']) <= cfg.imperfection_budget,
        iterations=iterations, residual=residual, fit_residual=p['fit_residual'])


def forward_batch(Q: ArrayLike, config: GprConfig | None = None, model: str | None = None,
                  check_limits: bool = True) -> ForwardBatch:
    """Forward kinematics of rod lengths ``Q (N, 3)`` [m], vectorised over ``N``.

    Raises:
        InputError: wrong shape, NaN or infinity; unknown model.
        LimitError: a rod outside the stroke, or a tilt beyond ``tilt_limit`` (if ``check_limits``).
        ConvergenceError: the closure did not converge (cannot happen inside the limits).
    """
    cfg = resolve_config(config)
    return _forward(_as_rows(Q, 'q', 3), cfg, make_model(cfg, model), check_limits)


def forward(q: ArrayLike, config: GprConfig | None = None, model: str | None = None,
            check_limits: bool = True) -> ForwardResult:
    """Forward kinematics of one configuration ``q = (q1, q2, q3)`` [m]; see :func:`forward_batch`.

    Evaluated in float arithmetic by the same kernels as the batch (no numpy overhead per step);
    the two agree to rounding (~1e-16).
    """
    qc = _three_floats(q, 'q')
    cfg = resolve_config(config)
    return _forward_scalar(qc, cfg, make_model(cfg, model), check_limits)


def _three_floats(values: ArrayLike, name: str) -> list[float]:
    """Three finite floats from a sequence, with the messages of :func:`_as_rows`."""
    if isinstance(values, (list, tuple)) and len(values) == 3:
        try:
            out = [float(v) for v in values]
        except (TypeError, ValueError):
            out = None
        if out is not None and all(math.isfinite(v) for v in out):
            return out
    Q = _as_rows(values, name, 3)
    if Q.shape[0] != 1:
        raise InputError(f'{name} must be 3 values, got shape {np.shape(values)}')
    return [float(v) for v in Q[0]]


@dataclass(frozen=True)
class InverseResult:
    """Inverse kinematics of one target: rod lengths ``q`` [m], the pose they give, Newton steps."""

    q: Array
    achieved: ForwardResult
    iterations: int


@dataclass(frozen=True)
class InverseBatch:
    """Inverse kinematics of ``N`` targets: ``q (N, 3)``, ``achieved`` and ``iterations (N,)``."""

    q: Array
    achieved: ForwardBatch
    iterations: NDArray[np.int64]

    def __len__(self) -> int:
        return self.q.shape[0]

    def __getitem__(self, i: int) -> InverseResult:
        return InverseResult(q=self.q[i], achieved=self.achieved[i], iterations=int(self.iterations[i]))


def _as_column(values: ArrayLike, name: str) -> Array:
    try:
        a = np.atleast_1d(np.asarray(values, dtype=float))
    except (TypeError, ValueError):
        raise InputError(f'{name} must be a number or an array of numbers, got {values!r}') from None
    if a.ndim != 1:
        raise InputError(f'{name} must be a scalar or a 1-D array, got shape {a.shape}')
    bad = ~np.isfinite(a)
    if bad.any():
        i = int(np.argmax(bad))
        raise InputError(f'{name}[{i}] = {a[i]} is not a finite number')
    return a


def _ik_state(ops: Ops, p: dict, tool: Sequence[Any]) -> tuple[Any, list[Any]]:
    """Height of the tool point and platform normal of a pose from :func:`_pose`."""
    R = p['rotation']
    h = p['position'][2] + R[2][0] * tool[0] + R[2][1] * tool[1] + R[2][2] * tool[2]
    return h, [R[0][2], R[1][2], R[2][2]]


def _ik_error(ops: Ops, h: Any, n: Sequence[Any], h_target: Any, n_target: Sequence[Any]) -> Any:
    err = ops.fabs(h - h_target)
    for i in range(3):
        err = ops.maximum(err, ops.fabs(n[i] - n_target[i]))
    return err


def _ik_failed(config: GprConfig, err: float, sample: int | None) -> ConvergenceError:
    where = '' if sample is None else f' for target {sample}'
    return ConvergenceError(f'inverse kinematics did not converge in {config.max_iterations} iterations'
                            f'{where}: error {err:.3e}')


def _check_tilt_targets(t: Array, config: GprConfig) -> None:
    over = np.abs(t) > config.tilt_limit + TILT_LIMIT_SLACK
    if over.any():
        i = int(np.argmax(np.abs(t)))
        raise LimitError(f'tilt = {t[i]:.9g} rad ({np.degrees(t[i]):.6g} deg) is beyond the tilt limit '
                         f'{config.tilt_limit:.9g} rad ({np.degrees(config.tilt_limit):.6g} deg)')


def inverse_batch(height: ArrayLike, tilt: ArrayLike, azimuth: ArrayLike, config: GprConfig | None = None,
                  model: str | None = None, tool: ArrayLike = (0.0, 0.0, 0.0)) -> InverseBatch:
    """Rod lengths that give platform tilts and heights under the virtual-joint model, vectorised.

    Args:
        height: z of the tool point (the platform origin by default) in ``gpr_base`` [m].
        tilt: tilt angle [rad]; a negative tilt is a tilt about ``azimuth + pi``.
        azimuth: direction of the tilt axis [rad]. The three broadcast to ``(N,)``.
        tool: point of the platform, in ``gpr_platform`` [m], whose height is prescribed: shape ``(3,)``
            (one point for every target) or ``(N, 3)`` (one point per target, e.g. per station).

    The target is the height ``h*`` and the platform normal ``n* = tilt_rotation(tilt, azimuth) e3``.
    With ``N(h, n)`` the naive inverse (:func:`naive_inverse`), the iteration is
    ``q <- q + N(h*, n*) - N(h(q), n(q))`` from ``q = N(h*, n*)``, where ``h(q), n(q)`` come from the
    virtual-joint forward kinematics: Newton's method with the naive model's Jacobian, which differs
    from the exact one only by the virtual-joint corrections (~1e-4), so each step gains ~4 digits.

    Raises:
        InputError: NaN, infinity, shapes that do not broadcast (``tool`` rows included).
        LimitError: ``|tilt| > tilt_limit``, or the answer leaves the stroke.
        ConvergenceError: no convergence within ``max_iterations`` (not seen inside the limits).
    """
    cfg = resolve_config(config)
    vjm = make_model(cfg, model)
    cols = [_as_column(v, n) for v, n in ((height, 'height'), (tilt, 'tilt'), (azimuth, 'azimuth'))]
    tools = _as_rows(tool, 'tool', 3)
    try:
        h, t, g, _ = (np.ascontiguousarray(c) for c in np.broadcast_arrays(*cols, tools[:, 0]))
    except ValueError:
        raise InputError('height, tilt, azimuth and tool must have the same length (one value or tool row per '
                         'target, or one for all), got ' + ', '.join(str(c.shape[0]) for c in cols + [tools])) from None
    # One platform point for all targets (floats), or one per target (columns of length N).
    tool_v: Sequence[Any] = (tuple(float(v) for v in tools[0]) if tools.shape[0] == 1 else
                             [np.ascontiguousarray(np.broadcast_to(tools[:, i], h.shape)) for i in range(3)])
    _check_tilt_targets(t, cfg)
    geo = _geometry(cfg)
    nt = tilt_normal(t, g)
    n_target = [np.ascontiguousarray(nt[:, i]) for i in range(3)]
    q_target = _naive_q(geo, h, n_target, tool_v)
    q = list(q_target)
    iterations = np.zeros(h.shape[0], dtype=np.int64)
    for step in range(cfg.max_iterations + 1):
        sol = solve_virtual_joints(np.stack(_side_lengths(ARRAY, geo, q), axis=-1), vjm, cfg)
        h_now, n_now = _ik_state(ARRAY, _pose(ARRAY, geo, q, sol.components), tool_v)
        err = _ik_error(ARRAY, h_now, n_now, h, n_target)
        active = ~(err <= IK_TOLERANCE)
        if not active.any():
            break
        if step == cfg.max_iterations:
            i = int(np.argmax(np.where(active, err, -1.0)))
            raise _ik_failed(cfg, float(err[i]), i)
        q_now = _naive_q(geo, h_now, n_now, tool_v)
        q = [np.where(active, q[k] + q_target[k] - q_now[k], q[k]) for k in range(3)]
        iterations += active
    Q = np.stack(q, axis=-1)
    _check_stroke(Q, cfg, what='q')
    return InverseBatch(q=Q, achieved=_forward(Q, cfg, vjm, check_limits=False), iterations=iterations)


def inverse(height: float, tilt: float, azimuth: float, config: GprConfig | None = None,
            model: str | None = None, tool: ArrayLike = (0.0, 0.0, 0.0)) -> InverseResult:
    """Inverse kinematics of one target (float arithmetic, same kernels); see :func:`inverse_batch`."""
    for v, n in ((height, 'height'), (tilt, 'tilt'), (azimuth, 'azimuth')):
        if np.ndim(v) != 0:
            raise InputError(f'{n} must be a single number, got shape {np.shape(v)}')
    h, t, g = (float(_as_column(v, n)[0]) for v, n in ((height, 'height'), (tilt, 'tilt'),
                                                       (azimuth, 'azimuth')))
    cfg = resolve_config(config)
    vjm = make_model(cfg, model)
    tool_v = tuple(_three_floats(tool, 'tool'))
    _check_tilt_targets(np.array([t]), cfg)
    geo = _geometry(cfg)
    s = math.sin(t)
    n_target = [s * math.sin(g), -s * math.cos(g), math.cos(t)]
    q_target = _naive_q(geo, h, n_target, tool_v)
    q = list(q_target)
    for step in range(cfg.max_iterations + 1):
        comps = solve_virtual_joints_scalar(_side_lengths(SCALAR, geo, q), vjm, cfg)[4]
        h_now, n_now = _ik_state(SCALAR, _pose(SCALAR, geo, q, comps), tool_v)
        err = _ik_error(SCALAR, h_now, n_now, h, n_target)
        if err <= IK_TOLERANCE:
            break
        if step == cfg.max_iterations:
            raise _ik_failed(cfg, err, None)
        q_now = _naive_q(geo, h_now, n_now, tool_v)
        q = [q[k] + q_target[k] - q_now[k] for k in range(3)]
    _check_stroke(np.array([q]), cfg, what='q')
    return InverseResult(q=np.array(q), achieved=_forward_scalar(q, cfg, vjm, check_limits=False),
                         iterations=step)
