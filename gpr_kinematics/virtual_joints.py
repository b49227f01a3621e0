"""Virtual-joint models of the GPR platform and their Newton-Raphson solution.

Seed: Bratovanov & Sotirov, *Virtualization for the purposes of modeling and computer simulation of a
class of overconstrained robots* (``shared/seeds/gpr-virtual-joints-bratovanov-sotirov.txt``), §IV-V.

The platform-frame joint centres ``r_k(X)`` (planar, z = 0) become functions of virtual-joint
coordinates ``X`` (design.md §3), ordered as in the paper: the three linear coordinates, then the three
angular ones.

=========  =====================  =====================================================  ==============
model      X                      r_k(X)                                                 X at singular
=========  =====================  =====================================================  ==============
radial     l1 l2 l3               l_k u(theta_k)                                          l = R
polar      l1 l2 l3 phi1..3       l_k u(theta_k + phi_k)                                  l = R, phi = 0
offset     dr1..3 dphi1..3        R u(theta_k) + dr_k u(theta_k + dphi_k)                 0
=========  =====================  =====================================================  ==============

with ``u(a) = (cos a, sin a)``. (The seed's §V-B formula for ``r_3`` has ``dphi_2`` where ``dphi_3``
is meant.) The closure equations (paper eq. 6 in the form of §V-B) are

    F_i(X) = |r_{i%3+1}(X) - r_i(X)|^2 - L_{i,i%3+1}^2 = 0,   i = 1, 2, 3,

with the side lengths ``L`` fixed by the rod lengths ``q``. ``radial`` is square, ``polar`` and
``offset`` are underdetermined (3 equations, 6 unknowns). They are solved by Newton-Raphson with the
Moore-Penrose pseudo-inverse of ``dF/dX`` (paper eq. 8), always starting from the singular ``X`` so
that the solution is a pure function of ``q``. The pseudo-inverse is taken in the metric
``|dX|_W^2 = sum dl^2 + c^2 sum dphi^2`` where ``c`` is a characteristic length (seed
``gsp-inverse-jacobians-toz-kucuk.txt`` §4.3, default ``R``), so the minimum-norm step is the smallest
displacement of the joint centres and does not depend on the units; ``weighting='unweighted'`` uses
``c = 1`` in SI units, the paper's eq. (8) as printed.
"""
from __future__ import annotations

import functools
import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ._ops import ARRAY, SCALAR, Ops
from .config import MODELS, GprConfig
from .errors import ConvergenceError, InputError

Array = NDArray[np.float64]

#: Edges of the joint triangle: (i, i % 3 + 1) in the paper's 1-based numbering.
EDGES = ((0, 1), (1, 2), (2, 0))
EDGE_NAMES = ('L12', 'L23', 'L31')


@dataclass(frozen=True)
class VirtualJointModel:
    """One virtual-joint parameterisation ``r_k(X)`` of the platform joint centres.

    Attributes:
        name: ``radial``, ``polar`` or ``offset``.
        radius: nominal radius ``R`` of the joint triangle [m].
        azimuths: nominal azimuths ``theta_k`` of the joints [rad].
    """

    name: str
    radius: float
    azimuths: tuple[float, float, float]

    @property
    def size(self) -> int:
        """Number ``M`` of virtual-joint coordinates."""
        return 3 if self.name == 'radial' else 6

    @property
    def names(self) -> tuple[str, ...]:
        """Names of the coordinates, in the order of ``X``."""
        if self.name == 'radial':
            return ('l1', 'l2', 'l3')
        if self.name == 'polar':
            return ('l1', 'l2', 'l3', 'phi1', 'phi2', 'phi3')
        return ('dr1', 'dr2', 'dr3', 'dphi1', 'dphi2', 'dphi3')

    @functools.cached_property
    def trig(self) -> tuple[float, ...]:
        """``cos theta_k`` and ``sin theta_k`` of the nominal joint azimuths."""
        th = self.azimuths
        return (math.cos(th[0]), math.cos(th[1]), math.cos(th[2]),
                math.sin(th[0]), math.sin(th[1]), math.sin(th[2]))

    @property
    def angular(self) -> NDArray[np.bool_]:
        """Mask of the angular coordinates (radians) in ``X``."""
        return np.arange(self.size) >= 3

    def singular(self, n: int = 1) -> Array:
        """``X`` at the singular configuration ``q1 = q2 = q3``, shape ``(n, M)``."""
        X = np.zeros((n, self.size))
        if self.name in ('radial', 'polar'):
            X[:, :3] = self.radius
        return X

    @functools.cached_property
    def singular_floats(self) -> tuple[float, ...]:
        """:meth:`singular` of one configuration, as floats."""
        return tuple(float(v) for v in self.singular(1)[0])

    @functools.cached_property
    def singular_components(self) -> tuple[list, ...]:
        """:func:`joint_components` (float arithmetic) at the singular ``X``: the start of every solve."""
        return joint_components(SCALAR, self, list(self.singular_floats))

    def points_and_partials(self, X: Array) -> tuple[Array, Array, Array]:
        """Joint centres ``r_k(X)`` ``(N, 3, 2)`` and their partials, as arrays (from
        :func:`joint_components`).

        Returns ``(r, dr_dlin, dr_dang)``: ``dr_dlin[:, k]`` is ``d r_k / d X_k`` (the linear coordinate
        of joint ``k``), ``dr_dang[:, k]`` is ``d r_k / d X_{k+3}`` (zero for ``radial``).
        """
        X = np.asarray(X, dtype=float)
        rx, ry, dlx, dly, dax, day = joint_components(ARRAY, self, list(X.T))

        def stack(cx: list, cy: list) -> Array:
            return np.broadcast_to(np.stack([np.stack(cx, -1), np.stack(cy, -1)], -1), (X.shape[0], 3, 2))

        r, dlin = stack(rx, ry), stack(dlx, dly)
        return r, dlin, np.zeros_like(dlin) if dax is None else stack(dax, day)

    def closure(self, X: Array, L2: Array) -> tuple[Array, Array, Array]:
        """Residuals ``F (N, 3)``, Jacobian ``dF/dX (N, 3, M)`` and current side lengths ``(N, 3)``.

        ``dF_i/dX = 2 (r_b - r_a) . (d r_b/dX - d r_a/dX)`` for edge ``i = (a, b)`` (paper §V-B).
        """
        r, dlin, dang = self.points_and_partials(X)
        n = X.shape[0]
        J = np.zeros((n, 3, self.size))
        d2 = np.empty((n, 3))
        for i, (a, b) in enumerate(EDGES):  # three edges: a fixed, tiny loop, vectorised over N
            e = r[:, b] - r[:, a]
            d2[:, i] = np.einsum('nj,nj->n', e, e)
            J[:, i, b] = 2.0 * np.einsum('nj,nj->n', e, dlin[:, b])
            J[:, i, a] = -2.0 * np.einsum('nj,nj->n', e, dlin[:, a])
            if self.size == 6:
                J[:, i, 3 + b] = 2.0 * np.einsum('nj,nj->n', e, dang[:, b])
                J[:, i, 3 + a] = -2.0 * np.einsum('nj,nj->n', e, dang[:, a])
        return d2 - L2, J, np.sqrt(d2)


def make_model(config: GprConfig, model: str | None = None) -> VirtualJointModel:
    """The virtual-joint model named ``model`` (default: ``config.model``) for ``config``'s geometry."""
    name = config.model if model in (None, '') else model
    key = (name, config.radius, config.rod_azimuths)
    vjm = _MODEL_CACHE.get(key)
    if vjm is None:
        if name not in MODELS:
            raise InputError(f'unknown virtual-joint model {name!r}; allowed: {", ".join(MODELS)}')
        vjm = _MODEL_CACHE[key] = VirtualJointModel(name, config.radius, tuple(config.rod_azimuths))
    return vjm


_MODEL_CACHE: dict[tuple, VirtualJointModel] = {}


def angle_scale(config: GprConfig) -> float:
    """Length ``c`` that turns an angular virtual joint into a displacement in the step's metric:
    the characteristic length, or 1 (SI units) for the paper's ``unweighted`` form."""
    return config.characteristic_length if config.weighting == 'characteristic' else 1.0


def coordinate_scale(vjm: VirtualJointModel, config: GprConfig) -> Array:
    """Metric scales ``s`` of the coordinates: 1 for lengths, :func:`angle_scale` for angles."""
    s = np.ones(vjm.size)
    s[vjm.angular] = angle_scale(config)
    return s


def angular_weight(config: GprConfig) -> float:
    """Weight ``w = s^-2`` of the angular coordinates in the step ``dX = -W J^T (J W J^T)^-1 F``."""
    return angle_scale(config) ** -2.0


def joint_components(ops: Ops, vjm: VirtualJointModel, X: Sequence[Any]) -> tuple[list, ...]:
    """Components of ``r_k(X)`` and of its partials, for kernels (arrays of shape ``(N,)`` or floats).

    Returns ``(rx, ry, dlx, dly, dax, day)``, lists over ``k``: ``(dlx, dly)[k] = d r_k / d X_k`` and
    ``(dax, day)[k] = d r_k / d X_{k+3}`` (``None`` for ``radial``).
    """
    c0, c1, c2, s0, s1, s2 = vjm.trig
    l0, l1, l2 = X[0], X[1], X[2]
    if vjm.name == 'radial':
        return ([l0 * c0, l1 * c1, l2 * c2], [l0 * s0, l1 * s1, l2 * s2], [c0, c1, c2], [s0, s1, s2],
                None, None)
    th0, th1, th2 = vjm.azimuths
    cos, sin = ops.cos, ops.sin
    a0, a1, a2 = th0 + X[3], th1 + X[4], th2 + X[5]
    u0, u1, u2, v0, v1, v2 = cos(a0), cos(a1), cos(a2), sin(a0), sin(a1), sin(a2)
    rx = [l0 * u0, l1 * u1, l2 * u2]
    ry = [l0 * v0, l1 * v1, l2 * v2]
    if vjm.name == 'offset':
        R = vjm.radius
        rx = [rx[0] + R * c0, rx[1] + R * c1, rx[2] + R * c2]
        ry = [ry[0] + R * s0, ry[1] + R * s1, ry[2] + R * s2]
    return rx, ry, [u0, u1, u2], [v0, v1, v2], [-l0 * v0, -l1 * v1, -l2 * v2], [l0 * u0, l1 * u1, l2 * u2]


def side_errors(ops: Ops, comps: tuple[list, ...], L: Sequence[Any]) -> tuple[list, Any]:
    """Side lengths ``d_i(X)`` and the closure error ``max_i |d_i - L_i|`` [m] from
    :func:`joint_components` (no Jacobian)."""
    (x0, x1, x2), (y0, y1, y2) = comps[0], comps[1]
    sqrt, fabs, maximum = ops.sqrt, ops.fabs, ops.maximum
    e0x, e0y, e1x, e1y, e2x, e2y = x1 - x0, y1 - y0, x2 - x1, y2 - y1, x0 - x2, y0 - y2
    d = [sqrt(e0x * e0x + e0y * e0y), sqrt(e1x * e1x + e1y * e1y), sqrt(e2x * e2x + e2y * e2y)]
    return d, maximum(maximum(fabs(d[0] - L[0]), fabs(d[1] - L[1])), fabs(d[2] - L[2]))


def newton_terms(ops: Ops, comps: tuple[list, ...], L: Sequence[Any], wa: float) -> list:
    """One Newton-Raphson step of the closure (paper eq. 8), component-wise.

    ``J`` is sparse: row ``i`` (edge ``a -> b``: 1->2, 2->3, 3->1) depends only on the coordinates of
    joints ``a`` and ``b``: ``dF_i/dX_b = 2 e_i . dr_b/dX_b``, ``dF_i/dX_a = -2 e_i . dr_a/dX_a`` with
    ``e_i = r_b - r_a``. So the Gram matrix ``G = J W J^T`` has closed-form entries (joint ``i+1`` is
    shared by edges ``i`` and ``i+1``) and ``y = G^-1 F`` is solved by the adjugate of the symmetric
    3x3 ``G``; the step is ``dX = -W J^T y``. ``comps`` are the :func:`joint_components` at the current
    ``X``; returns the step ``dX`` (list of ``M`` components).
    """
    (x0, x1, x2), (y0, y1, y2), (ux0, ux1, ux2), (uy0, uy1, uy2), dax, day = comps
    e0x, e0y, e1x, e1y, e2x, e2y = x1 - x0, y1 - y0, x2 - x1, y2 - y1, x0 - x2, y0 - y2
    F0 = e0x * e0x + e0y * e0y - L[0] * L[0]
    F1 = e1x * e1x + e1y * e1y - L[1] * L[1]
    F2 = e2x * e2x + e2y * e2y - L[2] * L[2]
    # gb_i: derivative of F_i by the coordinate of its end joint, ga_i: by that of its start joint.
    gb0, ga0 = 2.0 * (e0x * ux1 + e0y * uy1), -2.0 * (e0x * ux0 + e0y * uy0)
    gb1, ga1 = 2.0 * (e1x * ux2 + e1y * uy2), -2.0 * (e1x * ux1 + e1y * uy1)
    gb2, ga2 = 2.0 * (e2x * ux0 + e2y * uy0), -2.0 * (e2x * ux2 + e2y * uy2)
    g00, g11, g22 = gb0 * gb0 + ga0 * ga0, gb1 * gb1 + ga1 * ga1, gb2 * gb2 + ga2 * ga2
    g01, g12, g02 = gb0 * ga1, gb1 * ga2, gb2 * ga0
    if dax is not None:
        (ax0, ax1, ax2), (ay0, ay1, ay2) = dax, day
        hb0, ha0 = 2.0 * (e0x * ax1 + e0y * ay1), -2.0 * (e0x * ax0 + e0y * ay0)
        hb1, ha1 = 2.0 * (e1x * ax2 + e1y * ay2), -2.0 * (e1x * ax1 + e1y * ay1)
        hb2, ha2 = 2.0 * (e2x * ax0 + e2y * ay0), -2.0 * (e2x * ax2 + e2y * ay2)
        g00 = g00 + wa * (hb0 * hb0 + ha0 * ha0)
        g11 = g11 + wa * (hb1 * hb1 + ha1 * ha1)
        g22 = g22 + wa * (hb2 * hb2 + ha2 * ha2)
        g01 = g01 + wa * hb0 * ha1
        g12 = g12 + wa * hb1 * ha2
        g02 = g02 + wa * hb2 * ha0
    c00, c11, c22 = g11 * g22 - g12 * g12, g00 * g22 - g02 * g02, g00 * g11 - g01 * g01
    c01, c02, c12 = g12 * g02 - g01 * g22, g01 * g12 - g11 * g02, g01 * g02 - g00 * g12
    inv_det = 1.0 / (g00 * c00 + g01 * c01 + g02 * c02)
    y0 = (c00 * F0 + c01 * F1 + c02 * F2) * inv_det
    y1 = (c01 * F0 + c11 * F1 + c12 * F2) * inv_det
    y2 = (c02 * F0 + c12 * F1 + c22 * F2) * inv_det
    # Joint k is the end b of edge k-1 and the start a of edge k.
    dX = [-(gb2 * y2 + ga0 * y0), -(gb0 * y0 + ga1 * y1), -(gb1 * y1 + ga2 * y2)]
    if dax is not None:
        dX += [-wa * (hb2 * y2 + ha0 * y0), -wa * (hb0 * y0 + ha1 * y1), -wa * (hb1 * y1 + ha2 * y2)]
    return dX


@dataclass(frozen=True)
class VirtualJointSolution:
    """Solution of the closure for a batch: ``X (N, M)``, side lengths, iterations, residuals [m] and
    the :func:`joint_components` at the solution."""

    X: Array
    side_lengths: Array
    iterations: NDArray[np.int64]
    residual: Array
    components: tuple[list, ...]


def _not_converged(vjm: VirtualJointModel, config: GprConfig, err: float,
                   sample: int | None) -> ConvergenceError:
    where = '' if sample is None else f' for sample {sample}'
    return ConvergenceError(
        f'virtual-joint closure ({vjm.name}) did not converge in {config.max_iterations} iterations'
        f'{where}: side-length error {err:.3e} m > tolerance {config.tolerance:.1e} m')


def solve_virtual_joints(L: Array, vjm: VirtualJointModel, config: GprConfig) -> VirtualJointSolution:
    """Solve ``F(X) = 0`` for side lengths ``L (N, 3)`` by Newton-Raphson from the singular ``X``.

    Step (paper eq. 8, in the weighted metric ``W = diag(s)^-2``):
    ``dX = -W J^T (J W J^T)^-1 F(X)``, the minimum-``|dX|_W`` solution of ``J dX = -F``.
    Each sample stops as soon as its side-length error ``max_i |d_i(X) - L_i|`` is at most
    ``config.tolerance`` [m] (so batch and single solves agree); at most ``config.max_iterations``
    steps are taken.

    Raises:
        ConvergenceError: a sample did not reach the tolerance within ``max_iterations``.
    """
    n = L.shape[0]
    X = list(vjm.singular(n).T.copy())
    Lc = [np.ascontiguousarray(L[:, i]) for i in range(3)]
    wa = angular_weight(config)
    iterations = np.zeros(n, dtype=np.int64)
    comps = joint_components(ARRAY, vjm, X)
    d, err = side_errors(ARRAY, comps, Lc)
    for step in range(config.max_iterations + 1):
        active = ~(err <= config.tolerance)
        if not active.any():
            break
        if step == config.max_iterations:
            worst = int(np.argmax(np.where(active, err, -1.0)))
            raise _not_converged(vjm, config, float(err[worst]), worst)
        dX = newton_terms(ARRAY, comps, Lc, wa)
        everyone = bool(active.all())
        X = [x + dx if everyone else np.where(active, x + dx, x) for x, dx in zip(X, dX, strict=True)]
        iterations += active
        comps = joint_components(ARRAY, vjm, X)
        d, err = side_errors(ARRAY, comps, Lc)
    return VirtualJointSolution(X=np.stack(X, axis=-1), side_lengths=np.stack(d, axis=-1),
                                iterations=iterations, residual=err, components=comps)


def solve_virtual_joints_scalar(L: Sequence[float], vjm: VirtualJointModel,
                                config: GprConfig) -> tuple[list[float], list[float], int, float, tuple]:
    """:func:`solve_virtual_joints` for one configuration, in float arithmetic.

    Returns ``(X, side_lengths, iterations, residual, components)``.
    """
    X = list(vjm.singular_floats)
    wa = angular_weight(config)
    comps = vjm.singular_components
    d, err = side_errors(SCALAR, comps, L)
    step = 0
    while not err <= config.tolerance:
        if step == config.max_iterations:
            raise _not_converged(vjm, config, err, None)
        dX = newton_terms(SCALAR, comps, L, wa)
        X = [x + dx for x, dx in zip(X, dX, strict=True)]
        step += 1
        comps = joint_components(SCALAR, vjm, X)
        d, err = side_errors(SCALAR, comps, L)
    return X, d, step, err, comps
