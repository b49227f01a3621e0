"""The geometry of one GPR as the kernels use it: rods, zero offsets, rod directions, platform joints, stiffness.

Built once per :class:`~gpr_kinematics.config.GprConfig` (:meth:`MachineGeometry.of`, cached), it is the only
place the kernels take their constants from. Frames (``docs/core.md``): rod ``k`` has its base point
``B_k = (x_k, y_k, 0)`` in ``gpr_base`` (where ``q_k + o_k = 0``), the unit direction ``u_k`` (the base z axis
for parallel rods) and the zero offset ``o_k``; its joint centre is

    P_k = B_k + (q_k + o_k) u_k                                            (Bratovanov & Sotirov, eq. (1))

The platform joints are ``p_k = (x, y)`` in the platform plane of ``gpr_platform`` (the plane through the three
joint centres defines the frame's xy-plane). The nominal machine has ``B_k = p_k = R (cos theta_k,
sin theta_k)``, ``u_k = e3`` and ``o_k = 0``.

The geometry as a vector of named scalars (for calibration: a config from a parameter vector and back) is
:data:`PARAMETERS`, :func:`parameter_vector` and :func:`config_with_parameters`; forward kinematics
(:func:`gpr_kinematics.kinematics.forward_batch`) is a pure function of the rod lengths and that config.

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
from numpy.typing import ArrayLike, NDArray

from .config import GprConfig, Point2, Triple, nominal_points
from .errors import InputError

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

    #: Every rod parallel to the base z axis and no zero offset (the nominal rods): ``P_k = (B_k, q_k)``.
    upright: bool

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
    offsets = _floats(cfg.rod_offsets)
    return MachineGeometry(bx=bx, by=by, ux=ux, uy=uy, uz=uz, offsets=offsets, px=px, py=py, rho=rho, cos=cos,
                           sin=sin, kappa=_floats(kappa), naive_inv=naive_inv,
                           upright=uz == (1.0, 1.0, 1.0) and offsets == (0.0, 0.0, 0.0))


@dataclass(frozen=True)
class GeometryParameter:
    """One scalar of the geometry file: its name in the parameter vector, the config key and position in it,
    the unit (``m``, ``rad`` for the small rod tilts, ``1`` for a ratio) and what it is."""

    name: str
    key: str
    rod: int
    component: int
    unit: str
    description: str


def _parameters() -> tuple[GeometryParameter, ...]:
    out = []
    for k in range(3):
        n = k + 1
        out += [GeometryParameter(f'rod{n}_x', 'rod_positions', k, 0, 'm', f'x of the base point B_{n} of rod {n}'),
                GeometryParameter(f'rod{n}_y', 'rod_positions', k, 1, 'm', f'y of the base point B_{n} of rod {n}'),
                GeometryParameter(f'rod{n}_offset', 'rod_offsets', k, 0, 'm', f'zero offset o_{n} of rod {n}'),
                GeometryParameter(f'rod{n}_ux', 'rod_directions', k, 0, 'rad',
                                  f'x component of the direction u_{n} of rod {n} (its tilt towards +x)'),
                GeometryParameter(f'rod{n}_uy', 'rod_directions', k, 1, 'rad',
                                  f'y component of the direction u_{n} of rod {n} (its tilt towards +y)'),
                GeometryParameter(f'joint{n}_x', 'platform_joints', k, 0, 'm', f'x of the platform joint p_{n}'),
                GeometryParameter(f'joint{n}_y', 'platform_joints', k, 1, 'm', f'y of the platform joint p_{n}'),
                GeometryParameter(f'kappa{n}', 'kappa', k, 0, '1',
                                  f'k_t / k_r of joint {n} (the compliant model only)')]
    return tuple(out)


#: The geometry as a parameter vector (24 scalars): per rod its base point, zero offset and direction, per joint
#: its platform position and stiffness ratio. Every other config value (stroke, limits, model) is not a parameter.
PARAMETERS: tuple[GeometryParameter, ...] = _parameters()
PARAMETER_NAMES: tuple[str, ...] = tuple(p.name for p in PARAMETERS)


def _values(config: GprConfig) -> dict[str, list[list[float]]]:
    """The per-rod keys of ``config`` as 3 x width lists (nominal points where the file gives none)."""
    nominal = nominal_points(config)
    return {'rod_positions': [list(p) for p in (config.rod_positions or nominal)],
            'platform_joints': [list(p) for p in (config.platform_joints or nominal)],
            'rod_offsets': [[v] for v in config.rod_offsets],
            'rod_directions': [list(d) for d in config.rod_directions],
            'kappa': [[v] for v in config.kappa]}


def _indices(names: Sequence[str] | None) -> list[GeometryParameter]:
    if names is None:
        return list(PARAMETERS)
    by_name = {p.name: p for p in PARAMETERS}
    unknown = [n for n in names if n not in by_name]
    if unknown:
        raise InputError(f'unknown geometry parameter(s) {", ".join(map(str, unknown))}; allowed: '
                         + ', '.join(PARAMETER_NAMES))
    return [by_name[n] for n in names]


def parameter_vector(config: GprConfig, names: Sequence[str] | None = None) -> Array:
    """The values of the geometry parameters ``names`` (default: all of :data:`PARAMETER_NAMES`) of ``config``
    [SI]. ``parameter_vector(GprConfig())`` is the nominal machine's.

    >>> v = parameter_vector(GprConfig(), ['rod1_x', 'rod2_offset', 'kappa3'])
    >>> v.tolist()
    [0.093218, 0.0, 1000.0]
    """
    values = _values(config)
    return np.array([values[p.key][p.rod][p.component] for p in _indices(names)])


def config_with_parameters(config: GprConfig, vector: ArrayLike, names: Sequence[str] | None = None) -> GprConfig:
    """A copy of ``config`` whose geometry parameters ``names`` (default: all) take the values ``vector``
    [SI], validated like a geometry file (:class:`~gpr_kinematics.errors.ConfigError` names the key, the value
    and the allowed range). The inverse of :func:`parameter_vector`:

    >>> cfg = config_with_parameters(GprConfig(), [2e-5, 1e-4], ['rod2_offset', 'rod3_ux'])
    >>> cfg.rod_offsets, cfg.rod_directions[2]
    ((0.0, 2e-05, 0.0), (0.0001, 0.0))
    >>> parameter_vector(cfg, ['rod2_offset', 'rod3_ux']).tolist()
    [2e-05, 0.0001]
    """
    params = _indices(names)
    v = np.asarray(vector, dtype=float).ravel()
    if v.shape != (len(params),):
        raise InputError(f'a parameter vector of {len(params)} values is needed for {len(params)} names; '
                         f'got shape {np.shape(vector)}')
    values = _values(config)
    for p, x in zip(params, v.tolist(), strict=True):
        values[p.key][p.rod][p.component] = x
    changes: dict[str, Any] = {key: rows for key, rows in values.items() if key in {p.key for p in params}}
    for key in ('rod_offsets', 'kappa'):
        if key in changes:
            changes[key] = [row[0] for row in changes[key]]
    return config.replace(**changes)
