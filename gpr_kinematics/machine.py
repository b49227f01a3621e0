"""The geometry of one GPR as the kernels use it: rods, zero offsets, rod directions, platform joints, stiffness.

Built once per :class:`~gpr_kinematics.config.GprConfig` (:meth:`MachineGeometry.of`, cached), it is the only
place the kernels take their constants from. Frames (``docs/core.md``): rod ``k`` has its base point
``B_k = (x_k, y_k, 0)`` in ``gpr_base`` (where ``q_k + o_k = 0``), the unit direction ``u_k`` (the base z axis
for parallel rods) and the zero offset ``o_k``; its joint centre is

    P_k = B_k + (q_k + o_k) u_k                                            (Bratovanov & Sotirov, eq. (1))

The platform joints are ``p_k = (x, y)`` in the platform plane of ``gpr_platform`` (the plane through the three
joint centres defines the frame's xy-plane). The nominal machine has ``B_k = p_k = R (cos theta_k,
sin theta_k)``, ``u_k = e3`` and ``o_k = 0``.

>>> geo = MachineGeometry.of(GprConfig())
>>> [round(v, 6) for v in geo.bx], geo.uz, geo.offsets
([0.093218, -0.046609, -0.046609], (1.0, 1.0, 1.0), (0.0, 0.0, 0.0))
"""
from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from .config import GprConfig, Point2, Triple, nominal_points

Array = NDArray[np.float64]
Floats3 = tuple[float, float, float]


def _floats(values: Sequence[float]) -> Floats3:
    return (float(values[0]), float(values[1]), float(values[2]))


@dataclass(frozen=True)
class MachineGeometry:
    """Constants of one machine, as float triples (one value per rod or joint, index ``k = 0, 1, 2``).

    Attributes:
        bx, by: base points ``B_k`` [m]. ux, uy, uz: unit rod directions ``u_k``. offsets: ``o_k`` [m].
        px, py: platform joints ``p_k`` [m]; rho, cos, sin: their polar form ``p_k = rho_k (cos_k, sin_k)``
            (the joint's radial direction ``e_r = (cos_k, sin_k)``, tangential ``e_t = (-sin_k, cos_k)``).
        kappa: ``k_t / k_r`` per joint. naive_inv: inverse of the rows ``(1, p_kx, p_ky)`` (the naive model).
    """

    bx: Floats3
    by: Floats3
    ux: Floats3
    uy: Floats3
    uz: Floats3
    offsets: Floats3
    px: Floats3
    py: Floats3
    rho: Floats3
    cos: Floats3
    sin: Floats3
    kappa: Floats3
    naive_inv: tuple[Floats3, Floats3, Floats3]

    @property
    def upright(self) -> bool:
        """Every rod parallel to the base z axis and no zero offset (the nominal rods)."""
        return self.uz == (1.0, 1.0, 1.0) and self.offsets == (0.0, 0.0, 0.0)

    @staticmethod
    def of(config: GprConfig) -> MachineGeometry:
        """The geometry of ``config`` (cached per config)."""
        geo: MachineGeometry | None = config.derived.get('machine')
        if geo is None:
            geo = config.derived['machine'] = _build(config)
        return geo

    def joint_centres(self, q: Sequence[Any]) -> tuple[list[Any], list[Any], list[Any]]:
        """``P_k = B_k + (q_k + o_k) u_k`` as component lists ``(x, y, z)`` over ``k`` (floats or arrays)."""
        if self.upright:  # exactly parallel rods without offsets: P_k = (B_k, q_k), no arithmetic
            return list(self.bx), list(self.by), list(q)
        (o0, o1, o2), (ux0, ux1, ux2), (uy0, uy1, uy2), (uz0, uz1, uz2) = self.offsets, self.ux, self.uy, self.uz
        s0, s1, s2 = q[0] + o0, q[1] + o1, q[2] + o2
        return ([self.bx[0] + s0 * ux0, self.bx[1] + s1 * ux1, self.bx[2] + s2 * ux2],
                [self.by[0] + s0 * uy0, self.by[1] + s1 * uy1, self.by[2] + s2 * uy2],
                [s0 * uz0, s1 * uz1, s2 * uz2])

    def base_points(self, Q: Array) -> Array:
        """Joint centres ``P_k`` in ``gpr_base`` for rod lengths ``Q (N, 3)``, shape ``(N, 3, 3)`` [m]."""
        Q = np.asarray(Q, dtype=float)
        x, y, z = self.joint_centres([Q[..., k] for k in range(3)])
        return np.stack([np.stack(np.broadcast_arrays(*c, Q[..., 0])[:3], -1) for c in (x, y, z)], axis=-1)

    def platform_points(self) -> Array:
        """Platform joints ``p_k`` as ``(3, 3)`` points of ``gpr_platform`` (z = 0) [m]."""
        return np.array([[self.px[k], self.py[k], 0.0] for k in range(3)])


def _polar(points: tuple[Point2, Point2, Point2], cfg: GprConfig, nominal: bool) -> tuple[Floats3, ...]:
    """``rho, cos, sin`` of points; for the nominal points straight from ``R`` and ``theta_k`` (no rounding
    through ``hypot``), so the nominal machine gives the same bits as the closed form."""
    if nominal:
        th = cfg.rod_azimuths
        return ((cfg.radius,) * 3, _floats([math.cos(t) for t in th]), _floats([math.sin(t) for t in th]))
    rho = [math.hypot(x, y) for x, y in points]
    return (_floats(rho), _floats([p[0] / r for p, r in zip(points, rho, strict=True)]),
            _floats([p[1] / r for p, r in zip(points, rho, strict=True)]))


def _build(cfg: GprConfig) -> MachineGeometry:
    nominal = nominal_points(cfg)
    base = cfg.rod_positions or nominal
    joints = cfg.platform_joints or nominal
    rho, cos, sin = _polar(joints, cfg, cfg.platform_joints is None)
    if cfg.platform_joints is None:
        px, py = _floats([r * c for r, c in zip(rho, cos, strict=True)]), _floats([r * s for r, s in
                                                                                   zip(rho, sin, strict=True)])
    else:
        px, py = _floats([p[0] for p in joints]), _floats([p[1] for p in joints])
    if cfg.rod_positions is None:
        th = cfg.rod_azimuths
        bx, by = _floats([cfg.radius * math.cos(t) for t in th]), _floats([cfg.radius * math.sin(t) for t in th])
    else:
        bx, by = _floats([p[0] for p in base]), _floats([p[1] for p in base])
    ux, uy = _floats([d[0] for d in cfg.rod_directions]), _floats([d[1] for d in cfg.rod_directions])
    uz = _floats([math.sqrt(1.0 - a * a - b * b) for a, b in cfg.rod_directions])
    A = np.array([[1.0, px[k], py[k]] for k in range(3)])
    inv = np.linalg.inv(A)
    naive_inv = (_floats(inv[0]), _floats(inv[1]), _floats(inv[2]))
    kappa: Triple = cfg.kappa
    return MachineGeometry(bx=bx, by=by, ux=ux, uy=uy, uz=uz, offsets=_floats(cfg.rod_offsets), px=px, py=py,
                           rho=rho, cos=cos, sin=sin, kappa=_floats(kappa), naive_inv=naive_inv)
