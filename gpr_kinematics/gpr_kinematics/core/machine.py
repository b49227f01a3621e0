"""The geometry of one GPR as the kernels use it: rods, zero offsets, rod directions, platform joints, stiffness.

Built once per :class:`~gpr_kinematics.core.config.GprConfig` (:meth:`MachineGeometry.of`, cached), it is the only
place the kernels take their constants from. Frames (``docs/core.md``): rod ``k`` has its base point
``B_k = (x_k, y_k, 0)`` in ``gpr_base`` (where ``q_k + o_k = 0``), the unit direction ``u_k`` (the base z axis
for parallel rods) and the zero offset ``o_k``; its joint centre is

    P_k = B_k + (q_k + o_k) u_k                                            (Bratovanov & Sotirov, eq. (1))

The platform joints are ``p_k = (x, y)`` in the platform plane of ``gpr_platform`` (the plane through the three
joint centres defines the frame's xy-plane). The nominal machine has ``B_k = p_k = R (cos theta_k,
sin theta_k)``, ``u_k = e3`` and ``o_k = 0``.

The geometry as a vector of named scalars (for calibration: a config from a parameter vector and back) is
:data:`~gpr_kinematics.core.parameters.PARAMETERS`, :func:`parameter_vector` and :func:`config_with_parameters`;
forward kinematics (:func:`gpr_kinematics.core.forward_batch`) is a pure function of the rod lengths and that
config.

**One machine per row.** :meth:`MachineGeometry.per_row` builds the geometry of ``N`` machines at once (``N``
parameter vectors, checked like a geometry file, row by row): every constant is then an array ``(N,)`` instead
of a float, and the same kernels evaluate sample ``i`` of a batch on machine ``i``
(``forward_batch(Q, config, parameters=...)``): one call for the perturbed machines of a Jacobian or the
samples of a Monte Carlo budget.

>>> geo = MachineGeometry.of(GprConfig())
>>> [round(v, 6) for v in geo.bx], geo.uz, geo.offsets
([0.093218, -0.046609, -0.046609], (1.0, 1.0, 1.0), (0.0, 0.0, 0.0))
"""
from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, replace
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..errors import InputError, brief
from ..inputs.validation import float_array
from .config import (
    _TRIPLE_RANGES,
    FLOAT_RANGES,
    MAX_SIDE_MISMATCH,
    MIN_TRIANGLE_ANGLE,
    GprConfig,
    Point2,
    Triple,
    nominal_points,
)
from .ops import Value
from .parameters import PARAMETER_NAMES, PARAMETERS, GeometryParameter

Array = NDArray[np.float64]
Floats3 = tuple[float, float, float]
#: One value per rod or joint: floats (one machine) or arrays ``(N,)`` (one machine per row).
Values3 = tuple[Value, Value, Value]
#: Largest joint displacement [m] (:meth:`MachineGeometry.displaced`): the largest imperfection budget a geometry takes.
MAX_PLAY = FLOAT_RANGES['imperfection_budget'][1]


def _floats(values: Sequence[float]) -> Floats3:
    return (float(values[0]), float(values[1]), float(values[2]))


class GeometryRowError(InputError):
    """A row of a per-row geometry (:meth:`MachineGeometry.per_row`) that no geometry file could hold: ``row`` its
    index, ``reason`` what is wrong and what is allowed (a caller that drew the rows names where they came from)."""

    def __init__(self, row: int, reason: str) -> None:
        super().__init__(f'per-row geometry, row {row}: {reason}')
        self.row, self.reason = row, reason

    def __reduce__(self) -> tuple[type[GeometryRowError], tuple[int, str]]:
        return GeometryRowError, (self.row, self.reason)


@dataclass(frozen=True)
class MachineGeometry:
    """Constants of one machine, as float triples (one value per rod or joint, index ``k = 0, 1, 2``), or of
    ``rows`` machines, as triples of arrays ``(rows,)`` (:meth:`per_row`).

    Attributes:
        bx, by: base points ``B_k`` [m]. ux, uy, uz: unit rod directions ``u_k``. offsets: ``o_k`` [m].
        px, py: platform joints ``p_k`` [m]; rho, cos, sin: their polar form ``p_k = rho_k (cos_k, sin_k)``
            (the joint's radial direction ``e_r = (cos_k, sin_k)``, tangential ``e_t = (-sin_k, cos_k)``).
        kappa: ``k_t / k_r`` per joint. naive_inv: inverse of the rows ``(1, p_kx, p_ky)`` (the naive model).
    """

    bx: Values3
    by: Values3
    ux: Values3
    uy: Values3
    uz: Values3
    offsets: Values3
    px: Values3
    py: Values3
    rho: Values3
    cos: Values3
    sin: Values3
    kappa: Values3
    naive_inv: tuple[Values3, Values3, Values3]

    #: Every rod parallel to the base z axis, no zero offset, no play (the nominal rods): ``P_k = (B_k, q_k)``.
    upright: bool
    #: 0: one machine (floats); ``N``: one machine per row (arrays ``(N,)``).
    rows: int = 0
    #: Displacements ``(d_x, d_y, d_z)`` of the joint centres ``P_k`` in ``gpr_base`` [m] (a joint's play; arrays
    #: ``(N,)`` per joint and axis), or ``None`` (:meth:`displaced`).
    play: tuple[Values3, Values3, Values3] | None = None

    @staticmethod
    def of(config: GprConfig) -> MachineGeometry:
        """The geometry of ``config`` (cached per config)."""
        geo: MachineGeometry | None = config.derived.get('machine')
        if geo is None:
            geo = config.derived['machine'] = _build(config)
        return geo

    @staticmethod
    def per_row(config: GprConfig, values: ArrayLike, names: Sequence[str] | None = None) -> MachineGeometry:
        """``N`` machines: ``config``'s geometry with the parameters ``names`` (default all of
        :data:`~gpr_kinematics.core.parameters.PARAMETER_NAMES`) set to the rows of ``values (N, len(names))`` [SI].

        Each row is checked like a geometry file (the ranges of the keys, the triangles' cross checks);
        :class:`~gpr_kinematics.errors.InputError` names the row, the parameter and what is allowed. A parameter
        not in ``names`` keeps ``config``'s value, a float the kernels broadcast over the rows.

        >>> geo = MachineGeometry.per_row(GprConfig(), [[1e-5], [2e-5]], ['rod2_offset'])
        >>> geo.rows, geo.offsets[1].tolist(), geo.offsets[0]
        (2, [1e-05, 2e-05], 0.0)
        """
        return _build_rows(config, values, names)

    def repeat(self, k: int) -> MachineGeometry:
        """The machines of :meth:`per_row`, each repeated for ``k`` consecutive samples (``rows * k`` rows):
        ``M`` machines at the same ``k`` configurations are built and checked once per machine."""
        def rep(t: Values3) -> Values3:  # (a float shared by every row stays a float)
            a, b, c = (np.repeat(v, k) if np.ndim(v) else v for v in t)
            return a, b, c

        if not self.rows or self.play is not None:
            raise InputError('repeat() needs a per-row geometry (MachineGeometry.per_row) without play')
        n0, n1, n2 = self.naive_inv
        return MachineGeometry(
            bx=rep(self.bx), by=rep(self.by), ux=rep(self.ux), uy=rep(self.uy), uz=rep(self.uz),
            offsets=rep(self.offsets), px=rep(self.px), py=rep(self.py), rho=rep(self.rho), cos=rep(self.cos),
            sin=rep(self.sin), kappa=rep(self.kappa), naive_inv=(rep(n0), rep(n1), rep(n2)), upright=self.upright,
            rows=self.rows * k)

    def displaced(self, d: ArrayLike) -> MachineGeometry:
        """This geometry with the joint centre ``P_k`` of sample ``i`` displaced by ``d[i, k] (N, 3, 3)`` in
        ``gpr_base`` [m]: the play of a spherical joint (the platform joints stay at their places ``p_k``; the naive
        model, which knows only the rods' heights, ignores it). ``N`` must match a per-row geometry's rows."""
        D = float_array(d, 'joint displacements', 'numbers [m], shape (N, 3, 3)')
        if D.ndim != 3 or D.shape[1:] != (3, 3) or (self.rows and D.shape[0] != self.rows):
            raise InputError(f'joint displacements must have shape (N, 3, 3) (sample, joint, x y z) with N = '
                             f'{self.rows or "the samples"}; got shape {np.shape(d)}')
        if not np.all(np.abs(D) <= MAX_PLAY):   # NaN too: a metre of it failed the closure, 1 cm blamed the rods
            i, k, a = np.argwhere(~(np.abs(D) <= MAX_PLAY))[0]
            raise InputError(f'joint displacement [{i}, {k}, {a}] = {brief(float(D[i, k, a]))} m; allowed: finite, '
                             f'within +-{MAX_PLAY:g} m (the play of a spherical joint, at most the largest '
                             'imperfection budget)')
        play = tuple((D[:, 0, a], D[:, 1, a], D[:, 2, a]) for a in range(3))
        return replace(self, upright=False, play=play)  # type: ignore[arg-type]

    def joint_centres(self, q: Sequence[Value]) -> tuple[list[Value], list[Value], list[Value]]:
        """``P_k = B_k + (q_k + o_k) u_k`` as component lists ``(x, y, z)`` over ``k`` (floats or arrays)."""
        if self.upright:  # exactly parallel rods without offsets: P_k = (B_k, q_k), no arithmetic
            return list(self.bx), list(self.by), list(q)
        (o0, o1, o2), (ux0, ux1, ux2), (uy0, uy1, uy2), (uz0, uz1, uz2) = self.offsets, self.ux, self.uy, self.uz
        s0, s1, s2 = q[0] + o0, q[1] + o1, q[2] + o2
        x = [self.bx[0] + s0 * ux0, self.bx[1] + s1 * ux1, self.bx[2] + s2 * ux2]
        y = [self.by[0] + s0 * uy0, self.by[1] + s1 * uy1, self.by[2] + s2 * uy2]
        z = [s0 * uz0, s1 * uz1, s2 * uz2]
        if self.play is not None:
            (dx, dy, dz) = self.play
            x, y, z = [x[k] + dx[k] for k in range(3)], [y[k] + dy[k] for k in range(3)], [z[k] + dz[k] for k in
                                                                                           range(3)]
        return x, y, z

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
    naive_inv = _naive_inverse(px, py)
    kappa: Triple = cfg.kappa
    offsets = _floats(cfg.rod_offsets)
    return MachineGeometry(bx=bx, by=by, ux=ux, uy=uy, uz=uz, offsets=offsets, px=px, py=py, rho=rho, cos=cos,
                           sin=sin, kappa=_floats(kappa), naive_inv=naive_inv,
                           upright=uz == (1.0, 1.0, 1.0) and offsets == (0.0, 0.0, 0.0))


def slope_gain(config: GprConfig) -> float:
    """``max |d slope| / ||dq||`` [1/m] of the plane through the joint centres: the largest singular value of the slope
    rows of the inverse of the rows ``(1, x_k, y_k)`` of the platform joints and of the centres ``B_k + (q_k + o_k)
    u_k`` at the stroke's 8 corners (leaning rods: first order in the lean); ``sqrt(2/3) / R`` on the drawing."""
    geo = MachineGeometry.of(config)
    if geo.upright:
        triangles = [(np.asarray(geo.bx, dtype=float), np.asarray(geo.by, dtype=float))]
    else:
        ends = (config.stroke_min, config.stroke_max)
        P = geo.base_points(np.array([[a, b, c] for a in ends for b in ends for c in ends]))   # (8, rod, xyz)
        triangles = [(P[i, :, 0], P[i, :, 1]) for i in range(P.shape[0])]
    gains = []
    for x, y in (*triangles, (np.asarray(geo.px, dtype=float), np.asarray(geo.py, dtype=float))):
        rows = np.column_stack([np.ones(3), x, y])
        gains.append(float(np.linalg.svd(np.linalg.inv(rows)[1:], compute_uv=False)[0]))
    return max(gains)


def _naive_inverse(px: Sequence[Value], py: Sequence[Value]) -> tuple[Values3, Values3, Values3]:
    """Inverse of the matrix of rows ``r_k = (1, p_kx, p_ky)`` (the naive model's), as rows of entries (floats, or
    arrays for one machine per row): its columns are ``c_k = r_{k+1} x r_{k+2}`` over ``det = r_0 . c_0``."""
    c = [(px[(k + 1) % 3] * py[(k + 2) % 3] - px[(k + 2) % 3] * py[(k + 1) % 3], py[(k + 1) % 3] - py[(k + 2) % 3],
          px[(k + 2) % 3] - px[(k + 1) % 3]) for k in range(3)]
    inv_det = 1.0 / (c[0][0] + px[0] * c[0][1] + py[0] * c[0][2])
    rows = [tuple(c[k][i] * inv_det for k in range(3)) for i in range(3)]
    return (rows[0][0], rows[0][1], rows[0][2]), (rows[1][0], rows[1][1], rows[1][2]), (rows[2][0], rows[2][1],
                                                                                           rows[2][2])


def _build_rows(cfg: GprConfig, values: ArrayLike, names: Sequence[str] | None) -> MachineGeometry:
    """:meth:`MachineGeometry.per_row`: the fields of :func:`_build` as arrays over the rows (a parameter that is
    not given keeps ``cfg``'s value, a float, which the kernels broadcast)."""
    params = _indices(names)
    V = float_array(values, 'per-row geometry values', 'numbers [SI]')
    if V.ndim != 2 or V.shape[1] != len(params) or V.shape[0] == 0:
        raise InputError(f'per-row geometry needs values of shape (N, {len(params)}), N >= 1, one column per '
                         f'parameter ({", ".join(p.name for p in params[:4])}{", ..." if len(params) > 4 else ""}); '
                         f'got shape {np.shape(values)}')
    col: dict[str, Value] = dict(zip(PARAMETER_NAMES, parameter_vector(cfg).tolist(), strict=True))
    col.update(zip((p.name for p in params), np.ascontiguousarray(V.T), strict=True))
    _check_rows(V, params, col)

    def per_rod(pattern: str) -> Values3:
        return col[pattern.format(1)], col[pattern.format(2)], col[pattern.format(3)]

    ux, uy, px, py = per_rod('rod{}_ux'), per_rod('rod{}_uy'), per_rod('joint{}_x'), per_rod('joint{}_y')
    uz = tuple(np.sqrt(1.0 - a * a - b * b) for a, b in zip(ux, uy, strict=True))
    rho = tuple(np.hypot(x, y) for x, y in zip(px, py, strict=True))
    offsets = per_rod('rod{}_offset')
    return MachineGeometry(
        bx=per_rod('rod{}_x'), by=per_rod('rod{}_y'), ux=ux, uy=uy, uz=(uz[0], uz[1], uz[2]), offsets=offsets,
        px=px, py=py, rho=(rho[0], rho[1], rho[2]), cos=(px[0] / rho[0], px[1] / rho[1], px[2] / rho[2]),
        sin=(py[0] / rho[0], py[1] / rho[1], py[2] / rho[2]), kappa=per_rod('kappa{}'),
        naive_inv=_naive_inverse(px, py),
        upright=bool(all(np.all(u == 1.0) for u in uz) and all(np.all(o == 0.0) for o in offsets)),
        rows=V.shape[0])


def _triangles(x: Sequence[Array], y: Sequence[Array]) -> tuple[Array, Array, Array]:
    """Signed areas ``(N,)``, side lengths ``(N, 3)`` (1-2, 2-3, 3-1) and smallest angles ``(N,)`` of triangles
    with corners ``(x[k], y[k])`` (arrays ``(N,)``)."""
    ex = [x[1] - x[0], x[2] - x[1], x[0] - x[2]]
    ey = [y[1] - y[0], y[2] - y[1], y[0] - y[2]]
    area = 0.5 * (ey[0] * ex[2] - ex[0] * ey[2])
    twice = 2.0 * np.abs(area)
    # the angle at corner k, between the sides k-1 and k: |sin| from the area, cos from the dot product
    angle = np.minimum(np.minimum(np.arctan2(twice, -(ex[0] * ex[2] + ey[0] * ey[2])),
                                  np.arctan2(twice, -(ex[1] * ex[0] + ey[1] * ey[0]))),
                       np.arctan2(twice, -(ex[2] * ex[1] + ey[2] * ey[1])))
    return area, np.stack([np.hypot(a, b) for a, b in zip(ex, ey, strict=True)], axis=-1), angle


def _check_rows(V: Array, params: Sequence[GeometryParameter], col: dict[str, Value]) -> None:
    """The checks of a geometry file (:mod:`gpr_kinematics.core.config`), row by row: the values ``V (N, len(params))``
    of ``params`` in their keys' ranges, then both triangles (``col``: every parameter's column or float)."""
    def fail(i: int, what: str) -> GeometryRowError:
        return GeometryRowError(i, what)

    j_all = [PARAMETER_NAMES.index(p.name) for p in params]
    lo, hi = _RANGES[0][j_all], _RANGES[1][j_all]
    out = ~((lo <= V) & (hi >= V))  # NaN too
    if out.any():
        i, j = np.argwhere(out)[0]
        p = params[j]
        what = ('is not a finite number' if not math.isfinite(V[i, j]) else
                f'is outside [{lo[j]:g}, {hi[j]:g}] ({p.key}: {_TRIPLE_RANGES[p.key][3]})')
        raise fail(int(i), f'{p.name} = {float(V[i, j])!r} {what}')
    if not {p.key for p in params} & {'rod_positions', 'platform_joints'}:
        return                                    # the triangles are the config's, already checked
    n = V.shape[0]
    tri = {}
    for key, stem in (('rod_positions', 'rod{}'), ('platform_joints', 'joint{}')):
        tri[key] = _triangles([np.broadcast_to(col[stem.format(k) + '_x'], (n,)) for k in (1, 2, 3)],
                              [np.broadcast_to(col[stem.format(k) + '_y'], (n,)) for k in (1, 2, 3)])
        # points at one place have no angle (arctan2(0, -0) read pi and passed): an angle of 0, as the config says
        tri[key] = (tri[key][0], tri[key][1], np.where(np.min(tri[key][1], axis=-1) > 0.0, tri[key][2], 0.0))
        flat = np.flatnonzero(tri[key][2] < MIN_TRIANGLE_ANGLE)
        if flat.size:
            raise fail(int(flat[0]), f'the triangle of {key} has an angle of '
                                     f'{math.degrees(tri[key][2][flat[0]]):.3g} deg; allowed: every angle >= '
                                     f'{math.degrees(MIN_TRIANGLE_ANGLE):g} deg')
    flipped = np.flatnonzero((tri['rod_positions'][0] > 0) != (tri['platform_joints'][0] > 0))
    if flipped.size:
        raise fail(int(flipped[0]), 'rod_positions and platform_joints list the rods in opposite orders')
    sb, sp = tri['rod_positions'][1], tri['platform_joints'][1]
    off = np.argwhere(np.abs(sp - sb) > MAX_SIDE_MISMATCH * sb)
    if off.size:
        i, e = off[0]
        raise fail(int(i), f'side {("1-2", "2-3", "3-1")[e]} of the joint triangle is {sp[i, e]:.6g} m, the rods '
                           f'are {sb[i, e]:.6g} m apart; allowed: within {MAX_SIDE_MISMATCH:.0%} of each other')


#: Lowest and highest value of each parameter (the ranges of its key in a geometry file).
_RANGES = (np.array([_TRIPLE_RANGES[p.key][1] for p in PARAMETERS]),
           np.array([_TRIPLE_RANGES[p.key][2] for p in PARAMETERS]))


def parameter_range(name: str) -> tuple[float, float, str] | None:
    """The lowest and highest value of the geometry parameter ``name`` and its key's rule as a geometry file states
    it (``None``: not a geometry parameter), e.g. ``rod1_ux``: ``(-0.05, 0.05, 'a list of 3 pairs ...')``."""
    if name not in PARAMETER_NAMES:
        return None
    j = PARAMETER_NAMES.index(name)
    return float(_RANGES[0][j]), float(_RANGES[1][j]), _TRIPLE_RANGES[PARAMETERS[j].key][3]


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
    try:   # a 0-d array is an Iterable that cannot be iterated
        given = list(names) if isinstance(names, Iterable) and not isinstance(names, str) else None
    except TypeError:
        given = None
    if given is None or not all(isinstance(n, str) for n in given):
        raise InputError(f'geometry parameter names must be a list of names, got {brief(names)}; allowed: '
                         + ', '.join(PARAMETER_NAMES))
    unknown = [n for n in given if n not in by_name]
    if unknown:
        raise InputError(f'unknown geometry parameter(s) {", ".join(map(str, unknown))}; allowed: '
                         + ', '.join(PARAMETER_NAMES))
    twice = sorted({n for n in given if given.count(n) > 1})
    if twice:   # the last column won without a word
        raise InputError(f'geometry parameter(s) {", ".join(twice)} named twice; allowed: each name once')
    return [by_name[n] for n in given]


def parameter_vector(config: GprConfig, names: Sequence[str] | None = None) -> Array:
    """The values of the geometry parameters ``names`` (default: all of
    :data:`~gpr_kinematics.core.parameters.PARAMETER_NAMES`) of ``config`` [SI]. ``parameter_vector(GprConfig())``
    is the nominal machine's.

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
    v = float_array(vector, 'the parameter vector', 'numbers [SI]').ravel()
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
